"""Body model topology, shape files and limits files."""
import json

import numpy as np
import pytest

from ipf_jax.body import (
    DOF_NAMES,
    NUM_DOF,
    POINT_NAMES,
    SEGMENT_NAMES,
    default_shape,
    load_limits,
    load_shape,
    model,
)
from ipf_jax.body.limits import PRESET_DIR
from ipf_jax.body.model import SHAPE_INDEX
from ipf_jax.body.shape import BodyShape
from ipf_jax.errors import IPFError


def test_topology_counts_and_names():
    assert POINT_NAMES == ("sacrum", "left_hip", "left_knee", "left_ankle", "left_heel", "left_toe",
                           "right_hip", "right_knee", "right_ankle", "right_heel", "right_toe", "neck",
                           "head", "left_shoulder", "left_elbow", "left_wrist", "right_shoulder",
                           "right_elbow", "right_wrist")
    assert len(SEGMENT_NAMES) == 17 and NUM_DOF == 31
    assert DOF_NAMES[:6] == ("root_tx", "root_ty", "root_tz", "root_yaw", "root_pitch", "root_roll")


def test_four_kinematic_chains_hang_off_the_trunk():
    children = {}
    for f in model.FRAMES:
        children.setdefault(f.parent, []).append(f.name)
    chains = [c for c in children["pelvis"] if c.endswith("thigh")] + \
             [c for c in children["trunk"] if c.endswith("upper_arm")]
    assert sorted(chains) == ["left_thigh", "left_upper_arm", "right_thigh", "right_upper_arm"]


def test_default_shape_and_height_scaling():
    s = default_shape()
    assert s.height_m == pytest.approx(1.75)
    t = s.scaled_to(1.9)
    assert t["thigh"] == pytest.approx(s["thigh"] * 1.9 / 1.75)
    assert t.height_m == 1.9
    with pytest.raises(IPFError, match="height"):
        s.scaled_to(4.0)


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["params"].pop("thigh"), "misses parameters: thigh"),
    (lambda d: d["params"].update(thigh_r0=-0.1), "radii must be positive"),
    (lambda d: d["params"].update(thigh="long"), "must be numbers"),
    (lambda d: d["params"].update(wings=1.0), "unknown shape parameters: 'wings'"),
])
def test_bad_shape_files_name_the_problem(tmp_path, edit, message):
    doc = default_shape().to_json()
    edit(doc)
    path = tmp_path / "shape.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(IPFError, match=message) as err:
        load_shape(path)
    assert err.value.path == str(path)


def test_hip_joints_sit_in_front_of_the_pelvis_and_older_files_keep_theirs(tmp_path):
    # the hip joint centres lie hip_forward in front of the pelvis capsule's axis (Harrington's
    # centres are 4-5 cm in front of the pelvis centre); a shape file written before that
    # parameter describes hips in the pelvis's plane, and loads so, with a warning
    from ipf_jax.errors import IPFWarning
    from ipf_jax.geometry.host import forward_kinematics

    def hips_ahead(shape):
        pose = forward_kinematics(np.zeros(NUM_DOF), shape.values, np.eye(3))
        hips = pose.points[[POINT_NAMES.index("left_hip"), POINT_NAMES.index("right_hip")], 0]
        pelvis = pose.seg_a[SEGMENT_NAMES.index("pelvis"), 0]
        return hips - pelvis

    s = default_shape()
    assert hips_ahead(s) == pytest.approx([s["hip_forward"]] * 2)
    assert 0.03 < s["hip_forward"] < 0.05
    doc = s.to_json()
    del doc["params"]["hip_forward"]
    path = tmp_path / "old.json"
    path.write_text(json.dumps(doc))
    with pytest.warns(IPFWarning, match="written before hip_forward"):
        old = load_shape(path)
    assert old["hip_forward"] == 0.0 and hips_ahead(old) == pytest.approx([0.0, 0.0], abs=1e-12)


