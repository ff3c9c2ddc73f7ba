"""Everything about a run that can be checked before its footage is tracked.

:func:`prepare_run` loads the scene and checks, in this order, with nothing written
until the sources pass and nothing tracked until everything passes:

1. every view's source is a regular file or a folder (a FIFO, a device or a socket is
   refused before anything opens it: reading one blocks or never ends);
2. no two views read the same footage (a cross-check: ``accept_disagreement`` lets it
   through as a warning);
3. every source opens (a colour ``channel`` of grey footage is refused), its frame
   range is noted when clipped at the end, a ``sync_frame`` lies among the frames
   used, and so do the frames of a view's corrections (an ``exclude_frames`` range
   holds some of them, every manual point's frame is one of them; the manual points
   file is read and checked for each run or throw folder before any source is
   opened);
4. the outputs can be written: ``<run>/vidtrack/`` (and each throw's folder in it) is a
   folder or can be made one, a probe file can be created and removed there (a folder
   made for the probe is removed again), and no output name (fit.json, tracks.h5, ...)
   is taken by a folder or another non-file.

Nothing is left in the run folder by a run refused here.

Errors raised while a run is worked on name the run, the throw and the view they are
about, once (:func:`about`).
"""

import contextlib
import logging
import os
import stat
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from vidtrack.errors import INPUT_ERRORS, SceneError, VidtrackError

log = logging.getLogger(__name__)

__all__ = ["OUT_DIR", "RUN_OUTPUTS", "RunPlan", "prepare_run", "about", "where",
           "check_output_folder"]

OUT_DIR = "vidtrack"
#: The files a run (or a throw) writes into its output folder.
RUN_OUTPUTS = ("views.h5", "tracks.h5", "tracks.csv", "world.csv", "fit.json", "report.md",
               "report.html", "stages.json")


# ------------------------------------------------------------------ context

def where(run, throw=None, view=None, *, folder=None):
    """The label that says what an error is about: ``run 'run42', throw 02, view top``
    (``run 'run42' (runs/07)`` with the run's ``folder``)."""
    parts = [f"run {run!r}" + (f" ({folder})" if folder else "")]
    if throw:
        parts.append(f"throw {throw}")
    if view:
        parts.append(f"view {view}")
    return ", ".join(parts)


def add_context(exc, label, view=None):
    """Prefix ``exc``'s message with ``label`` (once: an exception that already has its
    context is left alone), dropping a leading ``view NAME: `` that the label repeats."""
    if getattr(exc, "_vidtrack_where", False) or not label:
        return exc
    msg = str(exc)
    if view:
        for lead in (f"view {view}: ", f"{view}: "):
            if msg.startswith(lead):
                msg = msg[len(lead):]
                break
    exc.args = (f"{label}: {msg}",)
    exc._vidtrack_where = True
    return exc


@contextlib.contextmanager
def about(label, view=None):
    """Bad-input errors raised inside get ``label`` (:func:`add_context`)."""
    try:
        yield
    except INPUT_ERRORS as exc:
        add_context(exc, label, view)
        raise


# ------------------------------------------------------------------ outputs

def _mode(path):
    try:
        return os.stat(path).st_mode
    except FileNotFoundError:
        return None
    except OSError:
        return 0


