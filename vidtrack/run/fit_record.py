"""fit.json (schema 1, docs/fit-outputs.md): one throw's record, and the mean over throws."""

import json

import numpy as np
from scipy import special

from fits.lsq_results import with_total
from vidtrack import __version__

SCHEMA = 1
K_NAMES = ("k1", "k2", "k3", "k4")
#: fit.json "model" for each fits.throw model
MODEL_NAMES = {"quadratic": "quadratic-drag", "linear": "linear-drag", "free": "drag-free"}


def _num(v):
    """JSON-safe number: numpy scalars to float, non-finite to None."""
    if v is None:
        return None
    v = float(v)
    return v if np.isfinite(v) else None


def throw_record(scene, fit, *, timings_s, world_points=None, extra=None):
    """The fit.json dict of one throw.

    Parameters
    ----------
    scene : vidtrack.scene.Scene
    fit : fits.lsq.ThrowFit
    timings_s : dict
        Seconds per stage (``frames``, ``track``, ``fit``, ...).
    world_points : dict, optional
        Points measured per axis before flagged frames were dropped (for the record).
    extra : dict, optional
        More fields (views, sync, checks), added after the fixed fields of schema 1.
    """
    d = fit.to_dict()
    record = {
        "schema": SCHEMA,
        "run": scene.run_name,
        "model": MODEL_NAMES[fit.model],
        "cp_s_per_m": _num(fit.cp_s_per_m),
        "factors": dict(scene.factors),
        "coefficients": d["coefficients"],
        "initial_state": {k: _num(v) for k, v in d["initial_state"].items()},
        "residual_rms_m": {k: _num(v) for k, v in d["residual_rms_m"].items()},
        "points": d["points"],
        "throws": 1,
        "timings_s": {k: round(float(v), 6) for k, v in timings_s.items()},
        "condition_number": {k: _num(v) for k, v in d["condition_number"].items()},
        "residual_autocorrelation": {k: _num(v) for k, v in
                                     d["residual_autocorrelation"].items()},
        "error_model": {k: (None if v is None else
                            {q: (x if isinstance(x, str) else _num(x)) for q, x in v.items()})
                        for k, v in d["error_model"].items()},
        "aic": _num(d["aic"]),
        "vidtrack_version": __version__,
        "scene_hash": scene.hash,
    }
    if world_points is not None:
        record["points_measured"] = world_points
    if extra:
        record.update(extra)
    return record


def mean_record(scene, records, *, timings_s):
    """The run's fit.json over replicate throws: the mean of each k, as Chen 2018 did.

    Each k is the mean over the throws where it was determined; its standard error is
    the standard deviation over those throws / sqrt(n), its interval from Student's t.
    A k determined in no throw is not determined, with the throws' reasons.
    """
    coeffs = {}
    for k in K_NAMES:
        values = [r["coefficients"][k]["value"] for r in records
                  if r["coefficients"][k]["determined"]]
        n = len(values)
        if n == 0:
            reasons = sorted({r["coefficients"][k].get("reason", "") for r in records})
            coeffs[k] = {"value": None, "stderr": None, "ci95": None, "determined": False,
                         "reason": "not determined in any throw: " + "; ".join(reasons)}
            continue
        mean = float(np.mean(values))
        if n >= 2:
            se = float(np.std(values, ddof=1) / np.sqrt(n))
            half = float(special.stdtrit(n - 1, 0.975) * se)
            ci = [mean - half, mean + half]
        else:
            one = records[[r["coefficients"][k]["determined"] for r in records].index(True)][
                "coefficients"][k]
            se = one.get("stderr_fit", one["stderr"])
            ci = None if se is None else [mean - 1.96 * se, mean + 1.96 * se]
        entry = {"value": mean, "stderr": se, "ci95": ci, "determined": True,
                 "throws_used": n}
        entry.update(_mean_calibration(records, k, mean, se, ci))
        with_total(entry)
        if n < len(records):
            entry["reason"] = f"mean over {n} of {len(records)} throws (not determined in the rest)"
        coeffs[k] = entry
    first = records[0]
    out = {
        "schema": SCHEMA, "run": scene.run_name, "model": first["model"],
        "cp_s_per_m": first["cp_s_per_m"], "factors": dict(scene.factors),
        "coefficients": coeffs,
        "initial_state": {k: _num(np.mean([r["initial_state"][k] for r in records
                                           if r["initial_state"][k] is not None]))
                          if any(r["initial_state"][k] is not None for r in records) else None
                          for k in first["initial_state"]},
        "residual_rms_m": {a: _num(np.sqrt(np.mean([r["residual_rms_m"][a] ** 2
                                                    for r in records
                                                    if r["residual_rms_m"][a] is not None])))
                           if any(r["residual_rms_m"][a] is not None for r in records)
                           else None for a in ("x", "y", "z")},
        "points": {a: int(sum(r["points"][a] for r in records)) for a in ("x", "y", "z")},
        "throws": len(records),
        "throw_names": [r.get("throw") for r in records],
        "timings_s": {k: round(float(v), 6) for k, v in timings_s.items()},
        "vidtrack_version": __version__,
        "scene_hash": scene.hash,
    }
    if first.get("calibration") is not None:
        out["calibration"] = first["calibration"]
    return out


def _mean_calibration(records, k, mean, se, ci):
    """The calibration's part of a mean over throws: the same scales converted every
    throw, so it does not average down. The mean's sensitivity to view v's scale is the
    mean of the throws' (dk / d(ln s_v)); sd_cal = sqrt(sum_v (that * rel_v)^2), rel_v
    from the run's ``calibration``. {} when a throw has no calibration part for k."""
    cal = records[0].get("calibration")
    used = [r["coefficients"][k] for r in records if r["coefficients"][k]["determined"]]
    if cal is None or se is None or ci is None or not used or any(
            c.get("stderr_calibration") is None for c in used):
        return {}
    rel = {v: d["scale_rel_uncertainty"] for v, d in cal["views"].items()}
    sens = {v: float(np.mean([c["scale_sensitivity"][v] for c in used]))
            for v in rel if all(v in (c.get("scale_sensitivity") or {}) for c in used)}
    sd = float(np.sqrt(sum((sens[v] * rel[v]) ** 2 for v in sens)))
    cal95 = float(special.ndtri(0.975)) * sd
    return {"stderr_fit": se, "stderr_calibration": sd,
            "stderr_total": float(np.hypot(se, sd)),
            "ci95_total": [mean - float(np.hypot(mean - ci[0], cal95)),
                           mean + float(np.hypot(ci[1] - mean, cal95))],
            "scale_sensitivity": sens}


def dumps(record):
    """fit.json text: full precision, stable key order as built."""
    return json.dumps(record, indent=2, allow_nan=False) + "\n"
