"""An experiment: many runs -> the coefficient table (Chen 2018 Table 2) -> its ANOVA.

``experiment.toml`` (docs/scene.md) names the design, the factors with their coding and the
responses; each run's ``fit.json`` gives the k's (the mean over its throws). The table
has one row per run: ``run``, the coded factors (``A``, ``B``, ``C``), the factors in
natural units (their names) and the responses, with standard errors beside them. A coded
level is rounded to :data:`CODED_DECIMALS` decimals, so that a design level is written as
the design gives it (``-1``, not ``-0.9999999999999999`` from ``(450 - 550) / 100``).
"""

import logging
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from vidtrack._atomic import atomic_path, write_text
from vidtrack._text import csv_cell
from vidtrack.errors import SceneError

log = logging.getLogger(__name__)

#: What ``vidtrack report`` writes into ``<experiment>/vidtrack/``.
OUTPUTS = ("coefficients.csv", "anova.json", "report.html", "notes.txt")
#: The responses a run's fit.json gives.
RESPONSES = ("k1", "k2", "k3", "k4")
#: Decimals a coded level is rounded to: far below any design's resolution, far above
#: the rounding error of (natural - centre) / step.
CODED_DECIMALS = 12


def check_runs(experiment, scenes):
    """What the analysis needs of the runs, checked before any run is fitted.

    Parameters
    ----------
    experiment : vidtrack.scene.Experiment
    scenes : sequence of vidtrack.scene.Scene
        Every run's scene, in run order.

    Raises
    ------
    SceneError
        A design the report cannot analyse, a response that no fit gives, two runs with
        one name (``[run] name``, by default the folder's name), a run whose
        scene.toml lacks a factor of the design or gives it as something else than a
        number (the message names the file, the factor, what the scene has).
    """
    import difflib

    if experiment.design != "ccd":
        raise SceneError(f"{experiment.path}: design = {experiment.design!r}: 'vidtrack "
                         "report' analyses a ccd design; fit the runs with 'vidtrack fit' "
                         "and analyse the table with 'vidtrack anova --design orthogonal'")
    for k in experiment.responses:
        if k not in RESPONSES:
            near = difflib.get_close_matches(k, RESPONSES, n=1)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            raise SceneError(f"{experiment.path}: responses names {k!r}{hint}; expected "
                             f"some of {', '.join(RESPONSES)}")
    named = {}
    for scene in scenes:
        first = named.setdefault(scene.run_name, scene)
        if first is not scene:
            raise SceneError(f"{first.folder} and {scene.folder} both have the run name "
                             f"{scene.run_name!r} ([run] name in scene.toml); expected each "
                             "run of an experiment named once (the coefficient table has a "
                             "row per run, told apart by its name)")
    for scene in scenes:
        for letter, factor in experiment.factors.items():
            if factor.name not in scene.factors:
                have = list(scene.factors)
                near = difflib.get_close_matches(factor.name, have, n=1)
                hint = f" (did you mean {near[0]!r}?)" if near else ""
                raise SceneError(
                    f"{scene.path}: [factors] has no {factor.name!r}{hint}, which "
                    f"{experiment.path.name}'s factor {letter} names; the scene has "
                    f"{', '.join(have) if have else 'no factors'}")
            value = scene.factors[factor.name]
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not np.isfinite(value):
                raise SceneError(f"{scene.path}: factors.{factor.name} must be a finite "
                                 f"number (factor {letter} of the design is coded from "
                                 f"it), got {value!r}")


def coefficient_table(experiment, records):
    """The Table-2-style DataFrame of an experiment from its runs' fit.json records.

    Parameters
    ----------
    experiment : vidtrack.scene.Experiment
    records : sequence of dict
        fit.json records, one per run (in run order).

    Raises
    ------
    SceneError
        A run whose scene lacks a factor of the design.
    """
    rows = []
    for rec in records:
        row = {"run": rec["run"]}
        for letter, factor in experiment.factors.items():
            if factor.name not in rec["factors"]:
                raise SceneError(f"run {rec['run']}: scene.toml [factors] has no "
                                 f"{factor.name!r}, which experiment.toml's factor "
                                 f"{letter} needs")
            value = float(rec["factors"][factor.name])
            row[letter] = round(factor.code(value), CODED_DECIMALS) + 0.0   # no -0.0
            row[factor.name] = value
        for k in experiment.responses:
            c = rec["coefficients"].get(k)
            row[k] = c["value"] if c and c["determined"] else np.nan
            row[f"{k}_stderr"] = c["stderr"] if c and c["determined"] else np.nan
        row["throws"] = rec.get("throws", 1)
        rows.append(row)
    return pd.DataFrame(rows)