def check_output_folder(folder, names, label):
    """``folder`` is (or can be made) a folder vidtrack can write into, and none of
    ``names`` in it is anything but a regular file.

    A probe file is created in the folder and removed; a folder that does not exist yet
    is created for the probe (with its missing parents) and removed again, so that a
    run refused later leaves nothing behind.

    Raises
    ------
    VidtrackError
        One line: the path, what is wrong, what was expected.
    """
    folder = Path(folder)
    if folder.is_symlink() and not folder.exists():
        raise VidtrackError(f"{label}: {folder} is a broken link; expected a folder for "
                            "vidtrack's outputs (remove the link)")
    if folder.exists() and not folder.is_dir():
        raise VidtrackError(f"{label}: {folder} is a file; expected a folder for "
                            "vidtrack's outputs (move the file away)")
    made = []
    try:
        for d in reversed([folder, *folder.parents]):
            if not d.exists():
                if d.is_symlink() or (d.parent.exists() and not d.parent.is_dir()):
                    raise VidtrackError(f"{label}: {d.parent} is not a folder; expected a "
                                        "folder for vidtrack's outputs")
                try:
                    d.mkdir()
                except OSError as exc:
                    raise VidtrackError(f"{label}: cannot create {d} ({exc.strerror or exc}); "
                                        "expected a run folder you can write to") from None
                made.append(d)
        try:
            fd, probe = tempfile.mkstemp(prefix=".vidtrack-probe-", dir=folder)
        except OSError as exc:
            raise VidtrackError(f"{label}: cannot write in {folder} ({exc.strerror or exc}); "
                                "expected a folder you can write to") from None
        os.close(fd)
        with contextlib.suppress(OSError):
            os.unlink(probe)
    finally:
        for d in reversed(made):            # made for the probe only: not left behind
            with contextlib.suppress(OSError):
                d.rmdir()
    for name in names:
        mode = _mode(folder / name)
        if mode is None or stat.S_ISREG(mode):
            continue
        what = "a folder" if stat.S_ISDIR(mode) else "not a regular file"
        raise VidtrackError(f"{label}: {folder / name} is {what}; expected a file vidtrack "
                            "can replace (move it away)")


# ------------------------------------------------------------------ sources

@dataclass
class RunPlan:
    """A run checked and ready: its scene, the folders to fit and what was found.

    Attributes
    ----------
    scene : vidtrack.scene.Scene
    out : pathlib.Path
        ``<run>/vidtrack``.
    throws : list of pathlib.Path
        The throw folders (empty: the run folder is the one throw).
    findings : dict
        Throw folder -> list of :class:`vidtrack.run.checks.Finding` found before
        tracking (the same footage for two views).
    notes : dict
        Throw folder -> notes for fit.json (a frame range clipped at the end).
    scenes : dict
        Throw folder -> the throw's scene (:meth:`scene_of`).
    corrections : dict
        Throw folder -> {view: (exclude_frames, ManualPoints or None)}: each view's
        corrections as read once for the run
        (:func:`vidtrack.run.corrections.read_corrections`).
    """

    scene: object
    out: Path
    throws: list
    findings: dict = field(default_factory=dict)
    notes: dict = field(default_factory=dict)
    scenes: dict = field(default_factory=dict)
    corrections: dict = field(default_factory=dict)

    def scene_of(self, folder):
        """The scene of the throw in ``folder``: the run's with the throw's own
        corrections (``throw.toml``) applied; the run's own for the run folder."""
        if Path(folder) == self.scene.folder:
            return self.scene
        if folder not in self.scenes:
            from vidtrack.scene.throw_file import throw_scene

            self.scenes[folder] = throw_scene(self.scene, folder)
        return self.scenes[folder]

    def label(self, folder=None, view=None):
        throw = (Path(folder).name if folder is not None and Path(folder) != self.scene.folder
                 else None)
        # a run with a name of its own: where it is, too
        folder = self.scene.folder if self.scene.folder.name != self.scene.run_name else None
        return where(self.scene.run_name, throw, view, folder=folder)

    def folders(self):
        """(throw folder, its output folder) pairs, in order."""
        if not self.throws:
            return [(self.scene.folder, self.out)]
        return [(d, self.out / d.name) for d in self.throws]


def _source_of(view, scene, folder):
    return view.source if Path(folder) == scene.folder else view.source_in(folder)


