"""k1..k4 at every run of a designed experiment: from regression equations or a k table.

A rehearsal renders each run of an experiment at the k its setting gives. Where the k's
come from:

- :class:`KEquations`, regression equations: for each of k1..k4 a polynomial of the
  factors, each term's parts a factor's letter (its coded level, as experiment.toml
  codes it: ``A``, ``A:B``, ``A^2``) or a factor's name (its natural level: ``n_rpm``,
  ``n_rpm:blade_angle_deg``, ``n_rpm^2``), as Chen 2018's eqs. 20-23 are written.
  :func:`read_equations` reads them from TOML (a table per k, ``term = coefficient``),
  CSV (columns ``response, term, coefficient``), the JSON of ``vidtrack anova --json``
  (its ``coefficients_natural``) or, by the name ``chen2018``, the published eqs. 20-23
  shipped with vidtrack.
- :class:`KTable`, a k table: a CSV with a ``run`` column (the run folders' names, as
  design.csv names them) and ``k1`` .. ``k4`` (other columns ignored), read by
  :func:`read_k_table`.

:func:`run_settings` reads each run's ``[factors]`` from its scene.toml (planned by
``vidtrack design`` or rendered since); :func:`k_of_runs` gives every run's k, each
checked > 0.
"""

import json
import math
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from fits.errors import InputError
from vidtrack.errors import SceneError, VidtrackError
from vidtrack.predict.regression import DEFAULT_REGRESSION, evaluate_term

__all__ = ["RESPONSES", "BUILTIN_EQUATIONS", "KEquations", "KTable", "RunSetting",
           "read_equations", "read_k_table", "run_settings", "k_of_runs"]

#: The coefficients a rehearsal renders, in order.
RESPONSES = ("k1", "k2", "k3", "k4")
#: Names of equations shipped with vidtrack: Chen 2018's eqs. 20-23 (natural units).
BUILTIN_EQUATIONS = {"chen2018": DEFAULT_REGRESSION}
#: The columns of an equations CSV.
EQUATION_COLUMNS = ("response", "term", "coefficient")


@dataclass(frozen=True)
class RunSetting:
    """One run of an experiment: its folder, name and factors (natural units, by name)."""

    folder: Path
    name: str
    factors: dict


@dataclass(frozen=True)
class KEquations:
    """k1..k4 as polynomials of the factors.

    Attributes
    ----------
    terms : dict
        ``{"k1": {"Intercept": 2.26, "A": 0.51, "A:B": -0.2, ...}, ...}``: per k, its
        terms (letters: coded levels; names: natural levels) and their coefficients.
    source : str
        Where they were read from.
    """

    terms: dict
    source: str

    def k_for(self, setting, values):
        """``(k1, k2, k3, k4)`` at a run: ``values`` maps letters to coded levels and
        names to natural levels (:func:`k_of_runs` builds it)."""
        out = []
        for r in RESPONSES:
            total = 0.0
            for term, coefficient in self.terms[r].items():
                try:
                    total += coefficient * evaluate_term(term, values)
                except InputError as exc:
                    raise VidtrackError(f"{self.source}: {r}: {exc}; a term's parts are the "
                                        "experiment's factor letters (coded) or names "
                                        "(natural)") from None
            out.append(total)
        return tuple(out)


@dataclass(frozen=True)
class KTable:
    """k1..k4 per run, by run name (a CSV's rows)."""

    k: dict
    source: str

    def k_for(self, setting, values):
        """``(k1, k2, k3, k4)`` of the run named as ``setting``'s folder."""
        if setting.folder.name not in self.k:
            raise VidtrackError(f"{self.source}: no row for run {setting.folder.name!r} "
                                f"(column run; it has {', '.join(sorted(self.k)) or 'none'})")
        return self.k[setting.folder.name]


def _number(value, where):
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(float(value)):
        raise VidtrackError(f"{where}: expected a finite number, got {value!r}")
    return float(value)