def rsm_factors(experiment):
    """The experiment's factors as ``fits.rsm.Factor`` objects, in letter order."""
    from fits.rsm import Factor

    return [Factor(letter, f.name, f.centre, f.step)
            for letter, f in sorted(experiment.factors.items())]


def analyse(experiment, table, *, alpha=0.05):
    """Response-surface fits of every response of the experiment (``fits.rsm``).

    Runs where a response was not determined are left out of that response's fit (and
    named in a note by the caller). A term the design cannot estimate is left out and
    said through the ``vidtrack`` logger.
    """
    from fits.rsm import fit_rsm

    if experiment.design != "ccd":
        raise SceneError(f"experiment.toml: design {experiment.design!r} is analysed with "
                         "'vidtrack anova --design orthogonal' on the coefficient table")
    factors = rsm_factors(experiment)
    fits = []
    # what the fit warns about (a term the design cannot estimate) is said through the
    # vidtrack logger, as every message of the library, not as a Python warning
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for k in experiment.responses:
            part = table[np.isfinite(table[k])]
            fits.append(fit_rsm(part, k, factors, alpha=alpha))
    for w in caught:
        log.warning("%s", w.message)
    return fits


def run_flags(record):
    """The frames flagged of those tracked, per view, from a fit.json record:
    ``"front 44/372, top 42/372"`` (flagged: not usable, i.e. flagged or lost); ``""``
    when the record has no view summaries."""
    parts = []
    for name, v in (record.get("views") or {}).items():
        if isinstance(v, dict) and "frames" in v and "usable" in v:
            parts.append(f"{name} {int(v['frames']) - int(v['usable'])}/{int(v['frames'])}")
    return ", ".join(parts)


def run_table(experiment, table, records, run_dirs, out_dir):
    """The runs of the experiment's report (:class:`vidtrack.report.anova_page.RunTable`).

    Parameters
    ----------
    experiment : vidtrack.scene.Experiment
    table : pandas.DataFrame
        :func:`coefficient_table` of ``records``.
    records : sequence of dict
        The runs' fit.json records, in run order.
    run_dirs : sequence of path
        The run folders, in the same order: each run's ``vidtrack/report.html`` is
        linked relative to ``out_dir`` where it exists.
    out_dir : path
        The folder of the experiment's report.html.
    """
    import os
    from urllib.parse import quote

    from vidtrack.report.anova_page import RunTable

    links = []
    for folder in run_dirs:
        page = Path(folder) / "vidtrack" / "report.html"
        links.append(quote(Path(os.path.relpath(page, out_dir)).as_posix())
                     if page.is_file() else None)
    letters = sorted(experiment.factors)
    return RunTable(table=table, coded=tuple(letters),
                    natural=tuple(experiment.factors[x].name for x in letters),
                    responses=tuple(experiment.responses), links=tuple(links),
                    flags=tuple(run_flags(r) for r in records))


def write_outputs(out_dir, experiment, table, fits, *, notes=(), runs=None):
    """coefficients.csv, anova.json and report.html in ``out_dir`` (each atomically; if
    one cannot be written, e.g. on a full disk, none of them is left). ``runs``
    (:func:`run_table`) opens report.html with the table of runs."""
    import json

    from vidtrack.report.anova_page import write_anova_report

    out_dir = Path(out_dir)
    try:
        with atomic_path(out_dir / "coefficients.csv") as tmp:
            # a run's name is the user's text: never a formula to a spreadsheet
            table.assign(run=table["run"].map(csv_cell)).to_csv(tmp, index=False)
        write_text(out_dir / "anova.json",
                   json.dumps([f.to_dict() for f in fits], indent=2, allow_nan=False) + "\n")
        write_anova_report(out_dir / "report.html", fits,
                           title=f"Experiment {experiment_name(experiment)}",
                           source="coefficients.csv", runs=runs)
        if notes:
            write_text(out_dir / "notes.txt", "\n".join(notes) + "\n")
    except BaseException:       # a report is its files together: none of a half one
        for name in OUTPUTS:
            (out_dir / name).unlink(missing_ok=True)
        raise


def experiment_name(experiment):
    return experiment.folder.name
