"""The pipeline behind ``vidtrack fit RUN``: footage -> tracks -> world track -> fit.

Everything that can be checked is checked before any footage is tracked
(:mod:`vidtrack.run.preflight`: the scene, the sources, the frame ranges and sync frames,
the output folders), for every run of a command before the first is tracked.

Only the stages a scene needs are run: the views it has, and a stage whose inputs and
settings are unchanged is reused when its files are still the ones it wrote (its key and
their sha256 digests kept in ``<run>/vidtrack/stages.json``, :mod:`vidtrack.run.cache`;
``force=True`` reruns); each view's tracking is reused on its own, from views.h5, when
what the tracker reads of it is unchanged. A stage about to be computed again first
removes the outputs it and the later stages wrote, so that a run that fails leaves
nothing that looks current. Every output is written whole or not at all, fit.json before
the reports, and each stage's record after its files, so an interrupted run is simply
run again.

After the tracks the views are cross-checked (:mod:`vidtrack.run.checks`); inputs that
disagree stop the run unless ``FitOptions.accept_disagreement``.

A run with ``throws/`` is fitted per throw (outputs in ``<run>/vidtrack/<throw>/``) and
the run's ``fit.json`` holds the mean over the throws, as Chen et al. 2018 did.
"""

import contextlib
import dataclasses
import hashlib
import json
import logging
import os
import time
from dataclasses import dataclass
from pathlib import Path

from vidtrack._atomic import write_text
from vidtrack.run._workers import (ViewProcess, ViewThread, preload_later_stages, source_of,
                                    track_view)
from vidtrack.errors import DisagreementError, FitError, SceneError, VidtrackError
from vidtrack.run.cache import (FIT_ALGORITHM, WORLD_ALGORITHM, stage_key,  # noqa: I001
                                tracker_version)
from vidtrack.run.cache import STAGES_FILE, Stages, file_digest  # noqa: F401 (STAGES_FILE,
from vidtrack.run.preflight import OUT_DIR, about, prepare_run  # noqa: F401  OUT_DIR: as before)

log = logging.getLogger(__name__)

#: What each stage writes (removed before the stage is computed again).
TABLE_FILES = ("tracks.csv", "world.csv", "xypts.csv", "xyzpts.csv", "xypts_cameras.txt")
TRACKS_FILES = ("tracks.h5",) + TABLE_FILES
#: Each view's track as the tracker gave it, before the corrections and the world track
#: (the ``views`` stage: reused per view, :func:`_view_key`).
VIEWS_FILE = "views.h5"
REPORT_FILES = ("report.md", "report.html")
FIT_FILES = ("fit.json",) + REPORT_FILES
#: Largest --bootstrap and --jobs (each resample is a full refit; jobs beyond the
#: cores only queue).
MAX_BOOTSTRAP = 100_000
MAX_JOBS = 256
#: Seconds to wait for a --scheduler to answer.
SCHEDULER_TIMEOUT_S = 10
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
    # inputs that disagree (the views on X, the same footage twice, implausible
    # accelerations) are reported as warnings instead of stopping the run
    accept_disagreement: bool = False

    def key(self):
        return {"model": self.model, "bootstrap": self.bootstrap,
                "seed": self.seed if self.bootstrap else None}


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


def _footage_bytes(path):
    path = Path(path)
    if path.is_dir():
        return sum(p.stat().st_size for p in path.iterdir() if p.is_file())
    return path.stat().st_size


def _note(message):
    """A line on stderr (``vidtrack fit: note: ...``) and in the log."""
    log.warning(message, extra={"label": "note"})


def _remove_outputs(out_dir, stages, stage_names, files):
    """Before a stage is computed again: forget it (and the later stages) in
    stages.json, then remove the files they wrote, so that a run failing from here on
    leaves no output that looks current."""
    stages.drop(*stage_names)
    for name in files:
        (Path(out_dir) / name).unlink(missing_ok=True)


@contextlib.contextmanager
def _whole_or_none(out_dir, files):
    """A stage's files and its stages.json entry written together or not at all: when
    writing them fails (a full disk, Ctrl-C), the files written so far are removed, so
    no output stands without the record that vouches for it."""
    try:
        yield
    except BaseException:
        for name in files:
            with contextlib.suppress(OSError):
                (Path(out_dir) / name).unlink()
        raise


