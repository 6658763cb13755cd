"""The direction of travel from the silhouettes' floor points, and the heading grid it restricts."""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ipf_jax.body import default_shape
from ipf_jax.data.dataset import MemoryDataset
from ipf_jax.geometry.world import up_rotation
from ipf_jax.tracking.initialise import headings
from ipf_jax.tracking.settings import TrackSettings
from ipf_jax.tracking.tracker import Tracker
from ipf_jax.tracking.travel import MIN_TRAVEL_M, travel_heading, window_frames
from ipf_jax.viz import synthetic as syn


def _angle(a: float, b: float) -> float:
    return abs((a - b + np.pi) % (2 * np.pi) - np.pi)


@settings(max_examples=60, deadline=None)
@given(heading=st.floats(-np.pi, np.pi), distance=st.floats(0.35, 3.0),
       up=st.sampled_from(["+z", "-y", "+y", "-z"]))
def test_a_steady_walk_gives_its_direction(heading, distance, up):
    U = up_rotation(up)
    forward = U @ np.array([np.cos(heading), np.sin(heading), 0.0])
    points = [np.array([0.2, -0.1, 0.3]) + forward * distance * k / 2 for k in range(3)]
    assert _angle(travel_heading(points, U), heading) < 1e-9


def test_no_direction_without_steady_travel():
    U = up_rotation("+z")
    x = np.array([1.0, 0.0, 0.0])
    assert travel_heading([np.zeros(3)], U) is None  # one point
    assert travel_heading([np.zeros(3), 0.1 * x, 0.2 * x], U) is None  # a shuffle, not a walk
    assert travel_heading([np.zeros(3), -0.3 * x, 0.5 * x], U) is None  # back, then forward
    assert travel_heading([np.zeros(3), np.full(3, np.nan)], U) is None
    # height changes (the floor point of one camera moves with the height guess) are not travel
    assert travel_heading([np.zeros(3), np.array([0, 0, 2.0])], U) is None
    assert travel_heading([np.zeros(3), (MIN_TRAVEL_M + 0.01) * x], U) == 0.0


def test_window_frames_look_ahead_a_second_or_back_at_the_end():
    frames = list(range(100, 140))
    assert window_frames(frames, 100, 20.0) == [100, 110, 120]
    assert window_frames(frames, 130, 20.0) == [119, 129, 139]  # less than a second left
    assert window_frames([5, 6], 5, 20.0) == [5, 6]
    assert window_frames([5], 5, 20.0) == [5]


@given(count=st.sampled_from([4, 8, 12, 16, 24]), facing=st.floats(-np.pi, np.pi))
def test_headings_facing_a_direction_keep_the_half_plane(count, facing):
    full = headings(count)
    assert len(full) == count
    half = headings(count, facing)
    assert len(half) == count // 2 + 1
    assert min(_angle(h, facing) for h in half) < 1e-9  # the direction itself is searched
    assert all(_angle(h, facing) <= np.pi / 2 + 1e-9 for h in half)
    assert np.all(np.abs(half) <= np.pi)


def test_the_tracker_finds_the_direction_a_synthetic_walker_travels():
    """Rendered walker (self-rendered synthetic check) heading 120 deg at 1.2 m/s, 2 cameras."""
    shape = default_shape(1.75)
    cams = syn.ring_cameras(2, width=160, height=120, focal_px=150)
    q = syn.procedural_walk(24, shape=shape, heading_deg=120.0, start=(0.6, -0.8))
    masks = syn.render_masks(q, shape, cams)
    ds = MemoryDataset(cams, masks, fps=20.0)
    tracker = Tracker(ds, TrackSettings(shape_fit=TrackSettings().shape_fit._replace(frames=0)))
    assert np.rad2deg(_angle(tracker.heading_of_travel(0), np.deg2rad(120.0))) < 10
    assert np.rad2deg(_angle(tracker.heading_of_travel(23), np.deg2rad(120.0))) < 10  # looks back
    off = Tracker(ds, TrackSettings(facing_travel=False))
    assert off.heading_of_travel(0) is None
    standing = MemoryDataset(cams, np.repeat(masks[:1], 24, axis=0), fps=20.0)
    assert Tracker(standing, TrackSettings()).heading_of_travel(0) is None
