"""Edits of a run's ``scene.toml`` (and its manual points file) asked for from the page.

Each edit sets one thing of one view from what the user clicked: the origin, the axes,
the ruler, the capture rate, the ``target``, a point placed by hand (``manual_points``)
or a frame excluded (``exclude_frames``). The file is edited in place with tomlkit, so
the user's comments, order and layout stay; only the keys edited change.

An edit is checked by the scene loader (:func:`vidtrack.scene.parse_scene`) before
anything is written: what it refuses is refused with its one-line message
(:class:`~vidtrack.errors.SceneError`) and nothing is written. A scene that does not
load yet (``vidtrack init`` writes one with values marked ``TODO(user)`` that the loader
refuses) can still be set up click by click: when the edited file does not load, a
``front``/``top`` view is checked alone, with stand-ins for the set-up values (fps,
origin, axes, scale) the edit did not give, and the edit is written if that passes; the
loader's message about what is still missing comes back with it
(:attr:`EditResult.scene_error`). An edit of a calibrated view is written only when the
file fails after it exactly as it failed before.

In a run with ``throws/`` the corrections (``target``, ``point``, ``exclude``) are the
throw's own: they go to the throw folder's ``throw.toml`` and manual points file
(:mod:`vidtrack.scene.throw_file`), checked as ``vidtrack fit`` checks them; the set-up
(origin, axes, ruler, fps) goes to the run's ``scene.toml``, shared by every throw.

Files are written whole or not at all (:mod:`vidtrack._atomic`): the manual points CSV
first, then ``scene.toml`` (or ``throw.toml``).
"""

import copy
import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

from vidtrack.errors import SceneError
from vidtrack.scene.model import SCENE_FILE

__all__ = ["EditResult", "apply_edit", "axes_from_clicks", "frames_to_ranges",
           "with_stand_ins", "EDITS", "ORTHOGONAL_VIEWS", "SET_UP"]

#: The edits the page can ask for (the ``set`` field of a request).
EDITS = ("origin", "axes", "ruler", "fps", "target", "point", "exclude")
#: The edits that correct the tracker: a throw's own, in a run with ``throws/``.
CORRECTIONS = ("target", "point", "exclude")
#: Views that have an origin, axes and a scale in scene.toml, and the world axes each sees.
ORTHOGONAL_VIEWS = {"front": ("x", "y"), "top": ("x", "z")}
#: Keys of a view that set its scale; a ruler clicked replaces the others.
SCALE_KEYS = ("ruler", "m_per_px", "m_per_px_rel_uncertainty", "calibration")
#: The set-up values of a front/top view: the loader refuses the view without each.
SET_UP = ("fps", "origin_px", "axes", "scale")
#: Stand-ins for set-up values, when a view is checked alone while its scene is not
#: complete yet: never written, never drawn.
_STAND_INS = {"fps": 1000.0, "origin_px": [0.0, 0.0], "m_per_px": 0.001}
#: Which set-up values each edit gives.
_GIVES = {"origin": ("origin_px",), "axes": ("axes",), "ruler": ("scale",), "fps": ("fps",)}
#: The manual points file a view gets when scene.toml names none.
MANUAL_FILE = "{view}_manual.csv"
#: The smallest ruler accepted from clicks (px): two clicks on one spot are a slip.
MIN_RULER_PX = 2.0


@dataclass(frozen=True)
class EditResult:
    """What an edit wrote.

    Attributes
    ----------
    written : tuple of pathlib.Path
        The files written (scene.toml, and the manual points CSV for a point).
    scene_error : str or None
        The loader's one-line message when the scene still does not load after the
        edit (a value it needs is missing), else None.
    """

    written: tuple
    scene_error: str | None = None

    def to_dict(self, root=None):
        """As JSON can take it: the files written named relative to ``root`` (the run
        folder: ``throws/02/throw.toml``), or by their names."""
        def name(p):
            return str(p.relative_to(root)) if root is not None and p.is_relative_to(
                root) else p.name

        return {"written": [name(p) for p in self.written], "scene_error": self.scene_error}


def _bad(label, key, message):
    raise SceneError(f"{label}: {key} {message}")


