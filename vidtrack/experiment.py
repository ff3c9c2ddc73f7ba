"""An experiment: many runs -> the coefficient table (Chen 2018 Table 2) -> its ANOVA.

``experiment.toml`` (SPEC.md) names the design, the factors with their coding and the
responses; each run's ``fit.json`` gives the k's (the mean over its throws). The table
has one row per run: ``run``, the coded factors (``A``, ``B``, ``C``), the factors in
natural units (their names) and the responses, with standard errors beside them.
"""

from pathlib import Path

import numpy as np
import pandas as pd

from vidtrack._atomic import atomic_path, write_text
from vidtrack.errors import SceneError


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
            row[letter] = factor.code(value)
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
    named in a note by the caller).
    """
    from fits.rsm import fit_rsm

    if experiment.design != "ccd":
        raise SceneError(f"experiment.toml: design {experiment.design!r} is analysed with "
                         "'vidtrack anova --design orthogonal' on the coefficient table")
    factors = rsm_factors(experiment)
    fits = []
    for k in experiment.responses:
        part = table[np.isfinite(table[k])]
        fits.append(fit_rsm(part, k, factors, alpha=alpha))
    return fits


def write_outputs(out_dir, experiment, table, fits, *, notes=()):
    """coefficients.csv, anova.json and report.html in ``out_dir`` (each atomically)."""
    import json

    from vidtrack.report.anova_page import write_anova_report

    out_dir = Path(out_dir)
    with atomic_path(out_dir / "coefficients.csv") as tmp:
        table.to_csv(tmp, index=False)
    write_text(out_dir / "anova.json",
               json.dumps([f.to_dict() for f in fits], indent=2, allow_nan=False) + "\n")
    write_anova_report(out_dir / "report.html", fits,
                       title=f"Experiment {experiment_name(experiment)}",
                       source="coefficients.csv")
    if notes:
        write_text(out_dir / "notes.txt", "\n".join(notes) + "\n")


def experiment_name(experiment):
    return experiment.folder.name
