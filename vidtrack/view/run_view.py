"""A run as the page shows it: each view's footage frame by frame with the marks drawn.

:class:`RunView` holds a run folder open for the page: the scene (or the loader's
message while it does not load yet), each view's footage (opened lazily, one frame read
at a time), the tracks and the fitted path when ``vidtrack fit`` has written them, and
the corrections of ``scene.toml``. In a run with ``throws/`` it shows one throw at a time
(:meth:`RunView.select_throw`): that throw's footage, tracks and fitted path, and its
corrections (scene.toml's with the throw's ``throw.toml`` over them).
:meth:`RunView.render` draws a frame with the overlay's own drawing
(:func:`vidtrack.report.overlay.draw_frame`: the scene's origin, axes and ruler, the
trail, the measured point in its flag colour, the fitted path, the banner with the flags
and their reason), plus the corrections: a point placed by hand (a square in
:data:`MANUAL_COLOUR`), the ``target`` (a diamond) and ``excluded`` in the banner.
"""

import json
import threading
import tomllib
from pathlib import Path

import numpy as np

from vidtrack.errors import SceneError, VidtrackError
from vidtrack.scene.model import SCENE_FILE
from vidtrack.view.edits import ORTHOGONAL_VIEWS, SET_UP, with_stand_ins
from vidtrack.view.view_data import EMPTY, view_data
from vidtrack.view.zoom import ZOOM_FACTOR, ZOOM_HALF_PX

__all__ = ["RunView", "DISPLAY_WIDTH_PX", "MANUAL_COLOUR", "TARGET_COLOUR"]

#: Width the page shows a frame at (px): small footage is enlarged to click it precisely.
DISPLAY_WIDTH_PX = 960
#: Colour (B, G, R) of a point placed by hand (a square) and of the target (a diamond).
MANUAL_COLOUR = (255, 64, 0)
TARGET_COLOUR = (255, 64, 0)
#: Size of those markers in drawn pixels.
MARKER_PX = 18
#: Frames of trail drawn behind the measured point.
PAGE_TRAIL_FRAMES = 30


def _valid_alone(folder, path, name, raw):
    """The view parsed alone, each set-up value the loader refuses replaced by a
    stand-in (:func:`~vidtrack.view.edits.with_stand_ins`); and which set-up values are
    the file's own (the others are not drawn)."""
    from vidtrack.scene.read import parse_scene

    def parsed(keep):
        try:
            scene = parse_scene({"schema": 1, "views": {name: with_stand_ins(raw, name, keep)}},
                                folder=folder, label=str(path), path=path)
        except SceneError:
            return None
        return scene.views[name]

    own = {key for key in SET_UP if parsed({key}) is not None}
    view = parsed(own)
    return (view, own) if view is not None else (None, set())


class _Footage:
    """One view's footage, opened on first use, read one frame at a time."""

    def __init__(self, path, fps, channel):
        self.path, self.fps, self.channel = Path(path), fps, channel
        self._source = None

    @property
    def source(self):
        if self._source is None:
            from vidtrack.footage import open_source

            self._source = open_source(self.path, fps=self.fps, channel=self.channel)
        return self._source

    def close(self):
        if self._source is not None:
            self._source.close()
            self._source = None


