"""The views' relative scale and offset, measured on the X both see; the scales reconciled.

The ``front`` and ``top`` views both see world X, each through its own scale (a ruler
read off a frame, ``m_per_px``). A ruler read 0.6 px long on an 80 px span makes that
view's X 0.75 % too short: over a flight of 250 px the views then disagree by more than
a pixel, which the cross-check (:mod:`vidtrack.run.checks`) would take for another
object or a wrong fps. The shared X measures that scale error:

1. **The estimate.** On the merged clock (:func:`vidtrack.world.orthogonal.merge_tracks`)
   the other view's X is interpolated at the reference view's times, and the
   difference ``x_other - x_ref = a + b (x_ref - mean)`` is fitted by least squares:
   the relative scale ``ratio = 1 + b`` (other over reference) and the offset at
   x = 0 (the origins' disagreement along X). The standard errors are widened for the
   residuals' lag-1 autocorrelation rho by sqrt((1 + rho) / (1 - rho))
   (:func:`widened_lstsq`, shared with :mod:`vidtrack.run.perspective`).
2. **What the rulers explain.** Each view's scale has a stated relative standard
   uncertainty sigma_v (:attr:`vidtrack.scene.ViewSpec.scale_rel_uncertainty`). The
   log-ratio d = ln(ratio) is the difference of the two scales' log errors, e_other -
   e_ref, seen with the estimate's own variance sigma_d^2. When
   ``|d| <= RECONCILE_Z * sqrt(sigma_ref^2 + sigma_other^2 + sigma_d^2)`` a reading
   error of the rulers explains it, and the views are **reconciled**: the log errors'
   best estimate given d (the Gaussian update, a Kalman step),
   ``e_v = K_v d`` with ``K = (-sigma_ref^2, sigma_other^2) / S``,
   ``S = sigma_ref^2 + sigma_other^2 + sigma_d^2``, is taken out of each view's scale
   (each moved by its share, the rulers' variances deciding), and the views are merged
   again (the clock offset found again on the reconciled X); estimated again on that
   merge, the ratio is the root of (ratio measured with the scales moved for d) - d,
   found by the secant method to a hundredth of its standard error. A ratio within
   :data:`SEEN_Z` of its own standard errors of 1 (no difference the points can tell,
   as on ``datasets/run42``: 1.00001 +- 0.00003; 0.99996 from the flight tracker's
   tracks) moves no scale: the world track is the
   merge of the scales as given, while the covariance below still holds. That is judged
   on the first estimate and again on the refined one (the first, on a clock found with
   the scales as given, can show what the refined one does not). The scales'
   errors that remain have the covariance ``P = diag(sigma^2) - S K K^T``: what the
   shared X cannot tell, the two scales wrong by the same factor, which
   :mod:`vidtrack.run.scale_error` carries into k. Beyond that bound (a wrong fps,
   another object) nothing is moved and the cross-check judges the views as they are.

Views whose scales carry no stated uncertainty are taken as exact and never moved.
The offset is reported, not reconciled (the scene states no uncertainty for an origin).
"""

import logging
import math
from dataclasses import dataclass, replace

import numpy as np

log = logging.getLogger(__name__)

__all__ = ["SharedScale", "shared_scale", "merge_reconciled", "common_points",
           "widened_lstsq", "RECONCILE_Z", "SEEN_Z", "MIN_POINTS", "MAX_RHO"]

#: Reconciled when the log-ratio of the views' scales lies within this many combined
#: standard uncertainties (the two rulers' and the estimate's own).
RECONCILE_Z = 3.0
#: A relative scale this many of its own standard errors from 1 is one the data show:
#: it is said in the run's notes (below it, fit.json keeps the numbers only).
SEEN_Z = 1.96
#: Fewest points at common times for a fit of the views' disagreement on X.
MIN_POINTS = 20
#: Largest lag-1 autocorrelation used to widen a standard error.
MAX_RHO = 0.95
#: Most merges of the reconciliation (each a merge of the views with the scales moved,
#: a step of the secant method; 3 to 4 on the tests' renders).
_PASSES = 6


