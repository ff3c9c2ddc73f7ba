"""Checks of a run's inputs: the footage before anything reads it, the views against
each other after the merge.

A wrong input often does not fail: a top view given the wrong ``fps``, the two views'
sources swapped, or one file named for both views still track, merge and fit, and give
coefficients with small errors that are simply wrong. What gives them away is that the
inputs disagree with each other or with physics. :func:`cross_checks` measures that
on the tracks (fresh or reused from tracks.h5), :func:`same_footage` before any
tracking; :mod:`vidtrack.run.pipeline` stops the run on a finding unless the user
accepted it (``vidtrack fit --accept-disagreement``). The limits below were set from
the values measured on good runs, with a wide margin (docs/fit-outputs.md, "Cross-checks").

- **The shared X** (:data:`X_RMS_MAX_PX`): both views see world X; on the common clock
  their RMS difference (:attr:`vidtrack.world.world_track.WorldTrack.x_rms_px`, in pixels
  of the coarser view) must stay below a pixel.
- **The speed along X** (:data:`SPEED_RATIO_TOL`): over the stretch of X both views
  saw, each view's mean speed along X from its own clock (frames / fps) and scale: the
  stretch over the time a quadratic t(x) through the view's points takes to cross it
  (whichever of its frames a view kept). A view whose fps (or scale) is wrong sees the
  same stretch crossed in a different time.
- **Accelerations** (:data:`VERTICAL_G`, :data:`HORIZONTAL_G_MAX`): a quadratic in t
  fitted to each world axis gives the mean acceleration. A thrown straw falls (its mean
  vertical acceleration is downward, between a few tenths of g and a few g) and drag
  slows it along x and z by a few g at most; far outside that the time base or the
  scale is wrong in every view (where the views cannot disagree).
- **The same footage** for two views (:func:`same_footage`): two cameras never record
  the same file.

The checks stand apart from the two-view merge so that another way of building the
world track (calibrated cameras) can use what applies to it: each check is skipped
when what it needs is missing.
"""

import os
import stat
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vidtrack.errors import SourceError

__all__ = ["Finding", "X_RMS_MAX_PX", "SPEED_RATIO_TOL", "VERTICAL_G", "HORIZONTAL_G_MAX",
           "check_source_path", "same_footage", "cross_checks", "speed_ratio",
           "mean_accelerations"]

#: Largest RMS disagreement of the shared X, in pixels of the coarser view. Measured on
#: 26 good throws: 0.016 to 0.090 px (docs/fit-outputs.md); a wrong fps, swapped or
#: repeated footage: 4 to 30 px.
X_RMS_MAX_PX = 1.0
#: Largest relative difference of the two views' speeds along X over the same stretch.
#: Good runs: at most 0.8 % (10.6 mm/px; 0.3 % at 6 mm/px); an fps of 1000 for 1200 is
#: 17 %, 600 for 1200 is 50 %.
SPEED_RATIO_TOL = 0.05
#: Plausible mean vertical acceleration, downward, in g: (least, most). Good runs: 1.15 g
#: (drag-free, k = 1.2 / 0.8) to 4.13 g; Chen 2018's k1, k2 span 1.4 to 4.6.
VERTICAL_G = (0.3, 15.0)
#: Largest plausible mean acceleration along x or z, in g. Good runs: at most 2.21 g.
HORIZONTAL_G_MAX = 30.0
#: Fewest world points (and least time span, s) an acceleration is judged on.
_ACCEL_MIN_POINTS = 10
_ACCEL_MIN_SPAN_S = 0.02
#: Points each view needs in the common stretch of X, and the least length of that
#: stretch in pixels of the coarser view, for the speed comparison.
_SPEED_MIN_POINTS = 10
_SPEED_MIN_SPAN_PX = 20.0
#: How many standard errors a value must lie beyond a limit to be a finding.
_SIGMAS = 3.0


@dataclass(frozen=True)
class Finding:
    """One way the inputs disagree: ``check`` (a short name), the one-line ``message``,
    the measured ``value`` and the ``limit`` it broke."""

    check: str
    message: str
    value: float | None = None
    limit: float | None = None

    def to_dict(self):
        return {"check": self.check, "message": self.message, "value": self.value,
                "limit": self.limit}


# ------------------------------------------------------------------ before reading

_KINDS = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def check_source_path(path, label):
    """Refuse footage that is missing or is not a regular file or a folder.

    Only ``stat`` is called (never ``open``): a FIFO, a device or a socket would block
    or stream forever when read.

    Raises
    ------
    SourceError
        ``label: PATH does not exist`` or ``label: PATH is a FIFO ...``, one line.
    """
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise SourceError(f"{label}: {path} does not exist (expected the view's video, "
                          "image folder or .cine)") from None
    except OSError as exc:
        raise SourceError(f"{label}: {path} cannot be read ({exc.strerror or exc}); "
                          "expected the view's video, image folder or .cine") from None
    if stat.S_ISREG(st.st_mode) or stat.S_ISDIR(st.st_mode):
        return
    what = next((name for test, name in _KINDS if test(st.st_mode)), "not a regular file")
    raise SourceError(f"{label}: {path} is {what}; expected a video file, an image folder "
                      "or a .cine file")