def _pair(value, label, key):
    """A clicked pixel ``[u, v]`` as two finite floats (SceneError otherwise)."""
    if (not isinstance(value, (list, tuple)) or len(value) != 2
            or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in value)
            or not all(math.isfinite(x) for x in value)):
        _bad(label, key, f"must be a pixel [u, v] (two finite numbers), got {value!r}")
    return [round(float(value[0]), 2), round(float(value[1]), 2)]


def _number(value, label, key, what):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(
            value):
        _bad(label, key, f"must be {what}, got {value!r}")
    return value


def _frame(value, label, key, n_frames):
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < n_frames:
        _bad(label, key, f"must be a frame of the footage (an integer 0 to {n_frames - 1}), "
             f"got {value!r}")
    return value


def axes_from_clicks(origin_px, first_px, second_px, names):
    """The ``axes`` value from two clicks: the tip of each world axis' positive direction.

    Parameters
    ----------
    origin_px : (u, v)
        The origin O in the frame's pixels.
    first_px, second_px : (u, v)
        A point on the positive side of the view's first and second world axis
        (``names``; front: X then Y, top: X then Z).
    names : (str, str)
        The view's world axes, lower case.

    Returns
    -------
    list of str
        ``[axis along increasing column, axis along increasing row]``, e.g. ``["+x", "-y"]``:
        each click is taken along the image direction (column or row) it is furthest
        from O in.

    Raises
    ------
    ValueError
        A click on O, or both clicks along the same image direction.
    """
    out = [None, None]
    for name, tip in zip(names, (first_px, second_px)):
        du, dv = tip[0] - origin_px[0], tip[1] - origin_px[1]
        if du == 0 and dv == 0:
            raise ValueError(f"the +{name} click is on the origin; expected a point along "
                             f"+{name}, away from O")
        along = 0 if abs(du) >= abs(dv) else 1
        sign = "+" if (du if along == 0 else dv) > 0 else "-"
        if out[along] is not None:
            raise ValueError(f"+{names[0]} and +{names[1]} were both clicked along the image "
                             f"{'columns' if along == 0 else 'rows'}; expected one along "
                             "the columns and one along the rows")
        out[along] = sign + name
    return out


def frames_to_ranges(frames):
    """Sorted frame numbers as half-open ranges of consecutive frames, ``[[a, b], ...]``."""
    out = []
    for f in sorted(set(frames)):
        if out and out[-1][1] == f:
            out[-1][1] = f + 1
        else:
            out.append([f, f + 1])
    return out


def _ranges_to_frames(ranges):
    frames = set()
    for r in ranges or ():
        frames.update(range(int(r[0]), int(r[1])))
    return frames


def _set(table, key, value):
    """``table[key] = value`` in place; a ``TODO(user)`` comment on the line goes (the
    value is given now), any other comment stays."""
    from vidtrack.scene_template import TODO

    table[key] = value
    trivia = getattr(table[key], "trivia", None)
    if trivia is not None and TODO in (trivia.comment or ""):
        trivia.comment = ""
        trivia.comment_ws = ""


def _load_doc(path):
    import tomlkit

    try:
        return tomlkit.parse(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"{path}: cannot be read ({exc})") from None
    except tomlkit.exceptions.ParseError as exc:
        raise SceneError(f"{path}: is not valid TOML ({exc})") from None


def _view_table(doc, name, label):
    views = doc.get("views")
    if not isinstance(views, dict) or name not in views:
        _bad(label, f"views.{name}", "is not in the file; expected a view of scene.toml")
    return views[name]


def with_stand_ins(view, name, keep):
    """A copy of a front/top view's table (``name``) in which the set-up values
    (:data:`SET_UP`) not in ``keep`` are stand-ins the loader accepts."""
    alone = copy.deepcopy(dict(view))
    if "fps" not in keep:
        alone["fps"] = _STAND_INS["fps"]
    if "origin_px" not in keep:
        alone["origin_px"] = _STAND_INS["origin_px"]
    if "axes" not in keep:
        alone["axes"] = ["+" + ORTHOGONAL_VIEWS[name][0], "+" + ORTHOGONAL_VIEWS[name][1]]
    if "scale" not in keep:
        for k in SCALE_KEYS:
            alone.pop(k, None)
        alone["m_per_px"] = _STAND_INS["m_per_px"]
    return alone


