"""Pixels to metres: ruler scale, camera calibration, view mappings, DLT.

This package imports numpy and cv2; never ``vidtrack`` or ``fits``.
"""

from calibration.camera import (
    CalibrationFile,
    CameraCalibration,
    board_points,
    calibrate_checkerboard,
    calibration_to_dict,
    calibration_to_toml,
    checkerboard_calibration,
    compact_toml,
    distort_points,
    find_board,
    load_calibration,
    parse_calibration,
    parse_pattern,
    plane_scale,
    read_calibration_images,
    undistort_points,
)
from calibration.dlt import DLT, estimate_dlt, project, reconstruct_with_known, triangulate
from calibration.errors import InputError
from calibration.scale import Scale, given_scale, pixel_point, ruler_scale
from calibration.views import ViewMapping, parse_axes, pixel_to_world, view_mapping, world_to_pixel

__all__ = [
    "InputError",
    # scale
    "Scale", "ruler_scale", "given_scale", "pixel_point",
    # camera
    "CameraCalibration", "CalibrationFile", "calibrate_checkerboard",
    "checkerboard_calibration", "compact_toml", "find_board",
    "board_points", "plane_scale", "undistort_points", "distort_points",
    "calibration_to_toml", "calibration_to_dict", "load_calibration", "parse_calibration",
    "read_calibration_images", "parse_pattern",
    # views
    "ViewMapping", "view_mapping", "pixel_to_world", "world_to_pixel", "parse_axes",
    # dlt
    "DLT", "estimate_dlt", "project", "triangulate", "reconstruct_with_known",
]
