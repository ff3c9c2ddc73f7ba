"""The pipeline behind ``vidtrack fit RUN``: footage -> tracks -> world track -> fit.

Only the stages a scene needs are run: the views it has, and a stage whose inputs and
settings are unchanged is reused (keyed on a hash kept in ``<run>/vidtrack/stages.json``;
``force=True`` reruns). Every output is written whole or not at all, and
``stages.json`` is written last, so an interrupted run is simply run again.

A run with ``throws/`` is fitted per throw (outputs in ``<run>/vidtrack/<throw>/``) and
the run's ``fit.json`` holds the mean over the throws, as Chen et al. 2018 did.
"""

import dataclasses
import hashlib
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

from vidtrack import __version__
from vidtrack._atomic import write_text
from vidtrack.run._workers import (ViewProcess, ViewThread, preload_later_stages, source_of,
                                    track_view)
from vidtrack.errors import FitError, SceneError

OUT_DIR = "vidtrack"
STAGES_FILE = "stages.json"
TRACKER_SETTINGS = {"k_sigma": 5.0, "min_area_px": 4, "max_gap": 5}


@dataclass(frozen=True)
class FitOptions:
    """Settings of a fit that change its result (and so its cache key), and how to run."""

    model: str = "quadratic"
    bootstrap: int = 0
    seed: int = 0
    force: bool = False
    report: bool = True
    quiet: bool = True
    threads: int = 0          # views tracked at once (0: as many as views and cores)
    # the second view in a process of its own, not a thread (spawned: needs a main module
    # that is safe to import, as the command line's is)
    view_process: bool = False

    def key(self):
        return {"model": self.model, "bootstrap": self.bootstrap,
                "seed": self.seed if self.bootstrap else None}


def _digest(obj):
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()


def _file_fingerprint(path):
    """Size, mtime and a hash of the first and last MiB: cheap even for a 10 GB .cine."""
    path = Path(path)
    if path.is_dir():
        return sorted((p.name, p.stat().st_size, p.stat().st_mtime_ns)
                      for p in path.iterdir() if p.is_file())
    st = path.stat()
    h = hashlib.sha256()
    with open(path, "rb") as f:
        h.update(f.read(1 << 20))
        if st.st_size > 2 << 20:
            f.seek(-(1 << 20), os.SEEK_END)
            h.update(f.read())
    return [st.st_size, st.st_mtime_ns, h.hexdigest()]


def _check_sources(scene, folder):
    """Every view's footage exists (before anything is read or written)."""
    from vidtrack.errors import SourceError

    for name in scene.view_names:
        path = source_of(scene.views[name], scene, folder)
        if not path.exists():
            raise SourceError(f"{scene.path}: views.{name}.source: {path} does not exist "
                              "(expected the view's video, image folder or .cine)")


def _footage_bytes(path):
    path = Path(path)
    if path.is_dir():
        return sum(p.stat().st_size for p in path.iterdir() if p.is_file())
    return path.stat().st_size


def _read_stages(out_dir):
    try:
        return json.loads((out_dir / STAGES_FILE).read_text())
    except (OSError, ValueError):
        return {}


def _track_views(scene, folder, options, timings, workers):
    """Track every view of the scene in ``folder``.

    With two views and ``options.threads`` above 1 the view with the larger footage is
    tracked beside the other (:mod:`vidtrack.run._workers`): in a process of its own
    when ``options.view_process`` (the command line), else in a thread. If the view
    tracked here fails (or Ctrl-C), the other is stopped before the error goes on; if
    the other fails, its error is raised here.

    The worker process is taken from ``workers`` (a dict kept over a run's throws; the
    caller stops what is in it), and put there when it is started here.

    Returns
    -------
    (dict, ViewProcess or None)
        {view: Track}, and the worker process when it is to draw this report.
    """
    names = list(scene.view_names)
    t0 = time.perf_counter()
    tracks = {}
    threads = options.threads or min(len(names), os.cpu_count() or 1)
    other, keep = None, False
    if threads > 1 and len(names) > 1:
        # the larger footage to the worker: this process loads the later stages' modules
        # meanwhile (measured on full-size two-view footage: 0.3 s sooner than the other
        # way round)
        name = max(names, key=lambda n: _footage_bytes(source_of(scene.views[n], scene,
                                                                 folder)))
        names.remove(name)
        if options.view_process:
            if "process" not in workers:
                workers["process"] = ViewProcess()
                preload_later_stages()
            other = workers["process"]
            other.start(scene, folder, name, TRACKER_SETTINGS, quiet=options.quiet,
                        report=options.report)
        else:
            other = ViewThread(scene, folder, name, TRACKER_SETTINGS, quiet=options.quiet)
    try:
        for name in names:
            tracks[name] = track_view(scene, folder, name, TRACKER_SETTINGS,
                                      quiet=options.quiet)
        if other is not None:
            tracks[other.name] = other.track()
            keep = isinstance(other, ViewProcess)
    finally:
        if other is not None and not keep:
            other.stop()
    timings["track"] = time.perf_counter() - t0
    return ({n: tracks[n] for n in scene.view_names},
            other if keep and options.report else None)