def _track_views(scene, folder, options, timings, workers, *, label_of=lambda view: None,
                 known=None):
    """Track every view of the scene in ``folder`` (a view that gives points digitized
    elsewhere is read instead, before any footage is tracked: a bad points file stops
    the run first; :mod:`vidtrack.run.view_points`), but those of ``known`` (view ->
    Track, taken as they are).

    With two views to track and ``options.threads`` above 1 the view with the larger footage is
    tracked beside the other (:mod:`vidtrack.run._workers`): in a process of its own
    when ``options.view_process`` (the command line), else in a thread. If the view
    tracked here fails (or Ctrl-C), the other is stopped before the error goes on; if
    the other fails, its error is raised here.

    The worker process is taken from ``workers`` (a dict kept over a run's throws; the
    caller stops what is in it), and put there when it is started here.

    A view's error is said with ``label_of(view)`` (:func:`vidtrack.run.preflight.about`).

    Returns
    -------
    (dict, ViewProcess or None)
        {view: Track}, and the worker process when it is to draw this report.
    """
    from vidtrack.run.view_points import points_track

    t0 = time.perf_counter()
    tracks = {}
    for name in scene.view_names:
        if scene.views[name].points is not None:
            with about(label_of(name), view=name):
                tracks[name] = points_track(scene, folder, name)
    tracks.update(known or {})
    names = [n for n in scene.view_names if n not in tracks]
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
            other = workers["process"]
            if not getattr(other, "preloading", False):
                # now, not before: the imports hold the GIL, decoding mostly does not
                preload_later_stages()
                other.preloading = True
            other.start(scene, folder, name, TRACKER_SETTINGS, quiet=options.quiet,
                        report=options.report)
        else:
            other = ViewThread(scene, folder, name, TRACKER_SETTINGS, quiet=options.quiet)
    try:
        for name in names:
            with about(label_of(name), view=name):
                tracks[name] = track_view(scene, folder, name, TRACKER_SETTINGS,
                                          quiet=options.quiet)
        if other is not None:
            with about(label_of(other.name), view=other.name):
                tracks[other.name] = other.track()
            keep = isinstance(other, ViewProcess)
    finally:
        if other is not None and not keep:
            other.stop()
    timings["track"] = time.perf_counter() - t0
    return ({n: tracks[n] for n in scene.view_names},
            other if keep and options.report else None)


def _tracks_stage(scene, folder, out_dir, options, timings, stages, workers, corrections, *,
                  label_of=lambda view: None):
    """Tracks and the world track: reused from tracks.h5 when nothing changed.

    ``corrections``: each view's corrections as the preflight read them
    (:attr:`vidtrack.run.preflight.RunPlan.corrections` of ``folder``).

    Writes tracks.h5 and, beside it, tracks.csv and world.csv (the same numbers), and
    records them in ``stages`` (:class:`vidtrack.run.cache.Stages`). Before tracking
    again it removes what this stage and the fit wrote before.

    The views are tracked again only where what their tracking reads changed
    (:func:`_reused_views`): when only what the world track or the fit reads changed
    (the run's name, a ruler, an origin...), the world track is rebuilt from the views'
    tracks kept in views.h5.

    Returns the tracks' key, the tracks, the world track, the stages reused
    (``["tracks"]``, ``["views"]`` or ``[]``), the views whose tracks were reused from
    views.h5, and the worker process that is to draw the report (or None).
    """
    from vidtrack.run.corrections import corrections_key

    # the scene's hash holds exclude_frames and the manual points file's name; the key
    # holds that file's content too (this folder's: a throw has its own), so an edited
    # CSV tracks again
    key = stage_key("tracks", algorithm={"tracker": tracker_version(),
                                         "world": WORLD_ALGORITHM},
                    settings={"tracker": TRACKER_SETTINGS, "track": scene.track},
                    inputs={"scene": scene.hash,
                            "sources": {n: _file_fingerprint(source_of(v, scene, folder))
                                        for n, v in scene.views.items()},
                            "corrections": corrections_key(scene, folder, corrections)})
    h5 = out_dir / "tracks.h5"
    if not options.force:
        reused = _reused_tracks(scene, out_dir, key, stages, timings, label_of(None))
        if reused is not None:
            return key, *reused, ["tracks"], [], None
    # tracked again: what this stage and the fit wrote before must not outlive a failure
    _remove_outputs(out_dir, stages, ("tracks", "fit"), TRACKS_FILES + FIT_FILES)
    from vidtrack.run.tracks_file import write_tracks

    from vidtrack.run.corrections import correct_tracks
    from vidtrack.run.reconstruct import calibration_of, reconstruct

    keys = {n: _view_key(scene, folder, n) for n in scene.view_names
            if scene.views[n].points is None}
    known = {} if options.force else _reused_views(out_dir, keys, stages, label_of(None))
    if set(known) != set(keys):
        # a view to track again: views.h5 is written again whole, with the reused views
        _remove_outputs(out_dir, stages, ("views",), (VIEWS_FILE,))
    tracks, helper = _track_views(scene, folder, options, timings, workers,
                                  label_of=label_of, known=known)
    if set(known) != set(keys):
        with _whole_or_none(out_dir, (VIEWS_FILE,)):
            write_tracks(out_dir / VIEWS_FILE, {n: tracks[n] for n in keys},
                         scene_hash=scene.hash, calibrated=scene.calibrated)
            stages.record("views", stage_key("views", algorithm=tracker_version(),
                                             inputs=keys), (VIEWS_FILE,), parts=keys)
    # the scene's exclude_frames and manual_points, before the reconstruction
    with about(label_of(None)):
        tracks = correct_tracks(tracks, corrections)
    t0 = time.perf_counter()
    world = reconstruct(scene, tracks)
    tracks = world.tracks
    timings["merge"] = time.perf_counter() - t0
    if helper is not None:
        helper.send_tracks({n: tr.data for n, tr in tracks.items()})
    calibration = calibration_of(scene)
    with _whole_or_none(out_dir, TRACKS_FILES):
        write_tracks(h5, tracks, world, scene_hash=scene.hash, calibration=calibration)
        _write_tables(scene, out_dir, tracks, world)
        stages.record("tracks", key, TRACKS_FILES)
    return key, tracks, world, ["views"] if known else [], sorted(known), helper


