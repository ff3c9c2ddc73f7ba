"""The orthographic mapping of a view: image pixels to world metres and back.

A view's camera looks square onto one world plane (docs/reference.md): ``front`` onto XOY,
``top`` onto XOZ. Its mapping needs three things: which world axis runs along
increasing image column and which along increasing row (``axes``, e.g. ``("+x", "-y")``:
column -> +X, row -> -Y, so up in the image is up in the world), the pixel position of
the world origin O (``origin_px``), and the scale in metres per pixel. With a camera
calibration the observed pixels are undistorted first, and ``origin_px`` (read off the
raw image) is undistorted the same way.

World coordinates come back in the order of the world axes (x before y before z),
whatever the order of ``axes``: a front view gives columns (x, y), a top view (x, z).
"""

import json
from dataclasses import dataclass

import numpy as np

from calibration.camera import CameraCalibration, distort_points, undistort_points
from calibration.errors import InputError
from calibration.scale import _point_array

__all__ = ["ViewMapping", "parse_axes", "view_mapping", "pixel_to_world", "world_to_pixel",
           "AXIS_NAMES"]

#: The accepted spellings of a signed world axis.
AXIS_NAMES = ("+x", "-x", "+y", "-y", "+z", "-z")


def parse_axes(axes):
    """Validate a view's axes.

    Parameters
    ----------
    axes : sequence of two str
        Signed world axes along increasing image column and row, from
        ``"+x" "-x" "+y" "-y" "+z" "-z"``.

    Returns
    -------
    tuple of str
        The two axes, lower case.

    Raises
    ------
    InputError
        Not two of the names above, or both on the same world axis.
    """
    names = ", ".join(f'"{a}"' for a in AXIS_NAMES)
    ok = not isinstance(axes, str) and hasattr(axes, "__len__") and len(axes) == 2 and all(
        isinstance(a, str) and a.strip().lower() in AXIS_NAMES for a in axes)
    if not ok:
        raise InputError(f"axes must be two of {names}, e.g. [\"+x\", \"-y\"], "
                         f"got {_show(axes)}")
    out = tuple(a.strip().lower() for a in axes)
    if out[0][1] == out[1][1]:
        raise InputError(f"axes must be two different world axes, got {_show(axes)}")
    return out


def _show(value):
    try:
        return json.dumps(list(value)) if not isinstance(value, str) else json.dumps(value)
    except TypeError:
        return repr(value)


@dataclass(frozen=True)
class ViewMapping:
    """Pixels of one view to metres on its two world axes, and back.

    Attributes
    ----------
    axes : tuple of str
        World axis along increasing column, then row (``("+x", "-y")``).
    origin_px : tuple of float
        Pixel (u, v) of the world origin O in the observed (raw) image.
    m_per_px : float
        Metres per (undistorted) pixel on the view's world plane.
    camera : CameraCalibration or None
        When given, pixels are undistorted before scaling (and distorted after, going
        back).
    """

    axes: tuple
    origin_px: tuple
    m_per_px: float
    camera: CameraCalibration | None = None

    def __post_init__(self):
        object.__setattr__(self, "axes", parse_axes(self.axes))
        o = np.asarray(self.origin_px, dtype=np.float64)
        if o.shape != (2,) or not np.all(np.isfinite(o)):
            raise InputError(f"origin_px must be two finite numbers [u, v], got "
                             f"{self.origin_px!r}")
        object.__setattr__(self, "origin_px", (float(o[0]), float(o[1])))
        m = self.m_per_px
        if isinstance(m, bool) or not isinstance(m, (int, float, np.floating)) \
                or not np.isfinite(m) or m <= 0:
            raise InputError(f"m_per_px must be a finite number > 0, got {m!r}")
        object.__setattr__(self, "m_per_px", float(m))

    @property
    def world_axes(self):
        """The world axes of the output columns, in world order: ``("x", "y")`` etc."""
        return tuple(sorted(a[1] for a in self.axes))

    @property
    def _columns(self):
        # For output column c (world order), the image axis index and sign feeding it.
        out = []
        for name in self.world_axes:
            idx = [a[1] for a in self.axes].index(name)
            out.append((idx, 1.0 if self.axes[idx][0] == "+" else -1.0))
        return out

    @property
    def origin_ideal_px(self):
        """The origin in undistorted pixels (equals origin_px without a camera)."""
        if self.camera is None:
            return self.origin_px
        u, v = undistort_points(np.asarray(self.origin_px), self.camera)
        return (float(u), float(v))

    def pixel_to_world(self, uv):
        """Pixels (u, v) -> world metres on the view's two axes.

        Parameters
        ----------
        uv : array_like, shape (N, 2) or (2,)
            Observed pixel positions (column, row); a row with a NaN gives a NaN row.

        Returns
        -------
        numpy.ndarray, same shape, float64
            World coordinates in m, columns in world order (:attr:`world_axes`).
        """
        pts, single = _points(uv, "uv")
        if self.camera is not None:
            pts = undistort_points(pts, self.camera)
        d = (pts - np.asarray(self.origin_ideal_px)) * self.m_per_px
        out = np.empty_like(d)
        for col, (idx, sign) in enumerate(self._columns):
            out[:, col] = sign * d[:, idx]
        return out[0] if single else out

    def world_to_pixel(self, world):
        """World metres on the view's two axes -> observed pixels (u, v).

        Parameters
        ----------
        world : array_like, shape (N, 2) or (2,)
            Coordinates in m, columns in world order (:attr:`world_axes`); a row with
            a NaN gives a NaN row.

        Returns
        -------
        numpy.ndarray, same shape, float64
            Pixel positions (column, row) in the observed image.
        """
        w, single = _points(world, "world")
        d = np.empty_like(w)
        for col, (idx, sign) in enumerate(self._columns):
            d[:, idx] = sign * w[:, col]
        pts = d / self.m_per_px + np.asarray(self.origin_ideal_px)
        if self.camera is not None:
            pts = distort_points(pts, self.camera)
        return pts[0] if single else pts

    def to_dict(self):
        """A plain dict (JSON can take it)."""
        out = {"axes": list(self.axes), "origin_px": list(self.origin_px),
               "m_per_px": self.m_per_px, "world_axes": list(self.world_axes)}
        if self.camera is not None:
            out["camera"] = self.camera.to_dict()
        return out


def _points(a, name):
    """(N, 2) float64 copy; a row with any NaN becomes all NaN (a point is whole or absent)."""
    arr, single = _point_array(a, 2, name)
    arr[np.isnan(arr).any(axis=1)] = np.nan
    return arr, single


def view_mapping(axes, origin_px, m_per_px, *, camera=None):
    """Build a :class:`ViewMapping` (validated).

    Parameters
    ----------
    axes : sequence of two str
        World axis along increasing column, then row, e.g. ``["+x", "-y"]``.
    origin_px : sequence of two float
        Pixel (u, v) of the world origin in the observed image.
    m_per_px : float
        Metres per pixel (> 0).
    camera : CameraCalibration, optional
        Undistort through this camera.

    Returns
    -------
    ViewMapping

    Raises
    ------
    InputError
        Bad axes, origin or scale.
    """
    return ViewMapping(axes=axes, origin_px=origin_px, m_per_px=m_per_px, camera=camera)


def pixel_to_world(uv, mapping):
    """Function form of :meth:`ViewMapping.pixel_to_world`."""
    return mapping.pixel_to_world(uv)


def world_to_pixel(world, mapping):
    """Function form of :meth:`ViewMapping.world_to_pixel`."""
    return mapping.world_to_pixel(world)
