"""Pixels to metres: ruler scale, camera calibration, view mappings, DLT.

This package imports numpy and cv2; never ``vidtrack`` or ``fits``.

Its names are loaded from their modules on first use (PEP 562): ``import calibration``
(and ``calibration.errors``, which every vidtrack command imports) stays light, while the
camera model pulls in scipy.

Messages are log records under the ``calibration`` logger (a ``NullHandler`` only, as a
library's should be).
"""

import logging

logging.getLogger(__name__).addHandler(logging.NullHandler())

_EXPORTS = {
    "calibration.errors": ("InputError",),
    "calibration.scale": ("Scale", "ruler_scale", "given_scale", "pixel_point"),
    "calibration.camera": ("CameraCalibration", "undistort_points", "distort_points"),
    "calibration.checkerboard": (
        "calibrate_checkerboard", "checkerboard_calibration", "find_board", "board_points",
        "plane_scale", "read_calibration_images", "parse_pattern"),
    "calibration.calibration_file": (
        "CalibrationFile", "compact_toml", "calibration_to_toml", "calibration_to_dict",
        "load_calibration", "parse_calibration"),
    "calibration.views": ("ViewMapping", "view_mapping", "pixel_to_world", "world_to_pixel",
                          "parse_axes"),
    "calibration.dlt": ("DLT", "estimate_dlt", "project", "triangulate",
                        "reconstruct_with_known"),
}
_MODULE_OF = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = list(_MODULE_OF)


def __getattr__(name):
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'calibration' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_MODULE_OF))