def _manual_rows(folder, view_table, label):
    """The view's manual points as ``{frame: (u, v)}`` (empty when none are named)."""
    from vidtrack.scene.corrections import manual_points_file, read_manual_points

    text = view_table.get("manual_points")
    if text is None:
        return {}
    path = manual_points_file(folder, str(text))
    if not path.is_file():
        return {}
    points = read_manual_points(path, label=label, key="manual_points", text=str(text))
    return {f: (u, v) for f, u, v in zip(points.frames, points.u_px, points.v_px)}


def _manual_csv(rows):
    lines = ["frame,u_px,v_px"]
    lines += [f"{f},{u:.2f},{v:.2f}" for f, (u, v) in sorted(rows.items())]
    return "\n".join(lines) + "\n"


def _check(folder, path, before, after, view, gives, manual_text=None, manual_name=None):
    """Refuse what the loader refuses of the edit (module docstring); the scene's own
    remaining error, or None."""
    from vidtrack.scene.read import parse_scene

    label = str(path)
    with tempfile.TemporaryDirectory() as tmp:
        after = copy.deepcopy(after)
        if manual_text is not None:
            # the new manual points are checked from a copy, before anything is written
            probe_csv = Path(tmp) / Path(manual_name).name   # messages name the file
            probe_csv.write_text(manual_text, encoding="utf-8")
            after["views"][view]["manual_points"] = str(probe_csv)

        def named(exc):
            """The message with the real manual points file's name, not the copy's."""
            text = str(exc)
            return text if manual_text is None else text.replace(str(probe_csv), manual_name)

        try:
            parse_scene(after, folder=folder, label=label, path=path)
            return None
        except SceneError as exc:
            error_after = named(exc)
        if view not in ORTHOGONAL_VIEWS:
            # a calibrated view: the edit must not be what makes the scene fail
            try:
                parse_scene(before, folder=folder, label=label, path=path)
                error_before = None
            except SceneError as exc:
                error_before = str(exc)
            if error_after != error_before:
                raise SceneError(error_after)
            return error_after
        alone = with_stand_ins(after["views"][view], view, gives)
        try:
            parse_scene({"schema": 1, "views": {view: alone}}, folder=folder, label=label,
                        path=path)
        except SceneError as exc:
            raise SceneError(named(exc)) from None
        return error_after


def _check_throw(folder, path, scene_doc, throw_dir, throw_doc, view, manual_text=None,
                 manual_name=None):
    """Refuse what ``vidtrack fit`` refuses of a throw's edited ``throw.toml`` (and its
    new manual points, checked from a copy); the run's own remaining error, or None.
    While scene.toml does not load yet, a front/top view is checked alone (stand-ins
    for its set-up values), with the throw's keys on it."""
    from vidtrack.scene.read import parse_scene
    from vidtrack.scene.throw_file import THROW_FILE, apply_throw

    throw_doc = copy.deepcopy(throw_doc)
    try:
        scene = parse_scene(scene_doc, folder=folder, label=str(path), path=path)
        scene_error = None
    except SceneError as exc:
        scene_error = str(exc)
        if view not in ORTHOGONAL_VIEWS:
            return scene_error           # a calibrated view: checked once the scene loads
        alone = with_stand_ins(scene_doc["views"][view], view, ())
        scene = parse_scene({"schema": 1, "views": {view: alone}}, folder=folder,
                            label=str(path), path=path)
        throw_doc = {"views": {view: throw_doc.get("views", {}).get(view, {})}}
    with tempfile.TemporaryDirectory() as tmp:
        probe = Path(tmp) / Path(manual_name or "none").name
        if manual_text is not None:
            probe.write_text(manual_text, encoding="utf-8")
            throw_doc["views"][view]["manual_points"] = str(probe)
        try:
            apply_throw(scene, throw_doc, throw_dir, label=str(throw_dir / THROW_FILE))
        except SceneError as exc:
            text = str(exc)
            raise SceneError(text if manual_text is None else
                             text.replace(str(probe), manual_name)) from None
    return scene_error


def _throw_folder(folder, throw, label):
    """The folder of throw ``throw`` (its name under ``throws/``)."""
    from vidtrack.scene.folders import find_throw_dirs

    dirs = {d.name: d for d in find_throw_dirs(folder)}
    if throw not in dirs:
        names = ", ".join(dirs) or "none: the run has no throws/"
        raise SceneError(f"{label}: throw {throw!r} is not a throw of the run; expected one "
                         f"of {names}")
    return dirs[throw]


