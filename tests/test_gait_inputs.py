"""Readers and bad inputs: every problem is one IPFError naming the file and what is wrong."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from ipf_jax.analysis.gait import analyse, load
from ipf_jax.analysis.gait.io import write_joints_csv
from ipf_jax.analysis.gait.markers import read_trc
from ipf_jax.analysis.gait.synthetic import synthetic_walk
from ipf_jax.errors import IPFError, IPFWarning

#: synthetic marker names for the roles (what a lab would call them)
MARKERS = {"sacrum": "SACR", "left_heel": "LHEE", "right_heel": "RHEE", "left_toe": "LTOE",
           "right_toe": "RTOE", "left_ankle": "LANK", "right_ankle": "RANK"}


def write_trc(traj, path, *, units="mm", up_to=None):
    """A TRC of ``traj``'s points under MARKERS names (Y up expected), optionally cut short."""
    scale = 1000.0 if units == "mm" else 1.0
    names = list(MARKERS.values())
    lines = ["PathFileType\t4\t(X/Y/Z)\tsynthetic.trc",
             "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\t"
             "OrigDataStartFrame\tOrigNumFrames",
             f"{traj.fps:g}\t{traj.fps:g}\t{len(traj.time)}\t{len(names)}\t{units}\t"
             f"{traj.fps:g}\t1\t{len(traj.time)}",
             "Frame#\tTime\t" + "\t\t\t".join(names) + "\t\t\t",
             "\t\t" + "\t".join(f"{c}{i + 1}" for i in range(len(names)) for c in "XYZ"), ""]
    for i, t in enumerate(traj.time):
        vals = [f"{v * scale:.6f}" for role in MARKERS for v in traj.points[role][i]]
        lines.append("\t".join([str(i + 1), f"{t:.5f}", *vals]))
    text = "\n".join(lines) + "\n"
    if up_to is not None:
        text = text[:up_to]
    path.write_text(text)
    return path


def write_map(path, roles):
    path.write_text(json.dumps({"name": "test", "roles": roles}))
    return path


@pytest.fixture(scope="module")
def walk():
    return synthetic_walk(duration_s=4.0, fps=50.0, up_axis="+y")


def test_trc_with_marker_map_matches_the_csv_route(tmp_path, walk):
    traj, truth = walk
    trc = write_trc(traj, tmp_path / "walk.trc")
    mp = write_map(tmp_path / "map.json", {r: [m] for r, m in MARKERS.items()})
    back = load(trc, marker_map=mp)
    assert back.up_axis == "+y" and back.fps == 50.0
    np.testing.assert_allclose(back.points["left_heel"], traj.points["left_heel"], atol=1e-6)
    res = analyse(back)
    ref = analyse(traj._replace(points={r: traj.points[r] for r in MARKERS}))
    np.testing.assert_allclose(res.events["left_heel_strike"], ref.events["left_heel_strike"],
                               atol=1e-5)
    assert res.parameters["step_length_m"]["all"]["mean"] == pytest.approx(
        truth.step_length_m, abs=0.01)


def test_marker_lists_are_averaged_and_units_override(tmp_path, walk):
    traj, _ = walk
    trc = write_trc(traj, tmp_path / "walk.trc", units="m")
    roles = {r: [m] for r, m in MARKERS.items()}
    roles["sacrum"] = ["LANK", "RANK"]
    back = load(trc, marker_map=write_map(tmp_path / "map.json", roles))
    mid = 0.5 * (traj.points["left_ankle"] + traj.points["right_ankle"])
    np.testing.assert_allclose(back.points["sacrum"], mid, atol=1e-6)
    assert any("sacrum = mean of LANK, RANK" in n for n in back.notes)
    scaled = load(trc, marker_map=tmp_path / "map.json", units="mm")
    np.testing.assert_allclose(scaled.points["sacrum"], mid / 1000.0, atol=1e-9)


def test_units_the_body_contradicts_are_a_warning(tmp_path, walk):
    """--units mm on a file in metres scaled the walk 1000x down silently (speeds 1000x off)."""
    traj, _ = walk
    trc = write_trc(traj, tmp_path / "walk.trc", units="m")
    roles = write_map(tmp_path / "map.json", dict(MARKERS))
    said = r"walk.trc: --units mm puts the pelvis 0.000\d+ m above the feet \(m would make it 0.\d\d m\)"
    with pytest.warns(IPFWarning, match=said):
        load(trc, marker_map=roles, units="mm")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load(trc, marker_map=roles, units="m")


def test_trc_reader_keeps_empty_cells_as_nan(tmp_path, walk):
    traj, _ = walk
    trc = write_trc(traj, tmp_path / "walk.trc")
    lines = trc.read_text().splitlines()
    cells = lines[10].split("\t")
    cells[2:5] = ["", "", ""]  # SACR missing on frame 5
    lines[10] = "\t".join(cells)
    trc.write_text("\n".join(lines) + "\n")
    raw = read_trc(trc)
    assert np.isnan(raw.markers["SACR"][4]).all() and np.isfinite(raw.markers["SACR"][5]).all()


# --------------------------------------------------------------------------------------------------
# Bad inputs


def _standing(tmp_path):
    traj, _ = synthetic_walk(duration_s=3.0, fps=50.0)
    rng = np.random.default_rng(3)
    still = {k: np.repeat(v[:1], len(v), axis=0) + rng.normal(0, 0.002, v.shape)
             for k, v in traj.points.items()}
    return write_joints_csv(traj._replace(points=still), tmp_path / "standing.csv"), {}


