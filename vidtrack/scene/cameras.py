"""Calibrated cameras in ``scene.toml``: the ``[world]`` table and views with a camera model.

A scene with a ``[world]`` table has calibrated views of any name instead of the
orthogonal ``front``/``top`` views with a scale (a scene uses one kind or the other)::

    [world]
    up = [0.0, 0.0, 1.0]        # the calibration frame's vertical (against gravity)
    forward = [1.0, 0.0, 0.0]   # optional: the throwing direction

    [views.cam1]
    source = "cam1.mp4"         # footage to track, or instead:
    # points = { file = "xypts.csv", camera = 1, point = 1 }   # points digitized elsewhere
    fps = 119.12
    dlt = [L1, ..., L11]        # DLTdv/easyWand coefficients, or:
    # projection = [[...], [...], [...]]   # 3x4 P = K [R | t] (OpenCV)
    # intrinsics = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]; distortion = [k1, k2, p1, p2, k3]
    # calibration = "cam1.toml" # the lens (intrinsics, distortion) from `vidtrack calibrate`
    pixel_origin = "bottom-left"   # DLTdv's convention; default "top-left"

Every key is checked like the rest of the file (file, key, what was expected).
"""

import math
from dataclasses import dataclass, field
from pathlib import Path

from calibration.errors import InputError
from vidtrack.scene._check import _resolve, _show, _type_name
from vidtrack.scene.corrections import corrections_to_dict
from vidtrack.scene.model import CHANNELS, channel_to_dict

__all__ = ["WorldSpec", "CameraView", "CAMERA_VIEW_KEYS", "POINT_FORMATS", "parse_world",
           "parse_camera_view", "check_parallax", "MIN_BASELINE_RATIO"]

#: Smallest distance between two cameras' centres, as a fraction of their distance from
#: the calibration frame's origin (in the calibrated volume), that triangulates: below
#: it the rays of the two cameras are parallel within 0.06 degrees (no parallax).
MIN_BASELINE_RATIO = 1e-3

#: Formats of points files: DLTdv's xypts CSV, Tracker's data table, frame,u_px,v_px.
POINT_FORMATS = ("dltdv", "tracker", "csv")

#: Keys of a calibrated view's table.
CAMERA_VIEW_KEYS = ("source", "points", "fps", "dlt", "projection", "intrinsics", "distortion",
                    "calibration", "pixel_origin", "frames", "sync_frame", "channel",
                    "target", "exclude_frames", "manual_points")
_POINT_KEYS = ("file", "format", "camera", "point")


@dataclass(frozen=True)
class WorldSpec:
    """``[world]``: the calibration frame's vertical and, optionally, the throw direction.

    Attributes
    ----------
    up : tuple of float
        Unit vector against gravity, in the calibration's frame.
    forward : tuple of float or None
        The throwing direction as given (its horizontal part becomes the throw frame's X).
    """

    up: tuple
    forward: tuple | None = None

    def to_dict(self):
        out = {"up": list(self.up)}
        if self.forward is not None:
            out["forward"] = list(self.forward)
        return out


@dataclass(frozen=True)
class PointsSpec:
    """A view's ``points``: the file and which of its points."""

    file: Path
    file_text: str
    format: str | None       # None: recognised from the file when it is read
    camera: int = 1
    point: int = 1

    def to_dict(self):
        out = {"file": self.file_text, "camera": self.camera, "point": self.point}
        if self.format is not None:
            out["format"] = self.format
        return out