def test_the_pelvis_reaches_crotch_depth_below_the_hips_whatever_its_breadth(tmp_path):
    # the pelvis capsule's lowest point (the crotch of a frontal silhouette) lies crotch_depth
    # below the hip joints: a broader pelvis (a larger pelvis_r) does not lower it; a file written
    # with the older pelvis_up (the capsule's axis over the hips) loads as the same body
    from ipf_jax.errors import IPFWarning
    from ipf_jax.geometry.host import forward_kinematics

    def crotch_below_hips(shape):
        pose = forward_kinematics(np.zeros(NUM_DOF), shape.values, np.eye(3))
        hip_z = pose.points[POINT_NAMES.index("left_hip"), 2]
        pelvis = SEGMENT_NAMES.index("pelvis")
        return hip_z - (pose.seg_a[pelvis, 2] - shape["pelvis_r"])

    s = default_shape()
    assert crotch_below_hips(s) == pytest.approx(s["crotch_depth"], abs=1e-12)
    broad = s.values.copy()
    broad[SHAPE_INDEX["pelvis_r"]] *= 1.2
    assert crotch_below_hips(BodyShape(broad, s.height_m)) == pytest.approx(s["crotch_depth"], abs=1e-12)
    doc = s.to_json()
    depth = doc["params"].pop("crotch_depth")
    doc["params"]["pelvis_up"] = doc["params"]["pelvis_r"] - depth
    path = tmp_path / "old.json"
    path.write_text(json.dumps(doc))
    with pytest.warns(IPFWarning, match="pelvis_up"):
        old = load_shape(path)
    assert old["crotch_depth"] == pytest.approx(depth, abs=1e-12)
    assert np.allclose(old.values, s.values, atol=1e-12)
    doc["params"]["pelvis_up"] = 0.0175  # the template before crotch_depth: a deeper pelvis
    path.write_text(json.dumps(doc))
    with pytest.warns(IPFWarning, match="pelvis_up"):
        assert load_shape(path)["crotch_depth"] == pytest.approx(s["pelvis_r"] - 0.0175)


def test_limits_presets():
    d = load_limits("default")
    w = load_limits("walking")
    knee = DOF_NAMES.index("left_knee_flexion")
    hip = DOF_NAMES.index("right_hip_flexion")
    assert d.lower[knee] == 0.0 and w.lower[knee] == 0.0  # knees never hyperextend
    assert np.rad2deg([w.lower[hip], w.upper[hip]]) == pytest.approx([-30.0, 60.0])
    assert np.all(w.lower >= d.lower) and np.all(w.upper <= d.upper)


def test_limits_clip_wraps_yaw():
    lim = load_limits("default")
    x = np.zeros((2, NUM_DOF))
    x[0, 3] = np.deg2rad(190.0)
    x[1, DOF_NAMES.index("left_knee_flexion")] = -0.5
    y = lim.clip(x.copy())
    assert np.rad2deg(y[0, 3]) == pytest.approx(-170.0)
    assert y[1, DOF_NAMES.index("left_knee_flexion")] == 0.0


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["dofs"].update(left_knee_flexion=[30, 10]), "min 30.0 > max 10.0"),
    (lambda d: d["dofs"].pop("root_yaw"), "misses DOFs: root_yaw"),
    (lambda d: d["dofs"].update(left_knee_flexion=[0, "x"]), "must be numbers"),
])
def test_bad_limits_files(tmp_path, edit, message):
    doc = json.loads((PRESET_DIR / "limits_default.json").read_text())
    edit(doc)
    path = tmp_path / "limits.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(IPFError, match=message):
        load_limits(path)


def test_missing_limits_file_lists_presets(tmp_path):
    with pytest.raises(IPFError, match="presets: default, walking"):
        load_limits(tmp_path / "nope.json")


def test_a_shape_file_without_height_gets_its_parameters_standing_height(tmp_path):
    from ipf_jax.body.model import SHAPE_PARAM_NAMES

    body = default_shape(1.857)
    params = dict(zip(SHAPE_PARAM_NAMES, map(float, body.values)))
    (tmp_path / "noh.json").write_text(json.dumps({"params": params}))  # was 1.75 m whatever the body
    assert abs(load_shape(tmp_path / "noh.json").height_m - 1.857) < 0.02


@pytest.mark.parametrize("rng, message", [([None, 30], "needs both ends"), ([0, 9000], "not a range of degrees")])
def test_limits_files_refuse_unbounded_or_radian_looking_angles(tmp_path, rng, message):
    doc = json.loads((PRESET_DIR / "limits_default.json").read_text())
    doc["dofs"]["left_knee_flexion"] = rng
    (tmp_path / "limits.json").write_text(json.dumps(doc))
    with pytest.raises(IPFError, match=f"left_knee_flexion: .*{message}"):
        load_limits(tmp_path / "limits.json")