def _view_key(scene, folder, name):
    """The cache key of view ``name``'s tracking: what
    :func:`vidtrack.run._workers.track_view` reads, and only that.

    The footage (its fingerprint, not its path), the view's ``fps``, ``frames``,
    ``channel`` and ``target``, the scene's ``[track]`` table and the tracker (its
    version and settings). Not the run's name, the scales, origins, cameras, sync
    frames, corrections (applied to the tracks afterwards) nor anything of the fit:
    these are read by the later stages, whose keys hold the scene's hash.
    """
    view = scene.views[name]
    return stage_key("view", algorithm=tracker_version(),
                     settings={"tracker": TRACKER_SETTINGS, "track": scene.track},
                     inputs={"view": name,
                             "source": _file_fingerprint(source_of(view, scene, folder)),
                             "fps": view.fps, "frames": view.frames, "channel": view.channel,
                             "target": getattr(view, "target", None)})


def _reused_views(out_dir, keys, stages, label):
    """The views' tracks kept in views.h5 whose key is still the one in ``keys`` (view ->
    :func:`_view_key`), as {view: Track}; none when views.h5 is not the file the
    ``views`` stage recorded (with a note when it changed or went missing) or does not
    read back whole."""
    from vidtrack.run.tracks_file import read_tracks

    recorded = stages.parts("views")
    same = [n for n, k in keys.items() if recorded.get(n) == k]
    if not same:
        return {}
    ok, why = stages.check("views", stages.entries["views"]["key"], (VIEWS_FILE,))
    if not ok:
        if why:
            _note(f"{label}: {why}; tracking the views again")
        return {}
    try:
        tf = read_tracks(Path(out_dir) / VIEWS_FILE)
    except Exception as exc:      # noqa: BLE001 (any failure to read back: track again)
        _note(f"{label}: {VIEWS_FILE} does not read back whole ({type(exc).__name__}: "
              f"{exc}); tracking the views again")
        return {}
    return {n: tf.tracks[n] for n in same if n in tf.tracks}


def _write_tables(scene, out_dir, tracks, world):
    """tracks.csv and world.csv (the numbers of tracks.h5), and the DLTdv-style
    xypts.csv, xyzpts.csv and xypts_cameras.txt (:mod:`vidtrack.run.dltdv_export`)."""
    from vidtrack.run.dltdv_export import write_dltdv
    from vidtrack.run.tracks_file import write_tables

    write_tables(out_dir, tracks, world)
    cameras = ({n: v.camera for n, v in scene.views.items()} if scene.calibrated else None)
    write_dltdv(out_dir, tracks, world, cameras=cameras)