def _throw_table(doc, name):
    """The view's table of a throw's file, made when missing."""
    import tomlkit

    if "views" not in doc:
        doc["views"] = tomlkit.table(is_super_table=True)
    if name not in doc["views"]:
        doc["views"][name] = tomlkit.table()
    return doc["views"][name]


def _correct(table, current, shared, request, *, label, key, n_frames, base, name,
             own=False):
    """A correction (target, point, exclude) written into ``table`` (a throw's ``own``
    table, or scene.toml's), the view's values in effect being ``current`` and
    scene.toml's ``shared``; the manual points file resolves in ``base``. Returns (the
    manual points CSV's path, its new text or None, its name as written)."""
    import tomlkit

    what = request.get("set")
    if what == "target" and request.get("at_px") is None:
        if "target" not in table:
            where = (" (the run's target, in scene.toml: it applies to every throw, remove "
                     "it there)" if "target" in current else "")
            _bad(label, f"{key}.target", f"is not set{where}; expected a target to remove")
        del table["target"]
        return None, None, None
    frame = _frame(request.get("frame"), label, f"{key} frame", n_frames)
    if what == "target":
        target = tomlkit.inline_table()
        target.update({"frame": frame,
                       "at_px": _pair(request.get("at_px"), label, f"{key}.target.at_px")})
        table["target"] = target
        return None, None, None
    if what == "exclude":
        excluded = request.get("excluded")
        if not isinstance(excluded, bool):
            _bad(label, f"{key}.exclude_frames", f"edit needs excluded true or false, got "
                 f"{excluded!r}")
        frames = _ranges_to_frames(current.get("exclude_frames"))
        (frames.add if excluded else frames.discard)(frame)
        if frames or (own and shared.get("exclude_frames")):
            table["exclude_frames"] = frames_to_ranges(frames)   # [] takes the run's out
        elif "exclude_frames" in table:
            del table["exclude_frames"]
        return None, None, None
    from vidtrack.scene.corrections import manual_points_file

    rows = _manual_rows(base, current, label)
    at = request.get("at_px")
    if at is None:
        rows.pop(frame, None)
    else:
        rows[frame] = tuple(_pair(at, label, f"{key}.manual_points (frame {frame})"))
    text = str(current.get("manual_points") or MANUAL_FILE.format(view=name))
    manual_text = _manual_csv(rows)
    if rows:
        table["manual_points"] = text
    elif "manual_points" in table:
        del table["manual_points"]
        manual_text = None
    return manual_points_file(base, text), manual_text, text