def widened_lstsq(a, r):
    """Least squares ``r ~ a @ coef`` with standard errors widened for the residuals'
    lag-1 autocorrelation.

    Parameters
    ----------
    a : numpy.ndarray, shape (N, P)
        The design (its columns scaled to unit norm for the solve, then scaled back).
    r : numpy.ndarray, shape (N,)

    Returns
    -------
    coef : numpy.ndarray, shape (P,)
    cov : numpy.ndarray, shape (P, P)
        The coefficients' covariance, widened by (1 + rho) / (1 - rho).
    rho : float
        The residuals' lag-1 autocorrelation, clipped to [0, :data:`MAX_RHO`].
    res : numpy.ndarray
        The residuals.
    """
    scale = np.linalg.norm(a, axis=0)
    scale[scale == 0] = 1.0
    coef, *_ = np.linalg.lstsq(a / scale, r, rcond=None)
    res = r - (a / scale) @ coef
    dof = max(a.shape[0] - a.shape[1], 1)
    s2 = float(res @ res) / dof
    cov = s2 * np.linalg.pinv((a / scale).T @ (a / scale))
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = float(np.corrcoef(res[:-1], res[1:])[0, 1]) if res.size > 2 else 0.0
    rho = float(np.clip(rho, 0.0, MAX_RHO)) if np.isfinite(rho) else 0.0
    widen = (1.0 + rho) / (1.0 - rho)
    return coef / scale, cov * widen / np.outer(scale, scale), rho, res


def common_points(points, t0, reference, steps):
    """The views' coordinates at the reference view's times t >= 0 (the other view's
    interpolated between its points, never across gaps): ``{(axis, view): array}, t``.

    ``points``: per view a table with ``t_s`` (its clock) and its world axes
    (:func:`vidtrack.world.parallax.corrected_points`); ``t0``: each view's t = 0 on its
    clock; ``steps``: each view's frame interval, s.
    """
    from vidtrack.world.resample import interp_gapless as _interp_gapless

    other = next(v for v in points if v != reference)
    p, q = points[reference], points[other]
    t = p["t_s"].to_numpy(dtype=np.float64) - t0[reference]
    keep = t >= 0
    t = t[keep]
    tq = q["t_s"].to_numpy(dtype=np.float64) - t0[other]
    cols = {}
    for c in ("x_m", "y_m", "z_m"):
        if c in p:
            cols[(c[0], reference)] = p[c].to_numpy(dtype=np.float64)[keep]
        if c in q:
            cols[(c[0], other)] = _interp_gapless(t, tq, q[c].to_numpy(dtype=np.float64),
                                                  2.5 * steps[other])
    return cols, t


