"""The page's zoom: the footage's own pixels around one pixel, magnified.

:func:`zoom_image` cuts the square of :data:`ZOOM_HALF_PX` frame pixels each side of a
pixel out of a frame as decoded (no marks drawn over it), magnifies it
:data:`ZOOM_FACTOR` times with each frame pixel a block of that size (nothing
interpolated), and outlines the centre pixel. Outside the frame the square is black.
"""

import math

import numpy as np

__all__ = ["zoom_image", "zoom_centre", "ZOOM_HALF_PX", "ZOOM_FACTOR", "ZOOM_COLOUR"]

#: Frame pixels shown each side of the centre pixel.
ZOOM_HALF_PX = 20
#: Drawn pixels a frame pixel becomes (each side).
ZOOM_FACTOR = 8
#: Colour (B, G, R) of the outline of the centre pixel.
ZOOM_COLOUR = (0, 255, 255)


def zoom_centre(at_px, shape):
    """The frame pixel ``(column, row)`` that ``at_px`` falls in (pixel centres at whole
    numbers).

    Raises
    ------
    ValueError
        ``at_px`` is not two finite numbers, or falls outside the frame (``shape``:
        rows, columns).
    """
    if (len(at_px) != 2 or not all(isinstance(x, float) and math.isfinite(x)
                                   for x in at_px)):
        raise ValueError(f"zoom: u and v must be the frame pixel to magnify (two finite "
                         f"numbers), got {list(at_px)!r}")
    u, v = (int(math.floor(x + 0.5)) for x in at_px)
    if not (0 <= u < shape[1] and 0 <= v < shape[0]):
        raise ValueError(f"zoom: pixel {list(at_px)!r} is outside the frame; expected u in "
                         f"0..{shape[1] - 1} and v in 0..{shape[0] - 1}")
    return u, v


def zoom_image(frame, centre):
    """The magnified square around ``centre`` (see the module's docstring).

    Parameters
    ----------
    frame : numpy.ndarray
        The frame as an 8-bit BGR image, ``(rows, columns, 3)``.
    centre : (int, int)
        The centre pixel ``(column, row)`` (:func:`zoom_centre`).

    Returns
    -------
    numpy.ndarray
        ``(n, n, 3)`` uint8, ``n = (2 * ZOOM_HALF_PX + 1) * ZOOM_FACTOR``: frame pixel
        ``(centre[0] + j, centre[1] + i)`` fills the block of rows
        ``(ZOOM_HALF_PX + i) * ZOOM_FACTOR`` onwards and the like columns.
    """
    import cv2

    side = 2 * ZOOM_HALF_PX + 1
    crop = np.zeros((side, side, 3), dtype=np.uint8)
    u0, v0 = centre[0] - ZOOM_HALF_PX, centre[1] - ZOOM_HALF_PX
    rows, cols = frame.shape[:2]
    a, b = max(v0, 0), min(v0 + side, rows)
    c, d = max(u0, 0), min(u0 + side, cols)
    crop[a - v0:b - v0, c - u0:d - u0] = frame[a:b, c:d]
    big = np.repeat(np.repeat(crop, ZOOM_FACTOR, axis=0), ZOOM_FACTOR, axis=1)
    first, last = ZOOM_HALF_PX * ZOOM_FACTOR, (ZOOM_HALF_PX + 1) * ZOOM_FACTOR - 1
    cv2.rectangle(big, (first, first), (last, last), ZOOM_COLOUR, 1)
    return big
