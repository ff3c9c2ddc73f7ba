"""A rehearsal scored: every throw's fitted k against its truth, and the regressions.

After ``vidtrack synth EXP --regression ...`` and ``vidtrack report EXP``,
:func:`score_experiment` pairs each throw's ``truth.json`` (what was rendered) with its
``fit.json`` (what vidtrack recovered): the error of each k, whether its 95 % interval
(``ci95``, the fit's and the scales' parts together) covers the truth, and per k the
errors and the coverage over all throws. Then the response-surface regression of each k
is fitted twice on the experiment's runs, as ``vidtrack report`` fits it: on the true k
(each run's mean over its throws' truth) and on the fitted k (each run's fit.json).
Backward elimination selects the terms on each; the coefficients are compared on the
terms selected on the true k (coded units), with the largest absolute difference.
:func:`write_score` writes the tables to ``EXP/vidtrack/``.
"""

import json
import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from vidtrack.errors import VidtrackError
from vidtrack.rehearsal.equations import RESPONSES

__all__ = ["OUTPUTS", "RehearsalScore", "score_experiment", "write_score"]

#: What ``vidtrack score`` writes into ``<experiment>/vidtrack/``.
OUTPUTS = ("score_throws.csv", "score_regression.csv", "score.json", "score.txt")
#: Per throw and k, the columns of score_throws.csv (after run, throw and the factors).
THROW_COLUMNS = ("true", "fit", "error", "error_pct", "ci95_low", "ci95_high", "covered")
_PCT = 100.0


def _read_json(path, what):
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise VidtrackError(f"{path}: not found; {what}") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise VidtrackError(f"{path}: cannot be read as JSON ({exc})") from None


def _k_of(truth, path):
    k = (truth.get("truth") or {}).get("k") if isinstance(truth, dict) else None
    if not isinstance(k, dict) or any(r not in k for r in RESPONSES):
        raise VidtrackError(f"{path}: no truth.k (k1..k4); expected the truth.json of one "
                            "throw that vidtrack synth wrote")
    return {r: float(k[r]) for r in RESPONSES}


def _run_pairs(run_dir, experiment):
    """(throw number, true k, fit record) per throw, the run's true k (the mean) and the
    run's own fit record (fit.json, read once: a single throw's is the run's)."""
    from vidtrack.scene import find_throw_dirs

    truth_path = run_dir / "truth.json"
    no_truth = ("vidtrack score compares fits with the truth of runs rendered by 'vidtrack "
                f"synth {experiment.folder} --regression ...' (or --k-table)")
    no_fit = f"run 'vidtrack report {experiment.folder}' first"
    root = _read_json(truth_path, no_truth)
    run_record = _read_json(run_dir / "vidtrack" / "fit.json", no_fit)
    throws = find_throw_dirs(run_dir)
    if not throws:
        k = _k_of(root, truth_path)
        return [(1, k, run_record)], k, run_record
    pairs = []
    for i, d in enumerate(throws, start=1):
        k = _k_of(_read_json(d / "truth.json", no_truth), d / "truth.json")
        pairs.append((i, k, _read_json(run_dir / "vidtrack" / d.name / "fit.json", no_fit)))
    mean = {r: float(np.mean([p[1][r] for p in pairs])) for r in RESPONSES}
    return pairs, mean, run_record


def _throw_row(run, throw, factors, truth, record):
    row = {"run": run, "throw": throw, **factors}
    for r in RESPONSES:
        c = record.get("coefficients", {}).get(r) or {}
        value = c.get("value") if c.get("determined") else None
        fit = np.nan if value is None else float(value)
        low, high = _interval(c, "ci95")
        row.update({f"{r}_true": truth[r], f"{r}_fit": fit, f"{r}_error": fit - truth[r],
                    f"{r}_error_pct": _PCT * (fit - truth[r]) / truth[r],
                    f"{r}_ci95_low": low, f"{r}_ci95_high": high,
                    f"{r}_covered": _covers(low, high, truth[r]),
                    f"{r}_covered_fit": _covers(*_interval(c, "ci95_fit"), truth[r])})
    return row


def _interval(coefficient, key):
    """``(low, high)`` of a fit.json coefficient's interval, NaN where there is none."""
    ci = coefficient.get(key) if coefficient.get("determined") else None
    return (np.nan, np.nan) if ci is None else (float(ci[0]), float(ci[1]))


def _covers(low, high, truth):
    """Whether [low, high] holds ``truth``; None without an interval."""
    return None if not (np.isfinite(low) and np.isfinite(high)) else bool(low <= truth <= high)


