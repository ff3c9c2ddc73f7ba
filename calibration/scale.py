"""The metric scale of an image plane: metres per pixel from a ruler, or given.

Chen et al. 2018 (section 2.2) read the scale off a ruler of known length W that spans
N pixels in the image: k = W / N (m per pixel). That is :func:`ruler_scale`; a scale
known some other way is :func:`given_scale`. Both return a :class:`Scale`.
"""

import math
from dataclasses import dataclass

import numpy as np

from calibration.errors import InputError

__all__ = ["Scale", "ruler_scale", "given_scale", "pixel_point", "M_PER_PX_RANGE",
           "check_m_per_px", "ruler_rel_uncertainty"]

#: Scales accepted, metres per pixel: a nanometre to a kilometre per pixel. Anything
#: outside is a typo or an overflow (a ruler of 1e300 m over 1e-10 px gives inf).
M_PER_PX_RANGE = (1e-9, 1e3)


@dataclass(frozen=True)
class Scale:
    """A metric scale of an image plane.

    Attributes
    ----------
    m_per_px : float
        Metres per pixel on the plane (k of Chen 2018, section 2.2), > 0.
    method : str
        ``"ruler"`` (k = W / N), ``"given"`` (stated directly) or ``"checkerboard"``
        (measured on a calibration board lying in the plane).
    length_m : float or None
        Ruler length W in m (ruler only).
    from_px, to_px : tuple of float or None
        Ruler end points (u, v) in pixels (ruler only).
    span_px : float or None
        N, the Euclidean distance between the ruler end points in pixels (ruler only).
    """

    m_per_px: float
    method: str
    length_m: float | None = None
    from_px: tuple[float, float] | None = None
    to_px: tuple[float, float] | None = None
    span_px: float | None = None

    @property
    def px_per_m(self):
        """Pixels per metre, 1 / m_per_px."""
        return 1.0 / self.m_per_px

    def to_dict(self):
        """A plain dict (JSON and TOML can take it); keys that do not apply are left out."""
        out = {"method": self.method, "m_per_px": self.m_per_px}
        if self.length_m is not None:
            out["length_m"] = self.length_m
        if self.from_px is not None:
            out["from_px"] = list(self.from_px)
        if self.to_px is not None:
            out["to_px"] = list(self.to_px)
        if self.span_px is not None:
            out["span_px"] = self.span_px
        return out


def _finite_number(value, name):
    if isinstance(value, np.generic) and np.issubdtype(type(value), np.number):
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise InputError(f"{name} must be finite, got {value!r}")
    return value


def check_m_per_px(value, name="m_per_px"):
    """``value`` as a float if it is a scale in :data:`M_PER_PX_RANGE`, else InputError."""
    number = _finite_number(value, name)
    if number <= 0:
        raise InputError(f"{name} must be > 0, got {value!r}")
    low, high = M_PER_PX_RANGE
    if not low <= number <= high:
        raise InputError(f"{name} must be between {low:g} and {high:g} m per pixel, "
                         f"got {value!r}")
    return number


def _point_array(a, width, name):
    """``a`` as an (N, width) float64 copy, and whether it was a single point (width,).

    Raises InputError for any other shape. The one array check of the package.
    """
    arr = np.array(a, dtype=np.float64)
    single = arr.ndim == 1
    if single:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != width:
        raise InputError(f"{name} must be an (N, {width}) array, got shape {np.shape(a)}")
    return arr, single


def pixel_point(value, name="point"):
    """Parse a pixel point: a pair of numbers, or a string ``"u,v"``.

    Parameters
    ----------
    value : sequence of two numbers or str
        ``(u, v)`` in pixels (column, row), or ``"80,482"``.
    name : str
        What the point is called in error messages.

    Returns
    -------
    tuple of float
        ``(u, v)`` in pixels.

    Raises
    ------
    InputError
        Not two finite numbers.
    """
    if isinstance(value, str):
        parts = [p.strip() for p in value.replace(";", ",").split(",")]
        if len(parts) != 2:
            raise InputError(f"{name} must be two numbers 'u,v' in pixels, got {value!r}")
        try:
            value = [float(p) for p in parts]
        except ValueError:
            raise InputError(f"{name} must be two numbers 'u,v' in pixels, "
                             f"got {value!r}") from None
    try:
        items = list(value)
    except TypeError:
        raise InputError(f"{name} must be two numbers [u, v] in pixels, got {value!r}") from None
    if len(items) != 2:
        raise InputError(f"{name} must be two numbers [u, v] in pixels, got {value!r}")
    return (_finite_number(items[0], name), _finite_number(items[1], name))


