"""OpenSim companions of a TRC export: a marker set for the 19 points and an IK setup file.

The marker set attaches each ipf-jax point, as a marker of the same name, to the body of OpenSim's
generic full-body model (Rajagopal et al. 2016, ``Rajagopal2015.osim``; gait2392 shares the leg
bodies) that holds the joint it stands for: joint centres sit at the child body's origin, which
is where those models put the joint (knee = ``tibia`` origin, ankle = ``talus``, shoulder =
``humerus``, elbow = ``ulna``, wrist = ``hand``, toe = ``toes``, the ball of the foot); the hips,
heel, sacrum, neck and head at generic offsets in ``pelvis``, ``calcn`` and ``torso``. The IK
setup weights joint centres above the points a silhouette places less well (see
:data:`WEIGHTS`). docs/export.md walks through scaling the generic model and running IK.
"""
from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import escape

from ...body.model import POINT_NAMES
from ...errors import IPFError

#: point -> (body, location in the body frame, metres); OpenSim axes: x forward, y up, z right
MARKERS = {
    "sacrum": ("pelvis", (-0.06, -0.02, 0.0)),
    "left_hip": ("pelvis", (-0.056, -0.078, -0.077)),
    "left_knee": ("tibia_l", (0.0, 0.0, 0.0)),
    "left_ankle": ("talus_l", (0.0, 0.0, 0.0)),
    "left_heel": ("calcn_l", (0.0, 0.01, 0.0)),
    "left_toe": ("toes_l", (0.0, 0.0, 0.0)),
    "right_hip": ("pelvis", (-0.056, -0.078, 0.077)),
    "right_knee": ("tibia_r", (0.0, 0.0, 0.0)),
    "right_ankle": ("talus_r", (0.0, 0.0, 0.0)),
    "right_heel": ("calcn_r", (0.0, 0.01, 0.0)),
    "right_toe": ("toes_r", (0.0, 0.0, 0.0)),
    "neck": ("torso", (-0.03, 0.42, 0.0)),
    "head": ("torso", (-0.01, 0.62, 0.0)),
    "left_shoulder": ("humerus_l", (0.0, 0.0, 0.0)),
    "left_elbow": ("ulna_l", (0.0, 0.0, 0.0)),
    "left_wrist": ("hand_l", (0.0, 0.0, 0.0)),
    "right_shoulder": ("humerus_r", (0.0, 0.0, 0.0)),
    "right_elbow": ("ulna_r", (0.0, 0.0, 0.0)),
    "right_wrist": ("hand_r", (0.0, 0.0, 0.0)),
}
#: IK weights: limb joint centres first; heel/toe, then the trunk points, whose anatomy the
#: silhouette model defines loosely (docs/formats.md)
WEIGHTS = {**{p: 10.0 for p in POINT_NAMES if p.split("_", 1)[-1] in
              ("hip", "knee", "ankle", "shoulder", "elbow", "wrist")},
           **{p: 5.0 for p in POINT_NAMES if p.endswith(("heel", "toe"))},
           "sacrum": 1.0, "neck": 2.0, "head": 1.0}


def marker_set_xml(markers: dict = MARKERS) -> str:
    """The OpenSim 4 ``MarkerSet`` document (load it onto a model, or give it to the Scale tool)."""
    rows = []
    for name in POINT_NAMES:
        body, loc = markers[name]
        rows.append(f'\t\t\t\t<Marker name="{escape(name)}">\n'
                    f"\t\t\t\t\t<socket_parent_frame>/bodyset/{escape(body)}</socket_parent_frame>\n"
                    f"\t\t\t\t\t<location>{' '.join(f'{v:.6g}' for v in loc)}</location>\n"
                    "\t\t\t\t\t<fixed>false</fixed>\n\t\t\t\t</Marker>")
    return ('<?xml version="1.0" encoding="UTF-8" ?>\n<OpenSimDocument Version="40000">\n'
            '\t<MarkerSet name="ipf-jax">\n\t\t<objects>\n' + "\n".join(rows)
            + "\n\t\t</objects>\n\t\t<groups />\n\t</MarkerSet>\n</OpenSimDocument>\n")


def ik_setup_xml(trc: str, model: str, motion: str, t0: float, t1: float,
                 weights: dict = WEIGHTS) -> str:
    """The OpenSim ``InverseKinematicsTool`` setup for a TRC of the 19 points."""
    tasks = "\n".join(f'\t\t\t\t<IKMarkerTask name="{escape(p)}">\n\t\t\t\t\t<apply>true</apply>\n'
                      f"\t\t\t\t\t<weight>{weights[p]:g}</weight>\n\t\t\t\t</IKMarkerTask>"
                      for p in POINT_NAMES)
    return ('<?xml version="1.0" encoding="UTF-8" ?>\n<OpenSimDocument Version="40000">\n'
            '\t<InverseKinematicsTool name="ipf-jax">\n'
            f"\t\t<model_file>{escape(model)}</model_file>\n"
            "\t\t<constraint_weight>Inf</constraint_weight>\n\t\t<accuracy>1e-05</accuracy>\n"
            f"\t\t<IKTaskSet>\n\t\t\t<objects>\n{tasks}\n\t\t\t</objects>\n\t\t\t<groups />\n"
            "\t\t</IKTaskSet>\n"
            f"\t\t<marker_file>{escape(trc)}</marker_file>\n"
            "\t\t<coordinate_file>Unassigned</coordinate_file>\n"
            f"\t\t<time_range>{t0:.6f} {t1:.6f}</time_range>\n"
            f"\t\t<output_motion_file>{escape(motion)}</output_motion_file>\n"
            "\t\t<report_errors>true</report_errors>\n"
            "\t\t<report_marker_locations>false</report_marker_locations>\n"
            "\t</InverseKinematicsTool>\n</OpenSimDocument>\n")


def write_opensim_files(trc: Path, t0: float, t1: float, model: str = "subject_scaled.osim"
                        ) -> tuple[Path, Path]:
    """``<stem>_markers.xml`` and ``<stem>_ik_setup.xml`` beside a TRC; returns their paths."""
    trc = Path(trc)
    markers = trc.with_name(trc.stem + "_markers.xml")
    setup = trc.with_name(trc.stem + "_ik_setup.xml")
    for path, text in ((markers, marker_set_xml()),
                       (setup, ik_setup_xml(trc.name, model, trc.stem + "_ik.mot", t0, t1))):
        tmp = path.with_name(path.name + ".tmp")
        try:
            tmp.write_text(text)
            tmp.replace(path)
        except OSError as e:
            tmp.unlink(missing_ok=True)
            raise IPFError(f"cannot write ({e.strerror or e})", path) from None
    return markers, setup
