"""Least squares, ANOVA partitions and canonical analysis behind ``fits.rsm``."""

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.special


@dataclass(frozen=True)
class AnovaRow:
    """One row of an ANOVA table: sum of squares, degrees of freedom, mean square, F, p.

    ``ms``, ``f`` and ``p`` are None where they do not apply (the total has no mean
    square in the papers' tables, a residual has no F) or cannot be computed (F with a
    zero error mean square).
    """

    ss: float
    df: int
    ms: float | None = None
    f: float | None = None
    p: float | None = None

    def to_dict(self):
        """The row as a dict with ``ss``, ``df`` and, where defined, ``ms``, ``f``, ``p``."""
        out = {"ss": float(self.ss), "df": int(self.df)}
        for key in ("ms", "f", "p"):
            v = getattr(self, key)
            if v is not None:
                out[key] = float(v)
        return out


def anova_frame(anova, labels):
    """An ANOVA dict (key -> AnovaRow or None) as a DataFrame with the printed row names.

    Rows follow ``labels`` (key -> printed name) and leave out the None rows; columns
    ``ss``, ``df``, ``ms``, ``f``, ``p``, NaN where a row has no such value.
    """
    import pandas as pd

    rows = []
    for key, label in labels.items():
        r = anova.get(key)
        if r is None:
            continue
        rows.append({"source": label, "ss": float(r.ss), "df": int(r.df),
                     **{q: np.nan if getattr(r, q) is None else float(getattr(r, q))
                        for q in ("ms", "f", "p")}})
    out = pd.DataFrame(rows, columns=["source", "ss", "df", "ms", "f", "p"])
    return out.set_index("source")


def ratio(num, den):
    """``num / den``, or None when ``den`` is zero or not finite (a guarded division)."""
    if den is None or num is None or not math.isfinite(den) or den <= 0.0:
        return None
    return num / den


def f_sf(f, dfn, dfd):
    """Upper-tail probability of the F distribution (scipy's cephes ``fdtrc``)."""
    return float(scipy.special.fdtrc(dfn, dfd, f))


def f_row(ss, df, ms_error, df_error):
    """An ANOVA row tested against an error mean square (F and its upper-tail p)."""
    ms = ratio(ss, df)
    f = ratio(ms, ms_error) if ms is not None else None
    p = f_sf(f, df, df_error) if f is not None and df_error > 0 else None
    return AnovaRow(ss=float(ss), df=int(df), ms=ms, f=f, p=p)


@dataclass(frozen=True)
class LeastSquares:
    """An ordinary least-squares fit with everything the ANOVA needs."""

    params: np.ndarray
    fitted: np.ndarray
    residuals: np.ndarray
    xtx_inv: np.ndarray       # (X'X)^-1 from the QR factor, never from inverting X'X
    leverage: np.ndarray
    sse: float
    df_resid: int

    def __repr__(self):
        return (f"LeastSquares(parameters={len(self.params)}, n={len(self.fitted)}, "
                f"sse={self.sse:.6g}, df_resid={self.df_resid})")

    @property
    def mse(self):
        """Residual mean square (None with no residual degrees of freedom)."""
        return ratio(self.sse, self.df_resid)

    @property
    def cov(self):
        """Covariance of the parameters: MSE (X'X)^-1."""
        return (self.mse or 0.0) * self.xtx_inv


