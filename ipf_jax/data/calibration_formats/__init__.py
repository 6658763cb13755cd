"""Readers for the calibration files of motion-capture labs: Qualisys ``.qca.txt``, Vicon ``.xcp``,
OptiTrack Motive ``.mcal``, and the recognition of a file's kind from its content.

Each reader returns :class:`ipf_jax.geometry.camera.Camera` objects (OpenCV conventions, metres) and raises
:class:`ipf_jax.errors.IPFError` naming the file. :func:`ipf_jax.data.calibration.read_calibration`
dispatches to them through :func:`.sniff.kind_of`.
"""
from .optitrack import read_optitrack, write_optitrack
from .qualisys import read_qualisys, write_qualisys
from .sniff import SUPPORTED, kind_of
from .vicon import read_vicon, write_vicon

__all__ = ["read_qualisys", "write_qualisys", "read_vicon", "write_vicon", "read_optitrack",
           "write_optitrack", "kind_of", "SUPPORTED"]
