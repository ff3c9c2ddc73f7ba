"""A run's first ``scene.toml``, written from the footage found in its folder (``vidtrack init``).

:func:`write_scene_template` looks in a run folder for footage (video files, image
folders, Phantom .cine), decides which is the ``front`` and which the ``top`` view (by
name, or as the caller says), opens each with :func:`vidtrack.footage.open_source` to
record what the file itself states (frame count, image size, the container's rate), and
writes a commented ``scene.toml`` in which every value only the user knows is marked
``TODO(user)``. The marked lines hold values the loader refuses (``fps = 0``,
``axes = ["?", "?"]``, ``origin_px = ["?", "?"]``, no scale), so the file does not load,
and ``vidtrack fit`` does not run, until they are filled in::

    runs/07/scene.toml: views.front.fps must be > 0, got 0

>>> t = write_scene_template("runs/07")                       # doctest: +SKIP
>>> t.path, t.views["front"].frames, t.views["front"].fps_container   # doctest: +SKIP
(PosixPath('runs/07/scene.toml'), 372, 30.0)

The file is written whole or not at all, and never over an existing ``scene.toml`` but
one that :func:`plan_scene_text` wrote (``vidtrack design``: a planned run's factors and no
views yet), whose ``[run]`` and ``[factors]`` the template keeps; nothing else in the
folder is written or changed.
"""

import json
import re
from dataclasses import dataclass, field
from pathlib import Path

from vidtrack._atomic import atomic_path
from vidtrack.errors import SceneError
from vidtrack.scene.folders import PLAN_MARK   # a planned run's first line (vidtrack design)

__all__ = ["write_scene_template", "find_footage", "SceneTemplate", "FootageFacts",
           "VIDEO_SUFFIXES", "TODO", "plan_scene_text", "PLAN_MARK"]

#: Files taken for videos when a run folder is searched (any other file is not footage).
VIDEO_SUFFIXES = (".avi", ".mp4", ".m4v", ".mov", ".mkv", ".wmv", ".mpg", ".mpeg", ".webm",
                  ".mxf", ".flv", ".mj2")
#: The mark on every line the user must still fill in.
TODO = "TODO(user)"
_VIEWS = ("front", "top")
# folders of a run that are never footage: the outputs, and the replicate throws
_NOT_FOOTAGE = ("vidtrack", "throws")
# "front" anywhere in a name; "top" not preceded by a letter (not "laptop", "stop")
_NAME_PATTERNS = {"front": re.compile(r"front", re.I), "top": re.compile(r"(?<![a-z])top", re.I)}


@dataclass(frozen=True)
class FootageFacts:
    """What one view's footage states about itself.

    Attributes
    ----------
    view : str
        ``"front"`` or ``"top"``.
    path : pathlib.Path
        The file or folder opened.
    source_text : str
        How ``scene.toml`` names it (relative to the run folder, or to each throw folder
        of a run with ``throws/``; absolute when outside).
    kind : str
        ``"video"``, ``"image folder"`` or ``"cine"``.
    frames : int
        Frames in the file.
    width_px, height_px : int
        Image size.
    bit_depth : int
    fps_container : float or None
        The rate the container states (a video's frame rate, a .cine's setup
        FrameRate; None for an image folder). For an exported high-speed video this is
        usually the PLAYBACK rate, not the capture rate.
    fps_time_stamps : float or None
        A .cine's rate from its per-image time stamps, when it has them.
    notes : tuple of str
        What the reader noticed while opening.
    """

    view: str
    path: Path
    source_text: str
    kind: str
    frames: int
    width_px: int
    height_px: int
    bit_depth: int
    fps_container: float | None = None
    fps_time_stamps: float | None = None
    notes: tuple = ()

    def to_dict(self):
        return {"view": self.view, "path": str(self.path), "source": self.source_text,
                "kind": self.kind, "frames": self.frames, "width_px": self.width_px,
                "height_px": self.height_px, "bit_depth": self.bit_depth,
                "fps_container": self.fps_container, "fps_time_stamps": self.fps_time_stamps,
                "notes": list(self.notes)}


