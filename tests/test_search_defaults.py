"""The tracker's camera rules for the factored filter's searches that are on only with enough views:
the posture group (ipf_jax.filters.posture) and the arms' reach search (ipf_jax.filters.reach)."""
import pytest

from ipf_jax.body import default_shape
from ipf_jax.data.dataset import MemoryDataset
from ipf_jax.filters import posture, reach
from ipf_jax.tracking.tracker import Tracker, TrackSettings
from ipf_jax.viz import synthetic as syn

FPS = 20.0


@pytest.mark.parametrize("key, views", [("posture", posture.MIN_VIEWS), ("reach", reach.MIN_VIEWS)])
def test_the_tracker_searches_it_with_enough_cameras_unless_told(key, views):
    """SYNTHETIC (self-rendered masks): the default follows the number of cameras; the option and
    its --no- form win; the budget is the same either way."""
    shape = default_shape(1.75)
    pose = syn.procedural_walk(1, FPS, shape=shape)
    cases = [(n, None, n >= views) for n in (1, 2, 3, 4)] + [(1, True, True), (4, False, False)]
    for n, asked, expected in cases:
        cams = syn.ring_cameras(n, width=80, height=60, focal_px=150.0)
        ds = MemoryDataset(cams, syn.render_masks(pose, shape, cams), fps=FPS, up_axis="+z")
        opts = {} if asked is None else {key: asked}
        tracker = Tracker(ds, TrackSettings(filter_options=opts, init_pose=pose[0], height_m=1.75))
        f = tracker.filter_for(shape)
        assert f.params[key] is expected, (n, asked)
        assert f.evaluations_per_frame == 6561 and tracker.filter.params == f.params
