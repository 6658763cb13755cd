"""Pictures: overlays of the fitted model, rendered runs (videos, PNGs), and self-rendered synthetic
scenes drawn with the tracker's own capsule model.
"""