def _open_and_check(view, path, label, manual):
    """Open a view's footage: its frame count, a clipped range, the sync frame, the
    frames of its corrections (excluded ranges, ``manual`` points), and that a colour
    ``channel`` has colour to take (``"auto"`` refuses nothing: it chooses when the
    footage is tracked, so it is not made to choose here too)."""
    from vidtrack.footage import open_source

    notes = []
    channel = getattr(view, "channel", "luma")
    with open_source(path, fps=view.fps, frames=getattr(view, "frames", None),
                     channel="luma" if channel == "auto" else channel) as src:
        numbers = src.frame_numbers
        first, last = int(numbers[0]), int(numbers[-1])
        for note in src.notes:
            if "past the last frame" in note:
                log.warning("%s: %s", label, note)
                notes.append(note)
        sync = getattr(view, "sync_frame", "auto")
        if not isinstance(sync, str) and sync is not None:
            if not first <= int(sync) <= last:
                rng = getattr(view, "frames", None)
                used = (f"the frames used, {first}..{last} (views.{view.name}.frames = "
                        f"[{rng[0]}, {rng[1]}])" if rng else
                        f"its {len(src)} frames, 0..{last}")
                raise SceneError(f"views.{view.name}.sync_frame = {int(sync)} is not among "
                                 f"{used} in {path}; expected a frame of the footage")
        from vidtrack.run.corrections import check_in_footage

        check_in_footage(view, manual, first, last, path)
    return notes


def _check_folder_sources(scene, folder, label_of, *, open_sources=True):
    """Steps 1-3 for one run or throw folder; returns (findings, notes, corrections):
    the corrections as :attr:`RunPlan.corrections` holds them."""
    from vidtrack.run.checks import check_source_path, same_footage
    from vidtrack.run.corrections import read_corrections

    paths, corrections = {}, {}
    for name in scene.view_names:
        view = scene.views[name]
        path = _source_of(view, scene, folder)
        key = "points" if view.points is not None else "source"
        with about(label_of(name), view=name):
            check_source_path(path, f"views.{name}.{key}")
            # read and checked per folder: a throw has a file of its own
            corrections[name] = read_corrections(scene, folder, name)
        paths[name] = path
    findings = []
    same = same_footage({n: p for n, p in paths.items()
                         if scene.views[n].points is None})
    if same is not None:
        findings.append(same)
    notes = []
    if open_sources:
        for name in scene.view_names:
            view = scene.views[name]
            if view.points is not None:
                continue                       # points digitized elsewhere, not footage
            with about(label_of(name), view=name):
                notes += [f"{name}: {n}" for n in
                          _open_and_check(view, paths[name], label_of(name),
                                          corrections[name][1])]
    return findings, notes, corrections


def prepare_run(run_dir, *, open_sources=True, check_outputs=True):
    """Load a run's scene and check everything that can be checked before tracking.

    Parameters
    ----------
    run_dir : str or pathlib.Path
    open_sources : bool
        Open each footage (frame counts, ranges, sync frames).
    check_outputs : bool
        Check the output folders (a probe file in each; nothing is left).

    Returns
    -------
    RunPlan

    Raises
    ------
    VidtrackError
        Bad scene, a source that is missing or not a file or folder, a source that does
        not open, a sync_frame outside the footage, an output that cannot be written.
        The message names the run, the throw and the view.
    """
    from vidtrack.scene import load_scene

    from vidtrack.run._workers import tracker_options

    scene = load_scene(run_dir)
    tracker_options(scene)          # the [track] table, checked before anything is tracked
    plan = RunPlan(scene=scene, out=scene.folder / OUT_DIR, throws=list(scene.throw_dirs()))
    for folder, _ in plan.folders():
        with about(plan.label(folder)):
            throw = plan.scene_of(folder)        # the throw's throw.toml, checked first
        findings, notes, corrections = _check_folder_sources(
            throw, folder, lambda v, f=folder: plan.label(f, v), open_sources=open_sources)
        plan.findings[folder] = findings
        plan.notes[folder] = notes
        plan.corrections[folder] = corrections
    if check_outputs:
        label = plan.label()
        check_output_folder(plan.out, RUN_OUTPUTS if not plan.throws else
                            ("fit.json", "report.md", "report.html", "stages.json"), label)
        for folder, out in plan.folders():
            if out != plan.out:
                check_output_folder(out, RUN_OUTPUTS, plan.label(folder))
    return plan