@dataclass(frozen=True)
class CameraView:
    """One calibrated ``[views.NAME]`` table, validated.

    Attributes
    ----------
    name : str
    source : pathlib.Path
        The footage, or the points file when the view gives points.
    source_text : str
    points : PointsSpec or None
        Points digitized elsewhere (no tracking is run for this view).
    fps : float
    camera : calibration.projective.ProjectiveCamera
    model : dict
        The camera keys as written (``dlt`` or ``projection``, ``intrinsics``,
        ``distortion``, ``calibration``), for :meth:`to_dict`.
    pixel_origin : str
    frames : tuple of int or None
    sync_frame : int or str
    channel : str
        The grey image tracked (footage only), as for the orthogonal views.
    target : (int, (float, float)) or None
        As for the orthogonal views: the object at that pixel of that frame (footage
        only; a view that gives points is not tracked).
    exclude_frames : tuple of (int, int)
        Half-open frame ranges never used (flagged EXCLUDED).
    manual_points, manual_points_text : pathlib.Path or None, str or None
        Points placed by hand (CSV ``frame,u_px,v_px``), in the view's own pixels.
    manual_points_read : vidtrack.scene.corrections.ManualPoints or None
        That file as the scene's reader read it (None: not read, a run with
        ``throws/`` reads each throw's own).
    """

    name: str
    source: Path
    source_text: str
    points: PointsSpec | None
    fps: float
    camera: object = field(compare=False)
    model: dict
    pixel_origin: str = "top-left"
    frames: tuple | None = None
    sync_frame: object = "auto"
    calibration: Path | None = None
    channel: str = "luma"
    target: tuple | None = None
    exclude_frames: tuple = ()
    manual_points: Path | None = None
    manual_points_text: str | None = None
    manual_points_read: object = field(default=None, compare=False, repr=False)

    def source_in(self, folder):
        """The source of this view inside ``folder`` (a throw's subfolder)."""
        return Path(folder) / self.source_text

    def manual_points_in(self, folder):
        """The manual points file for the run or throw folder ``folder`` (None: none)."""
        if self.manual_points_text is None:
            return None
        p = Path(self.manual_points_text)
        return p if p.is_absolute() else Path(folder) / p

    def to_dict(self):
        """The ``[views.NAME]`` table as it would be written."""
        out = {"points": self.points.to_dict()} if self.points else {"source": self.source_text}
        out["fps"] = self.fps
        out.update(self.model)
        out["pixel_origin"] = self.pixel_origin
        if self.frames is not None:
            out["frames"] = list(self.frames)
        out["sync_frame"] = self.sync_frame
        return corrections_to_dict(self, channel_to_dict(self, out))


def _vector(ck, table, key, path, *, required):
    if key not in table:
        if required:
            ck.fail(path, "is required: a 3-vector in the calibration's frame, e.g. "
                    "[0.0, 0.0, 1.0]")
        return None
    v = table[key]
    if (not isinstance(v, list) or len(v) != 3
            or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in v)
            or not all(math.isfinite(x) for x in v)):
        ck.fail(path, f"must be three finite numbers [x, y, z], got {_show(v)}")
    norm = math.sqrt(sum(float(x) ** 2 for x in v))
    if norm == 0:
        ck.fail(path, "must not be the zero vector")
    return tuple(float(x) / norm for x in v)


def parse_world(ck, data):
    """The ``[world]`` table, or None when the scene has none."""
    table = ck.table(data, "world", "world")
    if table is None:
        return None
    ck.keys(table, ("up", "forward"), "world")
    up = _vector(ck, table, "up", "world.up", required=True)
    forward = _vector(ck, table, "forward", "world.forward", required=False)
    if forward is not None and abs(sum(a * b for a, b in zip(up, forward))) > 0.999:
        ck.fail("world.forward", "is vertical (parallel to world.up): the throw direction "
                "must have a horizontal part")
    return WorldSpec(up=up, forward=forward)


def _matrix(ck, table, key, path, shape):
    value = table[key]
    rows, cols = shape
    ok = (isinstance(value, list) and len(value) == rows
          and all(isinstance(r, list) and len(r) == cols for r in value)
          and all(not isinstance(x, bool) and isinstance(x, (int, float)) and math.isfinite(x)
                  for r in value for x in r))
    if not ok:
        ck.fail(path, f"must be {rows} rows of {cols} finite numbers, got {_show(value)}")
    return [[float(x) for x in r] for r in value]


def _numbers(ck, table, key, path, lengths):
    value = table[key]
    if (not isinstance(value, list) or len(value) not in lengths
            or any(isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x)
                   for x in value)):
        want = " or ".join(str(n) for n in lengths)
        ck.fail(path, f"must be {want} finite numbers, got {_show(value)}")
    return [float(x) for x in value]


