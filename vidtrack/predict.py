"""From a machine setting to a predicted throw and a recovery device's place (Chen 2018, s. 4).

The chain of the paper's section 4 and Fig. 6:

1. k1..k4 at the setting (n, delta1, v1) from a regression in natural units: the
   published eqs. 20-23 by default (package data ``vidtrack/data/chen2018_eqs_20_23.json``,
   no covariance published, hence no uncertainty band), or a JSON written by
   ``vidtrack anova --json`` (then the coefficient covariance is carried into the k's by
   the delta method, exact for a model linear in its coefficients, and into the
   trajectory by linearisation).
2. The release state from the blade model (``fits.blade``, eqs. 1-10).
3. The 3-D throw (``fits.throw.position``, eqs. 11-19) until the straw reaches the ground
   plane ``y = -H`` (H: the shaft's height above the ground) or a given inlet plane.
4. Optionally the recovery device's position: H1 (horizontal) and H2 (vertical) from the
   blade shaft O to the device's impeller centre O1, for a given inlet geometry
   (:class:`InletGeometry`; the paper's Fig. 6 flow chart is not legible in our copy, so
   the placement rule is ours and written down there).

Every length is in m, in the world frame of SPEC.md (origin at the blade shaft, x outward,
y up, z along travel, z relative to the machine); the factors keep the paper's units.
"""

import json
import math
import warnings
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from fits.blade import BladeSetting, G_STANDARD, release as blade_release
from fits.errors import InputError
from vidtrack.errors import VidtrackError

#: The factors of Chen 2018 (Table 1) in the names ``vidtrack anova`` uses.
FACTOR_NAMES = ("n_rpm", "blade_angle_deg", "speed_kmh")
RESPONSES = ("k1", "k2", "k3", "k4")
DEFAULT_REGRESSION = "chen2018_eqs_20_23.json"

#: Default straw drag parameter, s/m: Cp = sqrt(C a_s rho / (2 m g)) with C = 1.0,
#: a_s = 0.0172 m^2 (the paper's mean straw, 25.7 mm x 669.3 mm, section 3.2),
#: rho = 1.205 kg/m^3 and an assumed mass m = 0.080 kg (not published): 0.1149 s/m.
DEFAULT_CP_S_PER_M = 0.115
#: Working depth of the blade tip in the soil (Chen 2018, section 3.2): the default
#: shaft height is H = R - 0.050 m.
WORKING_DEPTH_M = 0.050
#: Coded distance beyond which a setting is an extrapolation (the CCD's axial points).
CODED_LIMIT = 2.0
_Z95 = 1.959963984540054

__all__ = ["FACTOR_NAMES", "RESPONSES", "DEFAULT_CP_S_PER_M", "ExtrapolationWarning",
           "ResponseModel", "Regression", "load_regression", "build_published_regression",
           "evaluate_term", "Coefficient", "CoefficientPrediction", "predict_coefficients",
           "drag_parameter", "Trajectory", "throw_trajectory", "InletGeometry",
           "DevicePlacement", "place_device", "Prediction", "predict", "plot_prediction"]


class ExtrapolationWarning(UserWarning):
    """A setting lies outside the region the regression was fitted on."""


# ---------------------------------------------------------------- the regression

def evaluate_term(term, values):
    """The value of one natural-unit polynomial term at a setting.

    Parameters
    ----------
    term : str
        ``"Intercept"``, a factor name (``"n_rpm"``), a power (``"n_rpm^2"``) or a
        product of those joined by ``":"`` (``"n_rpm:blade_angle_deg"``), as in
        ``coefficients_natural`` of ``vidtrack anova --json``.
    values : mapping of str to float
        The factors' natural values.

    Returns
    -------
    float

    Raises
    ------
    fits.errors.InputError
        An unknown factor name or a malformed power.
    """
    if term == "Intercept":
        return 1.0
    out = 1.0
    for part in term.split(":"):
        name, _, power = part.partition("^")
        name = name.strip()
        if name not in values:
            raise InputError(f"term {term!r}: unknown factor {name!r} "
                             f"(expected one of {', '.join(values)})")
        p = 1
        if power:
            try:
                p = int(power)
            except ValueError:
                raise InputError(f"term {term!r}: power {power!r} is not an integer") from None
            if p < 1:
                raise InputError(f"term {term!r}: power must be >= 1, got {p}")
        out *= float(values[name]) ** p
    return out


@dataclass(frozen=True)
class ResponseModel:
    """One response's regression in natural units (one object of ``anova --json``).

    Attributes
    ----------
    response : str
    terms : tuple of str
    coefficients : ndarray
        In ``terms`` order.
    covariance : ndarray or None
        Covariance of the coefficients, ``terms`` order; None when not given.
    residual_ms : float or None
        Residual mean square (the scatter of one run about the model).
    residual_df : int or None
    factors : dict
        ``{"A": {"name", "centre", "step"}, ...}`` or empty.
    design_range : dict
        ``{"n_rpm": (lo, hi), ...}`` or empty.
    """

    response: str
    terms: tuple
    coefficients: np.ndarray
    covariance: object
    residual_ms: object
    residual_df: object
    factors: dict
    design_range: dict

    def design_vector(self, values):
        """The terms evaluated at ``values`` (a mapping of factor name to value)."""
        return np.array([evaluate_term(t, values) for t in self.terms])

    def predict(self, values):
        """``(value, variance or None)`` of the mean response at ``values``.

        The variance is ``f' C f`` (delta method, exact for a linear model)."""
        f = self.design_vector(values)
        value = float(f @ self.coefficients)
        var = None if self.covariance is None else float(max(0.0, f @ self.covariance @ f))
        return value, var


