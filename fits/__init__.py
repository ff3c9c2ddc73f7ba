"""Numbers only: throw models, blade release, least squares, response surfaces, ANOVA.

This package imports numpy, scipy, pandas and statsmodels; never cv2, never
``vidtrack`` or ``calibration``.
"""

from fits.errors import InputError

__all__ = ["InputError"]
