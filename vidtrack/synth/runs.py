"""Synthetic runs with known truth: ``vidtrack synth``.

:func:`render_run` renders a run folder as docs/reference.md describes it (``scene.toml``, the
footage of a ``front`` and/or ``top`` view, or of the pinhole cameras of
:mod:`~vidtrack.synth._cameras`, optionally ``throws/01 ..``) and writes
``truth.json``: every parameter, and for every frame of every view the time, the world
position of the straw and the true pixel centroid of its silhouette, with flags. It
returns a :class:`SynthRun`, what was written.

The parts, each in its module of :mod:`vidtrack.synth`: the parameters
(:mod:`~vidtrack.synth.spec`), what moves where (:mod:`~vidtrack.synth.motion`), the
framing and static scene of each view (:mod:`~vidtrack.synth._views`), the frames
(:mod:`~vidtrack.synth._renderer`), the footage (:mod:`~vidtrack.synth._writers`) and
``truth.json`` (:mod:`~vidtrack.synth.truth`).

Everything is rendered and written frame by frame; memory does not grow with the
number of frames.
"""

import logging
import os
import re
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vidtrack.errors import DiskFullError
from vidtrack.scene.folders import is_planned_scene

from vidtrack.synth._renderer import _ViewRenderer, _ViewTrack
from vidtrack.synth._views import _frame_times, _frame_view, _static_image
from vidtrack.synth._writers import _source_name, _write_avi, _write_cine, _write_png
from vidtrack.synth.motion import _make_throws, second_straw_state
from vidtrack.synth.spec import CAMERA_VIEW_NAMES, VIEW_NAMES, SynthSpec, _fail
from vidtrack.synth.truth import (_CONVENTIONS, TRUTH_FILE, TRUTH_SCHEMA, _release_frame_of,
                                  _throw_truth, _truth_text, _view_truth)