@dataclass(frozen=True)
class Regression:
    """k1..k4 regressions with where they came from."""

    models: dict
    source: str
    provenance: object = None

    @property
    def has_covariance(self):
        """True when every response carries a coefficient covariance."""
        return all(m.covariance is not None for m in self.models.values())


def _num(value, where):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise VidtrackError(f"{where}: expected a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise VidtrackError(f"{where}: expected a finite number, got {value}")
    return value


def _parse_model(obj, where):
    if not isinstance(obj, dict):
        raise VidtrackError(f"{where}: expected an object, got {type(obj).__name__}")
    response = obj.get("response")
    if not isinstance(response, str):
        raise VidtrackError(f"{where}: key 'response' missing or not a string")
    where = f"{where} ({response})"
    coefs = obj.get("coefficients_natural")
    if not isinstance(coefs, dict) or not coefs:
        raise VidtrackError(f"{where}: key 'coefficients_natural' missing or empty "
                            "(expected {\"Intercept\": ..., \"n_rpm\": ...})")
    terms = tuple(coefs)
    probe = dict.fromkeys(FACTOR_NAMES, 1.0)
    for term in terms:
        try:
            evaluate_term(term, probe)
        except InputError as exc:
            raise VidtrackError(f"{where}: coefficients_natural: {exc}") from None
    beta = np.array([_num(coefs[t], f"{where}: coefficients_natural.{t}") for t in terms])
    cov = None
    raw = obj.get("covariance_natural")
    if raw is not None:
        if not isinstance(raw, dict) or "terms" not in raw or "matrix" not in raw:
            raise VidtrackError(f"{where}: covariance_natural must be "
                                "{\"terms\": [...], \"matrix\": [[...]]}")
        cterms = list(raw["terms"])
        if sorted(cterms) != sorted(terms):
            raise VidtrackError(f"{where}: covariance_natural.terms {cterms} do not match "
                                f"the coefficients' terms {list(terms)}")
        try:
            mat = np.array(raw["matrix"], dtype=float)
        except (TypeError, ValueError):
            raise VidtrackError(f"{where}: covariance_natural.matrix is not numeric") from None
        k = len(cterms)
        if mat.shape != (k, k) or not np.all(np.isfinite(mat)):
            raise VidtrackError(f"{where}: covariance_natural.matrix must be a finite "
                                f"{k} x {k} matrix, got shape {mat.shape}")
        if not np.allclose(mat, mat.T, rtol=1e-8, atol=0):
            raise VidtrackError(f"{where}: covariance_natural.matrix is not symmetric")
        order = [cterms.index(t) for t in terms]
        cov = mat[np.ix_(order, order)]
    rms = obj.get("residual_ms")
    rms = None if rms is None else _num(rms, f"{where}: residual_ms")
    rdf = None
    anova = obj.get("anova")
    if isinstance(anova, dict) and isinstance(anova.get("residual"), dict):
        df = anova["residual"].get("df")
        if isinstance(df, (int, float)) and not isinstance(df, bool) and df > 0:
            rdf = int(df)
    factors = {}
    for letter, f in (obj.get("factors") or {}).items():
        if not isinstance(f, dict):
            raise VidtrackError(f"{where}: factors.{letter} must be an object")
        name = f.get("name")
        if name not in FACTOR_NAMES:
            raise VidtrackError(f"{where}: factors.{letter}.name must be one of "
                                f"{', '.join(FACTOR_NAMES)}, got {name!r}")
        step = _num(f.get("step"), f"{where}: factors.{letter}.step")
        if step <= 0:
            raise VidtrackError(f"{where}: factors.{letter}.step must be > 0, got {step}")
        factors[letter] = {"name": name, "step": step,
                           "centre": _num(f.get("centre"), f"{where}: factors.{letter}.centre")}
    ranges = {}
    for name, pair in (obj.get("design_range_natural") or {}).items():
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            raise VidtrackError(f"{where}: design_range_natural.{name} must be [low, high]")
        ranges[name] = (_num(pair[0], f"{where}: design_range_natural.{name}"),
                        _num(pair[1], f"{where}: design_range_natural.{name}"))
    return ResponseModel(response, terms, beta, cov, rms, rdf, factors, ranges)


def _regression_from(data, source):
    if not isinstance(data, list):
        raise VidtrackError(f"{source}: expected a JSON list with one object per response "
                            f"(as 'vidtrack anova --json' writes), got {type(data).__name__}")
    models = {}
    provenance = None
    for i, obj in enumerate(data):
        model = _parse_model(obj, f"{source}: item {i}")
        models[model.response] = model
        provenance = provenance or obj.get("provenance")
    missing = [r for r in RESPONSES if r not in models]
    if missing:
        raise VidtrackError(f"{source}: no regression for {', '.join(missing)} "
                            f"(found {', '.join(models) or 'none'}; k1..k4 are all needed)")
    return Regression({r: models[r] for r in RESPONSES}, str(source), provenance)


def load_regression(path=None):
    """Read k1..k4 regressions from a JSON in the format of ``vidtrack anova --json``.

    Parameters
    ----------
    path : str or Path, optional
        The file; default: the published eqs. 20-23 shipped with vidtrack.

    Returns
    -------
    Regression

    Raises
    ------
    vidtrack.errors.VidtrackError
        The file is missing, not JSON, or lacks a response or key (the message names them).
    """
    if path is None:
        ref = resources.files("vidtrack") / "data" / DEFAULT_REGRESSION
        data = json.loads(ref.read_text(encoding="utf-8"))
        return _regression_from(data, f"vidtrack/data/{DEFAULT_REGRESSION}")
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise VidtrackError(f"{path}: cannot read the regression file: {exc.strerror}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise VidtrackError(f"{path}: not valid JSON ({exc.msg}, line {exc.lineno})") from None
    return _regression_from(data, path)


def build_published_regression(equations_csv, anova_csv, factor_codes_csv):
    """The package data ``chen2018_eqs_20_23.json`` from the transcribed published tables.

    Parameters
    ----------
    equations_csv : path
        ``chen2018_equations_20_23_published.csv`` (response, term, coefficient).
    anova_csv : path
        ``chen2018_table3_anova_published.csv`` (for the residual mean square and df).
    factor_codes_csv : path
        ``chen2018_table1_factor_codes.csv`` (coding and design range).

    Returns
    -------
    list of dict
        One object per response, in the format of ``vidtrack anova --json``, with a
        ``provenance`` key and ``covariance_natural`` null (none is published).
    """
    import pandas as pd

    eq = pd.read_csv(equations_csv)
    table3 = pd.read_csv(anova_csv)
    codes = pd.read_csv(factor_codes_csv).set_index("code")
    factors, ranges = {}, {}
    for letter, name in zip("ABC", FACTOR_NAMES):
        centre = float(codes.loc[0, name])
        step = float(f"{codes.loc[1, name] - codes.loc[0, name]:.12g}")   # 9.0 - 7.2
        factors[letter] = {"name": name, "centre": centre, "step": step}
        ranges[name] = [float(codes[name].min()), float(codes[name].max())]
    out = []
    for response in RESPONSES:
        rows = eq[eq["response"] == response]
        resid = table3[(table3["response"] == response) & (table3["source"] == "residual")]
        out.append({
            "response": response,
            "design": "ccd",
            "coefficients_natural": {str(t): float(c) for t, c in zip(rows["term"],
                                                                      rows["coefficient"])},
            "covariance_natural": None,
            "residual_ms": float(resid["ms"].iloc[0]),
            "anova": {"residual": {"ss": float(resid["ss"].iloc[0]),
                                   "df": int(resid["df"].iloc[0]),
                                   "ms": float(resid["ms"].iloc[0])}},
            "factors": factors,
            "design_range_natural": ranges,
            "provenance": {
                "source": "Chen Haitao, Li Ang, Shi Naiyu, Xu Yuan (2018). Kinetics modeling "
                          "and experiment of lateral throwing of corn straws. Transactions "
                          "of the CSAM 49(5): 76-83, doi:10.6041/j.issn.1000-1298.2018.05.009",
                "coefficients": "eqs. 20-23 as printed (natural units: n in r/min, delta1 "
                                "in degrees, v1 in km/h)",
                "residual": "Table 3, residual SS, df and MS as printed",
                "coding": "Table 1",
                "transcribed_in": ["datasets/published/chen2018_equations_20_23_published.csv",
                                   "datasets/published/chen2018_table3_anova_published.csv",
                                   "datasets/published/chen2018_table1_factor_codes.csv"],
                "covariance": "not published: predictions from these equations carry no "
                              "uncertainty band",
            },
        })
    return out


@dataclass(frozen=True)
class Coefficient:
    """A predicted k with its uncertainty (None when the regression has no covariance).

    ``stderr`` and ``ci95`` are for the regression's mean at the setting; ``residual_sd``
    (sqrt of the residual mean square) is the scatter of one run's k about that mean."""

    value: float
    stderr: object = None
    ci95: object = None
    residual_sd: object = None

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


# ---------------------------------------------------------------- the throw

def drag_parameter(mass_kg, area_m2, *, drag_coefficient=1.0, air_density_kg_m3=1.205,
                   g=G_STANDARD):
    """Cp = sqrt(C a_s rho / (2 m g)), s/m (Chen 2018, after eq. 12).

    Raises
    ------
    fits.errors.InputError
        A mass or area that is not > 0, or a negative C or density.
    """
    for name, v in (("mass_kg", mass_kg), ("area_m2", area_m2)):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"{name} must be > 0, got {v}")
    for name, v in (("drag_coefficient", drag_coefficient),
                    ("air_density_kg_m3", air_density_kg_m3)):
        if not (math.isfinite(v) and v >= 0):
            raise InputError(f"{name} must be >= 0, got {v}")
    return math.sqrt(drag_coefficient * area_m2 * air_density_kg_m3 / (2.0 * mass_kg * g))


@dataclass(frozen=True)
class Trajectory:
    """The predicted flight from release to its end (the ground or an inlet plane).

    Attributes
    ----------
    t_s : ndarray (N,)
    xyz_m : ndarray (N, 3)
        Positions in the world frame (z relative to the machine).
    end : str
        ``"ground"`` (y = -H) or ``"inlet"`` (x = the inlet plane).
    t_end_s : float
    apex : dict or None
        ``{"t_s", "x_m", "y_m"}`` of the highest point, None when there is no ascent
        or it lies beyond the end.
    y_sd_at_x_m, z_sd_at_x_m : ndarray (N,) or None
        Linearised standard deviation of the height and of z across the path at each
        point's x (from the k covariance); None without covariance.
    end_sd_m : dict or None
        Standard deviation of the end point's free coordinates (x and z at the ground;
        y and z at an inlet plane).
    """

    t_s: np.ndarray
    xyz_m: np.ndarray
    end: str
    t_end_s: float
    cp_s_per_m: float
    v1_m_s: float
    shaft_height_m: float
    apex: object = None
    y_sd_at_x_m: object = None
    z_sd_at_x_m: object = None
    end_sd_m: object = None

    @property
    def end_point_m(self):
        """``(x, y, z)`` at the end."""
        return tuple(float(v) for v in self.xyz_m[-1])

    def to_dict(self):
        """Plain JSON-ready values; the 95 % band is ``value +- 1.96 sd`` at each x."""
        x, y, z = self.xyz_m.T
        d = {"end": self.end, "t_end_s": self.t_end_s,
             "end_point_m": dict(zip("xyz", self.end_point_m)),
             "apex": self.apex, "cp_s_per_m": self.cp_s_per_m, "v1_m_s": self.v1_m_s,
             "shaft_height_m": self.shaft_height_m, "ground_y_m": -self.shaft_height_m,
             "t_s": self.t_s.tolist(), "x_m": x.tolist(), "y_m": y.tolist(),
             "z_m": z.tolist(), "band95": None, "end_sd_m": self.end_sd_m}
        if self.y_sd_at_x_m is not None:
            d["band95"] = {"y_m_low": (y - _Z95 * self.y_sd_at_x_m).tolist(),
                           "y_m_high": (y + _Z95 * self.y_sd_at_x_m).tolist(),
                           "z_m_low": (z - _Z95 * self.z_sd_at_x_m).tolist(),
                           "z_m_high": (z + _Z95 * self.z_sd_at_x_m).tolist(),
                           "meaning": "pointwise 95 % band of y and z at each x of the "
                                      "path, from the k covariance (linearised)"}
        return d


class _Flight:
    """The throw for one release state and k, with its k-derivatives by central differences."""

    def __init__(self, state, k, cp, *, v1, g, k_variance=None):
        from fits import throw

        self._throw = throw
        self.state, self.k, self.cp, self.v1, self.g = state, tuple(k), cp, v1, g
        self.k_variance = k_variance

    def pos(self, t, k=None):
        return self._throw.position(np.atleast_1d(np.asarray(t, dtype=float)), self.state,
                                    self.k if k is None else k, self.cp, g=self.g, v1=self.v1)

    def vel(self, t):
        v = self._throw.velocity(np.atleast_1d(np.asarray(t, dtype=float)), self.state,
                                 self.k, self.cp, g=self.g, v1=self.v1)
        v[:, 2] -= self.v1                 # z relative to the machine
        return v

    def jacobian(self, t):
        """d position / d k_j, shape (N, 3, 4), by central differences (h = 1e-5 k)."""
        out = np.empty((np.size(t), 3, 4))
        for j in range(4):
            h = 1e-5 * self.k[j]
            up, dn = list(self.k), list(self.k)
            up[j] += h
            dn[j] -= h
            out[:, :, j] = (self.pos(t, up) - self.pos(t, dn)) / (2 * h)
        return out

    def sd_across(self, t, axis_along, axes):
        """Linearised sd of ``axes`` at fixed coordinate ``axis_along`` (moving along the
        path to keep it fixed), shape (N, len(axes))."""
        jac = self.jacobian(t)
        vel = self.vel(t)
        var_k = np.asarray(self.k_variance)
        out = []
        for a in axes:
            with np.errstate(divide="ignore", invalid="ignore"):
                slope = vel[:, a] / vel[:, axis_along]
            g = jac[:, a, :] - slope[:, None] * jac[:, axis_along, :]
            out.append(np.sqrt(np.sum(g * g * var_k, axis=1)))
        return np.column_stack(out)


def _first_crossing(func, t_lo, t_hi, *, n=513):
    """First t in [t_lo, t_hi] where func (vectorised) goes from < 0 to >= 0, or nan."""
    from scipy.optimize import brentq

    grid = np.linspace(t_lo, t_hi, n)
    vals = func(grid)
    idx = np.flatnonzero((vals[:-1] < 0) & (vals[1:] >= 0))
    if idx.size == 0:
        return math.nan
    i = int(idx[0])
    if vals[i + 1] == 0:
        return float(grid[i + 1])
    return float(brentq(lambda t: float(func(np.array([t]))[0]), grid[i], grid[i + 1],
                        xtol=1e-14, rtol=1e-13, maxiter=200))


def _ground_time(flight, ground_y):
    span = 1.0
    while span <= 1000.0:
        t = _first_crossing(lambda tt: ground_y - flight.pos(tt)[:, 1], 0.0, span)
        if math.isfinite(t):
            return t
        span *= 4.0
    raise InputError(f"the straw does not come down to the ground plane y = {ground_y:g} m "
                     "within 1000 s")


def _check_release_above_ground(state, shaft_height_m):
    if state[1] <= -shaft_height_m:
        raise InputError(
            f"the release point y0 = {state[1]:.4g} m lies at or below the ground plane "
            f"y = {-shaft_height_m:.4g} m (shaft height {shaft_height_m:g} m): the tip "
            "releases the straw in the soil; raise the shaft height or change the phase")


def throw_trajectory(state, k, cp, *, v1_m_s, shaft_height_m, inlet_x_m=None,
                     k_variance=None, points=101, g=G_STANDARD):
    """The 3-D throw from release until the ground plane or an inlet plane.

    Parameters
    ----------
    state : sequence of 6 floats
        ``(x0, y0, z0, vx0, vy0, vz0)``, m and m/s, vz0 absolute (SPEC.md).
    k : sequence of 4 floats
    cp : float
        Drag parameter, s/m.
    v1_m_s : float, keyword-only
        Machine speed, m/s.
    shaft_height_m : float, keyword-only
        H, the blade shaft's height above the ground; the ground is ``y = -H``.
    inlet_x_m : float, optional, keyword-only
        Stop where the straw reaches the vertical plane ``x = inlet_x_m`` (if before the
        ground).
    k_variance : sequence of 4 floats, optional, keyword-only
        Variances of k1..k4 (independent); gives the band.
    points : int, keyword-only
        Number of samples (>= 2), evenly spaced in time.

    Returns
    -------
    Trajectory

    Raises
    ------
    fits.errors.InputError
        A release below the ground, k <= 0, an inlet the straw does not reach.
    """
    k = tuple(float(v) for v in k)
    bad = [f"k{i} = {v:.4g}" for i, v in enumerate(k, start=1) if not v > 0]
    if bad:
        raise InputError(f"the regression predicts {', '.join(bad)} at this setting: a "
                         "throw needs every k > 0 (the setting is too far outside the "
                         "design region)")
    if not (math.isfinite(shaft_height_m) and shaft_height_m > 0):
        raise InputError(f"shaft_height_m must be > 0 m, got {shaft_height_m}")
    if int(points) < 2:
        raise InputError(f"points must be >= 2, got {points}")
    _check_release_above_ground(state, shaft_height_m)
    flight = _Flight(state, k, cp, v1=v1_m_s, g=g, k_variance=k_variance)
    t_ground = _ground_time(flight, -shaft_height_m)
    end, t_end = "ground", t_ground
    if inlet_x_m is not None:
        x_end = float(flight.pos(t_ground)[0, 0])
        if inlet_x_m <= state[0]:
            raise InputError(f"the inlet plane x = {inlet_x_m:g} m is not outward of the "
                             f"release point x0 = {state[0]:.4g} m")
        if x_end < inlet_x_m:
            raise InputError(f"the straw lands at x = {x_end:.4g} m, before the inlet plane "
                             f"x = {inlet_x_m:g} m")
        t_end = _first_crossing(lambda tt: flight.pos(tt)[:, 0] - inlet_x_m, 0.0, t_ground)
        end = "inlet"
    t = np.linspace(0.0, t_end, int(points))
    xyz = flight.pos(t)
    xyz[-1] = flight.pos(t_end)[0]
    from fits import throw
    top = throw.apex(state, k, cp, g=g)
    apex = None
    if top is not None and top.t_s <= t_end:
        apex = {"t_s": top.t_s, "x_m": float(flight.pos(top.t_s)[0, 0]), "y_m": top.y_m}
    y_sd = z_sd = end_sd = None
    if k_variance is not None:
        y_sd, z_sd = flight.sd_across(t, 0, (1, 2)).T
        if end == "ground":
            sd = flight.sd_across(np.array([t_end]), 1, (0, 2))[0]
            end_sd = {"x_m": float(sd[0]), "z_m": float(sd[1])}
        else:
            end_sd = {"y_m": float(y_sd[-1]), "z_m": float(z_sd[-1])}
    return Trajectory(t, xyz, end, float(t_end), float(cp), float(v1_m_s),
                      float(shaft_height_m), apex, y_sd, z_sd, end_sd)


# ---------------------------------------------------------------- the recovery device

@dataclass(frozen=True)
class InletGeometry:
    """The straw recovery device, relative to its impeller centre O1 (Chen 2018, Fig. 5).

    The paper gives neither the device's dimensions nor a legible Fig. 6; these are the
    inputs our placement rule needs (all in m; the defaults are assumptions).

    Attributes
    ----------
    offset_m : float
        Horizontal distance from the inlet plane (the vertical opening the straw enters,
        facing the blade) out to O1; H1 = inlet plane x + offset. Default 0.15.
    low_m, high_m : float
        The opening's lower and upper edge relative to O1's height (low < high).
        Default -0.10 and 0.10.
    bottom_m : float
        How far the housing reaches below O1 (its lowest point). Default 0.20.
    blade_clearance_m : float
        Least horizontal gap between the blade circle (radius R) and the inlet plane.
        Default 0.05.
    ground_clearance_m : float
        Least gap between the housing's lowest point and the ground. Default 0.05.
    """

    offset_m: float = 0.15
    low_m: float = -0.10
    high_m: float = 0.10
    bottom_m: float = 0.20
    blade_clearance_m: float = 0.05
    ground_clearance_m: float = 0.05

    def __post_init__(self):
        for name in ("offset_m", "low_m", "high_m", "bottom_m", "blade_clearance_m",
                     "ground_clearance_m"):
            v = float(getattr(self, name))
            if not math.isfinite(v):
                raise InputError(f"inlet geometry: {name} must be finite, got {v}")
            object.__setattr__(self, name, v)
        if self.low_m >= self.high_m:
            raise InputError(f"inlet geometry: low_m ({self.low_m}) must be below high_m "
                             f"({self.high_m})")
        for name in ("offset_m", "bottom_m", "blade_clearance_m", "ground_clearance_m"):
            if getattr(self, name) < 0:
                raise InputError(f"inlet geometry: {name} must be >= 0, got "
                                 f"{getattr(self, name)}")

    def to_dict(self):
        """Plain JSON-ready values."""
        return {"offset_m": self.offset_m, "low_m": self.low_m, "high_m": self.high_m,
                "bottom_m": self.bottom_m, "blade_clearance_m": self.blade_clearance_m,
                "ground_clearance_m": self.ground_clearance_m}


@dataclass(frozen=True)
class DevicePlacement:
    """H1, H2 and what they rest on (world frame, m; H2 > 0: O1 above the shaft)."""

    h1_m: float
    h2_m: float
    inlet_x_m: float
    inlet_y_m: tuple
    stream_y_m: tuple
    t_inlet_s: float
    binding: str
    geometry: InletGeometry

    def to_dict(self):
        """Plain JSON-ready values."""
        return {"h1_m": self.h1_m, "h2_m": self.h2_m, "inlet_x_m": self.inlet_x_m,
                "inlet_y_m": list(self.inlet_y_m), "stream_y_m": list(self.stream_y_m),
                "t_inlet_s": self.t_inlet_s, "binding": self.binding,
                "geometry": self.geometry.to_dict()}


def place_device(state, k, cp, geometry, *, radius_m, shaft_height_m, v1_m_s,
                 k_variance=None, g=G_STANDARD):
    """H1 and H2 of the recovery device's impeller centre O1 from the blade shaft O.

    Parameters
    ----------
    state, k, cp, v1_m_s, shaft_height_m, k_variance, g
        As :func:`throw_trajectory`.
    geometry : InletGeometry
    radius_m : float, keyword-only
        The blade's tip radius R.

    Returns
    -------
    DevicePlacement

    Raises
    ------
    fits.errors.InputError
        No place exists: the straw lands before the nearest admissible inlet plane, or
        the stream never rises high enough for a housing that clears the ground, or the
        95 % band is taller than the opening.

    Notes
    -----
    Our reading of section 4 (H1 as small as possible without touching the blade, H2
    such that the device does not touch the soil, the thrown straw entering the inlet):

    1. The inlet plane must lie at ``x_i >= R + blade_clearance``.
    2. At ``x_i`` the stream, ``y`` +- 1.96 sd (the sd only with a k covariance), must
       fit the opening ``[O1y + low, O1y + high]`` while the housing clears the ground:
       ``O1y - bottom >= -H + ground_clearance``.
    3. ``x_i`` is the smallest such plane (searched along the flight up to the landing),
       ``O1y`` centres the stream in the opening, raised if the ground requires.
    4. ``H1 = x_i + offset``, ``H2 = O1y``.
    """
    _check_release_above_ground(state, shaft_height_m)
    flight = _Flight(state, k, cp, v1=v1_m_s, g=g, k_variance=k_variance)
    t_ground = _ground_time(flight, -shaft_height_m)
    x_min = radius_m + geometry.blade_clearance_m
    x_land = float(flight.pos(t_ground)[0, 0])
    if x_land <= x_min:
        raise InputError(f"no place for the device: the straw lands at x = {x_land:.4g} m, "
                         f"before the nearest inlet plane x = R + blade clearance = "
                         f"{x_min:.4g} m")
    t_min = (0.0 if state[0] >= x_min else
             _first_crossing(lambda tt: flight.pos(tt)[:, 0] - x_min, 0.0, t_ground))
    floor = -shaft_height_m + geometry.ground_clearance_m + geometry.bottom_m  # lowest O1y
    width = geometry.high_m - geometry.low_m

    def spread(tt):
        if k_variance is None:
            return np.zeros(np.size(tt))
        return _Z95 * flight.sd_across(np.atleast_1d(tt), 0, (1,))[:, 0]

    def slack(tt):
        tt = np.atleast_1d(tt)
        y = flight.pos(tt)[:, 1]
        s = spread(tt)
        return np.minimum((y - s) - (floor + geometry.low_m), width - 2.0 * s)

    if slack(np.array([t_min]))[0] >= 0:
        t_i = t_min
        binding = "blade clearance"
    else:
        t_i = _first_crossing(slack, t_min, t_ground)
        binding = "ground clearance / opening"
        if not math.isfinite(t_i):
            s = spread(np.linspace(t_min, t_ground, 64))
            if np.all(2.0 * s > width):
                why = (f"the 95 % band of the stream is taller than the opening "
                       f"({width:g} m) everywhere")
            else:
                why = ("the stream never rises high enough for an opening whose lower "
                       f"edge is {geometry.low_m:g} m from O1 while the housing "
                       f"({geometry.bottom_m:g} m below O1) clears the ground by "
                       f"{geometry.ground_clearance_m:g} m")
            raise InputError(f"no place for the device between x = {x_min:.4g} m and the "
                             f"landing at x = {x_land:.4g} m: {why}")
    p = flight.pos(t_i)[0]
    s = float(spread(t_i)[0])
    o1y = max(floor, p[1] - 0.5 * (geometry.low_m + geometry.high_m))
    return DevicePlacement(
        h1_m=float(p[0] + geometry.offset_m), h2_m=float(o1y), inlet_x_m=float(p[0]),
        inlet_y_m=(float(o1y + geometry.low_m), float(o1y + geometry.high_m)),
        stream_y_m=(float(p[1] - s), float(p[1] + s)), t_inlet_s=float(t_i),
        binding=binding, geometry=geometry)


# ---------------------------------------------------------------- the whole chain

@dataclass(frozen=True)
class Prediction:
    """Everything ``vidtrack predict`` reports for one setting."""

    coefficients: CoefficientPrediction
    release: object
    trajectory: Trajectory
    device: object
    regression_source: str
    regression_provenance: object
    has_covariance: bool
    warnings: tuple = ()
    notes: tuple = ()
    extra: dict = field(default_factory=dict)

    def to_dict(self):
        """The ``vidtrack predict --json`` object (SPEC.md keys first)."""
        return {
            "coefficients": self.coefficients.to_dict(),
            "release": self.release.to_dict(),
            "trajectory": self.trajectory.to_dict(),
            "schema": 1,
            "setting": dict(self.coefficients.setting),
            "coded": dict(self.coefficients.coded),
            "extrapolation": self.coefficients.extrapolation,
            "regression": {"source": self.regression_source,
                           "covariance": self.has_covariance,
                           "provenance": self.regression_provenance},
            "device": None if self.device is None else self.device.to_dict(),
            "warnings": list(self.warnings),
            "notes": list(self.notes),
        }


def predict(n_rpm, blade_angle_deg, speed_kmh, *, regression=None, radius_m=0.25,
            start_m=0.10, friction=0.5, phase_deg=-30.0, release_method="exact",
            cp_s_per_m=DEFAULT_CP_S_PER_M, shaft_height_m=None, inlet_x_m=None,
            device=None, points=101, g=G_STANDARD):
    """Predict k1..k4, the release and the throw for one machine setting (section 4).

    Parameters
    ----------
    n_rpm, blade_angle_deg, speed_kmh : float
        Blade speed n (r/min), rake angle delta1 (deg), travel speed v1 (km/h).
    regression : Regression, optional, keyword-only
        Default: the published eqs. 20-23 (:func:`load_regression`).
    radius_m, start_m, friction, phase_deg : float, keyword-only
        The blade model's R, l1, mu and alpha0 (``fits.blade.BladeSetting``; defaults
        there are assumptions, the paper publishes none of them).
    release_method : {"exact", "series"}, keyword-only
        ``fits.blade.release`` method.
    cp_s_per_m : float, keyword-only
        Straw drag parameter (see ``DEFAULT_CP_S_PER_M``).
    shaft_height_m : float, optional, keyword-only
        H, the shaft's height above the ground; default R - 0.050 (the tip works 50 mm
        deep, section 3.2).
    inlet_x_m : float, optional, keyword-only
        End the trajectory at this vertical inlet plane instead of the ground.
    device : InletGeometry, optional, keyword-only
        Place the recovery device (H1, H2) for this geometry; the trajectory then ends
        at its inlet.
    points : int, keyword-only
        Trajectory samples.

    Returns
    -------
    Prediction

    Raises
    ------
    fits.errors.InputError
        A setting that violates a throwing condition (the message names eq. 5, 6, 7 or
        the exact slide), a release below the ground, no place for the device, bad values.

    Warns
    -----
    ExtrapolationWarning
        The setting lies outside the regression's design region.
    """
    if regression is None:
        regression = load_regression()
    coefs = predict_coefficients(regression, n_rpm=n_rpm, blade_angle_deg=blade_angle_deg,
                                 speed_kmh=speed_kmh)
    blade = BladeSetting(n_rpm, blade_angle_deg, radius_m=radius_m, start_m=start_m,
                         friction=friction, phase_deg=phase_deg, g_m_s2=g)
    rel = blade_release(blade, method=release_method, speed_kmh=speed_kmh).require_thrown()
    if not (math.isfinite(cp_s_per_m) and cp_s_per_m >= 0):
        raise InputError(f"cp_s_per_m must be >= 0 s/m, got {cp_s_per_m}")
    if shaft_height_m is None:
        shaft_height_m = radius_m - WORKING_DEPTH_M
    state = rel.state()
    v1 = float(speed_kmh) / 3.6
    notes = []
    if not regression.has_covariance:
        notes.append("the regression carries no coefficient covariance (the published "
                     "eqs. 20-23 give none): no uncertainty band")
    if rel.min_normal_accel_m_s2 < 0:
        notes.append(f"the blade's normal force in eq. 1 is negative during part of the "
                     f"slide (min N/m = {rel.min_normal_accel_m_s2:.3g} m/s^2): there the "
                     "paper's friction term pushes the straw outward, where in fact it "
                     "would lift off the blade face; the model (and this prediction) "
                     "ignores that")
    kvar = coefs.k_variance
    placement = None
    if device is not None:
        placement = place_device(state, coefs.k, cp_s_per_m, device, radius_m=radius_m,
                                 shaft_height_m=shaft_height_m, v1_m_s=v1, k_variance=kvar,
                                 g=g)
        inlet_x_m = placement.inlet_x_m
    traj = throw_trajectory(state, coefs.k, cp_s_per_m, v1_m_s=v1,
                            shaft_height_m=shaft_height_m, inlet_x_m=inlet_x_m,
                            k_variance=kvar, points=points, g=g)
    return Prediction(coefs, rel, traj, placement, regression.source,
                      regression.provenance, regression.has_covariance,
                      tuple(coefs.warnings), tuple(notes))


def plot_prediction(prediction, path):
    """Write the front (x-y) and top (x-z) views of the predicted throw as a PNG.

    The 95 % band (when the regression has a covariance) is shaded; the blade circle,
    the ground and, when placed, the device's inlet and O1 are drawn. Written atomically.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vidtrack._atomic import atomic_path

    tr = prediction.trajectory
    rel = prediction.release
    x, y, z = tr.xyz_m.T
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 8), sharex=True)
    r = rel.setting.radius_m
    ang = np.linspace(0, 2 * np.pi, 200)
    ax1.plot(r * np.cos(ang), r * np.sin(ang), color="0.6", lw=0.8, label="blade circle")
    ax1.axhline(-tr.shaft_height_m, color="saddlebrown", lw=1.2, label="ground")
    ax1.plot(x, y, color="C0", label="predicted throw")
    if tr.y_sd_at_x_m is not None:
        ax1.fill_between(x, y - _Z95 * tr.y_sd_at_x_m, y + _Z95 * tr.y_sd_at_x_m,
                         color="C0", alpha=0.25, label="95 % band (k covariance)")
        ax2.fill_between(x, z - _Z95 * tr.z_sd_at_x_m, z + _Z95 * tr.z_sd_at_x_m,
                         color="C0", alpha=0.25)
    ax1.plot([rel.x0_m], [rel.y0_m], "o", color="C1", label="release")
    if prediction.device is not None:
        d = prediction.device
        ax1.plot([d.inlet_x_m] * 2, list(d.inlet_y_m), color="C2", lw=3, label="inlet")
        ax1.plot([d.h1_m], [d.h2_m], "+", color="C2", ms=10, label="O1 (H1, H2)")
    ax1.set_ylabel("y (m)")
    ax1.set_aspect("equal", adjustable="datalim")
    ax1.legend(fontsize=8, loc="best")
    s = prediction.coefficients.setting
    ax1.set_title(f"n = {s['n_rpm']:g} r/min, delta1 = {s['blade_angle_deg']:g} deg, "
                  f"v1 = {s['speed_kmh']:g} km/h" + (" (extrapolation)"
                                                    if prediction.coefficients.extrapolation
                                                    else ""))
    ax2.plot(x, z, color="C0")
    ax2.set_xlabel("x (m)")
    ax2.set_ylabel("z relative to the machine (m)")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
