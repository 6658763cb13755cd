"""Validate a C3D file's header and parameter section in Python before ezc3d (C++) reads it.

ezc3d trusts the counts it reads: a damaged file can make it read past the end of a buffer, loop
for a long time, or allocate gigabytes before failing. :func:`check_c3d` walks the same structure
with bounds checked at every step and raises one :class:`~ipf_jax.errors.IPFError` naming the
file and what is inconsistent. It checks (C3D User Guide, c3d.org):

* file size: at least the 512-byte header, at most :data:`MAX_FILE_BYTES`;
* header (block 1): key byte 0x50, parameter block in the file, point and analog counts, frame
  numbers, frame rate finite and positive, data start block after the parameter section;
* parameter section: its 4-byte header (block count, processor type 84/85/86: Intel, DEC, MIPS)
  inside the file; every group and parameter record (name length, group id, data type -1/1/2/4,
  at most 7 dimensions, data inside the record and the section, forward links), at most
  :data:`MAX_RECORDS` records; parameters only in groups that exist;
* the counts ezc3d will read with (it lets POINT:USED, POINT:FRAMES, POINT:RATE, ANALOG:USED and
  ANALOG:RATE override the header) are finite and non-negative, and the data section (frames x
  (4 x points + analog samples) words of 2 or 4 bytes) fits in the file (not truncated);
* with analog channels, ANALOG:SCALE and ANALOG:OFFSET hold a value per channel and
  ANALOG:GEN_SCALE exists (ezc3d indexes them unchecked: a cut parameter section aborted it).

The result (:class:`C3DLayout`) also carries the few parameters the gait reader uses.
"""
from __future__ import annotations

import struct
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...errors import IPFError

BLOCK = 512
#: ezc3d holds about 7 bytes of objects per byte of file: 128 MiB keeps it under 1 GB.
MAX_FILE_BYTES = 128 << 20
MAX_RECORDS = 20000
_PROCESSORS = {84: "Intel", 85: "DEC", 86: "MIPS"}


class C3DLayout(NamedTuple):
    """What the header and parameters say. frames : stored 3-D frames.  first_frame : 0-based
    (ezc3d's convention).  rate : POINT:RATE or the header's.  params : (GROUP, NAME) -> values
    (numbers as a flat float array, strings as a list)."""

    processor: str
    points: int
    analog_per_frame: int
    frames: int
    first_frame: int
    rate: float
    float_data: bool
    data_start: int
    params: dict


def check_c3d(path: str | Path) -> C3DLayout:
    """Validate ``path`` (see module docs); raises :class:`IPFError` naming the file."""
    path = Path(path)
    try:
        size = path.stat().st_size
    except OSError as e:
        raise IPFError(f"cannot read C3D ({e})", path) from None
    if size < BLOCK:
        raise IPFError(f"not a C3D file: {size} bytes, shorter than the 512-byte header", path)
    if size > MAX_FILE_BYTES:
        raise IPFError(f"C3D file of {size / 2**20:.0f} MiB is larger than the "
                       f"{MAX_FILE_BYTES >> 20} MiB this reader accepts (cut the trial)", path)
    try:
        with path.open("rb") as f:
            head = f.read(BLOCK)
            pblock = head[0]
            if head[1] != 0x50:
                raise IPFError("not a C3D file (byte 2 of the header is not the C3D key 0x50)",
                               path)
            if pblock < 2 or (pblock - 1) * BLOCK + 4 > size:
                raise IPFError(f"C3D header points the parameter section at block {pblock}, "
                               f"outside the file ({size} bytes)", path)
            f.seek((pblock - 1) * BLOCK)
            phead = f.read(4)
            n_blocks, proc = phead[2], phead[3]
            if proc not in _PROCESSORS:
                raise IPFError(f"C3D processor type {proc} is not 84, 85 or 86 (corrupt "
                               "parameter section)", path)
            if n_blocks < 1 or (pblock - 1 + n_blocks) * BLOCK > size:
                raise IPFError(f"C3D parameter section of {n_blocks} blocks runs past the end "
                               "of the file", path)
            f.seek((pblock - 1) * BLOCK)
            section = f.read(n_blocks * BLOCK)
    except OSError as e:
        raise IPFError(f"cannot read C3D ({e})", path) from None
    endian = ">" if proc == 86 else "<"
    words = struct.unpack(endian + "12H", head[:24])
    h_points, h_analog, first, last, h_start, h_per_frame = (words[1], words[2], words[3],
                                                              words[4], words[8], words[9])
    h_scale = _float(head[12:16], proc)
    h_rate = _float(head[20:24], proc)
    params = _parameters(section, proc, path)
    return _layout(path, size, proc, pblock, n_blocks, params, h_points, h_analog, first, last,
                   h_start, h_per_frame, h_scale, h_rate)


