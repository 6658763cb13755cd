"""What kind of file a calibration path holds, from its content (the extension only breaks ties).

:func:`kind_of` returns the reader's key, or raises one :class:`ipf_jax.errors.IPFError` line
saying what the file is instead (an image, a video, a TRC, a Pose2Sim project ``Config.toml``,
a ``dataset.json`` ...) and which calibration formats are read.
"""
from __future__ import annotations

import re
from pathlib import Path

from ...errors import IPFError
from ._xml import MAX_BYTES, decode

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

SUPPORTED = ("bodytrack .cal, OpenCV .xml/.yml, Pose2Sim/anipose .toml, ipf-jax .json, "
             "Qualisys .qca.txt, Vicon .xcp, OptiTrack .mcal; see docs/formats.md")
HEAD = 1 << 16  # bytes looked at

_MAGIC = [  # (prefix, offset, what it is)
    (b"\x89PNG", 0, "a PNG image"), (b"\xff\xd8\xff", 0, "a JPEG image"),
    (b"GIF8", 0, "a GIF image"), (b"II*\x00", 0, "a TIFF image"), (b"MM\x00*", 0, "a TIFF image"),
    (b"RIFF", 0, "a RIFF file (an AVI video or a WAV sound)"), (b"ftyp", 4, "an MP4/MOV video"),
    (b"\x1a\x45\xdf\xa3", 0, "a Matroska/WebM video"), (b"PK\x03\x04", 0, "a ZIP/NPZ archive"),
    (b"%PDF", 0, "a PDF document"),
]
_POSE2SIM_SECTIONS = {"project", "pose", "synchronization", "personAssociation", "triangulation",
                      "filtering", "markerAugmentation", "kinematics", "logging"}


def _not_a_calibration(what: str, path: Path, hint: str = "") -> IPFError:
    return IPFError(f"this is {what}, not a calibration{hint}; calibrations read: {SUPPORTED}",
                    path)


def _xml_kind(text: str, path: Path) -> str:
    body = re.sub(r"<\?.*?\?>|<!--.*?-->", "", text, flags=re.S).lstrip()
    m = re.match(r"<\s*([A-Za-z_][\w.:-]*)", body)
    root = m.group(1) if m else ""
    if root == "opencv_storage":
        return "opencv"
    if root == "calibration" or root.startswith("QTM_Parameters"):
        return "qualisys"
    if root == "Cameras" or (root and "<KeyFrame" in body and "DEVICEID" in body):
        return "vicon"
    if root == "calibrationProfile":
        return "optitrack"
    if not root:
        return "opencv"  # malformed XML: the OpenCV reader says what is wrong with it
    raise _not_a_calibration(f"an XML file whose root element is <{root[:40]}>", path)


def _toml_kind(text: str, path: Path) -> str:
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        return "toml"  # the TOML reader says where the syntax is wrong
    tables = {k: v for k, v in doc.items() if isinstance(v, dict)}
    if any("matrix" in t for t in tables.values()):
        return "toml"
    if set(tables) & _POSE2SIM_SECTIONS:
        raise _not_a_calibration(
            "a Pose2Sim project file (Config.toml: [project], [pose], ... settings)", path,
            " (its calibration is the Calib*.toml file in the calibration folder)")
    return "toml"


def kind_of(path: Path) -> str:
    """One of ``cal``, ``opencv``, ``toml``, ``json``, ``qualisys``, ``vicon``, ``optitrack``."""
    path = Path(path)
    try:
        with path.open("rb") as f:
            head = f.read(HEAD)
        size = path.stat().st_size
    except FileNotFoundError:
        raise IPFError("calibration file not found", path) from None
    except IsADirectoryError:
        raise IPFError("calibration path is a folder without a known calibration", path) from None
    except OSError as e:
        raise IPFError(f"cannot read calibration file ({e.strerror or e})", path) from None
    if size > MAX_BYTES:
        raise IPFError(f"calibration file is {size / 2**20:.0f} MB: too large for a calibration "
                       f"(at most {MAX_BYTES >> 20} MB)", path)
    if not head.strip():
        raise IPFError("empty calibration file", path)
    for magic, at, what in _MAGIC:
        if head[at:at + len(magic)] == magic:
            raise _not_a_calibration(what, path)
    if head[:2] == b"BM" and len(head) > 14:
        raise _not_a_calibration("a BMP image", path)
    if len(head) > 1 and head[1] == 0x50 and head[0] < 0x20 and path.suffix.lower() == ".c3d":
        raise _not_a_calibration("a C3D motion file", path)
    text = decode(head)
    binary = sum(ch == "\x00" or (ord(ch) < 32 and ch not in "\t\n\r\f\v") for ch in text[:4096])
    if binary > 8:
        hint = (" (Motive before 3.2 writes a binary .cal: export an .mcal from Motive 3.2 or "
                "later)") if path.suffix.lower() == ".cal" else ""
        raise _not_a_calibration("a binary file", path, hint)
    stripped = text.lstrip()
    suffix = path.suffix.lower()
    if stripped.startswith("<"):
        return _xml_kind(stripped, path)
    if stripped.startswith("%YAML") or suffix in (".yml", ".yaml"):
        return "opencv"
    if stripped.startswith("PathFileType"):
        raise _not_a_calibration("a TRC marker file", path)
    if stripped.startswith("frame,time_s"):
        raise _not_a_calibration("an ipf-jax joints.csv/poses.csv table", path)
    if stripped.startswith("{"):
        if re.search(r'"(masks|video|images)"\s*:', text) and '"calibration"' in text:
            raise _not_a_calibration("a dataset.json (a description of a recording)", path,
                                     " (give its folder to 'ipf-jax track'; its 'calibration' key "
                                     "names the calibration)")
        return "json"
    first = stripped.split(None, 1)[0] if stripped else ""
    try:
        float(first)
        return "cal"
    except ValueError:
        pass
    if suffix == ".toml" or re.search(r"^\s*(\[[^\]\n]+\]|[\w.\"'-]+\s*=)", text, re.M):
        return _toml_kind(text, path)
    raise IPFError(f"unknown calibration format (calibrations read: {SUPPORTED})", path)
