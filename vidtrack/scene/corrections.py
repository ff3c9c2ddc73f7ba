"""A view's corrections of the tracker in ``scene.toml``: ``target``, ``exclude_frames``,
``manual_points`` (every view, orthogonal or calibrated; docs/scene.md, "Correcting the
tracker")::

    [views.front]
    target = { frame = 120, at_px = [640.0, 300.0] }   # the object at that pixel
    exclude_frames = [[200, 215], [300, 301]]          # half-open ranges never fitted
    manual_points = "front_manual.csv"                 # frame,u_px,v_px placed by a person

The keys are checked here like every other (file, key, what was expected). The manual
points file is read by :func:`read_manual_points`: a header naming ``frame``, ``u_px``
and ``v_px`` (in any order; other columns, a note for instance, are ignored), one row per
frame, integer frames >= 0, finite pixels, no frame twice, at least one row. It resolves
like ``source``: against the run folder, or against each throw's folder for a run with
``throws/`` (then it is read and checked per throw, before any tracking). Whether its
frames lie inside the footage is checked when the footage is opened
(:mod:`vidtrack.run.preflight`).
"""

import csv
import hashlib
import io
import math
from dataclasses import dataclass
from pathlib import Path

from vidtrack.errors import SceneError
from vidtrack.scene._check import MAX_ABS_PX, _show, _type_name

__all__ = ["ManualPoints", "MANUAL_COLUMNS", "parse_target", "parse_exclude",
           "parse_manual_points", "read_manual_points", "manual_points_file",
           "corrections_to_dict"]

#: The columns a manual points file must name in its header.
MANUAL_COLUMNS = ("frame", "u_px", "v_px")
#: Largest manual points file read (bytes): a few hundred thousand rows.
_MAX_BYTES = 64 * 1024 * 1024


@dataclass(frozen=True, eq=False)
class ManualPoints:
    """The points of a ``manual_points`` file.

    Attributes
    ----------
    path : pathlib.Path
    frames : tuple of int
        0-based frame indices in the view's file, in the file's order.
    u_px, v_px : tuple of float
        The pixels (column, row) placed by hand, in the view's own pixels (those of its
        rows in tracks.csv).
    sha256 : str
        Digest of the file's bytes (the tracks stage's cache key holds it).
    """

    path: Path
    frames: tuple
    u_px: tuple
    v_px: tuple
    sha256: str

    def __len__(self):
        return len(self.frames)


def corrections_to_dict(view, out):
    """Add a view's ``target``, ``exclude_frames`` and ``manual_points`` to ``out`` (the
    view's table as scene.toml writes it), each only when given; returns ``out``."""
    if view.target is not None:
        out["target"] = {"frame": view.target[0], "at_px": list(view.target[1])}
    if view.exclude_frames:
        out["exclude_frames"] = [list(r) for r in view.exclude_frames]
    if view.manual_points_text is not None:
        out["manual_points"] = view.manual_points_text
    return out


def _fail(label, key, message):
    raise SceneError(f"{label}: {key} {message}")


def parse_target(ck, view, path, frames):
    """A view's ``target = { frame = F, at_px = [u, v] }`` as ``(F, (u, v))``, or None."""
    if "target" not in view:
        return None
    tp = f"{path}.target"
    t = view["target"]
    if not isinstance(t, dict):
        ck.fail(tp, "must be a table { frame = F, at_px = [u, v] }: the object's pixel in "
                f"one frame, got {_type_name(t)} {_show(t)}")
    ck.keys(t, ("frame", "at_px"), tp)
    if "frame" not in t:
        ck.fail(f"{tp}.frame", "is required: the 0-based frame index where at_px is the "
                "object's pixel")
    frame = t["frame"]
    if isinstance(frame, bool) or not isinstance(frame, int):
        ck.fail(f"{tp}.frame", f"must be a frame index (an integer >= 0), got "
                f"{_type_name(frame)} {_show(frame)}")
    if frame < 0:
        ck.fail(f"{tp}.frame", f"must be >= 0 (a 0-based frame index), got {frame}")
    if frames is not None and not frames[0] <= frame < frames[1]:
        ck.fail(f"{tp}.frame", f"must be inside frames [{frames[0]}, {frames[1]}), got {frame}")
    at = ck.pair(t, "at_px", f"{tp}.at_px", required=True,
                 what="[u, v]: the object's pixel (column, row) in that frame")
    return frame, at


