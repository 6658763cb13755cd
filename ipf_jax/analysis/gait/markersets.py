"""Marker sets recognised without a marker map, and how markers become body points.

A marker set maps each role (a body point of :data:`ipf_jax.body.model.POINT_NAMES`, or
``pelvis``) to *alternatives*, tried in order; an alternative is a tuple of marker labels whose
per-frame mean is the role (a frame where one of them is missing is missing: a mean of fewer
markers would jump). The first alternative whose markers all exist **and hold data** is used, so
a Plug-in Gait file whose SACR marker is present but empty falls back to the mean of the PSIS.

Labels are compared after :func:`label_key`: a ``Subject:`` prefix is dropped, case and every
character other than letters and digits are ignored (``L_FCC``, ``l fcc`` and ``Bob:L.FCC`` are
one label). A file matches a set when the set's *identifying* roles resolve (heels, plus the set's
own sacrum markers); sets are tried in the order of :data:`MARKER_SETS`. Duplicate labels (Motion
Analysis files repeat some) resolve to the copy with the most frames of data.
"""
from __future__ import annotations

import re
from typing import NamedTuple

import numpy as np

from ...body.model import POINT_NAMES


class MarkerSet(NamedTuple):
    """name : shown in notes.  roles : role -> tuple of alternatives (tuples of labels).
    identify : roles that must resolve for a file to be taken as this set."""

    name: str
    roles: dict
    identify: tuple


def _sides(template: dict) -> dict:
    """Expand ``{"{s}_heel": (("{S}HEE",),)}`` into left/right roles ({s} side, {S} L/R etc.)."""
    out = {}
    for role, alts in template.items():
        if "{s}" not in role:
            out[role] = alts
            continue
        for side, letter in (("left", "L"), ("right", "R")):
            out[role.format(s=side)] = tuple(
                tuple(lab.format(S=letter, s=letter.lower()) for lab in alt) for alt in alts)
    return out


_PIG_LIMBS = {
    "{s}_heel": (("{S}HEE",),), "{s}_toe": (("{S}TOE",),), "{s}_ankle": (("{S}ANK",),),
    "{s}_knee": (("{S}KNE",),), "{s}_shoulder": (("{S}SHO",),), "{s}_elbow": (("{S}ELB",),),
    "{s}_wrist": (("{S}WRA", "{S}WRB"), ("{S}WRI",)),
}