class RunView:
    """A run folder held open for the page.

    Parameters
    ----------
    folder : str or pathlib.Path
        The run folder (with ``scene.toml``).
    throw : str, optional
        In a run with ``throws/``, the throw shown first (default: the first).

    Raises
    ------
    VidtrackError
        No such folder, no scene.toml, a file that is not TOML, no view with footage,
        footage that cannot be opened, a throw that is not one of the run's (one line
        each).
    """

    def __init__(self, folder, throw=None):
        folder = Path(folder)
        if not folder.is_dir():
            raise VidtrackError(f"{folder}: no such folder; expected a run folder with "
                                f"{SCENE_FILE}")
        self.folder = folder.resolve()
        self.scene_path = self.folder / SCENE_FILE
        if not self.scene_path.is_file():
            raise SceneError(f"{self.scene_path}: no such file; expected the run's "
                             f"{SCENE_FILE} (vidtrack init {folder} writes one)")
        from vidtrack.scene.folders import find_throw_dirs

        self.throws = [d.name for d in find_throw_dirs(self.folder)]
        self.throw = self.throws[0] if self.throws else None
        self._lock = threading.RLock()
        self._footage, self._data = {}, {}
        if throw is not None:
            self.select_throw(throw)
        else:
            self.reload()
        if not self._footage:
            raise SceneError(f"{self.scene_path}: no view gives footage (views.<name>.source);"
                             " expected at least one")
        for name in self._footage:
            with self._lock:
                self._footage[name].source  # noqa: B018 - opened now: bad footage refused

    # ------------------------------------------------------------------ state
    @property
    def throw_dir(self):
        """The folder of the throw shown (the run folder in a run of one throw)."""
        return self.folder / "throws" / self.throw if self.throw else self.folder

    def select_throw(self, throw):
        """Show throw ``throw`` (its name under ``throws/``) from now on.

        Raises
        ------
        VidtrackError
            Not a throw of the run (one line).
        """
        if throw not in self.throws:
            names = ", ".join(self.throws) or "none: the run has no throws/"
            raise VidtrackError(f"throw {throw!r}: not a throw of {self.folder}; expected "
                                f"one of {names}")
        with self._lock:
            self.throw = throw
            self.reload()

    def _throw_views(self):
        """The view tables of the throw's throw.toml ({} when it has none), and what
        reading it refused (None)."""
        from vidtrack.scene.throw_file import THROW_FILE

        path = self.throw_dir / THROW_FILE
        if not self.throw or not path.is_file():
            return {}, None
        try:
            raw = tomllib.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
            return {}, f"{path}: cannot be read as TOML ({exc})"
        views = raw.get("views") if isinstance(raw.get("views"), dict) else {}
        return {k: v for k, v in views.items() if isinstance(v, dict)}, None

    def reload(self):
        """Read scene.toml (and the throw's throw.toml), the tracks and the fit again
        (after an edit or a fit)."""
        from vidtrack.scene.read import parse_scene
        from vidtrack.scene.throw_file import throw_scene

        with self._lock:
            try:
                raw = tomllib.loads(self.scene_path.read_text(encoding="utf-8"))
            except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
                raise SceneError(f"{self.scene_path}: cannot be read as TOML ({exc})") from None
            self.raw = raw
            try:
                self.scene = parse_scene(raw, folder=self.folder, label=str(self.scene_path),
                                         path=self.scene_path)
                self.scene_error = None
            except SceneError as exc:
                self.scene, self.scene_error = None, str(exc)
            own, error = self._throw_views()
            if self.scene is not None and self.throw:
                try:
                    self.scene = throw_scene(self.scene, self.throw_dir)
                except SceneError as exc:
                    error = str(exc)
            self.scene_error = self.scene_error or error
            views = raw.get("views") if isinstance(raw.get("views"), dict) else {}
            for name, table in views.items():
                if not isinstance(table, dict) or not isinstance(table.get("source"), str):
                    continue
                fps = table.get("fps")
                fps = fps if isinstance(fps, (int, float)) and not isinstance(
                    fps, bool) and 0 < fps < 1e7 else None
                channel = table.get("channel") if isinstance(table.get("channel"), str) else "luma"
                path = self.throw_dir / table["source"]
                old = self._footage.get(name)
                if old is None or (old.path, old.fps, old.channel) != (path, fps, channel):
                    if old is not None:
                        old.close()
                    self._footage[name] = _Footage(path, fps, channel)
            self._views = {}
            for name in self._footage:
                self._views[name] = self._view_spec(name, views.get(name, {}))
            self._read_outputs()
            self._data = {name: view_data(self.throw_dir, self.scene_path, name,
                                          _in_effect(views.get(name), own.get(name)),
                                          self.tracks.get(name), self.paths.get(name))
                          for name in self._footage}

    def _view_spec(self, name, raw):
        if self.scene is not None:
            return self.scene.views.get(name), set(SET_UP)
        if name not in ORTHOGONAL_VIEWS or not isinstance(raw, dict):
            return None, set()
        return _valid_alone(self.folder, self.scene_path, name, raw)

    def _read_outputs(self):
        """The tracks, the fitted path and why they may not match the scene."""
        from vidtrack.run.tracks_file import read_tracks

        self.tracks, self.paths, self.notes = {}, {}, []
        out = self.folder / "vidtrack" / (self.throw or "")
        h5 = out / "tracks.h5"
        if not h5.is_file():
            self.notes.append("not fitted yet: no tracks (Fit draws them)")
            return
        try:
            tf = read_tracks(h5)
        except VidtrackError as exc:
            self.notes.append(f"tracks not shown: {exc}")
            return
        self.tracks = {n: t.data for n, t in tf.tracks.items()}
        if self.scene is None:
            return
        from vidtrack.run.overlay_run import stale_reason

        why = stale_reason(self.scene, self.throw_dir, out)
        if why:
            self.notes.append(f"tracks and fit not current: {why} (Fit updates them)")
        try:
            record = json.loads((out / "fit.json").read_text(encoding="utf-8"))
            if tf.world is None:
                return
            from vidtrack.report.view_path import view_paths

            world = {c: tf.world.data[c].to_numpy() for c in tf.world.data.columns}
            self.paths = view_paths(self.scene, record, world,
                                    frame_shapes={n: t.frame_shape
                                                  for n, t in tf.tracks.items()})
        except (OSError, ValueError, KeyError, TypeError, VidtrackError) as exc:
            self.notes.append(f"fitted path not shown: {exc}")

    def close(self):
        with self._lock:
            for f in self._footage.values():
                f.close()

    @property
    def view_names(self):
        return list(self._footage)

    def frame_count(self, name):
        """Frames in the view's footage."""
        with self._lock:
            return len(self._source(name))

    def _source(self, name):
        if name not in self._footage:
            raise VidtrackError(f"view {name!r}: not a view of {self.scene_path} with footage; "
                                f"expected one of {', '.join(self._footage)}")
        return self._footage[name].source

    def display_scale(self, name):
        from vidtrack.report.overlay import MAX_SCALE, MIN_SCALE

        cols = self._source(name).shape[1]
        return float(np.clip(DISPLAY_WIDTH_PX / cols, MIN_SCALE, MAX_SCALE))

    def state(self):
        """What the page shows beside the frames, as JSON can take it."""
        with self._lock:
            views = {}
            for name in self._footage:
                src = self._source(name)
                views[name] = {
                    "frames": len(src), "width_px": int(src.shape[1]),
                    "height_px": int(src.shape[0]), "scale": self.display_scale(name),
                    "world_axes": list(ORTHOGONAL_VIEWS.get(name, ())),
                    "source": str(self._footage[name].path.relative_to(self.folder))
                    if self._footage[name].path.is_relative_to(self.folder)
                    else str(self._footage[name].path),
                    "tracked": name in self.tracks,
                    "fps": self._footage[name].fps,
                    "target": self._data[name].target,
                }
            run_name = self.scene.run_name if self.scene is not None else self.folder.name
            return {"run": run_name, "folder": str(self.folder), "views": views,
                    "throws": list(self.throws), "throw": self.throw,
                    "zoom": {"half_px": ZOOM_HALF_PX, "factor": ZOOM_FACTOR},
                    "scene_error": self.scene_error, "notes": list(self.notes)}

    # ------------------------------------------------------------------ one frame
    def _frame_source(self, name, index):
        """The view's footage, once ``index`` is checked to be one of its frames."""
        src = self._source(name)
        if not 0 <= index < len(src):
            raise VidtrackError(f"frame {index}: not a frame of view {name} (0 to "
                                f"{len(src) - 1})")
        return src

    def frame_info(self, name, index):
        """The frame's number, time, flags and reason, measured point and corrections.

        Raises
        ------
        VidtrackError
            An unknown view, or an index outside the footage.
        """
        from vidtrack.report.overlay import flag_text

        with self._lock:
            src = self._frame_source(name, index)
            frame = int(src.frame_numbers[index])
            info = {"view": name, "index": index, "frame": frame,
                    "t_s": float(src.times_s[index]), "tracked": False, "flags": None,
                    "flag_text": "not tracked", "reason": None, "u_px": None, "v_px": None}
            data = self._data.get(name, EMPTY)
            i = data.row(frame)
            if i is not None:
                row = data.table.iloc[i]
                flags = int(row["flags"])
                reason = row["reason"] if "reason" in data.table.columns else None
                info.update(tracked=True, flags=flags, flag_text=flag_text(flags),
                            reason=reason if isinstance(reason, str) and reason else None,
                            u_px=_num(row["u_px"]), v_px=_num(row["v_px"]))
            target = data.target
            info["excluded"] = frame in data.excluded
            info["manual_px"] = list(data.manual[frame]) if frame in data.manual else None
            info["target_px"] = (target.get("at_px") if target and target.get("frame") == frame
                                 else None)
            return info

    def render(self, name, index):
        """The frame ``index`` of view ``name`` with every mark drawn, as PNG bytes."""
        import cv2

        from vidtrack.report.overlay import draw_frame, scene_marks, to_bgr8

        with self._lock:
            info = self.frame_info(name, index)
            src = self._source(name)
            scale = self.display_scale(name)
            img = to_bgr8(src[index], src.bit_depth, scale)
            spec, own = self._views.get(name, (None, set()))
            marks = None
            if spec is not None and "origin_px" in own:
                marks = scene_marks(spec, src.shape[:2])
                if marks is not None:
                    marks = type(marks)(origin=marks.origin,
                                        axes=marks.axes if "axes" in own else (),
                                        ruler=marks.ruler if "scale" in own else None)
            measured = trail = shift = fitted = None
            data = self._data.get(name, EMPTY)
            if data.frames is not None:
                frames = data.frames
                before = (frames < info["frame"]) & (frames >= info["frame"] - PAGE_TRAIL_FRAMES)
                trail = data.uv[before]
                i = data.row(info["frame"])
                if i is not None:
                    measured, shift = data.uv[i], data.shifts[i]
            if data.path is not None:
                fitted = data.path.at_frames(np.array([info["frame"]]),
                                             np.array([info["t_s"]]))[0]
            status = info["flag_text"]
            if info["reason"]:
                status += f" ({info['reason']})"
            if info["excluded"]:
                status += "  EXCLUDED"
            draw_frame(img, view=name, frame=info["frame"], time_s=info["t_s"],
                       flags=info["flags"], measured=measured, trail=trail, shift=shift,
                       path=data.polyline, fitted=fitted, scene=marks, scale=scale, status=status)
            for at, shape in ((info["manual_px"], cv2.MARKER_SQUARE),
                              (info["target_px"], cv2.MARKER_DIAMOND)):
                if at is not None:
                    c = (np.asarray(at, dtype=np.float64) + 0.5) * scale - 0.5
                    cv2.drawMarker(img, (int(round(c[0])), int(round(c[1]))), MANUAL_COLOUR,
                                   shape, MARKER_PX, 2, cv2.LINE_AA)
            return _png(img, name, index)

    def zoom(self, name, index, at_px):
        """The footage's pixels around ``at_px`` in frame ``index`` of view ``name``,
        magnified (:func:`vidtrack.view.zoom.zoom_image`), as PNG bytes.

        Raises
        ------
        VidtrackError
            An unknown view, or an index outside the footage.
        ValueError
            ``at_px`` is not a pixel of the frame (one line).
        """
        from vidtrack.report.overlay import to_bgr8
        from vidtrack.view.zoom import zoom_centre, zoom_image

        with self._lock:
            src = self._frame_source(name, index)
            centre = zoom_centre(at_px, src.shape[:2])
            return _png(zoom_image(to_bgr8(src[index], src.bit_depth), centre), name, index)


def _in_effect(shared, own):
    """A view's table as in effect for a throw: scene.toml's (``shared``) with the keys
    of the throw's throw.toml (``own``) over it."""
    shared = shared if isinstance(shared, dict) else {}
    return dict(shared, **own) if own else shared


def _png(img, name, index):
    """``img`` (BGR) as PNG bytes."""
    import cv2

    ok, png = cv2.imencode(".png", img)
    if not ok:
        raise VidtrackError(f"view {name}, frame {index}: cannot be encoded as PNG")
    return png.tobytes()


def _num(value):
    value = float(value)
    return value if np.isfinite(value) else None