def ruler_scale(length_m, from_px, to_px):
    """The scale k = W / N from a ruler of length W spanning N pixels.

    Parameters
    ----------
    length_m : float
        W, the ruler's (or any known distance's) length in m, > 0.
    from_px, to_px : sequence of two floats or str
        The ruler's end points (u, v) in pixels, in the same image plane as the throw.
        N is their Euclidean distance.

    Returns
    -------
    Scale
        ``method="ruler"``, ``m_per_px = length_m / span_px``.

    Raises
    ------
    InputError
        length_m not a finite number > 0; a point that is not two finite numbers; the
        two points equal (a ruler of zero pixels); a scale outside
        :data:`M_PER_PX_RANGE`.

    Notes
    -----
    Chen et al. 2018, section 2.2: k = W / N. The points should be read on an image
    corrected for lens distortion when the lens distorts (the view mapping does that
    when the scene names a camera calibration).

    Example
    -------
    >>> ruler_scale(0.5, (80, 482), (205, 482)).m_per_px
    0.004
    """
    length = _finite_number(length_m, "length_m")
    if length <= 0:
        raise InputError(f"length_m must be > 0, got {length_m!r}")
    a = pixel_point(from_px, "from_px")
    b = pixel_point(to_px, "to_px")
    span = math.hypot(b[0] - a[0], b[1] - a[1])
    if not span > 0:
        raise InputError(f"the ruler spans 0 pixels: its two ends are the same point "
                         f"({a[0]:g}, {a[1]:g})")
    if not math.isfinite(span):
        raise InputError(f"the ruler's span from ({a[0]:g}, {a[1]:g}) to ({b[0]:g}, "
                         f"{b[1]:g}) overflows; expected pixel positions of an image")
    m_per_px = length / span
    low, high = M_PER_PX_RANGE
    if not low <= m_per_px <= high:
        raise InputError(f"the ruler gives {length:g} m / {span:g} px = {m_per_px:g} m per "
                         f"pixel; expected a scale between {low:g} and {high:g} m per pixel")
    return Scale(m_per_px=m_per_px, method="ruler", length_m=length,
                 from_px=a, to_px=b, span_px=span)


def given_scale(m_per_px):
    """A scale stated directly.

    Parameters
    ----------
    m_per_px : float
        Metres per pixel, a finite number > 0.

    Returns
    -------
    Scale
        ``method="given"``.

    Raises
    ------
    InputError
        Not a finite number > 0, or outside :data:`M_PER_PX_RANGE`.
    """
    return Scale(m_per_px=check_m_per_px(m_per_px), method="given")


def ruler_rel_uncertainty(span_px, px_uncertainty):
    """The relative standard uncertainty of a ruler's scale from its ends' uncertainty.

    Parameters
    ----------
    span_px : float
        N, the ruler's length in pixels (> 0).
    px_uncertainty : float
        sigma, the standard uncertainty (px) of each end's position in each image
        direction, the two ends independent (>= 0).

    Returns
    -------
    float
        ``sqrt(2) sigma / N``: the length N is the difference of the two ends' positions
        along the ruler, each uncertain by sigma, so its uncertainty is sqrt(2) sigma
        (the ends' errors across the ruler change N only to second order); k = W / N is
        then uncertain by the same relative amount.

    Raises
    ------
    InputError
        ``span_px`` not > 0, or ``px_uncertainty`` negative or not finite.

    Example
    -------
    >>> round(ruler_rel_uncertainty(80.65, 0.5), 5)
    0.00877
    """
    n = _finite_number(span_px, "span_px")
    sigma = _finite_number(px_uncertainty, "px_uncertainty")
    if n <= 0:
        raise InputError(f"span_px must be > 0, got {span_px!r}")
    if sigma < 0:
        raise InputError(f"px_uncertainty must be >= 0, got {px_uncertainty!r}")
    return math.sqrt(2.0) * sigma / n
