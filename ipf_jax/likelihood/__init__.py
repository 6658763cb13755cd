"""The silhouette likelihood w = Nc / (Ns + Nm): the exact integer raster (:mod:`.raster`), the batched
scorer (:mod:`.scorer`) and the per-pixel model silhouette in NumPy (:mod:`.model_mask`).
"""
