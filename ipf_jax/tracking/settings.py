"""What a tracking run is set to: :class:`TrackSettings` and the presets it is built from.

Every field is one option of :data:`ipf_jax.tracking.options.OPTIONS` (flag, help and checks are
declared there); the defaults here are the tracker's.
"""
from __future__ import annotations

from types import MappingProxyType
from typing import Mapping, NamedTuple

import numpy as np

from ..filters import registry
from .initialise import InitSettings
from .loss import LEVELS
from .shape_fit import ShapeFitSettings

DEFAULT_RESOLUTION = 320  # long side of the scoring images, pixels
DEFAULT_FPS = 20.0  # the paper's rate

#: ``--init-budget``: the full search, or a ~10x cheaper one (8 headings, one refinement round;
#: one height when given) for quick looks and end-to-end tests.
INIT_BUDGETS: Mapping[str, Mapping] = MappingProxyType({
    "default": MappingProxyType({}),
    "small": MappingProxyType(dict(headings=8, position_steps=0, modes=1, keep=8, refine_rounds=1,
                                   refine_particles=64, pattern_keep=2, pattern_sweeps=1)),
})


def init_settings(name: str = "default") -> InitSettings:
    """The :class:`InitSettings` of an ``--init-budget`` preset."""
    return InitSettings(**INIT_BUDGETS[name])


class TrackSettings(NamedTuple):
    """One run's settings (immutable; see :mod:`ipf_jax.tracking.options` for each one's meaning)."""

    filter: str = registry.DEFAULT
    filter_options: Mapping = MappingProxyType({})  # the filter's own options (top_m, layers, ...)
    budget: int | None = None
    resolution: int = DEFAULT_RESOLUTION
    fps: float | None = None
    height_m: float | None = None
    shape_file: str | None = None
    limits: str = "default"
    up_axis: str | None = None
    seed: int = 0
    chunk: int | None = None  # None: the scorer's default or what fits the filter's calls
    threads: int | None = None  # None: the scorer's default (likelihood.scorer.default_threads)
    kernel: str = "scanline"
    checkpoint_every: int = 10
    confidence_drop: float = 0.5  # re-initialise below this fraction of the recent median weight...
    confidence_patience: int = 2  # ...for this many consecutive frames
    init: InitSettings = InitSettings()
    init_pose: np.ndarray | None = None
    origin_shift: bool = True  # body origin positioning from the silhouettes (tracking.origin)
    facing_travel: bool = True  # a walker's initialisation faces the way they travel (tracking.travel)
    pelvis_prior_deg: float = 0.0  # sigma of a weak prior that the pelvis is level (tracking.prior); 0: off
    height_from_view: bool = False  # one camera, no height given: measured (geometry.placement)
    lean_prior_deg: float = 10.0  # sigma of a prior against leaning along one camera's line of sight (tracking.prior)
    floor_range: tuple[float, float] | None = None  # floor contact (tracking.contact); None = off
    shape_fit: ShapeFitSettings = ShapeFitSettings()  # the subject's proportions (frames 0: none)
    passes: int = 1  # 2: track, re-fit the shape on the track, track again (tracking.passes)
    loss_test: bool = True  # the absolute loss test, the lost status and recovery (tracking.loss)
    lost_explained: float = LEVELS.explained  # its levels (per camera shares)
    lost_covered: float = LEVELS.covered
    recovery_retry: int = 3  # while lost, a recovery attempt every this many frames