def _layout(path, size, proc, pblock, n_blocks, params, h_points, h_analog, first, last,
            h_start, h_per_frame, h_scale, h_rate) -> C3DLayout:
    """The counts ezc3d will read with (it lets the parameters override the header), checked."""
    for key in (("POINT", "USED"), ("POINT", "RATE"), ("POINT", "FRAMES"), ("POINT", "SCALE"),
                ("ANALOG", "USED"), ("ANALOG", "RATE")):
        v = params.get(key)
        if v is None:
            continue
        if not isinstance(v, np.ndarray) or v.size == 0 or not np.all(np.isfinite(v)):
            raise IPFError(f"C3D parameter {key[0]}:{key[1]} holds no finite number", path)
        if key[1] in ("USED", "FRAMES", "RATE") and v.ravel()[0] < 0:
            raise IPFError(f"C3D parameter {key[0]}:{key[1]} is negative ({v.ravel()[0]:g}); "
                           "trials over 32767 frames are not supported", path)
    # ezc3d: a first frame of 0 means the header counts from 0, else from 1
    f0, l0 = (first - 1, last - 1 if last else 0) if first else (0, last)
    frames = l0 - f0 + 1
    p_frames = _int(params, ("POINT", "FRAMES"), 0)
    if p_frames:
        frames = p_frames
    points = _int(params, ("POINT", "USED"), h_points)
    rate = _num(params, ("POINT", "RATE"), 0.0) or h_rate
    per_frame = h_per_frame
    a_rate = _num(params, ("ANALOG", "RATE"), 0.0)
    if int(rate) != 0 and ("ANALOG", "RATE") in params and int(a_rate / rate) != per_frame:
        per_frame = int(a_rate / rate)
    analogs = _int(params, ("ANALOG", "USED"), h_analog // h_per_frame if h_per_frame else 0)
    analog_per_frame = analogs * per_frame
    for name in ("USED", "SCALE"):
        if _count(params, "POINT", name) < 1:
            raise IPFError(f"C3D POINT:{name} is missing (corrupt or cut parameter section)", path)
    if analogs and analog_per_frame:
        # ezc3d scales every analog sample by its channel's SCALE and OFFSET (and GEN_SCALE)
        # without checking that they exist: a missing entry is read out of bounds
        for name in ("SCALE", "OFFSET"):
            n = _count(params, "ANALOG", name)
            if n < analogs:
                raise IPFError(f"C3D ANALOG:{name} holds {n} values for {analogs} analog channels "
                               "(corrupt or cut parameter section)", path)
        if _count(params, "ANALOG", "GEN_SCALE") < 1:
            raise IPFError("C3D ANALOG:GEN_SCALE is missing (corrupt or cut parameter section)",
                           path)
    if points and not (np.isfinite(rate) and 0 < rate <= 1e6):
        raise IPFError(f"C3D frame rate {rate!r} is not a positive number", path)
    if not np.isfinite(h_scale) or h_scale == 0:
        raise IPFError(f"C3D point scale factor {h_scale!r} is zero or not finite", path)
    if frames <= 0 and (points or analog_per_frame):
        raise IPFError(f"C3D header frame range {first}-{last} holds no frames", path)
    if points == 0:
        raise IPFError("C3D file holds no 3-D points (POINT:USED is 0)", path)
    if h_start < pblock + n_blocks:
        raise IPFError(f"C3D data section (block {h_start}) starts inside the parameter section "
                       f"(blocks {pblock}-{pblock + n_blocks - 1})", path)
    word = 4 if h_scale < 0 else 2
    data_bytes = frames * (4 * points + analog_per_frame) * word
    avail = size - (h_start - 1) * BLOCK
    if data_bytes > avail:
        raise IPFError(f"C3D data truncated: {frames} frames of {points} points and "
                       f"{analog_per_frame} analog samples need {data_bytes} bytes, the file "
                       f"holds {max(avail, 0)} after block {h_start}", path)
    return C3DLayout(_PROCESSORS[proc], points, analog_per_frame, frames, max(f0, 0),
                     float(rate), h_scale < 0, h_start, params)


def _float(b: bytes, proc: int) -> float:
    if proc == 85:  # DEC: 16-bit words swapped, exponent bias 2 more than IEEE
        return struct.unpack("<f", b[2:4] + b[0:2])[0] / 4.0
    return struct.unpack((">" if proc == 86 else "<") + "f", b)[0]


def _parameters(section: bytes, proc: int, path: Path) -> dict:
    """Walk every record of the parameter section with bounds checks -> (GROUP, NAME) -> value."""
    endian = ">" if proc == 86 else "<"
    groups, pending, params = {}, [], {}
    pos, count, end = 4, 0, len(section)
    while pos + 2 <= end:
        n = abs(struct.unpack("b", section[pos:pos + 1])[0])
        gid = struct.unpack("b", section[pos + 1:pos + 2])[0]
        if n == 0:
            break
        count += 1
        if count > MAX_RECORDS:
            raise IPFError(f"C3D parameter section holds more than {MAX_RECORDS} records", path)
        if gid == 0:
            raise IPFError(f"C3D parameter record at byte {pos} has group id 0", path)
        name_end = pos + 2 + n
        if name_end + 2 > end:
            raise IPFError("C3D parameter section ends inside a record name", path)
        raw_name = section[pos + 2:name_end]
        if not raw_name.strip() or not all(32 <= c < 127 for c in raw_name):
            raise IPFError(f"C3D parameter or group name at byte {pos} is not printable ASCII",
                           path)
        name = raw_name.decode("ascii").strip().upper()
        offset = struct.unpack(endian + "h", section[name_end:name_end + 2])[0]
        nxt = name_end + offset if offset else end
        if offset < 0 or (offset and nxt <= name_end) or nxt > end:
            raise IPFError(f"C3D parameter {name!r} links outside the parameter section", path)
        body = name_end + 2
        if gid < 0:
            if -gid in groups or name in groups.values():
                raise IPFError(f"C3D group {name!r} (id {-gid}) is defined twice", path)
            if body + 1 > nxt or (offset and body + 1 + section[body] != nxt):
                raise IPFError(f"C3D group {name!r}: its description does not end where the "
                               "next record starts (corrupt parameter section)", path)
            groups[-gid] = name
        else:
            if body + 2 > nxt:
                raise IPFError(f"C3D parameter {name!r} is shorter than its type and size bytes",
                               path)
            dtype = struct.unpack("b", section[body:body + 1])[0]
            ndim = section[body + 1]
            if dtype not in (-1, 1, 2, 4):
                raise IPFError(f"C3D parameter {name!r} has data type {dtype} (not -1, 1, 2 or "
                               "4)", path)
            if ndim > 7 or body + 2 + ndim > nxt:
                raise IPFError(f"C3D parameter {name!r} has {ndim} dimensions (corrupt)", path)
            dims = tuple(section[body + 2:body + 2 + ndim])
            nbytes = abs(dtype) * int(np.prod(dims, dtype=np.int64)) if ndim else abs(dtype)
            data = body + 2 + ndim
            if data + nbytes + 1 > nxt or (offset and data + nbytes + 1 + section[data + nbytes]
                                           != nxt):
                raise IPFError(f"C3D parameter {name!r}: {nbytes} bytes of data and its "
                               "description do not end where the next record starts (corrupt "
                               "parameter section)", path)
            pending.append((gid, name, _decode(section[data:data + nbytes], dtype, dims, proc,
                                              endian)))
        if not offset:
            break
        pos = nxt
    for gid, name, value in pending:
        if gid not in groups:
            raise IPFError(f"C3D parameter {name!r} belongs to group {gid}, which is not defined",
                           path)
        params[(groups[gid], name)] = value
    return params


def _decode(raw: bytes, dtype: int, dims: tuple, proc: int, endian: str):
    if dtype == -1:
        if len(dims) <= 1:
            return [raw.decode("latin-1").strip()]
        width = dims[0]
        if width == 0:
            return [""] * int(np.prod(dims[1:], dtype=np.int64))
        return [raw[i:i + width].decode("latin-1").strip() for i in range(0, len(raw), width)]
    if dtype == 1:
        return np.frombuffer(raw, dtype=np.int8).astype(float)
    if dtype == 2:
        return np.frombuffer(raw, dtype=endian + "i2").astype(float)
    if proc == 85:
        return np.array([_float(raw[i:i + 4], proc) for i in range(0, len(raw), 4)])
    return np.frombuffer(raw, dtype=endian + "f4").astype(float)


def _count(params: dict, group: str, name: str) -> int:
    """Values of GROUP:NAME and its continuations NAME2, NAME3, ... (0 when absent)."""
    total, k, key = 0, 2, (group, name)
    while key in params:
        v = params[key]
        total += v.size if isinstance(v, np.ndarray) else len(v)
        key, k = (group, f"{name}{k}"), k + 1
    return total


def _num(params: dict, key: tuple, default: float) -> float:
    v = params.get(key)
    if isinstance(v, np.ndarray) and v.size:
        return float(v.ravel()[0])
    return float(default)


def _int(params: dict, key: tuple, default: int | None = None) -> int | None:
    v = params.get(key)
    if isinstance(v, np.ndarray) and v.size and np.isfinite(v.ravel()[0]):
        x = int(v.ravel()[0])
        return x + 65536 if x < 0 else x  # counts are stored as signed 16-bit words
    return default