def parse_exclude(ck, view, path, frames):
    """A view's ``exclude_frames = [[a, b], ...]`` as a tuple of ``(a, b)`` (half-open,
    0 <= a < b, inside ``frames`` when given), in the file's order; () when absent."""
    if "exclude_frames" not in view:
        return ()
    key = f"{path}.exclude_frames"
    value = view["exclude_frames"]
    want = "an array of half-open frame ranges [[first, end), ...], e.g. [[200, 215]]"
    if not isinstance(value, list):
        ck.fail(key, f"must be {want}, got {_type_name(value)} {_show(value)}")
    out = []
    for i, r in enumerate(value):
        if not isinstance(r, list) or len(r) != 2 or any(
                isinstance(x, bool) or not isinstance(x, int) for x in r):
            ck.fail(f"{key}[{i}]", f"must be two integers [first, end) (0-based frame "
                    f"indices), got {_show(r)}")
        a, b = r
        if a < 0 or b <= a:
            ck.fail(f"{key}[{i}]", f"must be a non-empty range [first, end) with "
                    f"0 <= first < end, got {_show(r)}")
        if frames is not None and (a < frames[0] or b > frames[1]):
            ck.fail(f"{key}[{i}]", f"must lie inside frames [{frames[0]}, {frames[1]}), "
                    f"got {_show(r)}")
        out.append((a, b))
    return tuple(out)


def parse_manual_points(ck, view, path, folder, frames, exclude):
    """A view's ``manual_points = "FILE.csv"``: ``(path, text, points)``, or three Nones.

    With a run folder (``folder``) that has no ``throws/``, the file is read and checked
    here (:func:`read_manual_points`), its frames against ``frames`` and ``exclude``:
    ``points`` is the :class:`ManualPoints` read (a run uses them as read here); else
    ``points`` is None (a run with ``throws/`` reads each throw's file).
    """
    if "manual_points" not in view:
        return None, None, None
    key = f"{path}.manual_points"
    text = ck.string(view, "manual_points", key)
    if folder is None:
        return Path(text), text, None
    file = manual_points_file(folder, text)
    points = None
    if not (Path(folder) / "throws").is_dir():
        points = read_manual_points(file, label=ck.label, key=key, text=text)
        check_manual_frames(points, label=ck.label, key=key, frames=frames, exclude=exclude)
    return file, text, points


def manual_points_file(folder, text):
    """The manual points file named ``text`` for the run (or throw) folder ``folder``."""
    p = Path(text)
    return p if p.is_absolute() else Path(folder) / p


def check_manual_frames(points, *, label, key, frames=None, exclude=()):
    """Manual frames inside the view's ``frames`` range and in no excluded range."""
    for f in points.frames:
        if frames is not None and not frames[0] <= f < frames[1]:
            _fail(label, key, f"({points.path.name}) has frame {f}, outside the view's "
                  f"frames [{frames[0]}, {frames[1]}); expected frames the view uses")
        for a, b in exclude:
            if a <= f < b:
                _fail(label, key, f"({points.path.name}) has frame {f}, which "
                      f"exclude_frames [{a}, {b}) takes out; expected a frame either "
                      "excluded or placed by hand, not both")