def same_footage(paths):
    """A :class:`Finding` when two views name the same file or folder, else None.

    ``paths``: {view: path}, each existing.
    """
    names = list(paths)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            try:
                same = os.path.samefile(paths[a], paths[b])
            except OSError:
                same = False
            if same:
                return Finding("same_footage",
                               f"views {a} and {b} both read {paths[a]}: two cameras "
                               "never record the same footage; give each view its own "
                               "source")
    return None


# ------------------------------------------------------------------ after the merge

def _usable_x(track, mapping, t0):
    """(t since this view's t = 0, world x) of a view's usable points at t >= 0."""
    d = track.data[track.usable]
    if not len(d) or "x" not in mapping.world_axes:
        return np.empty(0), np.empty(0)
    w = mapping.pixel_to_world(d[["u_px", "v_px"]].to_numpy(dtype=np.float64))
    x = w[:, list(mapping.world_axes).index("x")]
    t = d["t_s"].to_numpy(dtype=np.float64) - t0
    keep = (t >= 0) & np.isfinite(x)
    return t[keep], x[keep]


def _views_x(tracks, mappings, t0_s, names):
    """Each view's (t since its t = 0, world x), perspective corrected as the merge did
    when a view gives ``camera_distance_m`` (else a nearer straw looks faster)."""
    if not any(getattr(mappings[v], "camera_distance_m", None) for v in names):
        return {v: _usable_x(tracks[v], mappings[v], float(t0_s[v])) for v in names}
    from vidtrack.world.parallax import corrected_points

    points = corrected_points(tracks, mappings, t0_s)
    out = {}
    for v in names:
        d = points[v]
        t = d["t_s"].to_numpy(dtype=np.float64) - float(t0_s[v])
        x = d["x_m"].to_numpy(dtype=np.float64)
        keep = (t >= 0) & np.isfinite(x)
        out[v] = (t[keep], x[keep])
    return out


def speed_ratio(world, tracks, mappings):
    """The two views' mean speeds along X over the stretch of X both saw.

    Returns
    -------
    dict or None
        ``{"ratio": other / reference, "speeds_m_s": {view: speed}, "points": {view: n},
        "span_m": (x_a, x_b)}``; None with one view, or when the common stretch is too
        short or too thinly sampled to judge.
    """
    names = [v for v in ("front", "top") if v in tracks and v in mappings]
    if len(names) != 2 or world is None or not world.t0_s:
        return None
    if any(v not in world.t0_s for v in names):
        return None
    reference = world.reference
    tx = _views_x(tracks, mappings, world.t0_s, names)
    if any(t.size < _SPEED_MIN_POINTS for t, _ in tx.values()):
        return None
    lo = max(float(np.min(x)) for _, x in tx.values())
    hi = min(float(np.max(x)) for _, x in tx.values())
    scale = max(float(mappings[v].m_per_px) for v in names)
    if not hi - lo >= _SPEED_MIN_SPAN_PX * scale:
        return None
    # the inner 90 % of the common stretch: its ends are where one view's noise decides
    # whether a point is in or out
    pad = 0.05 * (hi - lo)
    lo, hi = lo + pad, hi - pad
    speeds, points = {}, {}
    for v, (t, x) in tx.items():
        inside = (x >= lo) & (x <= hi)
        if np.count_nonzero(inside) < _SPEED_MIN_POINTS or np.ptp(t[inside]) <= 0:
            return None
        # the time this view's clock takes to cross the stretch, from a quadratic t(x)
        # (in the stretch's own scale): a straight line through x(t) would give a
        # decelerating straw's speed where this view's points happen to lie (a view
        # that lost the frames of one half sees it faster or slower)
        s = (x[inside] - lo) / (hi - lo)
        q = np.polyfit(s, t[inside], 2)
        duration = float(np.polyval(q, 1.0) - np.polyval(q, 0.0))
        if not duration != 0.0:
            return None
        speeds[v], points[v] = (hi - lo) / duration, int(np.count_nonzero(inside))
    ref = reference if reference in names else names[0]
    other = names[1] if ref == names[0] else names[0]
    if speeds[ref] == 0:
        return None
    return {"ratio": speeds[other] / speeds[ref], "reference": ref, "other": other,
            "speeds_m_s": speeds, "points": points, "span_m": (lo, hi)}