@dataclass(frozen=True)
class SceneTemplate:
    """What :func:`write_scene_template` wrote.

    Attributes
    ----------
    path : pathlib.Path
        The ``scene.toml`` written.
    views : dict of str to FootageFacts
        The views, ``front`` before ``top``.
    todo : tuple of str
        The keys the user must still fill in (``views.front.fps``, ...).
    unused : tuple of pathlib.Path
        Footage found in the folder but given to no view.
    text : str
        The file's content.
    """

    path: Path
    views: dict
    todo: tuple
    unused: tuple = ()
    text: str = field(default="", repr=False)

    def to_dict(self):
        return {"path": str(self.path), "views": {v: f.to_dict() for v, f in self.views.items()},
                "todo": list(self.todo), "unused": [str(p) for p in self.unused]}


# -- finding the footage ---------------------------------------------------------------

def _is_image_folder(path):
    from vidtrack.footage import IMAGE_SUFFIXES

    try:
        return any(p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES for p in path.iterdir())
    except OSError:
        return False


def find_footage(folder):
    """Footage in ``folder`` (not in its sub-folders' sub-folders), in name order.

    Video files (:data:`VIDEO_SUFFIXES`), Phantom ``.cine`` files, and sub-folders that
    hold image files; hidden entries, the ``vidtrack/`` outputs and ``throws/`` are
    skipped.

    Returns
    -------
    list of pathlib.Path
    """
    found = []
    for p in sorted(Path(folder).iterdir(), key=lambda p: p.name.lower()):
        if p.name.startswith(".") or p.name in _NOT_FOOTAGE:
            continue
        if p.is_file() and p.suffix.lower() in VIDEO_SUFFIXES + (".cine",):
            found.append(p)
        elif p.is_dir() and _is_image_folder(p):
            found.append(p)
    return found


def _views_named(path):
    """The views whose name ``path``'s name contains (without its suffix)."""
    name = path.stem if path.is_file() else path.name
    return [v for v in _VIEWS if _NAME_PATTERNS[v].search(name)]


def _names(paths):
    return ", ".join(p.name for p in paths)


def _assign(run_dir, found, given):
    """{view: path} from the footage ``found`` and the views the user ``given``, and the
    footage left over.

    A view not given is the one footage whose name says it. Without any view given,
    footage left over while a view is still missing is refused (which view it is cannot
    be told); with a view given, it is left over (the user said what the views are).
    """
    views = dict(given)
    free = [p for p in found if not any(_same(p, g) for g in given.values())]
    flags = f"vidtrack init {run_dir} --front FILE --top FILE (or only one of them)"
    for view in _VIEWS:
        if view in views:
            continue
        named = [p for p in free if _views_named(p) == [view]]
        if len(named) > 1:
            each = "both" if len(named) == 2 else "all"
            raise SceneError(f"{run_dir}: {_names(named)} {each} look like the {view} view; "
                             f"say which with: vidtrack init {run_dir} --{view} FILE")
        if named:
            views[view] = named[0]
            free.remove(named[0])
    if free and len(views) < len(_VIEWS) and not given:
        # footage left that no name places: guessing a view would give a wrong world frame
        raise SceneError(f"{run_dir}: cannot tell which view {_names(free)} "
                         f"{'is' if len(free) == 1 else 'are'} (the name does not say \"front\" "
                         f"or \"top\"); say it with: {flags}")
    if not views:
        raise SceneError(f"{run_dir}: no footage found (video files "
                         f"{' '.join(VIDEO_SUFFIXES[:5])} ..., image folders, Phantom .cine); "
                         f"name it with: {flags}")
    return {v: views[v] for v in _VIEWS if v in views}, tuple(free)


def _same(a, b):
    try:
        return a.resolve() == b.resolve()
    except OSError:
        return False


def _resolve_given(base, text, view):
    """A ``--front``/``--top`` FILE: as given (from the working folder), else in ``base``."""
    p = Path(text)
    for candidate in ([p] if p.is_absolute() else [p, base / p]):
        if candidate.exists():
            return candidate
    where = "" if p.is_absolute() else f" (looked in the working folder and in {base})"
    raise SceneError(f"--{view} {text}: no such file or folder{where}")


def _source_text(path, base, throws):
    """How scene.toml names ``path``: relative to ``base`` (the run or the first throw)."""
    full, base_full = path.resolve(), base.resolve()
    if full.is_relative_to(base_full):
        return full.relative_to(base_full).as_posix()
    if throws:
        raise SceneError(f"{path}: not in {base}; a run with throws/ names each view's "
                         "footage inside every throw folder (throws/01/front.avi, "
                         "throws/02/front.avi, ...), so give a file of the first throw")
    return full.as_posix()


# -- what the footage says about itself ------------------------------------------------