__all__ = ["SynthRun", "render_run", "check_out_dir"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SynthRun:
    """What :func:`render_run` wrote.

    Attributes
    ----------
    out_dir : pathlib.Path
    scene_path, truth_path : pathlib.Path
        ``scene.toml`` and the run's ``truth.json``.
    views : tuple of str
    throws : int
    frames : int
        Frames per view.
    size_px : dict
        View -> (width, height).
    m_per_px : dict
        View -> scale (pinhole cameras: at the scale plane of the square rig, at the
        flight's middle for cameras at an angle).
    release_frame : dict
        View -> index of the first frame with t >= 0.
    files : tuple of str
        Everything written, relative to ``out_dir``.
    bytes_written : int
    elapsed_s : float
    """

    out_dir: Path
    scene_path: Path
    truth_path: Path
    views: tuple
    throws: int
    frames: int
    size_px: dict
    m_per_px: dict
    release_frame: dict
    files: tuple
    bytes_written: int
    elapsed_s: float
    spec: SynthSpec = field(repr=False, default=None)

    def to_dict(self):
        return {"out_dir": str(self.out_dir), "scene": str(self.scene_path),
                "truth": str(self.truth_path), "views": list(self.views),
                "throws": self.throws, "frames": self.frames,
                "size_px": {k: list(v) for k, v in self.size_px.items()},
                "m_per_px": dict(self.m_per_px), "release_frame": dict(self.release_frame),
                "files": list(self.files), "bytes_written": self.bytes_written,
                "elapsed_s": self.elapsed_s}


def _scene_dict(spec, views, run_name, release, factors=None):
    if factors is None:
        factors = {"n_rpm": spec.n_rpm, "blade_angle_deg": spec.blade_angle_deg,
                   "speed_kmh": spec.speed_kmh}
    out = {"schema": 1, "run": {"name": run_name},
           "factors": {name: value if isinstance(value, str) else _plain_number(value)
                       for name, value in factors.items()},
           "physics": {"gravity_m_s2": spec.gravity_m_s2},
           "straw": {"cp_s_per_m": spec.cp_s_per_m},
           "machine": {"speed_kmh": spec.speed_kmh},
           "views": {}}
    if spec.cameras != "orthographic":
        from vidtrack.synth._cameras import camera_scene_views

        world, out["views"] = camera_scene_views(spec, views, _source_name, release,
                                                 _plain_number)
        if world is not None:
            out["world"] = world
        return out
    for view in views:
        m = view.mapping
        entry = {"source": _source_name(spec, view.name), "fps": _plain_number(spec.fps),
                 "axes": list(m.axes), "origin_px": list(m.origin_px)}
        if spec.scale_in_scene == "ruler":
            entry["ruler"] = {"length_m": view.ruler_length_m,
                              "from_px": list(view.ruler_from_px),
                              "to_px": list(view.ruler_to_px)}
        else:
            entry["m_per_px"] = m.m_per_px
        if spec.sync_in_scene and release[view.name] is not None:
            entry["sync_frame"] = release[view.name]
        out["views"][view.name] = entry
    return out


def _plain_number(value):
    """A whole number as an int (``550``, not ``550.0``), anything else as a float."""
    value = float(value)
    return int(value) if value.is_integer() and abs(value) < 2 ** 53 else value


#: The marker ``vidtrack synth`` writes into every run folder it renders: TOML with the
#: generator, the vidtrack version, the time and the top-level entries it wrote. Without
#: it synth never writes into a non-empty folder (``--force`` included); with it,
#: ``--force`` replaces only those entries (and ``vidtrack/``, results computed from them).
MARKER_FILE = "vidtrack-synth.toml"


def _known_names():
    """Top-level entries synth can write: the only ones a marker may hand over."""
    out = {"scene.toml", TRUTH_FILE, "throws", MARKER_FILE}
    for view in VIEW_NAMES + CAMERA_VIEW_NAMES:
        out |= {view, f"{view}.avi", f"{view}.cine"}
    return out


def _read_marker(out_dir):
    """The entries a previous render listed in ``out_dir``'s marker, or None (no marker).

    Only names synth can write count (a marker cannot hand over anything else).
    """
    import tomllib

    path = out_dir / MARKER_FILE
    if not path.is_file():
        return None
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        _fail(f"{path}: the marker of a synthetic run cannot be read ({exc}); expected "
              "the TOML file vidtrack synth writes")
    files = data.get("files")
    if data.get("generator") != "vidtrack synth" or not isinstance(files, list) \
            or not all(isinstance(f, str) for f in files):
        _fail(f"{path}: not a marker written by vidtrack synth (expected generator = "
              "\"vidtrack synth\" and a files list)")
    return set(files) & _known_names()


def _marker_text(names):
    from datetime import datetime, timezone

    from vidtrack import __version__

    when = datetime.now(timezone.utc).replace(microsecond=0).isoformat()
    listed = ", ".join(f'"{n}"' for n in sorted(set(names) | {MARKER_FILE}))
    return ("# Written by 'vidtrack synth': this folder is a synthetic run. 'vidtrack synth\n"
            "# --force' may replace the entries listed in files (and vidtrack/); delete\n"
            "# this file to keep synth from ever writing here again.\n"
            f'generator = "vidtrack synth"\nvidtrack_version = "{__version__}"\n'
            f'created = "{when}"\nfiles = [{listed}]\n')


#: Name of synth's staging folder in OUT: ``.synth-<pid>-<random>.part`` (the pid of the
#: process rendering into it). Older vidtracks wrote ``.synth-<random>.part``.
_STAGE_PREFIX, _STAGE_SUFFIX = ".synth-", ".part"
_STAGE_NAME = re.compile(r"\.synth-(?:(\d+)-)?[a-z0-9_]{8}\.part")


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def _leftovers(out_dir):
    """The staging folders in ``out_dir`` that an interrupted synth left behind.

    A staging folder is synth's own by its name (:data:`_STAGE_NAME`); one whose process
    is still running (the pid in its name) is another render's and is not a leftover.
    """
    out = []
    for p in out_dir.iterdir():
        m = _STAGE_NAME.fullmatch(p.name)
        if m and p.is_dir() and not p.is_symlink() and not (m.group(1) and
                                                            _alive(int(m.group(1)))):
            out.append(p)
    return out


def _check_out(out_dir, force):
    """Refuse an output folder synth must not write into; the entries it may replace.

    The staging folder of an interrupted render (killed, power cut) is not counted:
    it is removed before the new render starts (:func:`_leftovers`).

    Returns the set of top-level names a previous synthetic run left (from its marker),
    ``{"scene.toml"}`` for a run folder `vidtrack design` planned, empty for a new or
    empty folder.
    """
    from vidtrack._atomic import check_output

    check_output(out_dir, folder=True)
    if not out_dir.is_dir():
        return set()
    stale = {p.name for p in _leftovers(out_dir)}
    present = sorted(p.name for p in out_dir.iterdir() if p.name not in stale)
    if not present:
        return set()
    if present == ["scene.toml"] and is_planned_scene(out_dir / "scene.toml"):
        return {"scene.toml"}
    shown = ", ".join(present[:5]) + (", ..." if len(present) > 5 else "")
    previous = _read_marker(out_dir)
    if previous is None:
        _fail(f"{out_dir}: the folder is not empty (holds {shown}) and has no "
              f"{MARKER_FILE}, so vidtrack synth did not write it; synth writes only into "
              "a new or empty folder or over a synthetic run of its own (with --force), "
              "expected one of those")
    if not force:
        _fail(f"{out_dir}: the folder is not empty (holds {shown}); choose a new or "
              "empty folder, or pass --force to replace the synthetic run in it")
    return previous


def _plan_factors(path):
    """The ``[factors]`` of a planned run's scene.toml (empty when it has none)."""
    import tomllib

    try:
        factors = tomllib.loads(path.read_text(encoding="utf-8")).get("factors")
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        _fail(f"{path}: cannot be read ({exc}); expected the scene.toml vidtrack design wrote")
    return dict(factors) if isinstance(factors, dict) else {}


def _top_names(spec):
    """The top-level entries a render of ``spec`` writes (besides the marker)."""
    if spec.throws > 1:
        footage = {"throws"}
    else:
        footage = {_source_name(spec, view) for view in spec.view_names}
    return footage | {"scene.toml", TRUTH_FILE}


def _check_clash(out_dir, spec, previous):
    """Refuse to replace an entry of a synthetic run's folder its marker does not list."""
    for name in sorted(_top_names(spec) - set(previous)):
        path = out_dir / name
        if path.exists() or path.is_symlink():
            _fail(f"{path}: exists, and the marker {MARKER_FILE} does not list it, so "
                  "vidtrack synth did not write it; expected it moved away (or another "
                  "output folder)")


def check_out_dir(out_dir, spec, *, force=False):
    """Refuse, before anything is rendered, a folder :func:`render_run` would refuse.

    Raises
    ------
    VidtrackError
        As :func:`render_run` for its ``out_dir`` and ``force``.
    """
    out_dir = Path(out_dir)
    _check_clash(out_dir, spec, _check_out(out_dir, force))


def _replaceable(names, previous):
    """Top-level entries replaced: what the previous render listed in its marker, the
    new render's entries, and ``vidtrack/`` (results computed from the old footage)."""
    return (set(previous) | set(names) | {"vidtrack"}) - {MARKER_FILE}


def _remove(path):
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()


def render_run(out_dir, spec=None, *, force=False, quiet=True, factors=None):
    """Render a synthetic run folder with its ``truth.json``.

    Parameters
    ----------
    out_dir : str or pathlib.Path
        The run folder to write; created if missing. It must be empty unless
        ``force``, or hold only the ``scene.toml`` of a run ``vidtrack design``
        planned (no views yet), which the run's own replaces.
    spec : SynthSpec, optional
        All parameters (default ``SynthSpec()``).
    force : bool, keyword-only
        Write into a non-empty folder that holds a synthetic run written by this
        function (its marker ``vidtrack-synth.toml``): the entries its marker lists
        (``scene.toml``, ``truth.json``, ``front``/``top`` footage in any format,
        ``throws/``) and ``vidtrack/`` (results computed from the old footage) are
        replaced; other files are left alone. A non-empty folder without the marker is
        refused, with or without ``force``.
    quiet : bool, keyword-only
        No progress bar.
    factors : dict, optional, keyword-only
        ``[factors]`` of the scene.toml written, by name (numbers in natural units, or
        text); default those of the planned scene.toml ``out_dir`` holds, else the
        spec's ``n_rpm``, ``blade_angle_deg`` and ``speed_kmh``.

    Returns
    -------
    SynthRun

    Raises
    ------
    VidtrackError
        A non-empty ``out_dir`` without ``force``, a non-empty ``out_dir`` without the
        marker (not a synthetic run), an ``out_dir`` that is a file or cannot be
        written to, or impossible parameters (checked by :class:`SynthSpec`).

    Notes
    -----
    Everything is rendered into a hidden staging folder inside ``out_dir`` and moved
    into place at the end; on any error the staging folder is removed and nothing of
    the run appears. Each file is written through :mod:`vidtrack._atomic`.
    Layout: ``scene.toml``, ``truth.json`` and the footage (``front.avi`` or
    ``front/frame_000000.png ..`` or ``front.cine``; likewise ``top``) at the root; with
    ``throws > 1`` the footage and a ``truth.json`` per throw in ``throws/01 ..``, and
    the root ``truth.json`` summarises the throws. The marker ``vidtrack-synth.toml``
    (generator, version, time, the entries written) is written last.
    """
    from vidtrack._atomic import write_text
    from vidtrack._progress import progress
    from vidtrack.scene import write_scene

    spec = SynthSpec() if spec is None else spec
    if not isinstance(spec, SynthSpec):
        raise TypeError(f"spec must be a SynthSpec, got {type(spec).__name__}")
    started = time.perf_counter()
    out_dir = Path(out_dir)
    previous = _check_out(out_dir, force)
    _check_clash(out_dir, spec, previous)
    if factors is None and previous == {"scene.toml"} and is_planned_scene(
            out_dir / "scene.toml"):
        factors = _plan_factors(out_dir / "scene.toml") or None
    run_name = spec.run_name or out_dir.resolve().name

    throws = _make_throws(spec)
    seconds = [second_straw_state(spec, th) if spec.second_straw else None for th in throws]
    pinhole = spec.cameras != "orthographic"
    if pinhole:
        from vidtrack.synth import _cameras

        views = _cameras.camera_views(spec, throws)
        statics = {v.name: _cameras.camera_static(spec, v) for v in views}
        frame = (_cameras._calibration_frame(views) if spec.cameras == "perspective"
                 else None)
    else:
        views = [_frame_view(spec, name, throws) for name in VIEW_NAMES if name in spec.views]
        statics = {v.name: _static_image(spec, v) for v in views}
    n = spec.n_frames
    release = {v.name: _release_frame_of(_frame_times(spec, v.delay_s)) for v in views}

    created = not out_dir.exists()
    out_dir.mkdir(parents=True, exist_ok=True)
    for leftover in _leftovers(out_dir):
        log.info("%s: removing the staging folder of an interrupted render", leftover)
        shutil.rmtree(leftover, ignore_errors=True)
    stage = Path(tempfile.mkdtemp(prefix=f"{_STAGE_PREFIX}{os.getpid()}-",
                                  suffix=_STAGE_SUFFIX, dir=out_dir))
    bar = progress(total=n * len(views) * len(throws), desc="synth", quiet=quiet,
                   unit="frame")
    from vidtrack import __version__

    head = {"schema": TRUTH_SCHEMA, "generator": "vidtrack synth",
            "vidtrack_version": __version__, "run": run_name, "spec": spec.to_dict(),
            "conventions": _CONVENTIONS}
    if spec.distractors:
        from vidtrack.synth.truth import DISTRACTOR_CONVENTIONS

        head["conventions"] = {**_CONVENTIONS, **DISTRACTOR_CONVENTIONS}
    if pinhole:
        head["conventions"] = {**_CONVENTIONS, **_cameras.CONVENTIONS}
        if frame is not None:
            head["calibration_frame"] = _cameras.calibration_truth(views)
    try:
        summaries = []
        for ti, (throw, second) in enumerate(zip(throws, seconds)):
            folder = stage if spec.throws == 1 else stage / "throws" / f"{ti + 1:02d}"
            folder.mkdir(parents=True, exist_ok=True)
            view_truth = {}
            for view in views:
                if pinhole:
                    track = _cameras._CameraTrack(spec, view, throw, second)
                    renderer = _cameras._CameraRenderer(spec, view, track, ti,
                                                        statics[view.name])
                else:
                    track = _ViewTrack(spec, view, throw, second)
                    renderer = _ViewRenderer(spec, view, track, ti, statics[view.name])
                target = folder / _source_name(spec, view.name)
                if spec.output_format == "avi":
                    _write_avi(target, renderer, n, spec, bar.update)
                elif spec.output_format == "png":
                    _write_png(target, renderer, n, spec, bar.update)
                else:
                    _write_cine(target, renderer, n, spec, release[view.name], bar.update)
                if pinhole:
                    view_truth[view.name] = _cameras.camera_view_truth(
                        spec, view, track, renderer, _source_name(spec, view.name), frame)
                else:
                    view_truth[view.name] = _view_truth(spec, view, track, renderer,
                                                        _source_name(spec, view.name))
            truth = {**head, "throw": ti + 1, "truth": _throw_truth(spec, throw, second),
                     "views": view_truth}
            if spec.throws == 1:
                root_truth = truth
            else:
                write_text(folder / TRUTH_FILE, _truth_text(truth))
                summaries.append({"folder": f"throws/{ti + 1:02d}",
                                  "truth": f"throws/{ti + 1:02d}/{TRUTH_FILE}",
                                  **{key: truth["truth"][key] for key in ("k", "state")}})
        if spec.throws > 1:
            k_all = np.array([[s["k"][f"k{i}"] for i in range(1, 5)] for s in summaries])
            root_truth = {**head, "throws": summaries,
                          "k_mean": {f"k{i + 1}": float(v) for i, v in
                                     enumerate(k_all.mean(axis=0))}}
        write_text(stage / TRUTH_FILE, _truth_text(root_truth))
        write_scene(stage, _scene_dict(spec, views, run_name, release, factors))
        names = sorted(p.name for p in stage.iterdir())
        # the marker first, listing the old entries and the new: an interruption while
        # they are swapped leaves a folder that 'synth --force' may replace
        write_text(out_dir / MARKER_FILE, _marker_text(set(names) | set(previous)))
        for name in sorted(_replaceable(names, previous)):
            _remove(out_dir / name)
        for name in names:
            os.replace(stage / name, out_dir / name)
        write_text(out_dir / MARKER_FILE, _marker_text(names))
        names.append(MARKER_FILE)
        stage.rmdir()
    except BaseException as exc:
        shutil.rmtree(stage, ignore_errors=True)
        if created:
            shutil.rmtree(out_dir, ignore_errors=True)
        if isinstance(exc, DiskFullError):      # named as the file it would have been
            raise DiskFullError(str(exc).replace(str(stage), str(out_dir))) from exc
        raise
    finally:
        bar.close()
    files, total = [], 0
    for p in sorted(out_dir.rglob("*")):
        rel = p.relative_to(out_dir)
        if p.is_file() and rel.parts[0] in names:
            files.append(rel.as_posix())
            total += p.stat().st_size
    return SynthRun(out_dir=out_dir, scene_path=out_dir / "scene.toml",
                    truth_path=out_dir / TRUTH_FILE, views=tuple(v.name for v in views),
                    throws=spec.throws, frames=n,
                    size_px={v.name: (v.width, v.height) for v in views},
                    m_per_px={v.name: (v.m_per_px if pinhole else v.mapping.m_per_px)
                              for v in views},
                    release_frame=release, files=tuple(files), bytes_written=total,
                    elapsed_s=time.perf_counter() - started, spec=spec)
