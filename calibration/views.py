"""The orthographic mapping of a view: image pixels to world metres and back.

A view's camera looks square onto one world plane (docs/reference.md): ``front`` onto XOY,
``top`` onto XOZ. Its mapping needs three things: which world axis runs along
increasing image column and which along increasing row (``axes``, e.g. ``("+x", "-y")``:
column -> +X, row -> -Y, so up in the image is up in the world), the pixel position of
the world origin O (``origin_px``), and the scale in metres per pixel. With a camera
calibration the observed pixels are undistorted first, and ``origin_px`` (read off the
raw image) is undistorted the same way.

A camera at a finite distance sees in perspective: a point nearer the camera than the
plane where the scale was measured looks larger. With ``camera_distance_m`` (the
distance from the camera's centre to that plane, the plane through the world origin
parallel to the image) :meth:`ViewMapping.pixel_to_world_at_depth` corrects the scale
of each point by the depth the other view measures: a point ``depth`` metres nearer the
camera than the plane looks larger by d / (d - depth), about the principal point. The
camera looks along u x v, the image axes in world terms (front ``["+x", "-y"]``: along
-Z, so a point at Z > 0 is nearer).

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
    camera_distance_m : float or None
        Distance from the camera's centre to the plane where the scale holds (the plane
        through the world origin parallel to the image); None: not known (orthographic,
        no perspective correction).
    principal_px : tuple of float or None
        The principal point in undistorted pixels (where the optical axis meets the
        image), for the perspective correction; None: the image centre (the world stage
        takes it from the frame size) or, with a camera, its (cx, cy).
    """

    axes: tuple
    origin_px: tuple
    m_per_px: float
    camera: CameraCalibration | None = None
    camera_distance_m: float | None = None
    principal_px: tuple | None = None

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
        d = self.camera_distance_m
        if d is not None:
            if isinstance(d, bool) or not isinstance(d, (int, float, np.floating, np.integer)) \
                    or not np.isfinite(d) or d <= 0:
                raise InputError(f"camera_distance_m must be a finite number > 0, got {d!r}")
            object.__setattr__(self, "camera_distance_m", float(d))
        if self.principal_px is None and self.camera is not None:
            object.__setattr__(self, "principal_px", (float(self.camera.cx),
                                                      float(self.camera.cy)))
        if self.principal_px is not None:
            pp = np.asarray(self.principal_px, dtype=np.float64)
            if pp.shape != (2,) or not np.all(np.isfinite(pp)):
                raise InputError(f"principal_px must be two finite numbers [u, v], got "
                                 f"{self.principal_px!r}")
            object.__setattr__(self, "principal_px", (float(pp[0]), float(pp[1])))

    @property
    def toward_camera(self):
        """``(axis, sign)``: the world axis the view does not see and the sign that makes
        ``sign * coordinate`` the offset of a point from the scale plane towards the
        camera (the camera looks along u x v of the image axes in world terms)."""
        unit = {"x": 0, "y": 1, "z": 2}
        e = np.zeros((2, 3))
        for k, a in enumerate(self.axes):
            e[k, unit[a[1]]] = 1.0 if a[0] == "+" else -1.0
        toward = -np.cross(e[0], e[1])
        i = int(np.argmax(np.abs(toward)))
        return "xyz"[i], float(np.sign(toward[i]))

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
        out = self._ideal_to_world(pts)
        return out[0] if single else out

    def _ideal_to_world(self, pts):
        d = (pts - np.asarray(self.origin_ideal_px)) * self.m_per_px
        out = np.empty_like(d)
        for col, (idx, sign) in enumerate(self._columns):
            out[:, col] = sign * d[:, idx]
        return out

    def pixel_to_world_at_depth(self, uv, depth_m, *, principal_px=None):
        """Pixels -> world metres, the perspective corrected for each point's depth.

        A point ``depth_m`` nearer the camera than the scale plane (the plane through
        the world origin parallel to the image, :attr:`toward_camera`) is imaged larger
        by d / (d - depth) about the principal point, d = :attr:`camera_distance_m`; its
        world offset from the principal point's foot on the plane is the orthographic
        one times (d - depth) / d.

        Parameters
        ----------
        uv : array_like, shape (N, 2)
            Observed pixels.
        depth_m : array_like, shape (N,)
            Each point's offset from the scale plane towards the camera (m); NaN gives
            a NaN row, as does a point at or behind the camera.
        principal_px : pair, optional
            The principal point (undistorted pixels) when :attr:`principal_px` is None,
            e.g. the image centre ``((width - 1) / 2, (height - 1) / 2)``.

        Returns
        -------
        numpy.ndarray, shape (N, 2)
            World coordinates (m), columns in world order (:attr:`world_axes`).
        """
        if self.camera_distance_m is None:
            raise InputError("pixel_to_world_at_depth needs camera_distance_m")
        pp = self.principal_px if self.principal_px is not None else principal_px
        if pp is None:
            raise InputError("pixel_to_world_at_depth needs the principal point "
                             "(principal_px), e.g. the image centre")
        w = np.atleast_2d(self.pixel_to_world(uv))
        depth = np.asarray(depth_m, dtype=np.float64).reshape(-1)
        if depth.size != len(w):
            raise InputError(f"depth_m must have one value per point ({len(w)}), got "
                             f"{depth.size}")
        foot = self._ideal_to_world(np.asarray(pp, dtype=np.float64).reshape(1, 2))[0]
        d = self.camera_distance_m
        factor = (d - depth) / d
        factor[~(factor > 0)] = np.nan
        return foot + (w - foot) * factor[:, None]

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
        if self.camera_distance_m is not None:
            out["camera_distance_m"] = self.camera_distance_m
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