def _tracks_stage(scene, folder, out_dir, options, timings, stages, workers):
    """Tracks and the world track: reused from tracks.h5 when nothing changed.

    Writes tracks.h5 and, beside it, tracks.csv and world.csv (the same numbers).

    Returns the tracks' key, the tracks, the world track, whether they were reused, and
    the worker process that is to draw the report (or None).
    """
    key = _digest({"version": __version__, "scene": scene.hash, "tracker": TRACKER_SETTINGS,
                   "sources": {n: _file_fingerprint(source_of(v, scene, folder))
                               for n, v in scene.views.items()}})
    h5 = out_dir / "tracks.h5"
    if not options.force and stages.get("tracks") == key and h5.is_file():
        from vidtrack.run.tracks_file import read_tracks, write_tables

        t0 = time.perf_counter()
        tf = read_tracks(h5)
        if tf.world is not None:
            # tracks.csv and world.csv belong to this stage: a missing one (or one older
            # than a tracks.h5 edited by hand) is written from the tracks reused
            write_tables(out_dir, tf.tracks, tf.world, missing_only=True)
            timings["tracks_reused"] = time.perf_counter() - t0
            return key, tf.tracks, tf.world, True, None
    tracks, helper = _track_views(scene, folder, options, timings, workers)
    from vidtrack.world.orthogonal import merge_tracks
    from vidtrack.run.tracks_file import write_tables, write_tracks

    t0 = time.perf_counter()
    mappings = {n: v.mapping() for n, v in scene.views.items()}
    world = merge_tracks(tracks, mappings,
                         sync={n: v.sync_frame for n, v in scene.views.items()})
    # the merge flags each view's frames before its t = 0 and carries the release over
    tracks = world.tracks or tracks
    timings["merge"] = time.perf_counter() - t0
    if helper is not None:
        helper.send_tracks({n: tr.data for n, tr in tracks.items()})
    write_tracks(h5, tracks, world, scene_hash=scene.hash,
                 calibration={n: v.to_dict() for n, v in scene.views.items()})
    write_tables(out_dir, tracks, world)        # tracks.csv, world.csv: the same numbers
    return key, tracks, world, False, helper


def _check_cp(scene, options):
    cp = scene.cp_s_per_m
    if cp is None:
        if options.model == "free":
            return 0.0
        raise SceneError(f"{scene.path}: [straw] gives no drag parameter: set cp_s_per_m, "
                         "or mass_kg, area_m2 and drag_coefficient (the quadratic and linear "
                         "models need Cp; --model free fits without drag)")
    return cp


