"""``vidtrack overlay RUN``: each view's footage with the tracks and the fit drawn on it.

The run is checked as ``vidtrack fit`` checks it (:func:`vidtrack.run.preflight.prepare_run`:
the scene, the sources, the output folders). Its tracks (tracks.h5) and fit (fit.json)
are used when they are current; when they are missing or stale (:func:`stale_reason`)
the run is fitted first by :func:`vidtrack.run.pipeline.fit_runs`, as ``vidtrack fit``
does, with the model fit.json names. Then every view with footage is drawn
(:func:`vidtrack.report.overlay.write_overlay`) with its fitted path
(:mod:`vidtrack.report.view_path`), the trail of measured points and the view's scene
(origin, axes, ruler) as H.264 MP4.
"""

import json
from pathlib import Path

__all__ = ["overlay_run", "stale_reason"]


def _record(out_dir):
    try:
        record = json.loads((Path(out_dir) / "fit.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) and "coefficients" in record else None


def stale_reason(scene, folder, out_dir):
    """Why the tracks and fit in ``out_dir`` cannot be drawn as they are (None: current).

    Missing tracks.h5 or fit.json, a fit of another scene or vidtrack version, a file
    changed since its stage wrote it (stages.json), footage changed since it was tracked.
    """
    from vidtrack import __version__
    from vidtrack.run._workers import source_of
    from vidtrack.run.cache import Stages
    from vidtrack.scene.throw_file import THROW_FILE

    out_dir = Path(out_dir)
    h5 = out_dir / "tracks.h5"
    if not h5.is_file():
        return "there is no tracks.h5"
    record = _record(out_dir)
    if record is None:
        return "there is no fit.json"
    if record.get("scene_hash") != scene.hash:
        own = (Path(folder) / THROW_FILE).is_file()
        return f"scene.toml{' or throw.toml' if own else ''} changed since the fit"
    if record.get("vidtrack_version") != __version__:
        return (f"the fit was made by vidtrack {record.get('vidtrack_version')}, this is "
                f"{__version__}")
    stages = Stages.read(out_dir)
    for stage, name in (("tracks", "tracks.h5"), ("fit", "fit.json")):
        if not stages.file_matches(stage, name):
            return f"{name} is not the one the {stage} stage wrote (stages.json)"
    tracked = h5.stat().st_mtime_ns
    for name, view in scene.views.items():
        src = Path(source_of(view, scene, folder))
        try:
            changed = max([src.stat().st_mtime_ns] + ([p.stat().st_mtime_ns
                                                       for p in src.iterdir()]
                                                      if src.is_dir() else []))
        except OSError:
            continue
        if changed > tracked:
            return f"the {name} footage changed since it was tracked"
    return None


def _fit_first(plan, reasons, quiet):
    """Fit the run as ``vidtrack fit`` would (the model of an existing fit.json kept)."""
    import logging

    from vidtrack.run.pipeline import FitOptions, fit_runs

    log = logging.getLogger("vidtrack")
    first = next(iter(reasons.items()))
    log.warning(f"{first[1]} in {first[0]}: fitting first, as 'vidtrack fit "
                f"{plan.scene.folder}' does", extra={"label": "note"})
    from vidtrack.report.view_path import MODELS

    old = [r for r in (_record(out) for _, out in plan.folders()) if r]
    model = MODELS.get(old[0].get("model"), "quadratic") if old else "quadratic"
    accept = any(r.get("checks") for r in old)
    options = FitOptions(model=model, quiet=quiet, view_process=True,
                         accept_disagreement=accept)
    fit_runs([plan.scene.folder], options, plans=[plan])


def overlay_run(run_dir, *, views=None, every=1, scale=1.0, frame_range=None, trail=None,
                quiet=True):
    """Write ``overlay_<view>.mp4`` for every view with footage (of every throw).

    Parameters
    ----------
    run_dir : path
        The run folder.
    views : list of str, optional
        Only these views (default: every view with footage).
    every, scale, trail : see :func:`vidtrack.report.overlay.write_overlay` (``trail``
        None: its default).
    frame_range : (int, int or None), optional
        Half-open range of the file's frames to draw (default: all).
    quiet : bool

    Returns
    -------
    (list of OverlayResult, list of str)
        What was written, and notes (views skipped, ranges clipped, codec fallback).

    Raises
    ------
    VidtrackError
        Bad input: the run's (as for ``vidtrack fit``), an unknown view, a range outside
        the footage, an output folder that cannot be written.
    """
    from vidtrack.errors import VidtrackError
    from vidtrack.footage import open_source
    from vidtrack.report.overlay import TRAIL_FRAMES, scene_marks, write_overlay
    from vidtrack.report.view_path import view_paths
    from vidtrack.run._workers import source_of
    from vidtrack.run.preflight import about, prepare_run
    from vidtrack.run.tracks_file import read_tracks
    from vidtrack.track.tracker import CAMERA_COLUMNS

    plan = prepare_run(run_dir)
    scene = plan.scene
    names = list(scene.view_names)
    if views:
        unknown = [v for v in views if v not in names]
        if unknown:
            raise VidtrackError(f"--view {unknown[0]}: run {scene.run_name!r} has no such view; "
                                f"expected one of {', '.join(names)}")
        names = [n for n in names if n in views]
    notes = []
    drawable = []
    for n in names:
        if getattr(scene.views[n], "points", None) is not None:
            notes.append(f"view {n} gives points ({scene.views[n].source_text}), not "
                         "footage: no overlay for it")
        else:
            drawable.append(n)
    if not drawable:
        return [], notes
    folders = list(plan.folders())
    for _, out in folders:
        for n in drawable:
            for ext in (".mp4", ".avi"):
                target = out / f"overlay_{n}{ext}"
                if target.is_dir() or target.is_symlink():
                    raise VidtrackError(f"{target}: is a folder or a link; expected the "
                                        "overlay's file name to be free or a regular file")
    reasons = {plan.label(folder): why for folder, out in folders
               if (why := stale_reason(plan.scene_of(folder), folder, out))}
    if reasons:
        _fit_first(plan, reasons, quiet)
    results = []
    for folder, out in folders:
        label = plan.label(folder)
        with about(label):
            record = _record(out)
            tf = read_tracks(out / "tracks.h5")
            world = {c: tf.world.data[c].to_numpy() for c in tf.world.data.columns}
            paths = view_paths(scene, record, world,
                               frame_shapes={n: t.frame_shape for n, t in tf.tracks.items()})
            for n in drawable:
                view = scene.views[n]
                with about(label, view=n), open_source(source_of(view, scene, folder),
                                                       fps=view.fps, frames=frame_range,
                                                       channel=view.channel) as src:
                    notes += [f"{label}, view {n}: {s}" for s in src.notes]
                    notes += [f"{label}, view {n}: {s}" for s in
                              (paths[n].notes if n in paths else ())]
                    data = tf.tracks[n].data
                    r = write_overlay(src, out, n, {c: data[c].to_numpy() for c in
                                                    ("frame", "u_px", "v_px", "flags",
                                                     *CAMERA_COLUMNS) if c in data},
                                      paths.get(n), every=every, scale=scale,
                                      trail=TRAIL_FRAMES if trail is None else trail,
                                      scene=scene_marks(view, src.shape[:2]), quiet=quiet)
                if r.note:
                    notes.append(f"{label}, view {n}: {r.note}")
                results.append(r)
    return results, notes