def mean_accelerations(world):
    """Mean acceleration of each world axis over the flight, with its standard error.

    A quadratic in t fitted by least squares to each axis' measured points (t >= 0);
    the acceleration is twice its t² coefficient.

    Returns
    -------
    dict
        {axis: (acceleration m/s², standard error, points)} for each axis with at least
        10 points over 20 ms.
    """
    out = {}
    if world is None or world.data is None or not len(world.data):
        return out
    t_all = world.data["t_s"].to_numpy(dtype=np.float64)
    for a in ("x", "y", "z"):
        col = f"{a}_m"
        if col not in world.data:
            continue
        y = world.data[col].to_numpy(dtype=np.float64)
        ok = np.isfinite(y) & np.isfinite(t_all) & (t_all >= 0)
        t, y = t_all[ok], y[ok]
        if t.size < _ACCEL_MIN_POINTS or np.ptp(t) < _ACCEL_MIN_SPAN_S:
            continue
        # centred and scaled for a well-conditioned solve; positions far beyond any
        # plausible (an edited track) overflow: then the axis is not judged here
        tc = (t - t.mean()) / np.ptp(t)
        A = np.column_stack([np.ones_like(tc), tc, tc ** 2])
        with np.errstate(all="ignore"):
            try:
                coef, *_ = np.linalg.lstsq(A, y, rcond=None)
                resid = y - A @ coef
                s2 = float(resid @ resid) / max(t.size - 3, 1)
                cov = s2 * np.linalg.inv(A.T @ A)
            except (np.linalg.LinAlgError, ValueError):
                continue
            acc = 2.0 * coef[2] / np.ptp(t) ** 2
            se = 2.0 * float(np.sqrt(max(cov[2, 2], 0.0))) / np.ptp(t) ** 2
        if np.isfinite(acc) and np.isfinite(se):
            out[a] = (float(acc), se, int(t.size))
    return out


def _shared_x_said(world):
    """What the views' relative scale on the shared X says (empty when not measured)."""
    shared = world.shared_x
    return "" if shared is None else f"; {shared.note()}"


def cross_checks(world, tracks, mappings, *, g=9.80665, sources=None):
    """Every way the inputs of a run (or throw) disagree, as :class:`Finding` s.

    Parameters
    ----------
    world : vidtrack.world.world_track.WorldTrack
        The world track (fresh from the merge or read back from tracks.h5).
    tracks : dict of str to vidtrack.track.tracker.Track
        The views' tracks as merged (pre-release frames flagged).
    mappings : dict of str to calibration.ViewMapping
    g : float
        Gravity (m/s²) of the scene.
    sources : dict, optional
        {view: {"fps": given fps}} for the messages.

    Returns
    -------
    list of Finding
        Empty when everything agrees.
    """
    found = []
    sources = sources or {}
    names = [v for v in ("front", "top") if v in tracks]
    x_rms_px = world.x_rms_px       # the orthogonal merge's measure (None: calibrated)
    if x_rms_px is not None and x_rms_px > X_RMS_MAX_PX:
        found.append(Finding(
            "x_disagreement",
            f"the views disagree on the X they both see by {1000 * world.x_rms_m:.3g} mm "
            f"RMS ({world.x_rms_px:.3g} px over {world.x_points} points; good runs agree "
            f"within {X_RMS_MAX_PX:g} px): check each view's fps, source, scale and "
            "origin_px, and whether one view followed another object (vidtrack overlay "
            "shows each view's track; a target in that view's table names the straw)"
            + _shared_x_said(world), world.x_rms_px, X_RMS_MAX_PX))
    sr = speed_ratio(world, tracks, mappings)
    if sr is not None and abs(sr["ratio"] - 1.0) > SPEED_RATIO_TOL:
        ref, other = sr["reference"], sr["other"]
        fps = {v: sources.get(v, {}).get("fps") for v in names}
        given = (f" (views.{other}.fps = {fps[other]:g}, views.{ref}.fps = {fps[ref]:g})"
                 if fps.get(other) and fps.get(ref) else "")
        found.append(Finding(
            "speed_ratio",
            f"the {other} view sees the straw cross the same stretch of X at "
            f"{sr['ratio']:.3g} times the {ref} view's speed ({sr['speeds_m_s'][other]:.3g} "
            f"against {sr['speeds_m_s'][ref]:.3g} m/s; good runs agree within "
            f"{100 * SPEED_RATIO_TOL:g} %): the frame counts and fps of the views do not "
            f"describe the same flight{given}; check the fps and the scales",
            sr["ratio"], SPEED_RATIO_TOL))
    acc = mean_accelerations(world)
    if "y" in acc:
        a, se, n = acc["y"]
        lo, hi = VERTICAL_G
        down = -a / g
        if (down + _SIGMAS * se / g < lo) or (down - _SIGMAS * se / g > hi):
            direction = "upward" if a > 0 else "downward"
            found.append(Finding(
                "acceleration",
                f"the straw's mean vertical acceleration is {abs(a) / g:.3g} g {direction} "
                f"({a:.3g} m/s² over {n} points); a thrown straw falls at {lo:g} to "
                f"{hi:g} g: check the fps (time base) and the scales of both views, and "
                "the sign of y in views.front.axes", down, lo if down < lo else hi))
    for axis in ("x", "z"):
        if axis in acc:
            a, se, n = acc[axis]
            if abs(a) / g - _SIGMAS * se / g > HORIZONTAL_G_MAX:
                found.append(Finding(
                    "acceleration",
                    f"the straw's mean acceleration along {axis} is {abs(a) / g:.3g} g "
                    f"({a:.3g} m/s² over {n} points); drag slows a straw by at most "
                    f"{HORIZONTAL_G_MAX:g} g: check the fps (time base) and the scales",
                    abs(a) / g, HORIZONTAL_G_MAX))
    return found
