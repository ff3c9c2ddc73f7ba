"""What the tracker scoreboard measures of one track, whatever its reference.

A clip's scorer (:mod:`vidtrack.bench.real`, :mod:`vidtrack.bench.scenes`) turns a track
and its reference into a :class:`Score`; this module holds the pieces they share: the
distance summary, the drag-free fits, and one engine's timed run on a clip.
"""

import dataclasses
import logging

import numpy as np

from vidtrack.bench._timing import timed

log = logging.getLogger(__name__)

#: Fewest points a quadratic (or the two-arc fit) is fitted to; fewer gives NaN.
MIN_FIT_POINTS = 5


@dataclasses.dataclass(frozen=True)
class Score:
    """One track against its reference.

    Attributes
    ----------
    flight_frames : int
        Frames of the flight (where the reference says the object flies).
    unflagged : int
        Of those, frames the track hands to a fit (flags 0, a finite position).
    dist_px : numpy.ndarray
        Distance (px) from the reference of each unflagged flight frame that has a
        reference point, after the clip's alignment (see the clip's scorer).
    fit : str
        What ``fit_track`` and ``fit_ref`` are (a name with its unit).
    fit_track, fit_ref : float
        That figure from the track's unflagged flight points and from the reference's
        own points (NaN when too few points).
    fit_ref_same : float
        That figure from the reference's points on the frames ``fit_track`` used only
        (what a perfect track flagged alike gives): ``fit_track`` against it is the
        positions' error alone, ``fit_ref`` against it what the flags cost.
    note : str
        The alignment used, or why something is missing.
    """

    flight_frames: int
    unflagged: int
    dist_px: np.ndarray
    fit: str
    fit_track: float
    fit_ref: float
    fit_ref_same: float = float("nan")
    note: str = ""

    def to_row(self):
        """The scoreboard's columns of this score (a dict)."""
        d = np.asarray(self.dist_px, dtype=float)
        d = d[np.isfinite(d)]
        have = d.size > 0
        ratio = (self.fit_track / self.fit_ref
                 if np.isfinite(self.fit_track) and np.isfinite(self.fit_ref)
                 and self.fit_ref != 0.0 else float("nan"))
        return {"flight_frames": self.flight_frames, "unflagged": self.unflagged,
                "unflagged_frac": (self.unflagged / self.flight_frames
                                   if self.flight_frames else float("nan")),
                "scored": int(d.size),
                "median_px": float(np.median(d)) if have else float("nan"),
                "p95_px": float(np.percentile(d, 95)) if have else float("nan"),
                "max_px": float(d.max()) if have else float("nan"),
                "rms_px": float(np.sqrt(np.mean(d ** 2))) if have else float("nan"),
                "fit": self.fit, "fit_track": float(self.fit_track),
                "fit_ref": float(self.fit_ref), "fit_ratio": float(ratio),
                "fit_ref_same": float(self.fit_ref_same),
                "note": self.note}


def quadratic_accel(t, y):
    """Second derivative (units of y per s^2) of a least-squares parabola ``y(t)``.

    Fitted in centred, scaled time (``lstsq``); NaN with fewer than
    :data:`MIN_FIT_POINTS` finite points or a zero time span.
    """
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    m = np.isfinite(t) & np.isfinite(y)
    t, y = t[m], y[m]
    if t.size < MIN_FIT_POINTS:
        return float("nan")
    half = 0.5 * (t.max() - t.min())
    if not half > 0.0:
        return float("nan")
    s = (t - 0.5 * (t.max() + t.min())) / half
    coef, *_ = np.linalg.lstsq(np.column_stack([s ** 2, s, np.ones_like(s)]), y, rcond=None)
    return float(2.0 * coef[0] / half ** 2)


def accel_2d(t, u, v):
    """Magnitude (px/s^2) of the acceleration of a drag-free 2-D parabola ``(u, v)(t)``."""
    return float(np.hypot(quadratic_accel(t, u), quadratic_accel(t, v)))


