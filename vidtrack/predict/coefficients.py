"""k1..k4 at one machine setting from a regression, with their uncertainty (Chen 2018, s. 4).

Step 1 of the chain of section 4 (:mod:`vidtrack.predict.forward`):
:func:`predict_coefficients` evaluates a :class:`~vidtrack.predict.regression.Regression`
at the setting (n, delta1, v1). When the regression carries a coefficient covariance (a
JSON written by ``vidtrack anova --json``), it is carried into the k's by the delta method,
exact for a model linear in its coefficients; the published eqs. 20-23 give none, hence no
uncertainty band. A setting outside the regression's design region is predicted with an
:class:`ExtrapolationWarning`.
"""

import math
import warnings
from dataclasses import dataclass

from fits.errors import InputError
from vidtrack.predict.regression import FACTOR_NAMES, RESPONSES

#: Coded distance beyond which a setting is an extrapolation (the CCD's axial points).
CODED_LIMIT = 2.0
_Z95 = 1.959963984540054

__all__ = ["CODED_LIMIT", "ExtrapolationWarning", "Coefficient", "CoefficientPrediction",
           "predict_coefficients"]


class ExtrapolationWarning(UserWarning):
    """A setting lies outside the region the regression was fitted on."""


@dataclass(frozen=True)
class Coefficient:
    """A predicted k with its uncertainty (None when the regression has no covariance).

    ``stderr`` and ``ci95`` are for the regression's mean at the setting; ``residual_sd``
    (sqrt of the residual mean square) is the scatter of one run's k about that mean."""

    value: float
    stderr: object = None
    ci95: object = None
    residual_sd: object = None

    def __repr__(self):
        se = "" if self.stderr is None else f", stderr={self.stderr:.3g}"
        return f"Coefficient(value={self.value:.5g}{se})"

    def to_dict(self):
        """Plain JSON-ready values."""
        return {"value": self.value, "stderr": self.stderr,
                "ci95": None if self.ci95 is None else list(self.ci95),
                "residual_sd": self.residual_sd}


@dataclass(frozen=True)
class CoefficientPrediction:
    """k1..k4 at one setting, the setting's coded values and whether it extrapolates."""

    setting: dict
    coefficients: dict
    coded: dict
    extrapolation: bool
    warnings: tuple = ()

    def __repr__(self):
        setting = ", ".join(f"{k}={v:g}" for k, v in self.setting.items())
        ks = ", ".join(f"{r}={c.value:#.4g}" + ("" if c.stderr is None else f"±{c.stderr:.2g}")
                       for r, c in self.coefficients.items())
        extra = ", extrapolation" if self.extrapolation else ""
        return f"CoefficientPrediction({setting}: {ks}{extra})"

    @property
    def k(self):
        """``(k1, k2, k3, k4)`` values."""
        return tuple(self.coefficients[r].value for r in RESPONSES)

    @property
    def k_variance(self):
        """Variances of k1..k4 (independent regressions), or None without covariance."""
        if any(self.coefficients[r].stderr is None for r in RESPONSES):
            return None
        return tuple(self.coefficients[r].stderr ** 2 for r in RESPONSES)

    def to_dict(self):
        """Plain JSON-ready values."""
        return {r: c.to_dict() for r, c in self.coefficients.items()}


def _t95(df):
    if df is None:
        return _Z95
    from scipy import special
    return float(special.stdtrit(df, 0.975))


def _design_check(regression, values):
    """Coded values and the extrapolation messages for ``values``."""
    coded, messages = {}, []
    model = regression.models["k1"]
    for f in model.factors.values():
        coded[f["name"]] = (values[f["name"]] - f["centre"]) / f["step"]
    ranges = model.design_range
    for name in FACTOR_NAMES:
        value = values[name]
        if name in ranges:
            lo, hi = ranges[name]
            outside = value < lo - 1e-9 * max(1.0, abs(lo)) or value > hi + 1e-9 * max(1.0, abs(hi))
            where = f"the design range [{lo:g}, {hi:g}]"
        elif name in coded:
            outside = abs(coded[name]) > CODED_LIMIT + 1e-9
            where = f"coded |x| <= {CODED_LIMIT:g}"
        else:
            continue
        if outside:
            extra = f" (coded {coded[name]:+.3g})" if name in coded else ""
            messages.append(f"{name} = {value:g} lies outside {where}{extra}: the "
                            "prediction is an extrapolation of the regression")
    return coded, messages


def predict_coefficients(regression, *, n_rpm, blade_angle_deg, speed_kmh):
    """k1..k4 at a machine setting, with the delta-method uncertainty when available.

    Parameters
    ----------
    regression : Regression
        From :func:`load_regression`.
    n_rpm, blade_angle_deg, speed_kmh : float, keyword-only
        The setting in the paper's units.

    Returns
    -------
    CoefficientPrediction

    Warns
    -----
    ExtrapolationWarning
        A factor lies outside the design region (the natural design range, or coded
        |x| > 2 when only the coding is known).

    Notes
    -----
    ``var(k) = f' C f`` with ``f`` the terms at the setting and ``C`` the coefficient
    covariance in natural units; exact for a model linear in its coefficients. The
    interval uses Student's t with the residual df when the file has it, else 1.96.
    """
    values = {"n_rpm": n_rpm, "blade_angle_deg": blade_angle_deg, "speed_kmh": speed_kmh}
    for name, value in values.items():
        if isinstance(value, bool) or not math.isfinite(float(value)):
            raise InputError(f"{name} must be a finite number, got {value!r}")
        values[name] = float(value)
    coded, messages = _design_check(regression, values)
    for msg in messages:
        warnings.warn(msg, ExtrapolationWarning, stacklevel=2)
    coefficients = {}
    for r, model in regression.models.items():
        value, var = model.predict(values)
        resid_sd = None if model.residual_ms is None else math.sqrt(max(0.0, model.residual_ms))
        if var is None:
            coefficients[r] = Coefficient(value, None, None, resid_sd)
        else:
            se = math.sqrt(var)
            q = _t95(model.residual_df)
            coefficients[r] = Coefficient(value, se, (value - q * se, value + q * se), resid_sd)
    return CoefficientPrediction(values, coefficients, coded, bool(messages), tuple(messages))
