"""Tracking one of a scene's two views beside the other: in a process or in a thread.

Internal to :mod:`vidtrack.run.pipeline`. The command line tracks the view with the larger
footage in a spawned process (:class:`ViewProcess`): the two views then run truly at
once on two cores, while the calling process also loads what the later stages need
(:func:`preload_later_stages`). That process stays on as the report's renderer: while
the calling process merges the views and fits, it loads matplotlib, draws the tracks
plot of the merged tracks it is sent, then the page. It is sent arrays, never the fit
or pandas objects, and so never loads scipy or pandas. One such process serves all
the throws of a run, job by job (:func:`_serve`). Library callers get a thread
(:class:`ViewThread`): spawning re-imports the caller's main module, which only a main
module written for it (as the command line's is) survives; in a thread decoding and
OpenCV's operations overlap, the tracker's Python does not.

Either way, a failure of the view raises its error in the caller, and :meth:`stop`
ends the worker whatever it is doing (the caller failed or Ctrl-C). What the process
logs (at the level the caller's ``vidtrack`` logger had when it was spawned) is sent
back with each job's answer and logged again in the caller (``vidtrack fit -v`` says
what both views did).
"""

import logging
import signal
import sys


def source_of(view, scene, folder):
    """The footage of ``view`` for the run (or throw) folder ``folder``."""
    from pathlib import Path

    return view.source if Path(folder) == scene.folder else view.source_in(folder)


def tracker_options(scene):
    """The scene's ``[track]`` table as :func:`vidtrack.track.tracker.track`'s keywords:
    ``engine`` and, for the flight tracker, its ``settings``.

    Raises
    ------
    SceneError
        An engine the tracker does not have, a setting it does not have, a setting
        without ``engine = "flight"``, a value out of range: one line naming the key.
    """
    from vidtrack.errors import SceneError, VidtrackError
    from vidtrack.track.settings import TrackerSettings
    from vidtrack.track.tracker import ENGINES

    table = dict(getattr(scene, "track", None) or {})
    engine = table.pop("engine", "rules")
    where = scene.path
    if engine not in ENGINES:
        raise SceneError(f"{where}: track.engine must be one of "
                         f"{', '.join(repr(e) for e in ENGINES)}, got {engine!r}")
    if engine != "flight":
        if table:
            raise SceneError(f"{where}: track.{sorted(table)[0]} is a setting of the flight "
                             f"tracker: give engine = \"flight\" with it")
        return {}
    try:
        return {"engine": engine, "settings": TrackerSettings.from_mapping(table)}
    except VidtrackError as err:
        raise SceneError(f"{where}: {err}") from None


def track_view(scene, folder, name, settings, *, quiet=True, cancel=None, parts=False):
    """Track view ``name`` of ``scene`` in ``folder`` with the tracker ``settings``.

    Returns the Track, or with ``parts`` its fields (:func:`vidtrack.track.tracker.track_parts`:
    no pandas needed). What ``channel = "auto"`` chose, and why, leads its notes.
    """
    import dataclasses

    from vidtrack.footage import open_source
    from vidtrack.track.tracker import track, track_parts

    view = scene.views[name]
    with open_source(source_of(view, scene, folder), fps=view.fps, frames=view.frames,
                     channel=view.channel) as src:
        out = (track_parts if parts else track)(src, view=name, quiet=quiet, cancel=cancel,
                                                target=getattr(view, "target", None),
                                                **settings, **tracker_options(scene))
        said = tuple(n for n in src.notes if n.startswith("channel "))
    if not said:
        return out
    if parts:
        return dict(out, notes=said + tuple(out["notes"]))
    return dataclasses.replace(out, notes=said + tuple(out.notes))


#: How long (s) the worker is given to end on SIGTERM before it is killed.
_STOP_WAIT_S = 5.0

#: What the stages after tracking import (about 0.8 s of CPU).
LATER_STAGES = ("scipy.optimize", "h5py", "vidtrack.world.orthogonal",
                "vidtrack.run.tracks_file", "fits.lsq", "vidtrack.run.fit_record")


def _import_all(names):
    import importlib

    for name in names:
        try:
            importlib.import_module(name)
        except Exception:      # noqa: S110  (the stage that needs it will say what is wrong)
            return


def preload_later_stages():
    """Import :data:`LATER_STAGES` in a daemon thread while the views are tracked.

    The tracker spends most of its time decoding, which releases the GIL, and this
    process has the smaller view: the imports take time it would otherwise spend
    waiting for the worker. A stage importing a module still being loaded waits for it
    (the import system's per-module lock).
    """
    import threading

    threading.Thread(target=_import_all, args=(LATER_STAGES,), name="preload",
                     daemon=True).start()


def _columns(frame):
    """A DataFrame's columns as a dict of numpy arrays."""
    return {c: frame[c].to_numpy() for c in frame.columns}