def descent_over_ascent(t, v):
    """k2/k1: the descent's gravity multiplier over the ascent's, from image rows.

    Fits ``v(t) = v_a + a1 (t - t_a)^2`` before the apex ``t_a`` and ``v_a + a2 (t -
    t_a)^2`` after it (one apex, no vertical speed there: the drag-free throw with its
    own gravity on each arc) and returns ``a2 / a1``; 1 for a drag-free ball. NaN when
    either arc has fewer than :data:`MIN_FIT_POINTS` points or no apex lies inside.
    """
    from scipy.optimize import least_squares

    t, v = np.asarray(t, dtype=float), np.asarray(v, dtype=float)
    m = np.isfinite(t) & np.isfinite(v)
    t, v = t[m], v[m]
    if t.size < 2 * MIN_FIT_POINTS:
        return float("nan")
    t0, half = 0.5 * (t.max() + t.min()), 0.5 * (t.max() - t.min())
    if not half > 0.0:
        return float("nan")
    s = (t - t0) / half
    c2, c1, c0 = np.polyfit(s, v, 2)
    if not c2 > 0.0:                          # rows grow downwards: an apex is a minimum
        return float("nan")
    sa = -c1 / (2.0 * c2)
    if not (s.min() < sa < s.max()):
        return float("nan")

    def resid(p):
        va, ta, a1, a2 = p
        ds = s - ta
        return va + np.where(ds < 0.0, a1, a2) * ds ** 2 - v

    fit = least_squares(resid, [c0 - c2 * sa ** 2, sa, c2, c2])
    va, ta, a1, a2 = fit.x
    up, down = np.count_nonzero(s < ta), np.count_nonzero(s >= ta)
    if min(up, down) < MIN_FIT_POINTS or not a1 > 0.0:
        return float("nan")
    return float(a2 / a1)


def linear_drag_k(t, y, g=9.81):
    """k (1/s) of ``y(t) = y0 - g/k t + (v0 + g/k)(1 - e^(-kt))/k`` (y up, m), g fixed.

    The fit of ``tests/test_real_footage_bear.py``; NaN with too few points.
    """
    from scipy.optimize import least_squares

    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    m = np.isfinite(t) & np.isfinite(y)
    t, y = t[m], y[m]
    if t.size < MIN_FIT_POINTS:
        return float("nan")
    t = t - t[0]

    def model(p):
        y0, v0, k = p
        return y0 - g / k * t + (v0 + g / k) * (1.0 - np.exp(-k * t)) / k

    fit = least_squares(lambda p: model(p) - y, [y[0], 0.0, 0.5],
                        bounds=([-np.inf, -50.0, 1e-6], [np.inf, 50.0, 50.0]))
    return float(fit.x[2])


def engine_kwargs(engine):
    """``{"engine": engine}`` when the tracker knows engines, else ``{}`` (the rules
    tracker of before ``ENGINES`` existed)."""
    from vidtrack.track import tracker

    return {"engine": engine} if hasattr(tracker, "ENGINES") else {}


def decode(open_fn):
    """Iterate every frame of ``open_fn()`` doing nothing: the number of frames."""
    n = 0
    with open_fn() as src:
        for _ in src:
            n += 1
    return n


def timed_decode(open_fn, *, repeats=3, warmup=1):
    """Decoding every frame of ``open_fn()``, timed (:func:`vidtrack.bench._timing.timed`;
    the result is the number of frames)."""
    return timed(lambda: decode(open_fn), repeats=repeats, warmup=warmup)


def track_once(open_fn, engine, *, view, target=None):
    """One engine on one clip: ``(track or None, status, message)``.

    Status ``"ok"``; ``"failed"`` for a :class:`vidtrack.errors.VidtrackError` (the
    engine found no object, or refused: what ``vidtrack fit`` exits 2 on); ``"error"``
    for any other exception (a bug, its traceback logged at WARNING), so that one
    engine's crash on one clip does not lose the rest of the scoreboard. Neither is
    raised: the message is returned in place of a track.
    """
    from vidtrack.errors import VidtrackError
    from vidtrack.track.tracker import track

    tr, status, msg = None, "ok", ""
    try:
        with open_fn() as src:
            tr = track(src, view=view, target=target, **engine_kwargs(engine))
    except VidtrackError as exc:
        status, msg = "failed", (str(exc).splitlines() or [type(exc).__name__])[0]
    except Exception as exc:                        # noqa: BLE001  (reported, not hidden)
        log.warning("engine %s on %s view raised", engine, view, exc_info=True)
        status, msg = "error", f"{type(exc).__name__}: {exc}".splitlines()[0]
    return tr, status, msg


def timed_track(open_fn, engine, *, view, target=None, repeats=3, warmup=1):
    """:func:`track_once`, timed: ``(track or None, Timing, status, message)`` of the
    last call (a failing engine is timed to its failure)."""
    t = timed(lambda: track_once(open_fn, engine, view=view, target=target),
              repeats=repeats, warmup=warmup)
    tr, status, msg = t.result
    return tr, t, status, msg