def least_squares(X, y):
    """Fit ``y = X b`` by ordinary least squares through the QR factorisation of ``X``.

    ``X`` must have full column rank (the caller checks aliasing first). ``(X'X)^-1`` is
    ``R^-1 R^-T`` and the leverages are the row sums of ``Q**2``; ``X'X`` itself is never
    formed or inverted.
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    Q, R = np.linalg.qr(X)
    params = scipy.linalg.solve_triangular(R, Q.T @ y)
    Rinv = scipy.linalg.solve_triangular(R, np.eye(R.shape[0]))
    xtx_inv = Rinv @ Rinv.T
    fitted = X @ params
    resid = y - fitted
    leverage = np.sum(Q * Q, axis=1)
    return LeastSquares(params=params, fitted=fitted, residuals=resid, xtx_inv=xtx_inv,
                        leverage=leverage, sse=float(resid @ resid),
                        df_resid=int(X.shape[0] - X.shape[1]))


def term_pvalues(fit):
    """Partial-F (= t squared) p-values of each parameter, guarded for an exact fit."""
    mse = fit.mse
    diag = np.diag(fit.xtx_inv)
    out = np.empty(len(fit.params))
    for j, b in enumerate(fit.params):
        if mse is None or mse <= 0.0:
            out[j] = 0.0 if b != 0.0 else 1.0
            continue
        f = b * b / (diag[j] * mse)
        out[j] = f_sf(f, 1, fit.df_resid)
    return out


def replicate_groups(coded, *, decimals=9):
    """Group index of each run by its design point (rows equal after rounding)."""
    keys = [tuple(np.round(row, decimals) + 0.0) for row in np.asarray(coded, dtype=float)]
    index = {}
    return np.array([index.setdefault(k, len(index)) for k in keys]), len(index)


def pure_error(y, groups):
    """Pure-error sum of squares and its degrees of freedom (replicates about their mean)."""
    y = np.asarray(y, dtype=float)
    ss = 0.0
    df = 0
    for g in np.unique(groups):
        yy = y[groups == g]
        if yy.size > 1:
            ss += float(np.sum((yy - yy.mean()) ** 2))
            df += yy.size - 1
    return ss, df


def studentized_external(residuals, leverage, mse, df_resid):
    """Externally studentized residuals (each run left out of its own variance)."""
    n = len(residuals)
    out = np.full(n, np.nan)
    if mse is None or mse <= 0.0 or df_resid < 2:
        return out
    for i in range(n):
        one_minus_h = 1.0 - leverage[i]
        if one_minus_h <= 1e-12:
            continue
        r = residuals[i] / math.sqrt(mse * one_minus_h)
        denom = df_resid - r * r
        if denom > 0:
            out[i] = r * math.sqrt((df_resid - 1) / denom)
    return out


@dataclass(frozen=True)
class CanonicalAnalysis:
    """Canonical analysis of a second-order surface in coded units.

    The fitted surface is ``y = b0 + x'b + x'Bx``; its stationary point is
    ``x_s = -B^-1 b / 2`` and the eigenvalues of ``B`` tell a maximum (all negative),
    a minimum (all positive) or a saddle (mixed signs). With an (almost) zero eigenvalue
    the stationary point is not unique (a ridge) and is not given.
    """

    available: bool
    reason: str | None = None
    eigenvalues: tuple = ()
    eigenvectors: tuple = ()          # one tuple per eigenvalue, in coded factor order
    stationary_point_coded: dict | None = None
    stationary_point_natural: dict | None = None
    response_at_stationary: float | None = None
    nature: str | None = None
    within_design: bool | None = None

    def __repr__(self):
        eig = ", ".join(f"{v:.4g}" for v in self.eigenvalues)
        if not self.available:
            return (f"CanonicalAnalysis(available=False, eigenvalues=({eig}), "
                    f"reason={self.reason.split(':')[0]!r})")
        pt = ", ".join(f"{k}={v:.5g}" for k, v in self.stationary_point_natural.items())
        return (f"CanonicalAnalysis({self.nature} at {pt}, "
                f"response={self.response_at_stationary:.5g}, "
                f"within_design={self.within_design}, eigenvalues=({eig}))")

    def to_dict(self):
        """JSON-ready dict."""
        return {
            "available": self.available,
            "reason": self.reason,
            "eigenvalues": [float(v) for v in self.eigenvalues],
            "eigenvectors": [[float(x) for x in v] for v in self.eigenvectors],
            "stationary_point_coded": self.stationary_point_coded,
            "stationary_point_natural": self.stationary_point_natural,
            "response_at_stationary": self.response_at_stationary,
            "nature": self.nature,
            "within_design": self.within_design,
        }


def canonical_analysis(terms, params, factors, coded_extent):
    """Stationary point and eigenvalues of the fitted second-order surface.

    Parameters
    ----------
    terms : list of exponent tuples, intercept first (matching ``params``)
    params : coded coefficients
    factors : sequence of :class:`fits.rsm.Factor`
    coded_extent : (k,) array, largest |coded value| of each factor in the design
    """
    k = len(factors)
    if any(sum(t) > 2 for t in terms):
        return CanonicalAnalysis(False, "the model has terms above second order")
    if not any(sum(t) for t in terms):
        return CanonicalAnalysis(False, "no model terms: the fitted surface is the mean")
    if not any(sum(t) == 2 for t in terms):
        return CanonicalAnalysis(False, "first-order model: the surface is a plane with "
                                        "no stationary point")
    b0 = 0.0
    b = np.zeros(k)
    B = np.zeros((k, k))
    for t, c in zip(terms, params):
        nz = [i for i, e in enumerate(t) if e]
        if not nz:
            b0 = float(c)
        elif sum(t) == 1:
            b[nz[0]] = c
        elif len(nz) == 1:
            B[nz[0], nz[0]] = c
        else:
            i, j = nz
            B[i, j] = B[j, i] = c / 2.0
    lam, vec = np.linalg.eigh(B)
    eigvecs = tuple(tuple(float(x) for x in vec[:, i]) for i in range(k))
    scale = float(np.max(np.abs(lam))) if lam.size else 0.0
    if scale == 0.0 or float(np.min(np.abs(lam))) <= 1e-10 * scale:
        return CanonicalAnalysis(
            False, "the quadratic part is singular (a zero eigenvalue): the surface is a "
                   "ridge or rises along some direction, so there is no unique stationary "
                   "point", eigenvalues=tuple(float(v) for v in lam), eigenvectors=eigvecs)
    xs = -0.5 * np.linalg.solve(B, b)
    ys = b0 + 0.5 * float(xs @ b)
    nature = "maximum" if np.all(lam < 0) else ("minimum" if np.all(lam > 0) else "saddle")
    return CanonicalAnalysis(
        True, None, eigenvalues=tuple(float(v) for v in lam), eigenvectors=eigvecs,
        stationary_point_coded={f.letter: float(x) for f, x in zip(factors, xs)},
        stationary_point_natural={f.name: float(f.decode(x)) for f, x in zip(factors, xs)},
        response_at_stationary=float(ys), nature=nature,
        within_design=bool(np.all(np.abs(xs) <= coded_extent + 1e-12)))