def _facts(view, path, source_text):
    from vidtrack.footage import open_source

    with open_source(path) as src:
        rows, cols = (int(n) for n in src.shape[:2])
        container = src.fps_container
        stamps = None
        if getattr(src, "time_stamps_used", False):
            stamps = getattr(src, "fps_time_stamps", None)
        return FootageFacts(
            view=view, path=Path(path), source_text=source_text, kind=str(src.kind),
            frames=int(len(src)), width_px=cols, height_px=rows,
            bit_depth=int(src.bit_depth),
            fps_container=None if container is None else float(container),
            fps_time_stamps=None if stamps is None else float(stamps),
            notes=tuple(str(n) for n in src.notes))


# -- the template ----------------------------------------------------------------------

def _toml_string(text):
    # a TOML basic string: JSON's escapes (\" \\ \n \uXXXX ...) are TOML's too
    return json.dumps(str(text), ensure_ascii=False)


def _rate(value):
    return f"{value:g}"


def _comment_block(lines, width=88):
    """Comment lines, wrapped at ``width`` characters."""
    import textwrap

    out = []
    for line in lines:
        out += textwrap.wrap(line, width=width - 2, break_on_hyphens=False,
                             break_long_words=False) or [""]
    return [f"# {t}".rstrip() for t in out]


def _view_facts_comment(f):
    what = {"video": "a video", "image folder": "an image folder", "cine": "a Phantom .cine"}
    lines = [f"{f.source_text}: {what.get(f.kind, f.kind)}, {f.frames} frames of "
             f"{f.width_px} x {f.height_px} px (width x height), {f.bit_depth}-bit."]
    if f.kind == "cine":
        rate = (f"Its header gives {_rate(f.fps_container)} fps (setup FrameRate)"
                if f.fps_container else "Its header gives no frame rate")
        if f.fps_time_stamps:
            rate += (f" and per-image time stamps at {_rate(f.fps_time_stamps)} fps, which "
                     "time the frames (fps is checked against them)")
        lines.append(rate + ". A .cine states the rate it was captured at: check it "
                     "against the camera's setting and write it as fps.")
    elif f.fps_container:
        lines.append(f"Its container says {_rate(f.fps_container)} fps. That is usually the "
                     "PLAYBACK rate of an exported high-speed video, not the CAPTURE rate: "
                     "fps below must be the capture rate (the camera's setting, e.g. 1200), "
                     "or every time, speed and k comes out wrong.")
    else:
        lines.append("It states no frame rate" + (" (image files have none)"
                                                 if f.kind == "image folder" else "")
                     + ": fps below must be the CAPTURE rate (the camera's setting).")
    lines += [f"Noted when opening it: {n}" for n in f.notes]
    return _comment_block(lines)


_COL = 30        # where a value's trailing comment starts


def _line(code, comment):
    return f"{code:<{_COL - 1}} # {comment}" if len(code) < _COL - 1 else f"{code}  # {comment}"


def _view_table(f, throws):
    v = f.view
    if v == "front":
        axes_help = ("each one of +x -x +y -y; the front view sees X and Y, e.g. "
                     '["+x", "-y"]: right in the image is +X, down is -Y')
    else:
        axes_help = ("each one of +x -x +z -z; the top view sees X and Z, e.g. "
                     '["+x", "+z"]: right in the image is +X, down is +Z')
    blank = '["?", "?"]'
    out = [f"[views.{v}]", f"source = {_toml_string(f.source_text)}"]
    if throws:
        out += _comment_block([f"(named so in every throw folder: throws/{throws[0].name}/"
                               f"{f.source_text}, throws/.../{f.source_text})"])
    out += _view_facts_comment(f)
    out += [
        _line("fps = 0", f"{TODO}: the CAPTURE rate in frames/s, e.g. 1200"),
        *_comment_block([f"The world axes along increasing image column, then row: {axes_help}."]),
        _line(f"axes = {blank}", TODO),
        *_comment_block(["The pixel [column, row] of the world origin O (the centre of the "
                         "blade shaft) in the raw image."]),
        _line(f"origin_px = {blank}", TODO),
        f"# The scale, {TODO}: give ONE of these three (uncomment it and fill it in): a ruler",
        "# seen in the view, length_m metres between its two ends' pixels [column, row];",
        "# metres per pixel measured otherwise; or a calibration file with a [scale] table.",
        f"# ruler = {{ length_m = 0, from_px = {blank}, to_px = {blank} }}",
        "# m_per_px = 0",
        '# calibration = "cal/front.toml"' if v == "front" else
        '# calibration = "cal/top.toml"',
        "# (Pixels of the raw image: read them off a frame exported by",
        f"# `vidtrack frames {f.source_text} OUT --range 0:1`.)",
        "# Optional:",
        _line(f"# frames = [0, {f.frames}]", "the frames to use, [first, end) (default: all)"),
        _line("# camera_distance_m = 2.0", "camera's distance (m) to the plane "
              f"{'Z' if v == 'front' else 'Y'} = 0: corrects perspective"),
        _line('# sync_frame = "auto"', "the frame at which t = 0, the release (default: "
              "found)"),
    ]
    return out