def _coverage(throws):
    rows = []
    for r in RESPONSES:
        err = throws[f"{r}_error_pct"].to_numpy(dtype=float)
        ok = np.isfinite(err)
        covered = throws.loc[ok, f"{r}_covered"].astype(bool)
        own = throws.loc[ok, f"{r}_covered_fit"].dropna().astype(bool)
        e = err[ok]
        rows.append({"response": r, "throws": len(err), "determined": int(ok.sum()),
                     "covered": int(covered.sum()),
                     "coverage": float(covered.mean()) if ok.any() else np.nan,
                     "covered_fit": int(own.sum()), "with_fit_interval": len(own),
                     "mean_error_pct": float(e.mean()) if ok.any() else np.nan,
                     "rms_error_pct": float(np.sqrt(np.mean(e ** 2))) if ok.any() else np.nan,
                     "max_abs_error_pct": float(np.abs(e).max()) if ok.any() else np.nan})
    return pd.DataFrame(rows)


class _Once(logging.Filter):
    """Lets each message through once (the design's notes, said by both analyses)."""

    def __init__(self):
        super().__init__()
        self.seen = set()

    def filter(self, record):
        message = record.getMessage()
        first = message not in self.seen
        self.seen.add(message)
        return first


def _regressions(experiment, recovered, true, alpha):
    """Per response: the terms each backward elimination selects, and the coefficients
    on the true k's terms fitted to both."""
    from fits.rsm import fit_rsm
    from vidtrack.experiment import analyse, rsm_factors
    from vidtrack.experiment import log as experiment_log

    for r in experiment.responses:
        true.loc[~np.isfinite(recovered[r].to_numpy(dtype=float)), r] = np.nan
    once = _Once()
    experiment_log.addFilter(once)
    try:
        on_true = analyse(experiment, true, alpha=alpha)
        on_fit = analyse(experiment, recovered, alpha=alpha)
    finally:
        experiment_log.removeFilter(once)
    factors = rsm_factors(experiment)
    rows, terms = [], {}
    for r, t, f in zip(experiment.responses, on_true, on_fit):
        part = recovered[np.isfinite(recovered[r].to_numpy(dtype=float))]
        same = fit_rsm(part, r, factors, terms=list(t.terms), alpha=alpha, eliminate=False)
        terms[r] = {"true": tuple(t.terms), "fitted": tuple(f.terms)}
        for term, value in t.coefficients_coded.items():
            fitted = same.coefficients_coded[term]
            rows.append({"response": r, "term": term, "true_k": value, "fitted_k": fitted,
                         "difference": fitted - value,
                         "selected_on_fitted": term == "Intercept" or term in f.terms})
    return pd.DataFrame(rows), terms


@dataclass(frozen=True)
class RehearsalScore:
    """A rehearsal's fits against its truth (:func:`score_experiment`).

    Attributes
    ----------
    experiment : str
        The experiment folder.
    throws : pandas.DataFrame
        One row per throw: ``run``, ``throw``, the factors (natural), and per k
        ``k1_true``, ``k1_fit``, ``k1_error`` (fit - true), ``k1_error_pct``,
        ``k1_ci95_low``, ``k1_ci95_high``, ``k1_covered`` (ci95, the fit's and the
        scales' parts together, holds the truth), ``k1_covered_fit`` (the fit's own
        ``ci95_fit`` does); NaN/None where the fit did not determine the k.
    coverage : pandas.DataFrame
        One row per k: ``throws``, ``determined``, ``covered``, ``coverage`` (fraction
        of the determined), ``covered_fit`` and ``with_fit_interval`` (of ci95_fit),
        ``mean_error_pct``, ``rms_error_pct``, ``max_abs_error_pct``.
    regression : pandas.DataFrame
        One row per response and term selected on the true k (coded): ``true_k``,
        ``fitted_k``, ``difference`` (fitted - true), ``selected_on_fitted``.
    terms : dict
        Per response, the terms backward elimination selects: ``{"true": (...),
        "fitted": (...)}``.
    alpha : float
        The elimination's significance level.
    """

    experiment: str
    throws: pd.DataFrame
    coverage: pd.DataFrame
    regression: pd.DataFrame
    terms: dict
    alpha: float

    def __repr__(self):
        cov = ", ".join(f"{row.response}={row.coverage:.0%}"
                        for row in self.coverage.itertuples())
        return (f"RehearsalScore(experiment={self.experiment!r}, runs="
                f"{self.throws['run'].nunique()}, throws={len(self.throws)}, coverage {cov})")

    @property
    def max_difference(self):
        """Per response, the largest |fitted - true| of the coded coefficients."""
        return {r: float(g["difference"].abs().max())
                for r, g in self.regression.groupby("response", sort=False)}

    def summary(self):
        """The text table ``vidtrack score`` prints."""
        from fits._text import fmt_num, format_table

        lines = [f"Rehearsal {self.experiment}: {self.throws['run'].nunique()} runs, "
                 f"{len(self.throws)} throws", "",
                 "Each throw's fitted k against its truth (error = fit - truth):"]
        rows = [[c.response, c.determined, f"{c.mean_error_pct:+.3f}",
                 f"{c.rms_error_pct:.3f}", f"{c.max_abs_error_pct:.3f}",
                 f"{c.covered}/{c.determined}", f"{c.covered_fit}/{c.with_fit_interval}"]
                for c in self.coverage.itertuples()]
        lines += [format_table(["k", "throws", "mean error %", "rms error %",
                                "max |error| %", "ci95 covers", "fit's own ci95 covers"],
                               rows),
                  "ci95: fit.json's 95 % interval, the fit's and the scales' parts together; "
                  "the fit's own: ci95_fit", "",
                  "The regression on the fitted k beside the same regression on the true k "
                  f"(coded units; terms selected on the true k, alpha {self.alpha:g}):"]
        for r, g in self.regression.groupby("response", sort=False):
            t = self.terms[r]
            same = "the same" if set(t["fitted"]) == set(t["true"]) else ", ".join(t["fitted"])
            lines += ["", f"{r}: terms on the true k: {', '.join(t['true']) or 'none'}; on "
                      f"the fitted k: {same}"]
            rows = [[row.term, fmt_num(row.true_k, sig=5), fmt_num(row.fitted_k, sig=5),
                     f"{row.difference:+.2g}"] for row in g.itertuples()]
            lines += [format_table(["term", "true k", "fitted k", "difference"], rows),
                      f"max |difference| {self.max_difference[r]:.2g}"]
        return "\n".join(lines)

    def to_dict(self):
        """JSON-ready: the coverage per k, the regressions, and every throw."""
        def clean(records):
            return [{k: (None if isinstance(v, float) and not math.isfinite(v) else
                         v.item() if isinstance(v, np.generic) else v)
                     for k, v in rec.items()} for rec in records]

        regression = {}
        for r, g in self.regression.groupby("response", sort=False):
            regression[r] = {"terms_true": list(self.terms[r]["true"]),
                             "terms_fitted": list(self.terms[r]["fitted"]),
                             "coefficients_coded": clean(g.drop(columns="response")
                                                         .to_dict("records")),
                             "max_abs_difference": self.max_difference[r]}
        return {"experiment": self.experiment, "alpha": self.alpha,
                "runs": int(self.throws["run"].nunique()), "throws": len(self.throws),
                "coverage": {row["response"]: {k: v for k, v in row.items() if k != "response"}
                             for row in clean(self.coverage.to_dict("records"))},
                "regression": regression,
                "per_throw": clean(self.throws.to_dict("records"))}