MARKER_SETS: tuple[MarkerSet, ...] = (
    MarkerSet("ipf-jax (the 19 body points)",
              {name: ((name,),) for name in POINT_NAMES},
              ("sacrum", "left_heel", "right_heel")),
    MarkerSet("OpenSim Rajagopal", _sides({
        "sacrum": (("S2",),),
        "pelvis": (("L.ASIS", "R.ASIS", "L.PSIS", "R.PSIS"),),
        "{s}_hip": (("{S}.ASIS", "{S}.PSIS"),),
        "{s}_knee": (("{S}.Knee",),), "{s}_ankle": (("{S}.Ankle",),),
        "{s}_heel": (("{S}.Heel",),), "{s}_toe": (("{S}.Toe",),),
        "neck": (("L.Shoulder", "R.Shoulder"),),
        "{s}_shoulder": (("{S}.Shoulder",),), "{s}_elbow": (("{S}.Elbow",),),
        "{s}_wrist": (("{S}.Wrist",),),
    }), ("sacrum", "left_heel", "right_heel")),
    MarkerSet("Plug-in Gait (Vicon)", _sides({
        "sacrum": (("SACR",), ("LPSI", "RPSI")),
        "pelvis": (("LASI", "RASI", "LPSI", "RPSI"), ("LASI", "RASI", "SACR")),
        "{s}_hip": (("{S}HJC",), ("{S}ASI", "{S}PSI")),
        "neck": (("LSHO", "RSHO"), ("C7",)),
        "head": (("LFHD", "RFHD", "LBHD", "RBHD"),),
        **_PIG_LIMBS,
    }), ("sacrum", "left_heel", "right_heel")),
    MarkerSet("Helen Hayes (VSAC)", _sides({
        "sacrum": (("VSAC",),),
        "pelvis": (("LASI", "RASI", "VSAC"),),
        "neck": (("LSHO", "RSHO"), ("C7",)),
        **_PIG_LIMBS,
    }), ("sacrum", "left_heel", "right_heel")),
    MarkerSet("Qualisys (CAST: FCC heels, FM1 toes)", _sides({
        "sacrum": (("L_IPS", "R_IPS"),),
        "pelvis": (("L_IAS", "R_IAS", "L_IPS", "R_IPS"),),
        "{s}_hip": (("{S}_IAS", "{S}_IPS"),),
        "{s}_heel": (("{S}_FCC",),), "{s}_toe": (("{S}_FM1",), ("{S}_FM2",)),
        "{s}_ankle": (("{S}_FAL", "{S}_TAM"), ("{S}_FAL",)),
        "{s}_knee": (("{S}_FLE", "{S}_FME"), ("{S}_FLE",)),
        "neck": (("L_SAE", "R_SAE"), ("L_SAJ", "R_SAJ"), ("CV7",)),
        "{s}_shoulder": (("{S}_SAE",), ("{S}_SAJ",)),
        "{s}_elbow": (("{S}_HLE", "{S}_HME"), ("{S}_HLE",)),
        "{s}_wrist": (("{S}_RSP", "{S}_UHE"), ("{S}_RSP",)),
    }), ("sacrum", "left_heel", "right_heel")),
    MarkerSet("Davis (BTS)", _sides({
        "sacrum": (("sacrum",),),
        "pelvis": (("l asis", "r asis", "sacrum"),),
        "{s}_heel": (("{s} heel",),), "{s}_toe": (("{s} met",), ("{s} toe",)),
        "{s}_ankle": (("{s} mall",),), "{s}_knee": (("{s} knee 1",), ("{s} knee",)),
        "neck": (("l should", "r should"), ("c7",)),
        "{s}_shoulder": (("{s} should",),), "{s}_elbow": (("{s} elbow",),),
        "{s}_wrist": (("{s} wrist",),),
    }), ("sacrum", "left_heel", "right_heel")),
)


def label_key(label: str) -> str:
    """Normalised label: no ``Subject:`` prefix, lower case, letters and digits only."""
    return re.sub(r"[^a-z0-9]", "", str(label).split(":")[-1].lower())


def index_labels(markers: dict) -> dict:
    """key -> label, keeping for a repeated key the label with the most frames of data."""
    out = {}
    for label, xyz in markers.items():
        key = label_key(label)
        if not key:
            continue
        if key not in out or _frames(xyz) > _frames(markers[out[key]]):
            out[key] = label
    return out


def mean_of(markers: dict, labels: tuple) -> np.ndarray:
    """(T, 3) per-frame mean of ``labels`` (NaN where any is missing)."""
    return np.stack([markers[lab] for lab in labels]).mean(axis=0)


def resolve(markers: dict, roles: dict) -> tuple[dict, dict, list]:
    """Body points of ``roles`` (role -> alternatives) from ``markers`` (label -> (T, 3)).

    Returns (points, used, notes): role -> (T, 3) for the roles resolved with data; role ->
    labels used; remarks (averaging, alternatives skipped because their markers hold no data).
    """
    index = index_labels(markers)
    points, used, notes = {}, {}, []
    for role, alternatives in roles.items():
        empty = []
        for alt in alternatives:
            labels = tuple(index.get(label_key(lab)) for lab in alt)
            if None in labels:
                continue
            xyz = mean_of(markers, labels)
            if _frames(xyz) == 0:
                empty.append("+".join(labels))
                continue
            points[role], used[role] = xyz, labels
            if len(labels) > 1:
                notes.append(f"{role} = mean of {', '.join(labels)}")
            break
        for e in empty:
            notes.append(f"{role}: {e} present but never has data"
                         + (f", {'+'.join(used[role])} used" if role in used else ""))
    return points, used, notes


def recognise(markers: dict) -> tuple[MarkerSet | None, dict, dict, list]:
    """The first :data:`MARKER_SETS` entry the file matches, with :func:`resolve`'s results."""
    for mset in MARKER_SETS:
        points, used, notes = resolve(markers, mset.roles)
        if all(r in points for r in mset.identify):
            return mset, points, used, notes
    return None, {}, {}, []


def _frames(xyz: np.ndarray) -> int:
    return int(np.all(np.isfinite(xyz), axis=1).sum())