def _parse_points(ck, view, path, folder):
    p = view["points"]
    if isinstance(p, str):
        p = {"file": p}
    if not isinstance(p, dict):
        ck.fail(f"{path}.points", "must be a file name or a table { file = \"...\", camera = 1, "
                f"point = 1 }}, got {_type_name(p)} {_show(p)}")
    ck.keys(p, _POINT_KEYS, f"{path}.points")
    text = ck.string(p, "file", f"{path}.points.file", required=True,
                     what="the points file (DLTdv xypts CSV, Tracker table, or frame,u_px,v_px)")
    file = _resolve(folder, text) if folder is not None else Path(text)
    fmt = ck.string(p, "format", f"{path}.points.format")
    if fmt is not None and fmt not in POINT_FORMATS:
        ck.fail(f"{path}.points.format", f"must be one of {', '.join(POINT_FORMATS)}, "
                f"got {fmt!r}")
    ints = {}
    for key in ("camera", "point"):
        v = p.get(key, 1)
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            ck.fail(f"{path}.points.{key}", f"must be an integer >= 1 (DLTdv numbers from 1), "
                    f"got {_show(v)}")
        ints[key] = v
    if folder is not None and not file.is_file():
        ck.fail(f"{path}.points.file", f"names {text!r}, but there is no such file ({file})")
    return PointsSpec(file=file, file_text=text, format=fmt, **ints), text