def score_experiment(exp_dir, *, alpha=0.05):
    """Pair every throw's truth with its fit, and the regressions on true and fitted k.

    Parameters
    ----------
    exp_dir : str or os.PathLike
        A rehearsed experiment folder: its runs rendered by ``vidtrack synth EXP
        --regression`` (or ``--k-table``) and fitted by ``vidtrack report EXP``.
    alpha : float, keyword-only
        Significance level of the backward elimination (as ``vidtrack report --alpha``).

    Returns
    -------
    RehearsalScore

    Raises
    ------
    VidtrackError
        A run without truth.json (not rendered) or without fit.json (not fitted), a
        design other than a central composite one; nothing is written then.
    """
    from vidtrack.experiment import check_runs, coefficient_table
    from vidtrack.scene import load_experiment, load_scene

    if not 0 < alpha < 1:
        raise VidtrackError(f"alpha must be in (0, 1), got {alpha}")
    experiment = load_experiment(exp_dir)
    run_dirs = experiment.run_dirs()
    check_runs(experiment, [load_scene(d) for d in run_dirs])
    rows, records, true_k = [], [], []
    for d in run_dirs:
        pairs, mean, run_record = _run_pairs(d, experiment)
        factors = {f.name: float(run_record["factors"][f.name])
                   for f in experiment.factors.values()}
        rows += [_throw_row(run_record["run"], n, factors, k, rec) for n, k, rec in pairs]
        records.append(run_record)
        true_k.append(mean)
    throws = pd.DataFrame(rows)
    recovered = coefficient_table(experiment, records)
    true = recovered.copy()
    for r in experiment.responses:
        true[r] = [k[r] for k in true_k]
        true[f"{r}_stderr"] = np.nan
    regression, terms = _regressions(experiment, recovered, true, alpha)
    return RehearsalScore(str(experiment.folder), throws, _coverage(throws), regression,
                          terms, alpha)


def write_score(out_dir, score):
    """score_throws.csv, score_regression.csv, score.json and score.txt in ``out_dir``,
    each written whole; if one cannot be written (a full disk), none of them is left."""
    from vidtrack._atomic import atomic_path, write_text
    from vidtrack._text import csv_cell

    out_dir = Path(out_dir)
    try:
        with atomic_path(out_dir / OUTPUTS[0]) as tmp:
            score.throws.assign(run=score.throws["run"].map(csv_cell)).to_csv(tmp, index=False)
        with atomic_path(out_dir / OUTPUTS[1]) as tmp:
            score.regression.to_csv(tmp, index=False)
        write_text(out_dir / OUTPUTS[2],
                   json.dumps(score.to_dict(), indent=2, allow_nan=False) + "\n")
        write_text(out_dir / OUTPUTS[3], score.summary() + "\n")
    except BaseException:
        for name in OUTPUTS:
            (out_dir / name).unlink(missing_ok=True)
        raise