@dataclass(frozen=True)
class SharedScale:
    """The views' relative scale and offset on the shared X, and what was done with them.

    Attributes
    ----------
    reference, other : str
        The world track's reference view and the other view.
    ratio, ratio_se : float
        The other view's X over the reference view's, with the scales as the scene gives
        them (1: they agree), and its standard error (widened for autocorrelation).
    offset_m, offset_se_m : float
        The other view's X minus the reference's at x = 0 (the origins' disagreement), m.
    rho : float
        The residuals' lag-1 autocorrelation.
    points : int
        Common points fitted.
    residual_rms_px : float
        RMS of what scale and offset leave, in px of the coarser view.
    rel_uncertainty : dict of str to float or None
        Each view's stated relative scale uncertainty (None: taken as exact).
    ruler_px : dict of str to float or None
        Each view's ruler span, px (None: no ruler), for the note.
    reconciled : bool
        The scales were moved (the ratio within :data:`RECONCILE_Z` combined standard
        uncertainties).
    factors : dict of str to float
        Per view, the factor its ``m_per_px`` was multiplied by (1.0: not moved).
    covariance : tuple of tuple of float
        The views' scales' relative errors' covariance after the reconciliation (in the
        order reference, other); the stated variances on the diagonal when not reconciled.
    passes : int
        Merges made (the first included).
    """

    reference: str
    other: str
    ratio: float
    ratio_se: float
    offset_m: float
    offset_se_m: float
    rho: float
    points: int
    residual_rms_px: float
    rel_uncertainty: dict
    ruler_px: dict
    reconciled: bool
    factors: dict
    covariance: tuple
    passes: int = 1

    @property
    def combined(self):
        """sqrt(sigma_ref^2 + sigma_other^2 + sigma_d^2): the bound's unit."""
        s = [self.rel_uncertainty.get(v) or 0.0 for v in (self.reference, self.other)]
        return math.sqrt(s[0] ** 2 + s[1] ** 2 + (self.ratio_se / self.ratio) ** 2)

    @property
    def seen(self):
        """The ratio differs from 1 by more than :data:`SEEN_Z` of its standard errors."""
        return abs(self.ratio - 1.0) > SEEN_Z * self.ratio_se

    def mappings(self, mappings):
        """``mappings`` with each view's ``m_per_px`` times its factor."""
        return {v: (replace(m, m_per_px=m.m_per_px * self.factors[v]) if v in self.factors
                    and self.factors[v] != 1.0 else m) for v, m in mappings.items()}

    def stderr_rel(self, view):
        """The view's scale's relative standard uncertainty after the reconciliation."""
        i = (self.reference, self.other).index(view)
        return math.sqrt(max(self.covariance[i][i], 0.0))

    def _left(self):
        return (", ".join(f"{v} {100 * self.stderr_rel(v):.2g} %"
                          for v in (self.reference, self.other)) + ", moving together")

    def note(self):
        """The plain-words statement of the relative scale and what was done."""
        pct = 100.0 * (self.ratio - 1.0)
        word = "longer" if pct > 0 else "shorter"
        d = math.log(self.ratio)
        reads = []
        # which ruler reading would explain it: the other's span read short (its X
        # longer), or the reference's read long, by the whole of it
        for v, sign in ((self.other, -1.0), (self.reference, 1.0)):
            n = self.ruler_px.get(v)
            if n and self.rel_uncertainty.get(v):
                px = sign * d * n
                reads.append(f"the {v} view's ruler read {abs(px):.2g} px "
                             f"{'long' if px > 0 else 'short'}")
        why = f" (as if {' or '.join(reads)})" if reads else ""
        head = (f"the {self.other} view sees the shared X {abs(pct):.2g} % {word} than the "
                f"{self.reference} view (relative scale {self.ratio:.5f} +- "
                f"{self.ratio_se:.1g}, {self.points} points){why}")
        bound = RECONCILE_Z * self.combined
        if self.reconciled and all(f == 1.0 for f in self.factors.values()):
            return (f"{head}: no difference the points can tell, so the scales were kept as "
                    f"given; k's interval holds what the shared X cannot tell, both scales "
                    f"wrong by the same factor ({self._left()})")
        if self.reconciled:
            moved = ", ".join(f"{v} {100 * (f - 1):+.2g} %" for v, f in self.factors.items())
            return (f"{head}: within what the rulers' stated uncertainty explains "
                    f"({abs(100 * d):.2g} % against {RECONCILE_Z:g} x {100 * self.combined:.2g}"
                    f" %), so the views' scales were reconciled, each moved by its share "
                    f"(weighted by the rulers' variances): {moved}; the scales' uncertainty "
                    f"in k's interval is that of the reconciled scales ({self._left()}); "
                    "check the rulers' ends in scene.toml if that is not expected")
        if not any(self.rel_uncertainty.get(v) for v in (self.reference, self.other)):
            return (f"{head}: no scale uncertainty is stated for either view, so nothing "
                    "was reconciled; give the rulers' px_uncertainty or "
                    "m_per_px_rel_uncertainty in scene.toml")
        return (f"{head}: more than the rulers' stated uncertainty explains "
                f"({abs(100 * d):.2g} % against {RECONCILE_Z:g} x {100 * self.combined:.2g} %"
                f" = {100 * bound:.2g} %), so nothing was reconciled: a wrong fps, another "
                "object or a wrong ruler length, not a reading error; check each view's fps, "
                "ruler and track (vidtrack overlay)")

    def to_dict(self):
        """A JSON-ready form (fit.json's ``world.shared_x``, tracks.h5's /world)."""
        return {"reference": self.reference, "other": self.other, "ratio": self.ratio,
                "ratio_se": self.ratio_se, "offset_m": self.offset_m,
                "offset_se_m": self.offset_se_m, "rho": self.rho, "points": self.points,
                "residual_rms_px": self.residual_rms_px,
                "rel_uncertainty": dict(self.rel_uncertainty),
                "ruler_px": dict(self.ruler_px), "reconciled": self.reconciled,
                "factors": dict(self.factors),
                "covariance": [list(r) for r in self.covariance], "passes": self.passes,
                "scale_rel_uncertainty_reconciled": {
                    v: self.stderr_rel(v) for v in (self.reference, self.other)}}

    @classmethod
    def from_dict(cls, d):
        """The inverse of :meth:`to_dict`."""
        keep = {k: d[k] for k in cls.__dataclass_fields__ if k in d}
        keep["covariance"] = tuple(tuple(float(x) for x in r) for r in d["covariance"])
        return cls(**keep)