class _Kept(logging.Handler):
    """Keeps the records of a job, as plain fields, to send with its answer."""

    def __init__(self, level):
        super().__init__(level)
        self.records = []

    def emit(self, record):
        try:
            self.records.append({"name": record.name, "levelno": record.levelno,
                                 "levelname": record.levelname, "msg": record.getMessage(),
                                 "label": getattr(record, "label", None)})
        except Exception:                          # as logging's own handlers do
            self.handleError(record)

    def take(self):
        out, self.records = self.records, []
        return out


def _keep_logs(level):
    """Install a :class:`_Kept` handler at ``level`` on this process's loggers."""
    kept = _Kept(level)
    from vidtrack import LOGGERS

    for name in LOGGERS:
        logger = logging.getLogger(name)
        logger.addHandler(kept)
        logger.setLevel(level)
    return kept


def _replay(records):
    """Log again in this process what the worker logged."""
    for fields in records:
        record = logging.makeLogRecord(dict(fields, args=None))
        if record.label is None:
            del record.label
        logger = logging.getLogger(record.name)
        if logger.isEnabledFor(record.levelno):
            logger.handle(record)


def _send(conn, status, value, what, logs=()):
    try:
        conn.send((status, value, list(logs)))
    except OSError:                # the caller is gone: _process_main ends quietly
        raise
    except Exception as exc:       # e.g. an exception that does not pickle
        conn.send(("error", RuntimeError(f"{what}: {value!r} ({exc})"), list(logs)))


def _exit_with_parent():
    """End this process at once, quietly, when the process that started it ends
    (killed, or stopped without stopping this one): nobody is left to answer."""
    import multiprocessing
    import os
    import threading

    parent = multiprocessing.parent_process()
    if parent is None:
        return

    def watch():
        from multiprocessing.connection import wait

        # a signal to this process is the main thread's to handle: were it delivered to
        # this thread, the main thread blocked reading its next job would never run the
        # handler (SIGTERM from the caller's stop, which then waited for ever)
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM, signal.SIGINT})
        wait([parent.sentinel])
        os._exit(0)

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def _warm_up_plots():
    """Load what drawing the report takes (while the caller merges and fits)."""
    from vidtrack.report import _html

    _html.png_bytes(_html.figure(1, 1))   # fonts and the Agg canvas, once


def _stopped(*_):
    """SIGTERM in the worker: the caller is stopping it (another view failed, Ctrl-C).
    Whatever the exit interrupts (an import half done: numpy then says its C extensions
    failed) concerns no one, so nothing more is printed: the caller says what went
    wrong, in one line."""
    import os

    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), 2)
    except OSError:
        pass
    sys.exit(1)


def _process_main(conn, level=logging.WARNING):
    """Body of the worker process: serve the jobs that come down ``conn`` until it closes;
    what it logs at ``level`` and above goes back with each answer."""
    # Ctrl-C reaches the whole process group: the caller stops this process itself, by
    # SIGTERM, on which it exits as from an error (finalisers run: no leaked semaphore)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # born with SIGINT blocked (see ViewProcess): ignored now, a pending one is dropped
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    signal.signal(signal.SIGTERM, _stopped)
    _exit_with_parent()
    try:
        _serve(conn, _keep_logs(level))
    except (EOFError, OSError):
        # the caller went away mid-job (its end of the pipe closed): nothing to report
        # to, and nothing to print on a terminal that is no longer its own
        sys.exit(0)
    finally:
        # done: a SIGTERM now (the caller stopping this process as it shuts down) ends
        # it at once
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _serve(conn, kept=None):
    """Jobs: ``("track", scene, folder, name, settings, quiet, report)`` -> the Track's
    fields; ``("views", columns)`` -> nothing (the tracks plot is drawn and kept);
    ``("page", record, curves, world, px_residuals)`` -> report.html's text. A job's
    error goes back in its place. After a track job with ``report`` matplotlib is loaded
    at once, while the caller merges and fits (once per process: a run's throws share
    it). ``kept``: the records logged meanwhile, sent with each answer."""
    from vidtrack.report.run_page import render_html, tracks_image

    warm, tracks_img = False, None
    while True:
        try:
            kind, *args = conn.recv()
        except EOFError:
            return
        if kind == "views":                       # no answer: kept for the page
            try:
                tracks_img = tracks_image(*args)
            except Exception as exc:              # said with the page
                tracks_img = exc
            continue
        try:
            if kind == "track":
                scene, folder, name, settings, quiet, report = args
                # the Track's fields, not the Track: this process never loads pandas
                value = track_view(scene, folder, name, settings, quiet=quiet, parts=True)
            else:
                record, curves, world, px_residuals = args
                if isinstance(tracks_img, Exception):
                    raise tracks_img
                value = render_html(record, world=world, curves=curves,
                                    tracks_img=tracks_img, px_residuals=px_residuals)
                tracks_img = None
            result = ("ok", value)
        except SystemExit:
            raise
        except BaseException as exc:              # re-raised in the caller
            result = ("error", exc)
        _send(conn, *result, f"the worker's {kind} job", kept.take() if kept else ())
        if kind == "track" and result[0] == "ok" and report and not warm:
            try:
                _warm_up_plots()
            except Exception:                     # noqa: S110 (the page will say)
                pass
            warm = True


