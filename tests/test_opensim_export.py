"""export --format trc also writes an OpenSim marker set and IK setup for the 19 points; a slow test
runs that IK with the opensim package on a small generic model with OpenSim's body names."""
from __future__ import annotations

import numpy as np
import pytest

from ipf_jax.analysis.export import write_run_dir
from ipf_jax.analysis.export.opensim import MARKERS, WEIGHTS
from ipf_jax.body.model import DOF_NAMES, NUM_DOF, POINT_NAMES
from ipf_jax.cli import main


def _walk(T=12):
    poses = np.zeros((T, NUM_DOF))
    idx = {n: i for i, n in enumerate(DOF_NAMES)}
    t = np.arange(T) / 10
    poses[:, idx["root_tx"]] = 0.6 * t
    poses[:, idx["root_tz"]] = 0.95
    poses[:, idx["left_hip_flexion"]] = 0.4 * np.sin(2 * np.pi * t)
    poses[:, idx["right_hip_flexion"]] = -0.4 * np.sin(2 * np.pi * t)
    poses[:, idx["left_knee_flexion"]] = 0.5 * (1 + np.sin(2 * np.pi * t))
    poses[:, idx["right_knee_flexion"]] = 0.5 * (1 - np.sin(2 * np.pi * t))
    poses[:, idx["left_elbow_flexion"]] = poses[:, idx["right_elbow_flexion"]] = 0.3
    return poses


def test_trc_export_writes_marker_set_and_ik_setup(tmp_path, capsys):
    import xml.etree.ElementTree as ET

    run = write_run_dir(tmp_path / "run", _walk(), fps=10)
    trc = tmp_path / "walk.trc"
    assert main(["export", str(run), "--out", str(trc)]) == 0, capsys.readouterr().err
    markers = ET.parse(tmp_path / "walk_markers.xml").getroot()
    names = [m.get("name") for m in markers.iter("Marker")]
    assert names == list(POINT_NAMES)
    setup = ET.parse(tmp_path / "walk_ik_setup.xml").getroot()
    assert setup.find(".//marker_file").text == "walk.trc"
    assert setup.find(".//time_range").text.split() == ["0.000000", "1.100000"]
    tasks = {t.get("name"): float(t.find("weight").text) for t in setup.iter("IKMarkerTask")}
    assert tasks == WEIGHTS and set(MARKERS) == set(POINT_NAMES)


def _generic_model(osim):
    """A small articulated model with the bodies (and joint placements) of OpenSim's Rajagopal
    model that the marker set refers to."""
    model = osim.Model()
    model.setName("ipf_jax_generic")
    bodies = {}

    def body(name, mass=1.0):
        b = osim.Body(name, mass, osim.Vec3(0), osim.Inertia(0.01, 0.01, 0.01))
        model.addBody(b)
        bodies[name] = b
        return b

    def join(kind, name, parent, at, child):
        p = model.getGround() if parent is None else bodies[parent]
        j = getattr(osim, kind)(name, p, osim.Vec3(*at), osim.Vec3(0), child, osim.Vec3(0),
                                osim.Vec3(0))
        model.addJoint(j)

    join("FreeJoint", "ground_pelvis", None, (0, 0, 0), body("pelvis", 10))
    for s, z in (("l", -0.077), ("r", 0.077)):
        join("BallJoint", f"hip_{s}", "pelvis", (-0.056, -0.078, z), body(f"femur_{s}", 8))
        join("PinJoint", f"knee_{s}", f"femur_{s}", (0, -0.41, 0), body(f"tibia_{s}", 3))
        join("PinJoint", f"ankle_{s}", f"tibia_{s}", (0, -0.41, 0), body(f"talus_{s}", 0.1))
        join("WeldJoint", f"subtalar_{s}", f"talus_{s}", (-0.05, -0.04, 0), body(f"calcn_{s}", 1))
        join("PinJoint", f"mtp_{s}", f"calcn_{s}", (0.18, -0.002, 0), body(f"toes_{s}", 0.2))
    join("BallJoint", "back", "pelvis", (-0.1, 0.08, 0), body("torso", 25))
    for s, z in (("l", -0.17), ("r", 0.17)):
        join("BallJoint", f"shoulder_{s}", "torso", (-0.02, 0.40, z), body(f"humerus_{s}", 2))
        join("PinJoint", f"elbow_{s}", f"humerus_{s}", (0, -0.29, 0), body(f"ulna_{s}", 1))
        join("BallJoint", f"wrist_{s}", f"ulna_{s}", (0, -0.26, 0), body(f"hand_{s}", 0.5))
    model.finalizeConnections()
    return model


@pytest.mark.slow
def test_opensim_ik_runs_on_the_exported_files(tmp_path, capsys, monkeypatch):
    osim = pytest.importorskip("opensim")
    monkeypatch.chdir(tmp_path)  # OpenSim resolves the setup's file names from here
    run = write_run_dir(tmp_path / "run", _walk(), fps=10)
    trc = tmp_path / "walk.trc"
    assert main(["export", str(run), "--out", str(trc)]) == 0, capsys.readouterr().err
    model = _generic_model(osim)
    markers = osim.MarkerSet(str(tmp_path / "walk_markers.xml"))
    for i in range(markers.getSize()):
        model.addMarker(markers.get(i).clone())
    model.finalizeConnections()
    model.printToXML(str(tmp_path / "subject_scaled.osim"))
    ik = osim.InverseKinematicsTool(str(tmp_path / "walk_ik_setup.xml"))
    ik.setResultsDir(str(tmp_path))
    assert ik.run()
    mot = osim.TimeSeriesTable(str(tmp_path / "walk_ik.mot"))
    assert mot.getNumRows() == 12
    errors = osim.TimeSeriesTable(str(tmp_path / "ipf-jax_ik_marker_errors.sto"))
    rms = np.array(errors.getDependentColumn("marker_error_RMS").to_numpy())
    print("IK marker RMS error per frame (m):", np.round(rms, 4))
    assert np.all(rms < 0.05)  # 2.6 cm: the generic model is not scaled to the subject