def read_manual_points(path, *, label, key, text=None):
    """Read and check a manual points CSV (``frame,u_px,v_px``).

    Parameters
    ----------
    path : pathlib.Path
    label : str
        The scene file, for messages.
    key : str
        The key that names the file (``views.front.manual_points``).
    text : str, optional
        The name as written in scene.toml.

    Returns
    -------
    ManualPoints

    Raises
    ------
    SceneError
        One line: the file, the key, the row and what was expected.
    """
    path = Path(path)
    name = text or path.name
    if not path.is_file():
        what = "it is not a file" if path.exists() else "there is no such file"
        _fail(label, key, f"names {name!r}, but {what} ({path}); expected a CSV "
              "frame,u_px,v_px")
    try:
        if path.stat().st_size > _MAX_BYTES:
            _fail(label, key, f"({name}) is larger than {_MAX_BYTES >> 20} MiB; expected a "
                  "CSV frame,u_px,v_px with a row per frame")
        raw = path.read_bytes()
    except OSError as exc:
        _fail(label, key, f"({name}) cannot be read ({exc.strerror or exc})")
    try:
        content = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        _fail(label, key, f"({name}) is not UTF-8 text ({exc.reason} at byte {exc.start}); "
              "expected a CSV frame,u_px,v_px")
    try:
        rows = list(csv.reader(io.StringIO(content)))
    except csv.Error as exc:
        _fail(label, key, f"({name}) is not a CSV file ({exc}); expected frame,u_px,v_px")
    rows = [(i + 1, r) for i, r in enumerate(rows) if any(c.strip() for c in r)]
    if not rows:
        _fail(label, key, f"({name}) is empty; expected a header frame,u_px,v_px and a row "
              "per frame")
    header = [c.strip() for c in rows[0][1]]
    missing = [c for c in MANUAL_COLUMNS if c not in header]
    if missing:
        _fail(label, key, f"({name}) has the header {','.join(header)!r}, without "
              f"{', '.join(missing)}; expected a header frame,u_px,v_px (other columns "
              "are ignored)")
    twice = [c for c in MANUAL_COLUMNS if header.count(c) > 1]
    if twice:
        _fail(label, key, f"({name}) names the column {twice[0]} twice in its header; "
              "expected it once")
    at = {c: header.index(c) for c in MANUAL_COLUMNS}
    if len(rows) < 2:
        _fail(label, key, f"({name}) has a header but no points; expected a row per frame "
              "placed by hand")
    frames, us, vs, seen = [], [], [], {}
    for line, row in rows[1:]:
        where = f"({name}, line {line})"
        if len(row) <= max(at.values()):
            _fail(label, key, f"{where} has {len(row)} cells; expected frame,u_px,v_px")
        cell = row[at["frame"]].strip()
        try:
            frame = int(cell)
        except ValueError:
            _fail(label, key, f"{where} frame must be an integer frame index, got {cell!r}")
        if frame < 0:
            _fail(label, key, f"{where} frame must be >= 0 (a 0-based frame index), "
                  f"got {frame}")
        if frame in seen:
            _fail(label, key, f"{where} gives frame {frame} again (first on line "
                  f"{seen[frame]}); expected one point per frame")
        seen[frame] = line
        px = []
        for c in ("u_px", "v_px"):
            cell = row[at[c]].strip()
            try:
                value = float(cell)
            except ValueError:
                _fail(label, key, f"{where} {c} must be a number (pixels), got {cell!r}")
            if not math.isfinite(value):
                _fail(label, key, f"{where} {c} must be a finite number (pixels), "
                      f"got {cell!r}")
            if abs(value) > MAX_ABS_PX:
                _fail(label, key, f"{where} {c} must be within +-{MAX_ABS_PX:g} px (an "
                      f"image position), got {cell!r}")
            px.append(value)
        frames.append(frame)
        us.append(px[0])
        vs.append(px[1])
    return ManualPoints(path=path, frames=tuple(frames), u_px=tuple(us), v_px=tuple(vs),
                        sha256=hashlib.sha256(raw).hexdigest())
