"""``vidtrack bench fit --coverage``: how often each k's 95 % interval covers the truth.

Rendering and tracking hundreds of throws would take hours, so the throws are made as
tracks: the sample run (``datasets/run42``, tracked once by ``vidtrack fit``) gives the
geometry (each view's frames, clock, flags and scale) and the tracker's own errors
(its tracked centroid minus the render's true one, per view and frame: correlated
over frames, as the tracker's errors are). Each throw draws k1..k4 about the sample's
(normal, 10 % sd) and its release state (5 % sd), computes the true path
(:func:`fits.throw.position`), projects it into each view with the scene's exact
scales and origins, and adds the tracker's errors, circularly shifted by a random
number of frames. The scene is then read two ways: **exact** (as rendered), and **by
eye** (every ruler end and the origin off by N(0, ``sigma_px``) in u and v, as a person
reads them off a frame). Each throw is merged, cross-checked and fitted, with the
views' scales' part of the interval, the way ``vidtrack fit`` does, in two variants:
``independent`` (the views' scales taken as independent, never reconciled) and
``shared_x`` (the scales measured on the shared X and reconciled,
:mod:`vidtrack.world.shared_x`). A throw the cross-checks would refuse is counted
apart (the run would exit 2).
"""

import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

K_NAMES = ("k1", "k2", "k3", "k4")
#: How the throws' k and release state spread about the sample's (relative sd).
K_SPREAD = 0.10
STATE_SPREAD = 0.05
#: A person's reading of a ruler end or the origin off a frame, px (sd in u and in v).
SIGMA_PX = 0.4
VARIANTS = ("independent", "shared_x")


def read_by_eye(scene, rng, sigma_px, *, origin=True):
    """``scene`` with every ruler end (and, with ``origin``, the origin) moved by
    N(0, sigma_px) in u and v."""
    from calibration.scale import Scale, ruler_scale

    views = {}
    for n, v in scene.views.items():
        a = tuple(np.add(v.ruler.from_px, rng.normal(0, sigma_px, 2)))
        b = tuple(np.add(v.ruler.to_px, rng.normal(0, sigma_px, 2)))
        s = ruler_scale(v.ruler.length_m, a, b)
        ruler = dataclasses.replace(v.ruler, from_px=a, to_px=b)
        changes = {"ruler": ruler, "scale": Scale(
            m_per_px=s.m_per_px, method="ruler", length_m=s.length_m, from_px=a, to_px=b,
            span_px=s.span_px)}
        if origin:
            changes["origin_px"] = tuple(np.add(v.origin_px, rng.normal(0, sigma_px, 2)))
        views[n] = dataclasses.replace(v, **changes)
    return dataclasses.replace(scene, views=views)


def _tracker_errors(tracks, truth):
    """Per view, the tracker's errors (u, v) px at each frame of its track (NaN where it
    has no usable point)."""
    out = {}
    for v, tr in tracks.items():
        pf = pd.DataFrame(truth["views"][v]["per_frame"]).set_index("frame")
        d = tr.data
        cols = [("u_exposure_px" if "u_exposure_px" in pf else "u_px"),
                ("v_exposure_px" if "v_exposure_px" in pf else "v_px")]
        true = pf.reindex(d["frame"].to_numpy())[cols].to_numpy(dtype=np.float64)
        err = d[["u_px", "v_px"]].to_numpy(dtype=np.float64) - true
        err[~np.asarray(tr.usable)] = np.nan
        out[v] = err
    return out


def _throw_tracks(tracks, scene, errors, t0, rng, truth):
    """The sample's tracks with a new throw's path in their pixels; its true k."""
    from fits.throw import position

    tr = truth["truth"]
    k = {n: tr["k"][n] * (1.0 + K_SPREAD * rng.normal()) for n in K_NAMES}
    k = {n: max(v, 0.2 * tr["k"][n]) for n, v in k.items()}
    state = [tr["state"][s] * (1.0 + STATE_SPREAD * rng.normal()) if tr["state"][s] else 0.0
             for s in ("x0_m", "y0_m", "z0_m", "vx0_m_s", "vy0_m_s", "vz0_m_s")]
    out = {}
    for v, track in tracks.items():
        d = track.data.copy()
        t = d["t_s"].to_numpy(dtype=np.float64) - t0
        xyz = np.full((t.size, 3), np.nan)
        after = t >= 0
        xyz[after] = position(t[after], state, [k[n] for n in K_NAMES], tr["cp_s_per_m"],
                              g=tr["gravity_m_s2"], v1=tr["v1_m_s"])
        mapping = scene.views[v].mapping()
        cols = ["xyz".index(a) for a in mapping.world_axes]
        uv = mapping.world_to_pixel(xyz[:, cols])
        err = np.roll(errors[v], int(rng.integers(len(d))), axis=0)
        # a frame whose shifted error is unknown takes a known one (its flags decide)
        fill = ~np.isfinite(err).all(axis=1)
        known = err[~fill]
        err[fill] = known[rng.integers(len(known), size=int(fill.sum()))]
        keep = np.isfinite(d["u_px"].to_numpy(dtype=np.float64))
        d.loc[keep, "u_px"] = uv[keep, 0] + err[keep, 0]
        d.loc[keep, "v_px"] = uv[keep, 1] + err[keep, 1]
        out[v] = dataclasses.replace(track, data=d)
    return out, k