def fit_throw_folder(scene, folder, out_dir, options, workers=None):
    """Track, merge and fit one throw (the run folder or one of its throws/ folders).

    ``workers``: a dict holding the worker process across a run's throws (the caller
    stops it: :func:`_stop_workers`); without it one is started and stopped here.
    Returns the fit.json record written to ``out_dir``.
    """
    if workers is None:
        workers = {}
        try:
            return fit_throw_folder(scene, folder, out_dir, options, workers)
        finally:
            _stop_workers(workers)
    out_dir = Path(out_dir)
    _check_sources(scene, folder)
    stages = _read_stages(out_dir)
    timings = {}
    t_start = time.perf_counter()
    tracks_key, tracks, world, reused, helper = _tracks_stage(
        scene, folder, out_dir, options, timings, stages, workers)
    import numpy as np

    from fits.errors import ConvergenceError
    from fits.lsq import fit_throw
    from vidtrack.run.fit_record import dumps, throw_record
    from vidtrack.report.run_page import write_run_report

    cp = _check_cp(scene, options)
    # tracks.h5 itself too: a track edited by hand (flags set, points removed) is refitted
    fit_key = _digest({"tracks": tracks_key, "fit": options.key(), "cp": cp,
                       "tracks_file": _file_fingerprint(out_dir / "tracks.h5")})
    if (not options.force and stages.get("fit") == fit_key
            and (out_dir / "fit.json").is_file()):
        return json.loads((out_dir / "fit.json").read_text())
    t0 = time.perf_counter()
    try:
        fit = fit_throw(world.data, cp, g=scene.physics.gravity_m_s2, v1=scene.v1_m_s,
                        model=options.model, bootstrap=options.bootstrap,
                        rng=np.random.default_rng(options.seed))
    except ConvergenceError as exc:
        # no fit.json (nor report) of an earlier fit may stand in for this one
        for name in ("fit.json", "report.md", "report.html"):
            (out_dir / name).unlink(missing_ok=True)
        write_text(out_dir / STAGES_FILE, json.dumps({"tracks": tracks_key}, indent=2) + "\n")
        raise FitError(f"{folder}: the fit did not converge: {exc}; the tracks are in "
                       f"{out_dir / 'tracks.h5'} (see the report of a run that fits, and "
                       "docs/fit-outputs.md)") from exc
    timings["fit"] = time.perf_counter() - t0
    notes = list(world.warnings)
    for name, tr in tracks.items():
        notes += [f"{name}: {n}" for n in tr.notes]
    extra = {"throw": Path(folder).name if Path(folder) != scene.folder else None,
             "views": {n: tr.to_dict() for n, tr in tracks.items()},
             "world": world.to_dict(), "stages_reused": ["tracks"] if reused else [],
             "notes": notes}
    record = throw_record(scene, fit, timings_s=timings, extra=extra)
    if options.report:
        t0 = time.perf_counter()
        views = {n: tr.data for n, tr in tracks.items()}
        # drawn by the process that tracked the second view, if it is there (it loaded
        # matplotlib and drew the tracks plot while this one fitted)
        html = helper.render(record, fit=fit, world=world.data) if helper else None
        write_run_report(out_dir, record, fit=fit, world=world.data, views=views, html=html)
        timings["report"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_start
    record["timings_s"] = {k: round(float(v), 6) for k, v in timings.items()}
    write_text(out_dir / "fit.json", dumps(record))
    write_text(out_dir / STAGES_FILE, json.dumps({"tracks": tracks_key, "fit": fit_key},
                                                 indent=2) + "\n")
    return record


def _stop_workers(workers):
    for w in workers.values():
        w.stop()


def fit_run(run_dir, options=FitOptions()):
    """Fit one run folder (and each of its throws); returns the run's fit.json record."""
    from vidtrack.scene import load_scene

    scene = load_scene(run_dir)
    out = scene.folder / OUT_DIR
    throws = scene.throw_dirs()
    if not throws:
        return fit_throw_folder(scene, scene.folder, out, options)
    from vidtrack.run.fit_record import dumps, mean_record
    from vidtrack.report.run_page import write_run_report

    t0 = time.perf_counter()
    workers = {}                     # one worker process serves all the throws
    try:
        records = [fit_throw_folder(scene, d, out / d.name, options, workers)
                   for d in throws]
    finally:
        _stop_workers(workers)
    record = mean_record(scene, records, timings_s={
        "throws_total": time.perf_counter() - t0})
    if options.report:
        write_run_report(out, record)
    write_text(out / "fit.json", dumps(record))
    return record


def find_runs(paths):
    """Run folders named by ``paths``: a run (has scene.toml), an experiment (its runs),
    or a folder whose sub-folders are runs."""
    from vidtrack.scene import load_experiment

    runs = []
    for p in map(Path, paths):
        if (p / "scene.toml").is_file() or (p.is_file() and p.name == "scene.toml"):
            runs.append(p if p.is_dir() else p.parent)
        elif (p / "experiment.toml").is_file():
            runs += load_experiment(p).run_dirs()
        elif p.is_dir():
            subs = sorted(d for d in p.iterdir() if (d / "scene.toml").is_file())
            if not subs:
                raise SceneError(f"{p}: no scene.toml here nor in its sub-folders "
                                 "(expected a run folder or a folder of runs)")
            runs += subs
        else:
            raise SceneError(f"{p}: no such run folder")
    return runs


def _fit_one(args):
    run_dir, options = args
    return fit_run(run_dir, options)


def fit_runs(run_dirs, options=FitOptions(), *, jobs=1, scheduler=None, progress=None):
    """Fit several runs, in parallel processes (``jobs``) or on a Dask cluster.

    Parameters
    ----------
    run_dirs : sequence of path
    options : FitOptions
    jobs : int
        Worker processes (1: in this process).
    scheduler : str, optional
        Address of a dask.distributed scheduler (needs the ``dask`` extra).
    progress : callable, optional
        Called with each finished run's record.

    Returns
    -------
    list of dict
        The fit.json records, in the order of ``run_dirs``.
    """
    if scheduler or (jobs > 1 and len(run_dirs) > 1):
        # the runs share the cores: one view at a time within each
        options = dataclasses.replace(options, threads=1)
    work = [(Path(r), options) for r in run_dirs]
    if scheduler:
        try:
            from distributed import Client
        except ImportError:
            raise SceneError("--scheduler needs dask.distributed: pip install "
                             "'vidtrack[dask]'") from None
        with Client(scheduler) as client:
            futures = client.map(_fit_one, work, pure=False)
            results = client.gather(futures)
        for r in results:
            if progress:
                progress(r)
        return results
    if jobs <= 1 or len(work) == 1:
        results = []
        for w in work:
            results.append(_fit_one(w))
            if progress:
                progress(results[-1])
        return results
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=jobs) as pool:
        results = []
        for r in pool.map(_fit_one, work):
            results.append(r)
            if progress:
                progress(r)
        return results
