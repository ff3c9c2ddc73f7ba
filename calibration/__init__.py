"""Pixels to metres: ruler scale, camera calibration, view mappings, DLT.

This package imports numpy and cv2; never ``vidtrack`` or ``fits``.
"""

from calibration.errors import InputError

__all__ = ["InputError"]
