"""The NumPy reference: the likelihood pipeline, simple and obviously right, the oracle in tests.

:mod:`.likelihood` counts pixels particle by particle on the host geometry
(:mod:`ipf_jax.geometry.host`: textbook float64 FK and projection) and the model silhouette drawn
row by row in exact integers (:mod:`ipf_jax.likelihood.model_mask`); :mod:`.scanline` is the
vectorised NumPy scanline, the fair NumPy baseline of the benchmarks. Only tests, ``ipf-jax bench`` and ``ipf-jax score --backend
numpy`` use it (an import-linter contract in pyproject.toml). Pixel counts must equal the JAX
kernels' exactly given the same 2D capsules; geometry agrees to :data:`GEOMETRY_ATOL_M` /
:data:`PIXEL_ATOL`.
"""
GEOMETRY_ATOL_M = 1e-5  # metres: FK in float32 (JAX) vs float64 (NumPy)
PIXEL_ATOL = 2e-3  # pixels: projection float32 vs float64 (and vs OpenCV projectPoints)