def _reused_tracks(scene, out_dir, key, stages, timings, label):
    """(tracks, world) from tracks.h5 when the tracks stage may be reused, else None
    (with a note on stderr when a file of the stage changed or went missing).

    Reused: tracks.h5 is the file the stage recorded (its sha256), or it was changed
    after it was written but reads back whole (HDF5 checksums, every dataset and
    attribute) for this scene: a view's track edited by hand (flags set, points moved
    or set to NaN) counts. The world track is then rebuilt from the edited views (the
    merge, or the triangulation, run again: a frame flagged by hand leaves the world
    track and the fit), tracks.h5 is written again with it and recorded, said in a
    note. When the views are as written (the root attribute ``views_sha256``) the edit
    is elsewhere, /world edited itself: it is used as edited. The fit is then computed
    again (its key holds tracks.h5's digest). A file damaged on disk
    fails to read back and is tracked again. tracks.csv and world.csv are written again
    from tracks.h5 unless they are the files recorded.
    """
    from vidtrack.run.tracks_file import read_tracks

    ok, why = stages.check("tracks", key, ("tracks.h5",))
    edited = False
    h5 = Path(out_dir) / "tracks.h5"
    if not ok and not stages.changed("tracks", key, "tracks.h5"):
        if why:
            _note(f"{label}: {why}; making the tracks again")
        return None
    t0 = time.perf_counter()
    try:
        tf = read_tracks(h5)
    except Exception as exc:      # noqa: BLE001 (any failure to read back: track again)
        _note(f"{label}: tracks.h5 {'changed and ' if why else ''}does not read back "
              f"whole ({type(exc).__name__}: {exc}); making the tracks again")
        return None
    if tf.world is None or set(tf.tracks) != set(scene.view_names):
        _note(f"{label}: tracks.h5 does not hold this scene's views and world track; "
              "making the tracks again")
        return None
    if not ok:
        if tf.scene_hash != scene.hash:
            _note(f"{label}: {why}, for another scene; making the tracks again")
            return None
        from vidtrack.run.tracks_file import views_digest

        if tf.views_sha256 is not None and views_digest(tf.tracks) == tf.views_sha256:
            # the views are as written: the edit is elsewhere (/world): used as edited
            _note(f"{label}: {why}, and reads back whole: using it as edited (its views "
                  "are as written; --force tracks again)")
            return _edited_tables(scene, out_dir, key, stages, timings, t0, tf)
        from vidtrack.run.reconstruct import reconstruct

        try:
            world = reconstruct(scene, tf.tracks)
            tracks = world.tracks
        except (VidtrackError, ValueError, KeyError) as exc:
            raise SceneError(f"{h5} was edited by hand and its views no longer give a world "
                             f"track ({exc}); undo the edit, or run again with --force to "
                             "track again (scene.toml's exclude_frames and manual_points "
                             "correct the tracker without editing tracks.h5)") from None
        _note(f"{label}: {why}, and reads back whole: using it as edited, the world track "
              "rebuilt from its edited views (--force tracks again)")
        from vidtrack.run.tracks_file import write_tracks

        write_tracks(h5, tracks, world, scene_hash=tf.scene_hash, calibration=tf.calibration)
        tf = dataclasses.replace(tf, tracks=tracks, world=world)
        edited = True
    return _edited_tables(scene, out_dir, key, stages, timings, t0, tf, edited=edited,
                          label=label)


def _edited_tables(scene, out_dir, key, stages, timings, t0, tf, *, edited=True, label=""):
    """The tables of a reused tracks.h5 written again where stale (or edited), the stage
    recorded; returns (tracks, world)."""
    stale = [n for n in TABLE_FILES if not stages.file_matches("tracks", n)]
    if edited or stale:
        # tracks.csv and world.csv belong to this stage: written again from the tracks
        # reused when missing, changed, or from before tracks.h5 was edited
        for name in stale:
            if not edited:
                how = "changed since it was written" if (Path(out_dir) / name).exists() \
                    else "is missing"
                _note(f"{label}: {name} {how}; written again from tracks.h5")
        _write_tables(scene, out_dir, tf.tracks, tf.world)
        stages.record("tracks", key, TRACKS_FILES,
                      at=None if edited else stages.at("tracks"))
    timings["tracks_reused"] = time.perf_counter() - t0
    return tf.tracks, tf.world


def _check_cp(scene, options):
    cp = scene.cp_s_per_m
    if cp is None:
        if options.model == "free":
            return 0.0
        raise SceneError(f"{scene.path}: [straw] gives no drag parameter: set cp_s_per_m, "
                         "or mass_kg, area_m2 and drag_coefficient (the quadratic and linear "
                         "models need Cp; --model free fits without drag)")
    return cp


def fit_throw_folder(scene, folder, out_dir, options, workers=None, *, plan=None):
    """Track, merge, cross-check and fit one throw (the run folder or one of its throws/
    folders).

    ``workers``: a dict holding the worker process across a run's throws (the caller
    stops it: :func:`_stop_workers`); without it one is started and stopped here.
    ``plan``: the run as :func:`vidtrack.run.preflight.prepare_run` checked it (without
    it this throw's sources and output folder are checked here).
    Returns the fit.json record written to ``out_dir`` (or reused from it: then
    ``stages_reused`` is ``["tracks", "fit"]`` and ``fitted_at`` says when it was fitted).

    Raises
    ------
    VidtrackError
        Bad input, inputs that disagree (unless ``options.accept_disagreement``), a fit
        that does not converge; the message names the run, the throw and the view.
    """
    if workers is None:
        workers = {}
        try:
            return fit_throw_folder(scene, folder, out_dir, options, workers, plan=plan)
        finally:
            _stop_workers(workers)
    from vidtrack.run.preflight import RunPlan, check_output_folder, RUN_OUTPUTS
    from vidtrack.run.preflight import _check_folder_sources

    out_dir = Path(out_dir)
    if plan is None:                 # a library caller: this throw's checks, here
        plan = RunPlan(scene=scene, out=out_dir, throws=[])
        with about(plan.label(folder)):
            scene = plan.scene_of(folder)                # a throw's own throw.toml
            found, notes, corrections = _check_folder_sources(
                scene, folder, lambda v: plan.label(folder, v))
            plan.findings[folder], plan.notes[folder] = found, notes
            plan.corrections[folder] = corrections
            _refuse(found, options)
            check_output_folder(out_dir, RUN_OUTPUTS, plan.label(folder))
    label = plan.label(folder)
    with about(label):
        return _fit_throw(scene, folder, out_dir, options, workers, plan, label)


