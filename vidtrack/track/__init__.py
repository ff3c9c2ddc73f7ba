"""Tracking one view: background, segmentation, selection, refinement -> a per-frame ``Track``."""