def _all_nan(tmp_path):
    traj, _ = synthetic_walk(duration_s=2.0, fps=50.0)
    nan = {k: np.full_like(v, np.nan) for k, v in traj.points.items()}
    return write_joints_csv(traj._replace(points=nan), tmp_path / "empty.csv"), {}


def _missing_marker(tmp_path):
    traj, _ = synthetic_walk(duration_s=2.0, fps=50.0, up_axis="+y")
    trc = write_trc(traj, tmp_path / "walk.trc")
    roles = {r: m for r, m in MARKERS.items()}
    roles["left_heel"] = "L.Heal"
    return trc, {"marker_map": write_map(tmp_path / "map.json", roles)}


def _truncated_trc(tmp_path):
    traj, _ = synthetic_walk(duration_s=2.0, fps=50.0, up_axis="+y")
    full = write_trc(traj, tmp_path / "full.trc").read_text()
    cut = tmp_path / "cut.trc"
    cut.write_text(full[: len(full) // 2])
    return cut, {"marker_map": write_map(tmp_path / "map.json", dict(MARKERS))}


def _unknown_type(tmp_path):
    p = tmp_path / "walk.xyz"
    p.write_text("1 2 3\n")
    return p, {}


def _garbage_c3d(tmp_path):
    p = tmp_path / "broken.c3d"
    p.write_bytes(b"\x00\x01not a c3d file" * 10)
    return p, {}


def _no_up(tmp_path):
    # no run.json, and no pelvis/foot points for the body to show its up axis
    traj, _ = synthetic_walk(duration_s=2.0, fps=50.0)
    arms = {k: v for k, v in traj.points.items() if "wrist" in k or "elbow" in k}
    return write_joints_csv(traj._replace(points=arms), tmp_path / "joints.csv",
                            run_json=False), {}


def _bad_map(tmp_path):
    traj, _ = synthetic_walk(duration_s=2.0, fps=50.0, up_axis="+y")
    bad = tmp_path / "map.json"
    bad.write_text("{not json")
    return write_trc(traj, tmp_path / "walk.trc"), {"marker_map": bad}


def _walking_in_circles(tmp_path):
    # the sacrum path turns on a 0.5 m circle: no stretch keeps its heading for 0.8 s
    t = np.arange(200) / 50.0
    theta = 1.2 * t / 0.5
    circle = np.stack([0.5 * np.cos(theta), 0.5 * np.sin(theta), np.full_like(t, 0.95)], 1)
    traj, _ = synthetic_walk(duration_s=4.0, fps=50.0)
    pts = {k: v - traj.points["sacrum"] + circle for k, v in traj.points.items()}
    return write_joints_csv(traj._replace(points=pts), tmp_path / "circles.csv"), {}


BAD = {
    "no walking": (_standing, "standing.csv", "no walking"),
    "all nan": (_all_nan, "empty.csv", "all missing"),
    "missing marker": (_missing_marker, "walk.trc", "L.Heal"),
    "truncated trc": (_truncated_trc, "cut.trc", "truncated"),
    "unknown type": (_unknown_type, "walk.xyz", "unknown file type"),
    "garbage c3d": (_garbage_c3d, "broken.c3d", "not a C3D file"),
    "no up axis": (_no_up, "joints.csv", "--up"),
    "bad marker map": (_bad_map, "map.json", "not readable JSON"),
    "no straight part": (_walking_in_circles, "circles.csv", "no straight walking part"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_input_is_one_clear_error(tmp_path, case):
    make, filename, problem = BAD[case]
    path, kwargs = make(tmp_path)
    with pytest.raises(IPFError) as info:
        analyse(load(path, **kwargs))
    msg = str(info.value)
    assert filename in msg and problem in msg, msg


def test_joints_csv_without_run_json_takes_the_up_axis_from_the_body(tmp_path):
    traj, _ = synthetic_walk(duration_s=3.0, fps=50.0, up_axis="-y")
    back = load(write_joints_csv(traj, tmp_path / "joints.csv", run_json=False))
    assert back.up_axis == "-y" and any("from the body" in n for n in back.notes)


def test_c3d_clock_starts_at_its_first_frame(tmp_path, walk):
    ezc3d = pytest.importorskip("ezc3d")
    traj, _ = walk
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [traj.fps]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = tuple(MARKERS.values())
    pts = np.ones((4, len(MARKERS), len(traj.time)))
    for k, role in enumerate(MARKERS):
        pts[:3, k, :] = traj.points[role].T * 1000.0
    c3d["data"]["points"] = pts
    c3d.add_parameter("POINT", "UNITS", "mm")
    c3d.add_parameter("POINT", "Y_SCREEN", "+Y")
    c3d["header"]["points"]["first_frame"] = 25  # recording started 0.5 s into the session
    path = tmp_path / "walk.c3d"
    c3d.write(str(path))
    back = load(path, marker_map=write_map(tmp_path / "map.json", dict(MARKERS)))
    assert back.time[0] == pytest.approx(0.5) and back.up_axis == "+y"
    ref = analyse(traj._replace(points={r: traj.points[r] for r in MARKERS}))
    res = analyse(back)
    for name in ("left_heel_strike", "right_toe_off"):
        np.testing.assert_allclose(res.events[name], ref.events[name] + 0.5, atol=1e-4)