def _cross_check(scene, tracks, world):
    """The findings of :func:`vidtrack.run.checks.cross_checks` on this throw."""
    from vidtrack.run.checks import cross_checks

    mappings = {}
    for n, v in scene.views.items():
        if hasattr(v, "mapping"):
            mappings[n] = v.mapping()
    mappings = world.mappings(mappings)     # the scales as merged (reconciled on X)
    return cross_checks(world, tracks, mappings, g=scene.physics.gravity_m_s2,
                        sources={n: {"fps": getattr(v, "fps", None)}
                                 for n, v in scene.views.items()})


def _refuse(findings, options, *, where_tracks=None):
    """Stop on findings (DisagreementError, one line) unless they are accepted."""
    if not findings or options.accept_disagreement:
        return
    what = "; ".join(f.message for f in findings)
    kept = f" (the tracks are in {where_tracks})" if where_tracks else ""
    raise DisagreementError(f"the inputs disagree: {what}; the fit would be wrong{kept}. "
                            "To fit anyway, rerun with --accept-disagreement")


def _accepted(findings, label):
    """The findings let through: each a warning on stderr, and notes for fit.json."""
    notes = []
    for f in findings:
        log.warning("%s: %s (accepted with --accept-disagreement)", label, f.message)
        notes.append(f"inputs disagree ({f.check}, accepted): {f.message}")
    return notes


def _read_record(path):
    try:
        record = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) and "coefficients" in record else None