#: The commented [physics], [straw] and [machine] tables of every template.
_STRAW_AND_MACHINE = (
    _line("[physics]", "the defaults:"),
    "# gravity_m_s2 = 9.80665",
    "# air_density_kg_m3 = 1.205",
    "",
    _line("[straw]", "the drag parameter Cp in s/m (1/Cp: the terminal speed)."),
    _line("", "vidtrack fit needs it (except with --model free), and k3"),
    _line("", "and k4 are only as right as Cp. Give it directly:"),
    "# cp_s_per_m = 0.115",
    _line("", "or the straw's data, Cp = sqrt(C a_s rho / (2 m g)):"),
    "# mass_kg = 0.080",
    _line("# area_m2 = 0.0172", "the average characteristic area a_s"),
    "# drag_coefficient = 1.0",
    "",
    "[machine]",
    _line("# speed_kmh = 7.2", "the machine's travel speed v1 (the cameras ride on it);"),
    _line("", "default: factors.speed_kmh, else 0 (standing still)"),
)


def _toml_value(value):
    """A factor's value as TOML: a whole number without a decimal point, a string quoted."""
    if isinstance(value, str):
        return _toml_string(value)
    if float(value).is_integer() and abs(value) < 2 ** 53:
        return str(int(value))
    return repr(float(value))


def _run_and_factors(run_dir, plan):
    """The [run] and [factors] tables: commented examples, or a plan's real values."""
    run_name = (plan or {}).get("run", {}).get("name")
    lines = ["[run]"]
    if run_name is not None:
        lines.append(_line(f"name = {_toml_string(run_name)}", "its name in tables and reports"))
    else:
        lines.append(_line(f"# name = {_toml_string(Path(run_dir).resolve().name)}",
                           "its name in tables and reports; default: the folder's"))
    lines.append("")
    factors = (plan or {}).get("factors")
    if factors:
        lines += [_line("[factors]", "this run's setting of the experiment's factors"),
                  _line("", "(natural units), from `vidtrack design`")]
        lines += [f"{name} = {_toml_value(v)}" for name, v in factors.items()]
    else:
        lines += [
            _line("[factors]", "the experiment's factors (free names, natural units),"),
            _line("", "copied to fit.json and the experiment's tables, e.g.:"),
            "# n_rpm = 550",
            "# blade_angle_deg = 0",
            _line("# speed_kmh = 7.2", "also the default of [machine] speed_kmh"),
        ]
    return lines + [""]


def _template_text(run_dir, views, throws, *, plan=None):
    first = (f"throws/{throws[0].name}/" if throws else "")
    lines = [
        "# vidtrack scene, schema 1 (docs/scene.md lists every key).",
        f"# Written by `vidtrack init` from the footage found in {first or 'this folder'}"
        + (", and [run] and [factors] from `vidtrack design`." if plan else "."),
        f"# Fill in every line marked {TODO}: vidtrack refuses this file (and `vidtrack fit`",
        "# does not run) until they hold real values.",
        "schema = 1",
        "",
        *_run_and_factors(run_dir, plan),
        *_STRAW_AND_MACHINE,
    ]
    for f in views.values():
        lines += [""] + _view_table(f, throws)
    return _joined(lines)


def _joined(lines):
    return "\n".join(line.rstrip() if line.strip() else "" for line in lines) + "\n"