def _estimate(tracks, mappings, t0, reference):
    """(d_cur, se_d, offset_m, offset_se_m, rho, n, residual_rms_m) from the views'
    disagreement on X with these mappings, or None with too few common points."""
    from vidtrack.world.resample import frame_step as _frame_step
    from vidtrack.world.parallax import corrected_points

    steps = {v: _frame_step(tracks[v]) for v in tracks}
    points = corrected_points(tracks, mappings, t0)
    cols, _ = common_points(points, t0, reference, steps)
    other = next(v for v in points if v != reference)
    if ("x", reference) not in cols or ("x", other) not in cols:
        return None
    x, xo = cols[("x", reference)], cols[("x", other)]
    ok = np.isfinite(x) & np.isfinite(xo)
    n = int(np.count_nonzero(ok))
    if n < MIN_POINTS + 2:
        return None
    x, xo = x[ok], xo[ok]
    mean = float(x.mean())
    a = np.column_stack([np.ones(n), x - mean])
    coef, cov, rho, res = widened_lstsq(a, xo - x)
    ratio = 1.0 + float(coef[1])
    if not ratio > 0:
        return None
    offset = float(coef[0] - coef[1] * mean)
    offset_se = math.sqrt(max(cov[0, 0] + mean ** 2 * cov[1, 1] - 2 * mean * cov[0, 1], 0.0))
    return (math.log(ratio), math.sqrt(max(cov[1, 1], 0.0)) / ratio, offset, offset_se, rho, n,
            float(np.sqrt(np.mean(res ** 2))))


def _update(d, se_d, sig):
    """The Gaussian update of the two scales' log errors (reference, other) by the
    observed d = e_other - e_ref: (shifts, covariance, S)."""
    s = sig[0] ** 2 + sig[1] ** 2 + se_d ** 2
    k = np.array([-sig[0] ** 2, sig[1] ** 2]) / s
    cov = np.diag([sig[0] ** 2, sig[1] ** 2]) - s * np.outer(k, k)
    return k * d, cov, s


def shared_scale(tracks, mappings, t0, reference, *, rel, ruler_px=None):
    """The views' relative scale and offset on the shared X (the module's step 1, 2).

    Parameters
    ----------
    tracks : dict of str to vidtrack.track.tracker.Track
        Both views' merged tracks (:attr:`WorldTrack.tracks`).
    mappings : dict of str to calibration.ViewMapping
        The mappings as the scene gives them.
    t0 : dict of str to float
        Each view's t = 0 on its clock (:attr:`WorldTrack.t0_s`).
    reference : str
        The world track's reference view.
    rel : dict of str to float or None
        Each view's relative scale uncertainty (None or 0: exact).
    ruler_px : dict of str to float, optional
        Each view's ruler span (px), for the note.

    Returns
    -------
    SharedScale or None
        None with one view or too few common points; ``reconciled`` says whether the
        ratio is within :data:`RECONCILE_Z` combined standard uncertainties (the
        mappings to use are then :meth:`SharedScale.mappings`).
    """
    names = [v for v in ("front", "top") if v in tracks and v in mappings]
    if len(names) != 2 or reference not in names:
        return None
    other = next(v for v in names if v != reference)
    est = _estimate(tracks, mappings, t0, reference)
    if est is None:
        return None
    d, se_d, offset, offset_se, rho, n, rms = est
    sig = [float(rel.get(v) or 0.0) for v in (reference, other)]
    shifts, cov, s = _update(d, se_d, sig)
    reconciled = (sig[0] > 0 or sig[1] > 0) and abs(d) <= RECONCILE_Z * math.sqrt(s)
    if reconciled and abs(d) > SEEN_Z * se_d:
        factors = {reference: math.exp(-shifts[0]), other: math.exp(-shifts[1])}
    elif reconciled:        # no difference the points can tell: the scales kept as given
        factors = {reference: 1.0, other: 1.0}
    else:
        factors = {reference: 1.0, other: 1.0}
        cov = np.diag([sig[0] ** 2, sig[1] ** 2])
    coarser = max(mappings[v].m_per_px for v in names)
    return SharedScale(reference=reference, other=other, ratio=math.exp(d),
                       ratio_se=se_d * math.exp(d), offset_m=offset, offset_se_m=offset_se,
                       rho=rho, points=n, residual_rms_px=rms / coarser,
                       rel_uncertainty={v: rel.get(v) for v in names},
                       ruler_px={v: (ruler_px or {}).get(v) for v in names},
                       reconciled=bool(reconciled), factors=factors,
                       covariance=tuple(tuple(float(x) for x in r) for r in cov))