def _fit_throw(scene, folder, out_dir, options, workers, plan, label):
    stages = Stages.read(out_dir)
    if stages.problem:
        _note(f"{label}: {stages.problem}; computing every stage again")
    timings = {}
    t_start = time.perf_counter()
    tracks_key, tracks, world, reused, views_reused, helper = _tracks_stage(
        scene, folder, out_dir, options, timings, stages, workers, plan.corrections[folder],
        label_of=lambda view: plan.label(folder, view) if view else label)
    findings = list(plan.findings.get(folder, [])) + _cross_check(scene, tracks, world)
    if findings and not options.accept_disagreement:
        # no fit.json (nor report) of an earlier fit may stand in for this one
        _remove_outputs(out_dir, stages, ("fit",), FIT_FILES)
        _refuse(findings, options, where_tracks=out_dir / "tracks.h5")
    import numpy as np

    from fits.errors import ConvergenceError
    from fits.lsq import fit_throw
    from vidtrack.run.cache import utc_now
    from vidtrack.run.fit_record import dumps, throw_record

    cp = _check_cp(scene, options)
    # tracks.h5 itself too: a track edited by hand (flags set, points removed) is refitted
    # the views' scale uncertainties: they change the intervals (not the tracks)
    scale_rel = {n: v.scale_rel_uncertainty[0] for n, v in scene.views.items()
                 if hasattr(v, "scale_rel_uncertainty")}
    fit_key = stage_key("fit", algorithm=FIT_ALGORITHM,
                        settings={**options.key(), "cp": cp, "scale_rel": scale_rel},
                        inputs={"tracks": tracks_key,
                                "tracks_file": file_digest(out_dir / "tracks.h5")})
    needed = ("fit.json",) + (REPORT_FILES if options.report else ())
    if not options.force:
        ok, why = stages.check("fit", fit_key, needed)
        record = _read_record(out_dir / "fit.json") if ok else None
        if record is not None:
            notes = _accepted(findings, label)
            if not options.report:
                # --no-report: a report is kept only when it is the one of this fit
                for name in REPORT_FILES:
                    if not stages.file_matches("fit", name):
                        (out_dir / name).unlink(missing_ok=True)
            record = dict(record, stages_reused=["tracks", "fit"],
                          fitted_at=record.get("fitted_at") or stages.at("fit"))
            if notes and not record.get("checks"):
                record["checks"] = [f.to_dict() for f in findings]
            return record
        if why:
            _note(f"{label}: {why}; fitting again")
    _remove_outputs(out_dir, stages, ("fit",), FIT_FILES)
    notes = list(plan.notes.get(folder, [])) + _accepted(findings, label)
    shared = world.shared_x
    if shared is not None and (shared.seen or not shared.reconciled):
        # the views' relative scale: said when the data show it (or it was not reconciled)
        _note(f"{label}: {shared.note()}")
        notes.append(shared.note())
    if "tracks" in reused:      # said on stderr and kept in fit.json: the tracks are not new
        said = (f"tracks reused from {out_dir / 'tracks.h5'} (computed at "
                f"{stages.at('tracks') or 'an earlier run'}, same scene, footage, tracker and "
                "settings; --force tracks again)")
        _note(f"{label}: {said}")
        notes.append(said)
    if views_reused:
        said = (f"the tracks of the {' and '.join(views_reused)} "
                f"view{'s' if len(views_reused) > 1 else ''} reused from "
                f"{out_dir / VIEWS_FILE} (same footage, frames, fps, channel, target, tracker "
                "and settings), the world track rebuilt from them (--force tracks again)")
        _note(f"{label}: {said}")
        notes.append(said)
    t0 = time.perf_counter()
    try:
        fit = fit_throw(world.data, cp, g=scene.physics.gravity_m_s2, v1=scene.v1_m_s,
                        model=options.model, bootstrap=options.bootstrap,
                        rng=np.random.default_rng(options.seed))
    except ConvergenceError as exc:
        raise FitError(f"the fit did not converge: {exc}; the tracks are in "
                       f"{out_dir / 'tracks.h5'} (see the report of a run that fits, and "
                       "docs/fit-outputs.md)") from exc
    timings["fit"] = time.perf_counter() - t0
    # the views' scales in k's error: refits with each scale moved by its uncertainty
    from vidtrack.run.scale_error import scale_error

    t0 = time.perf_counter()
    try:
        scale_part = scale_error(scene, tracks, fit, cp=cp, model=options.model,
                                 world=world)
    except ConvergenceError as exc:      # pragma: no cover (the refits catch their own)
        scale_part = None
        notes.append(f"the views' scales could not be carried into k: {exc}")
    if scale_part is not None:
        fit = fit.with_calibration(scale_part.parts())
        notes += list(scale_part.notes)
        timings["calibration"] = time.perf_counter() - t0
    said = {f.check for f in findings}
    notes += [w for w in world.warnings          # not twice: the finding says it
              if not ("x_disagreement" in said and w.startswith("the views disagree on X"))]
    # a view without camera_distance_m: a note only when its perspective could move k
    # by a standard error (vidtrack.run.perspective)
    from vidtrack.run.perspective import perspective_effect

    t0 = time.perf_counter()
    effect = perspective_effect(scene, tracks, world, fit, cp=cp, model=options.model)
    if effect is not None:
        notes += list(effect.notes)
        timings["perspective"] = time.perf_counter() - t0
    for name, tr in tracks.items():
        notes += [f"{name}: {n}" for n in tr.notes]
    extra = {"throw": Path(folder).name if Path(folder) != scene.folder else None,
             "views": {n: tr.to_dict() for n, tr in tracks.items()},
             "world": world.to_dict(), "stages_reused": reused,
             "checks": [f.to_dict() for f in findings], "notes": notes}
    if scale_part is not None:
        extra["calibration"] = scale_part.to_dict()
    record = throw_record(scene, fit, timings_s=timings, extra=extra)
    pages = None
    if options.report:
        pages = _render_report(record, fit, world, tracks, helper, timings,
                               scene=scene, folder=folder)
    timings["total"] = time.perf_counter() - t_start
    record["timings_s"] = {k: round(float(v), 6) for k, v in timings.items()}
    record["fitted_at"] = utc_now()
    # fit.json first: a report never stands without the fit it shows
    with _whole_or_none(out_dir, FIT_FILES):
        write_text(out_dir / "fit.json", dumps(record))
        for name, text in (pages or {}).items():
            write_text(out_dir / name, text)
        stages.record("fit", fit_key, needed, at=record["fitted_at"])
    return record


def _render_report(record, fit, world, tracks, helper, timings, *, scene=None, folder=None):
    """report.md and report.html as text (written after fit.json).

    With ``scene`` the page has each view's residuals in pixels, and with ``folder`` too
    the sections drawn on the footage (the trajectory over a full frame, the contact
    sheet: read and drawn here, after the helper drew the plots)."""
    from vidtrack.report.run_page import render_html, render_markdown, with_contact_sheet

    t0 = time.perf_counter()
    paths = _view_paths(scene, record, fit, world, tracks) if scene else None
    px = None
    if paths is not None:
        from vidtrack.report.trajectory import pixel_residuals

        px = pixel_residuals({n: tr.data for n, tr in tracks.items()}, paths)
    # drawn by the process that tracked the second view, if it is there (it loaded
    # matplotlib and drew the tracks plot while this one fitted)
    html = (helper.render(record, fit=fit, world=world.data, px_residuals=px) if helper
            else None)
    sheet = _footage(scene, folder, tracks, paths) if scene else None
    if html is None:
        html = render_html(record, fit=fit, world=world.data,
                           views={n: tr.data for n, tr in tracks.items()},
                           contact_sheet=sheet, px_residuals=px)
    elif sheet is not None:
        html = with_contact_sheet(html, sheet)
    pages = {"report.md": render_markdown(record, px_residuals=px), "report.html": html}
    timings["report"] = time.perf_counter() - t0
    return pages


