"""Body model: topology (:mod:`.model`), subject shape (:mod:`.shape`), DOF ranges (:mod:`.limits`)."""
from .limits import Limits, load_limits
from .model import (
           DOF_NAMES,
           NUM_DOF,
           NUM_POINTS,
           NUM_SEGMENTS,
           POINT_NAMES,
           SEGMENT_NAMES,
)
from .shape import BodyShape, default_shape, load_shape

__all__ = ["BodyShape", "default_shape", "load_shape", "Limits", "load_limits", "DOF_NAMES",
           "POINT_NAMES", "SEGMENT_NAMES", "NUM_DOF", "NUM_POINTS", "NUM_SEGMENTS"]