def _fit_variant(scene, tracks, variant):
    """(coefficients with the scales' part, refused) as ``vidtrack fit`` has them."""
    from fits.lsq import fit_throw
    from vidtrack.run.checks import cross_checks
    from vidtrack.run.scale_error import scale_error
    from vidtrack.world.orthogonal import merge_tracks
    from vidtrack.world.shared_x import merge_reconciled

    mappings = {n: v.mapping() for n, v in scene.views.items()}
    sync = {n: v.sync_frame for n, v in scene.views.items()}
    if variant == "shared_x":
        world = merge_reconciled(tracks, mappings, sync=sync, rel={
            n: v.scale_rel_uncertainty[0] for n, v in scene.views.items()})
    else:
        world = merge_tracks(tracks, mappings, sync=sync)
    merged = world.tracks or tracks
    refused = bool(cross_checks(world, merged, world.mappings(mappings),
                                g=scene.physics.gravity_m_s2))
    fit = fit_throw(world.data, scene.cp_s_per_m, g=scene.physics.gravity_m_s2,
                    v1=scene.v1_m_s)
    part = scale_error(scene, merged, fit, cp=scene.cp_s_per_m,
                       world=world if variant == "shared_x" else None)
    return fit.with_calibration(part.parts()), refused


def run_coverage_bench(out_dir, *, throws=200, sample=None, seed=0, sigma_px=SIGMA_PX,
                       variants=VARIANTS, progress=None):
    """Coverage of ci95_total (and ci95_fit) per k over ``throws`` synthetic throws.

    Writes ``bench_coverage.csv`` (one row per throw, reading and variant) and
    ``bench_coverage.txt`` (the table) into ``out_dir``; returns the text.
    """
    from vidtrack.run.pipeline import FitOptions, fit_run
    from vidtrack.run.tracks_file import read_tracks
    from vidtrack.scene import load_scene

    sample = Path(sample or Path(__file__).parents[2] / "datasets" / "run42")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    fit_run(sample, FitOptions(report=False))               # the tracks, once (reused)
    scene = load_scene(sample)
    tf = read_tracks(sample / "vidtrack" / "tracks.h5")
    truth = json.loads((sample / "truth.json").read_text())
    errors = _tracker_errors(tf.tracks, truth)
    t0 = tf.world.t0_s[tf.world.reference]
    rng = np.random.default_rng(seed)
    rows = []
    t_start = time.perf_counter()
    for i in range(throws):
        tracks, true_k = _throw_tracks(tf.tracks, scene, errors, t0, rng, truth)
        for reading in ("exact", "by eye"):
            sc = scene if reading == "exact" else read_by_eye(scene, rng, sigma_px)
            for variant in variants:
                row = {"throw": i, "reading": reading, "variant": variant}
                try:
                    fit, refused = _fit_variant(sc, tracks, variant)
                except Exception as exc:     # noqa: BLE001 (a failure is a result)
                    row["failed"] = f"{type(exc).__name__}: {exc}"
                    rows.append(row)
                    continue
                row["refused"] = refused
                for k in K_NAMES:
                    c = fit.coefficients[k]
                    if not c.determined:
                        continue
                    lo, hi = c.ci95_total
                    row[f"{k}_true"] = true_k[k]
                    row[f"{k}_error_sd"] = (c.value - true_k[k]) / c.stderr_total
                    row[f"{k}_covered"] = float(lo <= true_k[k] <= hi)
                    row[f"{k}_covered_fit"] = float(c.ci95[0] <= true_k[k] <= c.ci95[1])
                rows.append(row)
        if progress:
            progress(f"throw {i + 1}")
    table = pd.DataFrame(rows)
    text = coverage_text(table, throws=throws, sigma_px=sigma_px,
                         seconds=time.perf_counter() - t_start)
    from vidtrack._atomic import atomic_path, write_text

    with atomic_path(out_dir / "bench_coverage.csv") as t:
        table.to_csv(t, index=False)
    write_text(out_dir / "bench_coverage.txt", text + "\n")
    return text


def coverage_text(table, *, throws, sigma_px, seconds):
    """The coverage table: per reading and variant, each k's share of throws covered."""
    lines = [f"{throws} synthetic throws (datasets/run42's geometry and tracker errors, k "
             f"+- {100 * K_SPREAD:g} %), scenes exact and read by eye (ruler ends and "
             f"origin N(0, {sigma_px:g} px)); {seconds:.0f} s",
             "coverage of the 95 % interval (ci95_total; in brackets the fit's own), "
             "mean error in total standard errors, throws refused by the cross-checks"]
    head = f"{'reading':<8} {'variant':<12} " + " ".join(f"{k:>16}" for k in K_NAMES) \
        + f" {'refused':>8} {'failed':>7}"
    lines += [head, "-" * len(head)]
    for (reading, variant), grp in table.groupby(["reading", "variant"], sort=False):
        cells = []
        for k in K_NAMES:
            cov = grp.get(f"{k}_covered")
            fit = grp.get(f"{k}_covered_fit")
            cells.append("-" if cov is None else
                         f"{100 * cov.mean():.1f} ({100 * fit.mean():.0f}) n{int(cov.count())}")
        refused = int(grp["refused"].fillna(False).astype(bool).sum()) \
            if "refused" in grp else 0
        failed = int(grp["failed"].notna().sum()) if "failed" in grp else 0
        lines.append(f"{reading:<8} {variant:<12} " + " ".join(f"{c:>16}" for c in cells)
                     + f" {refused:>8} {failed:>7}")
        lines.append(f"{'':<21} " + " ".join(f"{_z(grp, k):>16}" for k in K_NAMES))
    return "\n".join(lines)


def _z(grp, k):
    """Mean and sd of (k - truth) / stderr_total: 0 and 1 for an honest interval."""
    col = f"{k}_error_sd"
    if col not in grp:
        return "-"
    return f"z {grp[col].mean():+.2f} sd {grp[col].std():.2f}"