def _view_paths(scene, record, fit, world, tracks):
    """The fitted path in each view's pixels; None (and a warning) when it cannot be put
    there: the report then stands without what is drawn in pixels."""
    from vidtrack.report.view_path import view_paths

    try:
        return view_paths(scene, record, world.data, positions=fit.predict,
                          frame_shapes={n: tr.frame_shape for n, tr in tracks.items()})
    except Exception as exc:     # noqa: BLE001 (the report stands without it)
        log.warning("the fitted path could not be put into the views' pixels: %s: %s",
                    type(exc).__name__, exc)
        return None


def _footage(scene, folder, tracks, paths):
    """The report's sections drawn on the footage (the trajectory over a full frame, the
    contact sheet); a failure to draw them is said in their place."""
    from vidtrack.report import _html
    from vidtrack.report.trajectory import footage_html

    try:
        if paths is None:
            raise ValueError("the fitted path could not be put into the views' pixels")
        return footage_html(scene, folder, {n: tr.data for n, tr in tracks.items()}, paths)
    except Exception as exc:     # noqa: BLE001 (the report stands without its images)
        log.warning("the footage's images could not be drawn: %s: %s", type(exc).__name__,
                    exc)
        return (f'<h2>Contact sheet</h2><p class="note">Not drawn: '
                f"{_html.esc(type(exc).__name__)}: {_html.esc(exc)}</p>")


def _stop_workers(workers):
    for w in workers.values():
        w.stop()


def fit_run(run_dir, options=FitOptions(), *, plan=None, workers=None):
    """Fit one run folder (and each of its throws): footage to tracks, world track, k1..k4.

    What ``vidtrack fit RUN`` does for one run: the outputs are written to
    ``<run>/vidtrack/`` (tracks.h5, tracks.csv, world.csv, fit.json, the reports), and a
    stage whose inputs are unchanged is reused.

    Parameters
    ----------
    run_dir : str or os.PathLike
        The run folder (with scene.toml).
    options : FitOptions, optional
        The model, bootstrap, ``force``, ``report``, ...
    plan : vidtrack.run.preflight.RunPlan, optional
        The run as :func:`vidtrack.run.preflight.prepare_run` checked it (default:
        checked here, before anything is tracked).
    workers : dict, optional
        Holds a worker process to use (the caller stops it); default one of the run's own.

    Returns
    -------
    vidtrack.run.results.RunFit
        k1..k4 (``params``, ``bse``, ``conf_int()``, ``summary()``), the tracks and the
        world track as DataFrames, ``to_dict()`` (what fit.json holds); as a mapping, the
        run's record (fit.json's fields, ``stages_reused`` as this call found them).

    Raises
    ------
    VidtrackError
        Bad input, inputs that disagree (unless ``options.accept_disagreement``), a fit
        that does not converge; the message names the run, the throw and the view.

    Examples
    --------
    >>> from vidtrack import fit_run                                # doctest: +SKIP
    >>> fit = fit_run("datasets/run42")                             # doctest: +SKIP
    >>> print(fit.summary())                                        # doctest: +SKIP
    >>> fit.conf_int()                                              # doctest: +SKIP
    """
    from vidtrack.run.results import RunFit

    plan = plan or prepare_run(run_dir)
    _refuse_early(plan, options)
    scene = plan.scene
    out = plan.out
    if not plan.throws:
        return RunFit.of(fit_throw_folder(scene, scene.folder, out, options, workers,
                                          plan=plan), out)
    from vidtrack.run.cache import utc_now
    from vidtrack.run.fit_record import dumps, mean_record
    from vidtrack.report.run_page import render_markdown, render_html

    # the run's mean is written again from its throws: until then there is none
    for name in FIT_FILES:
        (out / name).unlink(missing_ok=True)
    t0 = time.perf_counter()
    own = workers is None
    workers = {} if own else workers      # one worker process serves all the throws
    try:
        records = [fit_throw_folder(plan.scene_of(d), d, out / d.name, options, workers,
                                    plan=plan) for d in plan.throws]
    finally:
        if own:
            _stop_workers(workers)
    record = mean_record(scene, records, timings_s={
        "throws_total": time.perf_counter() - t0})
    record["fitted_at"] = utc_now()
    write_text(out / "fit.json", dumps(record))
    if options.report:
        write_text(out / "report.md", render_markdown(record))
        write_text(out / "report.html", render_html(record))
    if all("fit" in r.get("stages_reused", []) for r in records):
        record["stages_reused"] = ["tracks", "fit"]
        record["throws_fitted_at"] = max((r.get("fitted_at") or "") for r in records) or None
    return RunFit.of(record, out, throws={d.name: RunFit.of(r, out / d.name)
                                          for d, r in zip(plan.throws, records)})