def _complete(terms, source):
    missing = [r for r in RESPONSES if not terms.get(r)]
    if missing:
        raise VidtrackError(f"{source}: no equation for {', '.join(missing)}; expected all "
                            f"of {', '.join(RESPONSES)}")
    extra = sorted(set(terms) - set(RESPONSES))
    if extra:
        raise VidtrackError(f"{source}: {extra[0]!r} is not one of {', '.join(RESPONSES)}")
    return KEquations({r: dict(terms[r]) for r in RESPONSES}, source)


def _from_toml(text, source):
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise VidtrackError(f"{source}: not valid TOML ({exc})") from None
    terms = {}
    for r, table in data.items():
        if not isinstance(table, dict):
            raise VidtrackError(f"{source}: {r} must be a table [{r}] of term = "
                                f"coefficient, got {table!r}")
        terms[r] = {str(t): _number(c, f"{source}: {r}.{t}") for t, c in table.items()}
    return _complete(terms, source)


def _from_csv(path, source):
    import pandas as pd

    try:
        table = pd.read_csv(path, dtype={"response": str, "term": str})
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise VidtrackError(f"{source}: cannot be read as CSV ({exc})") from None
    missing = [c for c in EQUATION_COLUMNS if c not in table.columns]
    if missing:
        raise VidtrackError(f"{source}: no column {missing[0]!r}; expected the columns "
                            f"{', '.join(EQUATION_COLUMNS)}")
    terms = {}
    for i, row in enumerate(table.itertuples(index=False), start=2):
        value = pd.to_numeric(row.coefficient, errors="coerce")
        terms.setdefault(str(row.response).strip(), {})[str(row.term).strip()] = _number(
            None if pd.isna(value) else float(value), f"{source}: line {i}: coefficient")
    return _complete(terms, source)


def _from_json(text, source):
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise VidtrackError(f"{source}: not valid JSON ({exc.msg}, line {exc.lineno})") from None
    if not isinstance(data, list):
        raise VidtrackError(f"{source}: expected a list of one object per response, as "
                            "'vidtrack anova --json' prints it")
    terms = {}
    for i, obj in enumerate(data):
        coefs = obj.get("coefficients_natural") if isinstance(obj, dict) else None
        if not isinstance(coefs, dict) or not isinstance(obj.get("response"), str):
            raise VidtrackError(f"{source}: item {i} has no response and "
                                "coefficients_natural (expected 'vidtrack anova --json')")
        terms[obj["response"]] = {t: _number(c, f"{source}: item {i}: {t}")
                                  for t, c in coefs.items()}
    return _complete({r: t for r, t in terms.items() if r in RESPONSES}, source)


