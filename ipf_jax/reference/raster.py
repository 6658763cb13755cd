"""Reference counts: the model silhouette (:mod:`ipf_jax.likelihood.model_mask`, drawn row by row in
exact integers over the whole image) against a mask, int64, no region of interest."""
from __future__ import annotations

import numpy as np

from ..likelihood.model_mask import model_mask

__all__ = ["model_mask", "counts_from_caps"]


def counts_from_caps(caps: np.ndarray, mask: np.ndarray) -> tuple[int, int, int]:
    """(Nc, Ns, Nm) of one capsule set against one boolean mask (H, W)."""
    model = model_mask(caps, *mask.shape)
    nc = int(np.count_nonzero(model & mask))
    return nc, int(np.count_nonzero(mask)) - nc, int(np.count_nonzero(model)) - nc