def _refuse_early(plan, options):
    """Findings of the preflight (the same footage for two views) stop the run before
    anything is tracked, unless accepted."""
    for folder, found in plan.findings.items():
        if found and not options.accept_disagreement:
            with about(plan.label(folder)):
                _refuse(found, options)


def check_counts(*, jobs=1, bootstrap=0, seed=0):
    """Counts a user types, within bounds (VidtrackError naming the limit)."""
    from vidtrack.errors import VidtrackError

    if not 1 <= jobs <= MAX_JOBS:
        raise VidtrackError(f"--jobs must be between 1 and {MAX_JOBS}, got {jobs}")
    if not 0 <= bootstrap <= MAX_BOOTSTRAP:
        raise VidtrackError(f"--bootstrap must be between 0 and {MAX_BOOTSTRAP} "
                            f"resamples, got {bootstrap}")
    if not 0 <= seed < 2 ** 32:
        raise VidtrackError(f"--seed must be between 0 and {2 ** 32 - 1}, got {seed}")


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
    # a run named twice is fitted once (two processes must never write one folder)
    seen, unique = set(), []
    for r in runs:
        key = os.path.realpath(r)
        if key not in seen:
            seen.add(key)
            unique.append(r)
    return unique


def _fit_one(args, workers=None):
    """One run's record (the dict that fit.json's fields and this call's reuse make)."""
    plan, options = args
    return fit_run(plan.scene.folder, options, plan=plan, workers=workers).record


def prepare_runs(run_dirs, options=FitOptions()):
    """Every run's preflight (:func:`vidtrack.run.preflight.prepare_run`) and early
    cross-checks, all before the first run is tracked. Returns the plans in order."""
    plans = []
    for r in run_dirs:
        plan = prepare_run(r)
        _refuse_early(plan, options)
        plans.append(plan)
    return plans


def _connect(scheduler):
    """A dask.distributed Client, or one line on what is wrong with ``scheduler``."""
    from vidtrack.errors import VidtrackError

    try:
        from distributed import Client
    except ImportError:
        raise SceneError("--scheduler needs dask.distributed: pip install "
                         "'vidtrack[dask]'") from None
    try:
        return Client(scheduler, timeout=SCHEDULER_TIMEOUT_S)
    except (ValueError, TypeError) as exc:
        raise VidtrackError(f"--scheduler {scheduler}: not a scheduler address ({exc}); "
                            "expected e.g. tcp://10.0.0.5:8786") from None
    except (OSError, TimeoutError) as exc:
        raise VidtrackError(f"--scheduler {scheduler}: no dask scheduler answered within "
                            f"{SCHEDULER_TIMEOUT_S} s ({type(exc).__name__}: {exc}); "
                            "expected the address of a running scheduler, e.g. "
                            "tcp://10.0.0.5:8786") from None


def fit_runs(run_dirs, options=FitOptions(), *, jobs=1, scheduler=None, progress=None,
             plans=None):
    """Fit several runs, in parallel processes (``jobs``) or on a Dask cluster.

    Every run is checked first (:func:`prepare_runs`): a bad input anywhere stops the
    command before any footage is tracked.

    Parameters
    ----------
    run_dirs : sequence of path
    options : FitOptions
    jobs : int
        Worker processes (1: in this process; at most :data:`MAX_JOBS`).
    scheduler : str, optional
        Address of a dask.distributed scheduler (needs the ``dask`` extra).
    progress : callable, optional
        Called with each finished run's record.
    plans : list of RunPlan, optional
        The runs already checked by :func:`prepare_runs` (``run_dirs`` is then ignored).

    Returns
    -------
    list of dict
        The runs' records (:attr:`vidtrack.run.results.RunFit.record`: fit.json's fields,
        ``stages_reused`` as this call found them), in the order of ``run_dirs``.
    """
    check_counts(jobs=jobs, bootstrap=options.bootstrap, seed=options.seed)
    if plans is None:
        plans = prepare_runs(run_dirs, options)
    if scheduler or (jobs > 1 and len(plans) > 1):
        # the runs share the cores: one view at a time within each
        options = dataclasses.replace(options, threads=1)
    work = [(p, options) for p in plans]
    if scheduler:
        with _connect(scheduler) as client:
            futures = client.map(_fit_one, work, pure=False)
            results = client.gather(futures)
        for r in results:
            if progress:
                progress(r)
        return results
    if jobs <= 1 or len(work) == 1:
        workers = {}
        try:
            return _fit_in_turn(plans, options, progress, workers)
        finally:
            _stop_workers(workers)
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=min(jobs, len(work))) as pool:
        results = []
        for r in pool.map(_fit_one, work):
            results.append(r)
            if progress:
                progress(r)
        return results


def _fit_in_turn(plans, options, progress, workers):
    """The runs one after the other in this process, sharing one worker process (spawned
    and loaded once)."""
    results = []
    for plan in plans:
        results.append(_fit_one((plan, options), workers))
        if progress:
            progress(results[-1])
    return results