def read_equations(path):
    """Read k1..k4 regression equations.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.toml`` file (a table ``[k1]`` .. ``[k4]`` of ``term = coefficient``), a
        ``.csv`` file (columns ``response, term, coefficient``), a ``.json`` file as
        ``vidtrack anova --json`` prints it (its ``coefficients_natural``), or
        ``chen2018``: the published eqs. 20-23 of Chen 2018 (natural units: n_rpm,
        blade_angle_deg, speed_kmh).

    Returns
    -------
    KEquations

    Raises
    ------
    VidtrackError
        A file that cannot be read, a k without an equation, a coefficient that is not
        a finite number (the message names the file and where).

    Example
    -------
    >>> eq = read_equations("chen2018")
    >>> sorted(eq.terms)
    ['k1', 'k2', 'k3', 'k4']
    >>> eq.terms.get("k4").get("n_rpm:speed_kmh")
    0.005402
    """
    if str(path) in BUILTIN_EQUATIONS:
        name = BUILTIN_EQUATIONS[str(path)]
        text = (resources.files("vidtrack") / "data" / name).read_text(encoding="utf-8")
        return _from_json(text, f"{path} (vidtrack/data/{name})")
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".toml", ".csv", ".json"):
        raise VidtrackError(f"{path}: expected equations as .toml, .csv or .json (or "
                            f"{', '.join(BUILTIN_EQUATIONS)}), got {suffix or 'no suffix'}")
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise VidtrackError(f"{path}: not found; expected a file of k1..k4 equations (or "
                            f"{', '.join(BUILTIN_EQUATIONS)})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise VidtrackError(f"{path}: cannot read the equations ({exc})") from None
    if suffix == ".toml":
        return _from_toml(text, str(path))
    if suffix == ".json":
        return _from_json(text, str(path))
    return _from_csv(path, str(path))


def read_k_table(path):
    """Read k1..k4 per run: a CSV with the columns ``run`` and ``k1`` .. ``k4``.

    ``run`` names the run folders (``01``, as design.csv names them; read as text, so
    ``01`` stays ``01``); other columns are ignored, so design.csv with k columns added
    serves.

    Returns
    -------
    KTable

    Raises
    ------
    VidtrackError
        A missing column, a run named twice, a k that is not a finite number.
    """
    import pandas as pd

    source = str(path)
    try:
        table = pd.read_csv(path, dtype={"run": str})
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise VidtrackError(f"{source}: cannot be read as CSV ({exc})") from None
    missing = [c for c in ("run", *RESPONSES) if c not in table.columns]
    if missing:
        raise VidtrackError(f"{source}: no column {missing[0]!r}; expected run, "
                            f"{', '.join(RESPONSES)}")
    k = {}
    for i, row in enumerate(table.itertuples(index=False), start=2):
        run = str(row.run).strip()
        if run in k:
            raise VidtrackError(f"{source}: line {i}: run {run!r} given twice")
        values = [pd.to_numeric(getattr(row, r), errors="coerce") for r in RESPONSES]
        k[run] = tuple(_number(None if pd.isna(v) else float(v), f"{source}: line {i}: {r}")
                       for r, v in zip(RESPONSES, values))
    return KTable(k, source)


def run_settings(experiment):
    """Every run of an experiment with its ``[run] name`` and ``[factors]``.

    Read from each run's scene.toml as TOML (a run `vidtrack design` planned has no
    views yet, which a scene needs), each factor of the design checked a number.

    Returns
    -------
    list of RunSetting
        In run order.
    """
    out = []
    for folder in experiment.run_dirs():
        path = folder / "scene.toml"
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
            raise SceneError(f"{path}: cannot be read ({exc})") from None
        factors = data.get("factors") if isinstance(data.get("factors"), dict) else {}
        for letter, f in experiment.factors.items():
            value = factors.get(f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise SceneError(f"{path}: [factors] has no number {f.name!r}, which "
                                 f"factor {letter} of {experiment.path.name} names")
        run = data.get("run") if isinstance(data.get("run"), dict) else {}
        out.append(RunSetting(folder, str(run.get("name", folder.name)), dict(factors)))
    return out


def _values(experiment, setting, fixed):
    """Letters to coded levels, names to natural levels: the run's factors over ``fixed``."""
    values = dict(fixed)
    for letter, f in experiment.factors.items():
        natural = float(setting.factors[f.name])
        values[f.name] = natural
        if f.centre is not None and f.step is not None:
            values[letter] = f.code(natural)
    return values


def k_of_runs(experiment, source, settings, *, fixed=None):
    """Every run's k1..k4, each checked a finite number > 0.

    Parameters
    ----------
    experiment : vidtrack.scene.Experiment
    source : KEquations or KTable
    settings : sequence of RunSetting
        From :func:`run_settings`.
    fixed : dict, optional, keyword-only
        Natural values of factors the equations name that the design does not vary
        (e.g. ``{"speed_kmh": 7.2}`` for Chen's equations on a two-factor design).

    Returns
    -------
    list of tuple
        ``(k1, k2, k3, k4)`` per run, in the order of ``settings``.
    """
    out = []
    for s in settings:
        k = source.k_for(s, _values(experiment, s, fixed or {}))
        for r, v in zip(RESPONSES, k):
            if not (math.isfinite(v) and v > 0):
                raise VidtrackError(f"{source.source}: {r} = {v:.6g} at run {s.folder.name} "
                                    f"({_setting_text(s, experiment)}); a k must be > 0")
        out.append(tuple(float(v) for v in k))
    return out


def _setting_text(setting, experiment):
    return ", ".join(f"{f.name} = {setting.factors[f.name]:g}"
                     for f in experiment.factors.values())