class WorkerGone(RuntimeError):
    """The worker process ended before answering (killed, out of memory, a crash)."""


class ViewProcess:
    """A spawned process that tracks views and draws their reports, job by job.

    One serves all the throws of a run (spawning it and loading its libraries once).
    :meth:`start` a view, take its :meth:`track`; for the report :meth:`send_tracks` the
    merged tracks (the plot is drawn while the caller fits) and :meth:`render` the page.
    """

    def __init__(self):
        import multiprocessing
        from multiprocessing import resource_tracker

        ctx = multiprocessing.get_context("spawn")
        self.name = None
        self.conn, child = ctx.Pipe()
        level = logging.getLogger("vidtrack").getEffectiveLevel()
        self.proc = ctx.Process(target=_process_main, args=(child, level),
                                name="vidtrack-worker", daemon=True)
        # the process starts with SIGINT blocked (a signal mask outlives fork and exec):
        # a Ctrl-C while its interpreter starts, before _process_main ignores SIGINT,
        # would print a KeyboardInterrupt traceback from its imports. This process gets
        # a SIGINT sent meanwhile once it unblocks it, and stops the worker as usual.
        # multiprocessing's resource tracker, started first: starting it unblocks SIGINT
        resource_tracker.ensure_running()
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            self.proc.start()
        finally:
            if signal.SIGINT not in blocked:
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        child.close()

    def start(self, scene, folder, name, settings, *, quiet=True, report=False):
        """Start tracking view ``name`` (:func:`track_view`'s arguments); ``report``:
        load the plotting libraries after it, a report will be asked for."""
        self.name = name
        self.conn.send(("track", scene, folder, name, settings, quiet, report))

    def _result(self, what):
        try:
            status, value, logs = self.conn.recv()
        except EOFError:
            self.proc.join()
            raise WorkerGone(f"the worker process ended while {what} (exit code "
                             f"{self.proc.exitcode})") from None
        _replay(logs)
        if status != "ok":
            raise value
        return value

    def track(self):
        """The view's Track (its error raised here)."""
        from vidtrack.track.tracker import Track, log_tracked

        tr = Track.from_parts(self._result(f"tracking view {self.name}"))
        log_tracked(tr)
        return tr

    def send_tracks(self, views):
        """The merged tracks ({view: rows}), for the report's tracks plot (drawn now)."""
        try:
            self.conn.send(("views", {n: _columns(d) for n, d in views.items()}))
        except OSError:                      # gone: render() will find out
            pass

    def render(self, record, *, fit, world, px_residuals=None):
        """report.html's text drawn in the process; None if the process is gone.

        ``px_residuals``: the views' residuals in pixels
        (:func:`vidtrack.report.trajectory.pixel_residuals`), for their table and plot."""
        from vidtrack.report.run_page import fit_curves

        try:
            # the curves, not the fit, and columns, not frames: the process loads neither
            # the fitting code nor pandas
            self.conn.send(("page", record, fit_curves(world, fit), _columns(world),
                            px_residuals))
            return self._result("drawing the report")
        except (WorkerGone, OSError):
            return None

    def stop(self):
        """End the process (at once if it is still working) and wait for it (killed if it
        has not ended 5 s after SIGTERM)."""
        if self.proc.is_alive():
            self.proc.terminate()
            self.proc.join(_STOP_WAIT_S)
            if self.proc.is_alive():
                self.proc.kill()
        self.proc.join()
        self.conn.close()


class ViewThread:
    """View ``name`` tracked in a thread, cancelled at its next frame by :meth:`stop`."""

    def __init__(self, scene, folder, name, settings, *, quiet=True):
        import threading

        self.name = name
        self.cancel = threading.Event()
        self.out = {}
        self.thread = threading.Thread(target=self._run, name=f"track-{name}",
                                       args=(scene, folder, name, settings, quiet))
        self.thread.start()

    def _run(self, scene, folder, name, settings, quiet):
        from vidtrack.track.tracker import Cancelled

        try:
            self.out["ok"] = track_view(scene, folder, name, settings, quiet=quiet,
                                        cancel=self.cancel)
        except Cancelled:
            pass
        except BaseException as exc:           # re-raised in the calling thread
            self.out["error"] = exc

    def track(self):
        """The view's Track (its error raised here)."""
        self.thread.join()
        if "error" in self.out:
            raise self.out["error"]
        return self.out["ok"]

    def stop(self):
        self.cancel.set()
        self.thread.join()