def plan_scene_text(factors, *, folder, run_name=None, about=()):
    """The scene.toml of a planned run: its factor settings, no views yet.

    Parameters
    ----------
    factors : dict of str to float
        The run's setting in natural units, by factor name (``{"n_rpm": 450, ...}``).
    folder : str or os.PathLike, keyword-only
        The run folder (its name is the run's default name).
    run_name : str, optional
        ``[run] name`` (default: none written, so the folder's name).
    about : sequence of str, keyword-only
        Comment lines on the run (its place in the design).

    Returns
    -------
    str
        The text. It has no ``[views]``, so vidtrack refuses it (``views is required``)
        until the run is filmed and ``vidtrack init RUN`` has added the views from the
        footage found in the folder (keeping ``[run]`` and ``[factors]``).
    """
    plan = {"factors": dict(factors)}
    if run_name is not None:
        plan["run"] = {"name": run_name}
    lines = [
        PLAN_MARK,
        *_comment_block([*about, "Written by `vidtrack design` (docs/scene.md lists every "
                         "key). Film the run into this folder, then run `vidtrack init` "
                         "on it: it adds the views from the footage found here and keeps "
                         "[run] and [factors]."]),
        "schema = 1",
        "",
        *_run_and_factors(folder, plan),
        *_STRAW_AND_MACHINE,
    ]
    return _joined(lines)


def _plan_of(target):
    """The [run] and [factors] of a scene.toml `vidtrack design` wrote, else None."""
    import tomllib

    try:
        text = target.read_text(encoding="utf-8")
        data = tomllib.loads(text)
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    if not text.startswith(PLAN_MARK) or "views" in data:
        return None
    return {k: data[k] for k in ("run", "factors") if isinstance(data.get(k), dict)}


def write_scene_template(run_dir, *, front=None, top=None):
    """Write ``run_dir/scene.toml``: a commented template from the footage found there.

    Parameters
    ----------
    run_dir : str or os.PathLike
        The run folder (must exist). With a ``throws/`` folder the footage is looked for
        in its first throw, and named as every throw names it.
    front, top : str or os.PathLike, keyword-only
        A view's footage (a video file, image folder or .cine), as a path from the
        working folder or inside the run folder. A view not given is found by name:
        footage whose name contains "front" or "top".

    Returns
    -------
    SceneTemplate

    Raises
    ------
    SceneError
        ``run_dir`` missing or not a folder; a ``scene.toml`` already there (never
        overwritten, except one that ``vidtrack design`` wrote, which has no views yet:
        its ``[run]`` and ``[factors]`` are kept in the file written); no footage;
        footage whose view cannot be told from its name (the message shows the flags to
        give); a given FILE that does not exist.
    SourceError
        Footage that cannot be opened.
    """
    run_dir = Path(run_dir)
    if not run_dir.exists():
        raise SceneError(f"{run_dir}: no such folder (expected the run folder that holds "
                         "the footage)")
    if not run_dir.is_dir():
        raise SceneError(f"{run_dir}: not a folder (expected the run folder that holds the "
                         "footage)")
    target = run_dir / "scene.toml"
    plan = _plan_of(target) if target.is_file() else None
    if target.exists() and plan is None:
        raise SceneError(f"{target} already exists; vidtrack init never overwrites it (edit "
                         "it, or move it away to start again)")
    planned = target.read_bytes() if plan is not None else None
    from vidtrack.scene import find_throw_dirs

    throws = find_throw_dirs(run_dir)
    base = throws[0] if throws else run_dir
    given = {}
    for view, text in (("front", front), ("top", top)):
        if text is not None:
            given[view] = _resolve_given(base, text, view)
    if "front" in given and "top" in given and _same(given["front"], given["top"]):
        raise SceneError(f"--front and --top name the same footage ({given['front']}); "
                         "each view has its own")
    found = find_footage(base)
    paths, unused = _assign(run_dir, found, given)
    views = {}
    for view, path in paths.items():
        views[view] = _facts(view, path, _source_text(path, base, throws))
    text = _template_text(run_dir, views, throws, plan=plan)
    if throws:
        missing = [f"{d.name}/{f.source_text}" for d in throws[1:] for f in views.values()
                   if not (d / f.source_text).exists()]
        if missing:
            text += "\n" + "\n".join(_comment_block(
                [f"Not found in the other throws (vidtrack fit will refuse them): "
                 f"{', '.join(missing)}."])) + "\n"
    todo = tuple(f"views.{v}.{k}" for v in views for k in ("fps", "axes", "origin_px", "scale"))
    with atomic_path(target) as tmp:
        tmp.write_text(text, encoding="utf-8")
        # appeared or changed meanwhile: still never overwritten (a plan of `vidtrack
        # design` is completed only as it was read)
        if (target.read_bytes() if target.is_file() else None) != planned \
                or (planned is None and target.exists()):
            raise SceneError(f"{target} already exists; vidtrack init never overwrites it")
    return SceneTemplate(path=target, views=views, todo=todo, unused=unused, text=text)