def merge_reconciled(tracks, mappings, *, sync=None, rel, ruler_px=None):
    """:func:`vidtrack.world.orthogonal.merge_tracks`, then the views' scales measured on
    the shared X and, when a reading error of the rulers explains them, reconciled.

    Parameters
    ----------
    tracks, mappings, sync
        As :func:`vidtrack.world.orthogonal.merge_tracks`.
    rel : dict of str to float or None
        Each view's relative scale uncertainty (None or 0: exact, never moved).
    ruler_px : dict of str to float, optional
        Each view's ruler span, px (for the note).

    Returns
    -------
    vidtrack.world.world_track.WorldTrack
        With ``shared_x`` (:class:`SharedScale`, the ratio as the scene's scales give
        it; None with one view); merged with :meth:`SharedScale.mappings` when reconciled.
    """
    from vidtrack.world.orthogonal import merge_tracks

    world = merge_tracks(tracks, mappings, sync=sync)
    names = [v for v in ("front", "top") if v in tracks]
    if len(names) != 2:
        return world
    first = shared_scale(world.tracks, mappings, world.t0_s, world.reference, rel=rel,
                         ruler_px=ruler_px)
    if first is None or not first.reconciled or not first.seen:
        return replace(world, shared_x=first)
    # the merge's clock offset, found on the shared X, moves with the scales (on
    # datasets/run42 with the top ruler read 0.6 px long the first estimate is 0.44 %
    # off): the ratio is found again on the merge with the scales moved, until it is
    # the ratio the scales were moved for; h(d) = (ratio measured with the scales moved
    # for d) - d has its root there, found by the secant method
    sig = [float(rel.get(v) or 0.0) for v in (first.reference, first.other)]
    gain = _update(1.0, first.ratio_se / first.ratio, sig)[0]
    names = (first.reference, first.other)

    def moved_for(d):
        factors = {v: math.exp(-gain[i] * d) for i, v in enumerate(names)}
        maps = {v: (replace(m, m_per_px=m.m_per_px * factors[v]) if v in factors else m)
                for v, m in mappings.items()}
        w = merge_tracks(tracks, maps, sync=sync)
        est = (_estimate(w.tracks, maps, w.t0_s, first.reference)
               if w.reference == first.reference else None)
        if est is None:
            return None
        # the ratio measured with the moved scales, back to the scene's scales
        back = est[0] - math.log(factors[first.other] / factors[first.reference])
        return back, est, w, factors, maps

    d_a, h_a = 0.0, math.log(first.ratio)
    d_b, passes, best = h_a, 1, None
    for _ in range(_PASSES):
        got = moved_for(d_b)
        passes += 1
        if got is None:
            break
        best = (d_b,) + got
        h_b = got[0] - d_b
        if abs(h_b) < 0.01 * got[1][1] or h_b == h_a:
            break
        d_a, h_a, d_b = d_b, h_b, d_b - h_b * (d_b - d_a) / (h_b - h_a)
    if best is None:                    # the moved merge failed: as given
        return replace(world, shared_x=first)
    _, d, est, moved, factors, maps = best
    shifts, cov, s = _update(d, est[1], sig)
    shared = replace(first, ratio=math.exp(d), ratio_se=est[1] * math.exp(d),
                     offset_m=est[2], offset_se_m=est[3], rho=est[4], points=est[5],
                     residual_rms_px=est[6] / max(m.m_per_px for m in maps.values()),
                     reconciled=abs(d) <= RECONCILE_Z * math.sqrt(s), factors=factors,
                     covariance=tuple(tuple(float(x) for x in r) for r in cov),
                     passes=passes)
    if shared.reconciled and not shared.seen:
        # the first estimate, on a clock found with the scales as given, showed a
        # difference the refined ratio does not (on datasets/run42 with the flight
        # tracker: 0.99994 +- 0.00003, 2.1 standard errors, then 0.99996, 1.4): judged on
        # the refined ratio, as SEEN_Z says, no scale moves and the merge is the one of
        # the scales as given (else the scales moved by 0.002 % unsaid, and the clock
        # offset with them by a hundredth of a frame)
        shared = replace(shared, factors={v: 1.0 for v in shared.factors})
    elif shared.reconciled:
        world = moved
    else:                               # the refined ratio left the bound: as given
        shared = replace(shared, factors={v: 1.0 for v in shared.factors},
                         covariance=((sig[0] ** 2, 0.0), (0.0, sig[1] ** 2)))
    log.info("world track: %s", shared.note())
    return replace(world, shared_x=shared)
