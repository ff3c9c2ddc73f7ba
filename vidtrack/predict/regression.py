"""The k1..k4 regressions in natural units: the published eqs. 20-23 or ``vidtrack anova --json``.

Step 1 of the chain of Chen 2018, section 4 (:mod:`vidtrack.predict.forward`) starts from
a regression of each of k1..k4 on the setting (n, delta1, v1) in natural units: the
published eqs. 20-23 by default (package data ``vidtrack/data/chen2018_eqs_20_23.json``,
no covariance published, hence no uncertainty band), or a JSON written by
``vidtrack anova --json`` (then with the coefficient covariance). This module reads and
validates such a file (:func:`load_regression`), evaluates its polynomial terms
(:func:`evaluate_term`, :class:`ResponseModel`) and builds the shipped file from the
transcribed published tables (:func:`build_published_regression`);
:mod:`vidtrack.predict.coefficients` evaluates it at a setting.
"""

import json
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from fits.errors import InputError
from vidtrack.errors import VidtrackError

#: The factors of Chen 2018 (Table 1) in the names ``vidtrack anova`` uses.
FACTOR_NAMES = ("n_rpm", "blade_angle_deg", "speed_kmh")
RESPONSES = ("k1", "k2", "k3", "k4")
DEFAULT_REGRESSION = "chen2018_eqs_20_23.json"

__all__ = ["FACTOR_NAMES", "RESPONSES", "DEFAULT_REGRESSION", "ResponseModel", "Regression",
           "load_regression", "build_published_regression", "evaluate_term"]


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

    def __repr__(self):
        cov = "with" if self.covariance is not None else "no"
        return (f"ResponseModel(response={self.response!r}, terms={len(self.terms)}, "
                f"{cov} covariance)")

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

    def __repr__(self):
        from pathlib import PurePath

        cov = "with" if self.has_covariance else "no"
        return (f"Regression(responses={', '.join(self.models)}, "
                f"source={PurePath(str(self.source)).name!r}, {cov} covariance)")

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