def apply_edit(folder, request, *, n_frames, throw=None):
    """Apply one edit from the page to the run's scene.toml (and manual points file).

    Parameters
    ----------
    folder : pathlib.Path
        The run folder.
    request : dict
        ``view`` (a view of scene.toml), ``set`` (one of :data:`EDITS`) and its values:

        - ``origin``: ``at_px`` [u, v];
        - ``axes``: ``first_px`` and ``second_px``, points along the view's first and
          second world axis (:func:`axes_from_clicks`; needs the origin);
        - ``ruler``: ``from_px``, ``to_px`` and ``length_m`` (replaces ``m_per_px`` or
          ``calibration``);
        - ``fps``: ``fps``, the capture rate;
        - ``target``: ``frame`` and ``at_px`` (``at_px`` None removes the target: the
          rest of the file stays byte for byte);
        - ``point``: ``frame`` and ``at_px`` (None removes the frame's point): the
          view's ``manual_points`` file (``<view>_manual.csv`` unless scene.toml names
          one);
        - ``exclude``: ``frame`` and ``excluded`` (true or false): ``exclude_frames``.
    n_frames : int
        Frames in the view's footage (a frame clicked must be one of them).
    throw : str, optional
        In a run with ``throws/``, the throw shown (``"02"``): a target, point or
        exclusion is written to that throw's ``throw.toml`` and manual points file.

    Returns
    -------
    EditResult

    Raises
    ------
    SceneError
        One line (the file, the key, what was expected): a malformed request, or what
        the loader refuses of the edited scene. Nothing is written then.
    """
    import tomlkit

    from vidtrack._atomic import write_text

    folder = Path(folder)
    path = folder / SCENE_FILE
    label = str(path)
    if not isinstance(request, dict):
        raise SceneError(f"{label}: the edit must be a JSON object, got {request!r}")
    what = request.get("set")
    if what not in EDITS:
        raise SceneError(f"{label}: edit {what!r} is not one the page makes; expected one of "
                         f"{', '.join(EDITS)}")
    name = request.get("view")
    doc = _load_doc(path)
    if not isinstance(name, str):
        raise SceneError(f"{label}: the edit names no view; expected a view of scene.toml")
    table = _view_table(doc, name, label)
    before = doc.unwrap()
    key = f"views.{name}"
    if what in _GIVES and name not in ORTHOGONAL_VIEWS:
        _bad(label, key, f"is a calibrated view: its {what} comes from its camera model; "
             "expected a front or top view")
    if what in CORRECTIONS and throw is not None:
        from vidtrack.scene.throw_file import THROW_FILE

        throw_dir = _throw_folder(folder, throw, label)
        own = throw_dir / THROW_FILE
        throw_doc = _load_doc(own) if own.exists() else tomlkit.document()
        shared = before["views"][name]
        current = dict(shared, **throw_doc.unwrap().get("views", {}).get(name, {}))
        csv_path, manual_text, text = _correct(
            _throw_table(throw_doc, name), current, shared, request, label=str(own),
            key=key, n_frames=n_frames, base=throw_dir, name=name, own=True)
        if not throw_doc["views"][name]:
            del throw_doc["views"][name]
        scene_error = _check_throw(folder, path, before, throw_dir, throw_doc.unwrap(), name,
                                   manual_text=manual_text, manual_name=text)
        path, doc = own, throw_doc
    else:
        csv_path = manual_text = text = None
        if what == "origin":
            _set(table, "origin_px", _pair(request.get("at_px"), label, f"{key}.origin_px"))
        elif what == "axes":
            origin = before["views"][name].get("origin_px")
            try:
                origin = _pair(origin, label, f"{key}.origin_px")
            except SceneError:
                _bad(label, f"{key}.origin_px", f"is {origin!r}; set the origin before the "
                     "axes")
            first = _pair(request.get("first_px"), label, f"{key}.axes (first click)")
            second = _pair(request.get("second_px"), label, f"{key}.axes (second click)")
            try:
                _set(table, "axes", axes_from_clicks(origin, first, second,
                                                        ORTHOGONAL_VIEWS[name]))
            except ValueError as exc:
                _bad(label, f"{key}.axes", f"cannot be read from the clicks: {exc}")
        elif what == "ruler":
            a = _pair(request.get("from_px"), label, f"{key}.ruler.from_px")
            b = _pair(request.get("to_px"), label, f"{key}.ruler.to_px")
            if math.hypot(b[0] - a[0], b[1] - a[1]) < MIN_RULER_PX:
                _bad(label, f"{key}.ruler", f"ends {a} and {b} are less than "
                     f"{MIN_RULER_PX:g} px apart; expected a click on each end of the ruler")
            length = _number(request.get("length_m"), label, f"{key}.ruler.length_m",
                             "the ruler's length in m (a number > 0)")
            for k in SCALE_KEYS:
                if k in table:
                    del table[k]
            ruler = tomlkit.inline_table()
            ruler.update({"length_m": length, "from_px": a, "to_px": b})
            table["ruler"] = ruler
        elif what == "fps":
            _set(table, "fps", _number(request.get("fps"), label, f"{key}.fps",
                                       "the capture rate in frames/s (a number > 0)"))
        else:
            csv_path, manual_text, text = _correct(
                table, before["views"][name], before["views"][name], request, label=label,
                key=key, n_frames=n_frames, base=folder, name=name)
        scene_error = _check(folder, path, before, doc.unwrap(), name, _GIVES.get(what, ()),
                             manual_text=manual_text, manual_name=text)
    written = []
    if csv_path is not None and (manual_text is not None or csv_path.is_file()):
        write_text(csv_path, manual_text if manual_text is not None else _manual_csv({}))
        written.append(csv_path)
    write_text(path, tomlkit.dumps(doc))
    written.append(path)
    return EditResult(written=tuple(written), scene_error=scene_error)