def parse_camera_view(ck, name, view, folder, *, fps_range, frames_and_sync):
    """One calibrated view (``[views.NAME]`` of a scene with ``[world]``)."""
    from calibration.projective import PIXEL_ORIGINS, ProjectiveCamera

    path = f"views.{name}"
    if not isinstance(view, dict):
        ck.fail(path, f"must be a table, got {_type_name(view)} {_show(view)}")
    ck.keys(view, CAMERA_VIEW_KEYS, path)
    if ("source" in view) == ("points" in view):
        ck.fail(path, "needs either source (footage to track) or points (points digitized "
                "elsewhere), not " + ("both" if "source" in view else "neither"))
    points = None
    if "points" in view:
        points, source_text = _parse_points(ck, view, path, folder)
    else:
        source_text = ck.string(view, "source", f"{path}.source", required=True)
    fps = ck.number(view, "fps", f"{path}.fps", required=True, gt=0,
                    within=(*fps_range, "frames/s"), what="the capture rate in frames/s")
    origin = ck.string(view, "pixel_origin", f"{path}.pixel_origin", default="top-left")
    if origin not in PIXEL_ORIGINS:
        ck.fail(f"{path}.pixel_origin", f"must be \"top-left\" (OpenCV) or \"bottom-left\" "
                f"(DLTdv, easyWand), got {origin!r}")
    if ("dlt" in view) == ("projection" in view):
        ck.fail(path, "needs a camera model: dlt = [11 coefficients] (DLTdv, easyWand) or "
                "projection = 3x4 (OpenCV), exactly one")
    model = {}
    lens_keys = [k for k in ("intrinsics", "distortion", "calibration") if k in view]
    calib = None
    try:
        if "dlt" in view:
            if lens_keys:
                ck.fail(f"{path}.{lens_keys[0]}", "goes with projection, not dlt (a DLT maps "
                        "straight to observed pixels)")
            model["dlt"] = _numbers(ck, view, "dlt", f"{path}.dlt", (11,))
            camera = ProjectiveCamera.from_dlt(model["dlt"], pixel_origin=origin, name=name)
        else:
            model["projection"] = _matrix(ck, view, "projection", f"{path}.projection", (3, 4))
            intr = dist = None
            if "calibration" in view:
                if "intrinsics" in view or "distortion" in view:
                    ck.fail(f"{path}.calibration", "gives the lens: leave out intrinsics and "
                            "distortion")
                text = ck.string(view, "calibration", f"{path}.calibration")
                model["calibration"] = text
                calib = _resolve(folder, text) if folder is not None else Path(text)
                if folder is not None:
                    from calibration.calibration_file import load_calibration

                    if not calib.is_file():
                        ck.fail(f"{path}.calibration", f"names {text!r}, but there is no "
                                f"such file ({calib})")
                    content = load_calibration(calib)
                    if content.camera is None:
                        ck.fail(f"{path}.calibration", f"({text}) has no [camera] table: "
                                "no lens to undistort with")
                    intr = content.camera.camera_matrix.tolist()
                    dist = list(content.camera.dist_coeffs)
            if "intrinsics" in view:
                model["intrinsics"] = intr = _matrix(ck, view, "intrinsics",
                                                     f"{path}.intrinsics", (3, 3))
            if "distortion" in view:
                model["distortion"] = dist = _numbers(ck, view, "distortion",
                                                      f"{path}.distortion", (4, 5, 8, 12, 14))
            if origin != "top-left" and (intr is not None or dist is not None):
                ck.fail(f"{path}.pixel_origin", "must be \"top-left\" with a lens model "
                        "(OpenCV's convention)")
            camera = ProjectiveCamera.from_projection(model["projection"], intrinsics=intr,
                                                      distortion=dist, name=name)
            if origin != "top-left":
                camera = ProjectiveCamera(camera.matrix, pixel_origin=origin, name=name)
    except InputError as exc:
        ck.fail(path, str(exc).removeprefix(f"{name}: "))
    frames, sync = frames_and_sync(ck, view, path)
    from vidtrack.scene.corrections import parse_exclude, parse_manual_points, parse_target

    channel = ck.choice(view, "channel", f"{path}.channel", CHANNELS, default="luma")
    target = parse_target(ck, view, path, frames)
    for key, given in (("channel", "channel" in view), ("target", target is not None)):
        if given and points is not None:
            ck.fail(f"{path}.{key}", "goes with source (footage to track), not points: a "
                    "view that gives points is not tracked")
    exclude = parse_exclude(ck, view, path, frames)
    manual, manual_text, manual_read = parse_manual_points(ck, view, path, folder, frames,
                                                           exclude)
    source = (points.file if points else
              (_resolve(folder, source_text) if folder is not None else Path(source_text)))
    return CameraView(name=name, source=source, source_text=source_text, points=points,
                      fps=fps, camera=camera, model=model, pixel_origin=origin, frames=frames,
                      sync_frame=sync, calibration=calib, channel=channel, target=target,
                      exclude_frames=exclude, manual_points=manual,
                      manual_points_text=manual_text, manual_points_read=manual_read)


def check_parallax(ck, views):
    """Refuse two calibrated views whose cameras stand in one place (no parallax).

    Two cameras with the same centre see every point along the same ray: nothing can
    be triangulated (a DLT copied from one view to another does this). The centres are
    compared relative to their distance from the calibration frame's origin
    (:data:`MIN_BASELINE_RATIO`).

    Parameters
    ----------
    ck : vidtrack.scene._check._Checker
    views : dict of str to CameraView

    Raises
    ------
    SceneError
        Naming both views, their centres and what was expected.
    """
    import numpy as np

    names = list(views)
    for j, b in enumerate(names):
        for a in names[:j]:
            ca, cb = views[a].camera.centre, views[b].camera.centre
            if not (np.all(np.isfinite(ca)) and np.all(np.isfinite(cb))):
                continue        # a camera at infinity (affine) has no centre to compare
            reach = max(float(np.linalg.norm(ca)), float(np.linalg.norm(cb)), 1e-12)
            baseline = float(np.linalg.norm(ca - cb))
            if baseline < MIN_BASELINE_RATIO * reach:
                where = ", ".join(f"{v:.4g}" for v in cb)
                ck.fail(f"views.{b}", f"has its camera centre where views.{a} has its "
                        f"([{where}], {baseline:.3g} apart, {reach:.3g} from the "
                        "calibration origin): no parallax, nothing can be triangulated "
                        "(a camera model copied from one view to the other?); expected "
                        "cameras at different places, each with its own calibration")
