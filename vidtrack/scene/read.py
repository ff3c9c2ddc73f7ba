"""Reading a run's ``scene.toml``: :func:`load_scene` and :func:`parse_scene`.

:func:`load_scene` reads the file and validates it into a frozen
:class:`~vidtrack.scene.model.Scene`; every bad value is refused with a
:class:`~vidtrack.errors.SceneError` that names the file, the key and what was
expected::

    runs/07/scene.toml: views.front.fps must be > 0, got 0

:func:`parse_scene` checks content already parsed (the writer checks with it too):
every table and key, the scale of each view, and the calibration files the views name,
which are read here. Every key is documented in ``docs/scene.md``.
"""

import dataclasses
import difflib
import math
from pathlib import Path

from calibration.errors import InputError
from calibration.scale import M_PER_PX_RANGE
from calibration.views import parse_axes
from vidtrack.errors import SceneError
from vidtrack.scene.cameras import check_parallax, parse_camera_view, parse_world
from vidtrack.scene.corrections import parse_exclude, parse_manual_points, parse_target
from vidtrack.scene._check import (
    _canonical_hash,
    _Checker,
    _read_toml,
    _resolve,
    _show,
    _type_name,
)
from vidtrack.scene.model import (
    _TOP_KEYS,
    _VIEW_KEYS,
    AIR_DENSITY_KG_M3,
    AIR_DENSITY_RANGE_KG_M3,
    AREA_RANGE_M2,
    CAMERA_DISTANCE_RANGE_M,
    CHANNELS,
    CP_MAX_S_PER_M,
    CP_TOLERANCE,
    DRAG_COEFFICIENT_RANGE,
    FPS_RANGE,
    GRAVITY_M_S2,
    GRAVITY_RANGE_M_S2,
    MASS_RANGE_KG,
    MAX_ABS_FACTOR,
    MAX_SCALE_REL_UNCERTAINTY,
    PX_UNCERTAINTY_RANGE,
    RULER_PX_UNCERTAINTY,
    SCENE_FILE,
    SCHEMA,
    SPEED_RANGE_KMH,
    UNCERTAINTY_KEYS,
    VIEW_AXES,
    VIEW_NAME,
    Physics,
    Ruler,
    Scene,
    Straw,
    ViewSpec,
)


def _parse_factors(ck, data):
    table = ck.table(data, "factors", "factors")
    if table is None:
        return {}
    out = {}
    for key, value in table.items():
        if isinstance(value, bool) or not isinstance(value, (int, float, str)):
            ck.fail(f"factors.{key}", "must be a number or a string, got "
                    f"{_type_name(value)} {_show(value)}")
        if isinstance(value, float) and not math.isfinite(value):
            ck.fail(f"factors.{key}", f"must be a finite number, got {value}")
        if isinstance(value, (int, float)) and abs(value) > MAX_ABS_FACTOR:
            ck.fail(f"factors.{key}", f"must be within +-{MAX_ABS_FACTOR:g} (a setting in "
                    f"natural units; larger ones overflow the analysis), got {value:g}")
        out[key] = value
    return out


def _parse_straw(ck, data, physics):
    table = ck.table(data, "straw", "straw")
    if table is None:
        return Straw(gravity_m_s2=physics.gravity_m_s2,
                     air_density_kg_m3=physics.air_density_kg_m3)
    ck.keys(table, ("mass_kg", "area_m2", "drag_coefficient", "cp_s_per_m"), "straw")
    straw = Straw(
        mass_kg=ck.number(table, "mass_kg", "straw.mass_kg", gt=0,
                          within=(*MASS_RANGE_KG, "kg")),
        area_m2=ck.number(table, "area_m2", "straw.area_m2", gt=0,
                          within=(*AREA_RANGE_M2, "m^2")),
        drag_coefficient=ck.number(table, "drag_coefficient", "straw.drag_coefficient", ge=0,
                                   within=(*DRAG_COEFFICIENT_RANGE, "(dimensionless)")),
        cp_given_s_per_m=ck.number(table, "cp_s_per_m", "straw.cp_s_per_m", ge=0),
        gravity_m_s2=physics.gravity_m_s2, air_density_kg_m3=physics.air_density_kg_m3,
    )
    given, computed = straw.cp_given_s_per_m, straw.cp_computed_s_per_m
    for cp, key in ((given, "straw.cp_s_per_m"), (computed, "straw.mass_kg")):
        if cp is not None and not cp <= CP_MAX_S_PER_M:
            how = ("" if key == "straw.cp_s_per_m" else " (Cp = sqrt(C a_s rho / (2 m g)) "
                   "from straw.mass_kg, straw.area_m2, straw.drag_coefficient and [physics])")
            ck.fail(key, f"gives Cp = {cp:.4g} s/m{how}; expected Cp <= {CP_MAX_S_PER_M:g} "
                    "s/m (a straw: about 0.1)")
    if given is not None and computed is not None:
        ref = max(given, computed)
        if ref > 0 and abs(given - computed) > CP_TOLERANCE * ref:
            ck.fail("straw.cp_s_per_m", f"= {given} disagrees with sqrt(C a_s rho / (2 m g)) "
                    f"= {computed:.6g} from straw.mass_kg, straw.area_m2, "
                    "straw.drag_coefficient and [physics]; give Cp or the three, not both")
    return straw


def _parse_scale(ck, view, path, folder):
    """The view's scale, camera and the raw entries (ruler, m_per_px, calibration)."""
    from calibration.scale import Scale, given_scale, ruler_scale

    ruler = None
    if "ruler" in view:
        r = view["ruler"]
        rp = f"{path}.ruler"
        if not isinstance(r, dict):
            ck.fail(rp, "must be a table { length_m = ..., from_px = [u, v], to_px = [u, v] }, "
                    f"got {_type_name(r)} {_show(r)}")
        ck.keys(r, ("length_m", "from_px", "to_px", "px_uncertainty"), rp)
        ruler = Ruler(length_m=ck.number(r, "length_m", f"{rp}.length_m", required=True, gt=0),
                      from_px=ck.pair(r, "from_px", f"{rp}.from_px", required=True),
                      to_px=ck.pair(r, "to_px", f"{rp}.to_px", required=True),
                      px_uncertainty=ck.number(
                          r, "px_uncertainty", f"{rp}.px_uncertainty",
                          default=RULER_PX_UNCERTAINTY, ge=0,
                          within=(*PX_UNCERTAINTY_RANGE, "px (each end's standard "
                                  "uncertainty)")))
        if ruler.from_px == ruler.to_px:
            ck.fail(rp, f"spans 0 pixels: from_px {list(ruler.from_px)} equals to_px "
                    f"{list(ruler.to_px)}; expected two different points")
    m_given = ck.number(view, "m_per_px", f"{path}.m_per_px", gt=0,
                        within=(*M_PER_PX_RANGE, "m per pixel"))
    calib_text = ck.string(view, "calibration", f"{path}.calibration")
    if ruler is not None and m_given is not None:
        ck.fail(path, "gives two scales (ruler and m_per_px); expected one of them")

    camera = file_scale = calib_path = None
    if calib_text is not None:
        calib_path = _resolve(folder, calib_text) if folder is not None else Path(calib_text)
        if folder is not None:
            from calibration.calibration_file import load_calibration

            if not calib_path.is_file():
                ck.fail(f"{path}.calibration", f"names {calib_text!r}, but there is no such "
                        f"file ({calib_path})")
            try:
                content = load_calibration(calib_path)
            except InputError as exc:
                ck.fail(f"{path}.calibration", f"({calib_text}): {exc}")
            camera, file_scale = content.camera, content.scale
            if file_scale is not None and (ruler is not None or m_given is not None):
                ck.fail(path, f"gives two scales: {calib_text} has a [scale] table and the "
                        f"view has {'ruler' if ruler is not None else 'm_per_px'}; "
                        "expected one of them")

    if ruler is not None:
        a, b = ruler.from_px, ruler.to_px
        if camera is not None:
            from calibration.camera import undistort_points

            a, b = (tuple(p) for p in undistort_points([a, b], camera))
        try:
            scale = ruler_scale(ruler.length_m, a, b)
        except InputError as exc:
            ck.fail(f"{path}.ruler", str(exc))
        scale = Scale(m_per_px=scale.m_per_px, method="ruler", length_m=ruler.length_m,
                      from_px=ruler.from_px, to_px=ruler.to_px, span_px=scale.span_px)
        rel = math.sqrt(2.0) * ruler.px_uncertainty / scale.span_px
        # (a stated uncertainty that makes the scale meaningless is refused; the default
        # half pixel on a short ruler is carried into the intervals as it is)
        if rel > MAX_SCALE_REL_UNCERTAINTY and ruler.px_uncertainty != RULER_PX_UNCERTAINTY:
            ck.fail(f"{path}.ruler.px_uncertainty", f"= {ruler.px_uncertainty:g} px on a ruler "
                    f"of {scale.span_px:.4g} px gives a scale uncertain by {100 * rel:.3g} % "
                    f"(sqrt(2) x {ruler.px_uncertainty:g} / {scale.span_px:.4g}); expected at "
                    f"most {100 * MAX_SCALE_REL_UNCERTAINTY:g} %: read the ends more closely "
                    "or use a longer ruler")
    elif m_given is not None:
        scale = given_scale(m_given)
    elif file_scale is not None:
        scale = file_scale
    elif calib_text is not None and folder is None:
        scale = None  # checked when written into a folder
    elif calib_text is not None:
        ck.fail(path, f"needs a scale: {calib_text} has no [scale] table, so give ruler or "
                "m_per_px as well")
    else:
        ck.fail(path, "needs a scale: expected ruler = { length_m, from_px, to_px }, "
                "m_per_px, or calibration = \"FILE\"")
    return scale, ruler, m_given, calib_path, calib_text, camera


def _scale_rel_uncertainty(ck, view, path, ruler):
    """A view's ``m_per_px_rel_uncertainty`` (None when not given)."""
    key = f"{path}.m_per_px_rel_uncertainty"
    rel = ck.number(view, "m_per_px_rel_uncertainty", key, ge=0,
                    within=(0.0, MAX_SCALE_REL_UNCERTAINTY,
                            "(a relative standard uncertainty, e.g. 0.005 for 0.5 %)"))
    if rel is not None and ruler is not None:
        ck.fail(key, f"is for a scale given directly (m_per_px or a calibration file's "
                "[scale]); a ruler's uncertainty is its ends': give "
                f"{path}.ruler.px_uncertainty (px) instead")
    return rel


def _frames_and_sync(ck, view, path):
    """A view's ``frames`` range and ``sync_frame``."""
    frames = None
    if "frames" in view:
        fr = view["frames"]
        if not isinstance(fr, list) or len(fr) != 2 or any(
                isinstance(v, bool) or not isinstance(v, int) for v in fr):
            ck.fail(f"{path}.frames", "must be two integers [first, end) of 0-based frame "
                    f"indices, got {_show(fr)}")
        if fr[0] < 0 or fr[1] <= fr[0]:
            ck.fail(f"{path}.frames", "must be a non-empty range [first, end) with "
                    f"0 <= first < end, got {_show(fr)}")
        frames = (fr[0], fr[1])
    sync = view.get("sync_frame", "auto")
    if not (sync == "auto" and isinstance(sync, str)):
        if isinstance(sync, bool) or not isinstance(sync, int):
            ck.fail(f"{path}.sync_frame", "must be a frame index (an integer >= 0) or \"auto\", "
                    f"got {_type_name(sync)} {_show(sync)}")
        if sync < 0:
            ck.fail(f"{path}.sync_frame", f"must be >= 0 (a 0-based frame index), got {sync}")
    return frames, sync


def _parse_target(ck, view, path, frames):
    """A view's ``target`` (:func:`vidtrack.scene.corrections.parse_target`)."""
    return parse_target(ck, view, path, frames)


def _parse_view(ck, name, view, folder):
    path = f"views.{name}"
    if not isinstance(view, dict):
        ck.fail(path, f"must be a table, got {_type_name(view)} {_show(view)}")
    ck.keys(view, _VIEW_KEYS, path)
    source_text = ck.string(view, "source", f"{path}.source", required=True,
                            what="the footage (video file, image folder or .cine), e.g. "
                                 f"\"{name}.avi\"")
    fps = ck.number(view, "fps", f"{path}.fps", required=True, gt=0,
                    within=(*FPS_RANGE, "frames/s"),
                    what="the capture rate in frames/s, e.g. 1200")
    if "axes" not in view:
        ck.fail(f"{path}.axes", f"is required: the world axes along image column and row, "
                f"e.g. {_example_axes(name)}")
    try:
        axes = parse_axes(view["axes"])
    except InputError as exc:
        ck.fail(f"{path}.axes", str(exc).removeprefix("axes "))
    want = VIEW_AXES[name]
    if tuple(sorted(a[1] for a in axes)) != want:
        ck.fail(f"{path}.axes", f"must be the world axes {want[0]} and {want[1]} (the {name} "
                f"view sees {want[0].upper()} and {want[1].upper()}), got {_show(list(axes))}")
    origin = ck.pair(view, "origin_px", f"{path}.origin_px", required=True,
                     what="[u, v]: the pixel of the world origin O")
    scale, ruler, m_given, calib_path, calib_text, camera = _parse_scale(ck, view, path, folder)
    rel = _scale_rel_uncertainty(ck, view, path, ruler)
    distance = ck.number(view, "camera_distance_m", f"{path}.camera_distance_m", gt=0,
                         within=(*CAMERA_DISTANCE_RANGE_M, "m"))

    frames, sync = _frames_and_sync(ck, view, path)
    channel = ck.choice(view, "channel", f"{path}.channel", CHANNELS, default="luma")
    target = _parse_target(ck, view, path, frames)
    exclude = parse_exclude(ck, view, path, frames)
    manual, manual_text, manual_read = parse_manual_points(ck, view, path, folder, frames,
                                                           exclude)
    source = _resolve(folder, source_text) if folder is not None else Path(source_text)
    return ViewSpec(name=name, source=source, source_text=source_text, fps=fps, axes=axes,
                    origin_px=origin, scale=scale, ruler=ruler, m_per_px_given=m_given,
                    calibration=calib_path, calibration_text=calib_text, camera=camera,
                    frames=frames, sync_frame=sync, channel=channel,
                    camera_distance_m=distance, target=target, exclude_frames=exclude,
                    manual_points=manual, manual_points_text=manual_text,
                    manual_points_read=manual_read,
                    m_per_px_rel_uncertainty=rel)


def _example_axes(name):
    return '["+x", "-y"]' if name == "front" else '["+x", "+z"]'


def parse_scene(data, *, folder, label=SCENE_FILE, path=None):
    """Validate a parsed scene (a dict as ``tomllib`` gives it).

    Parameters
    ----------
    data : dict
        The scene's content.
    folder : str, pathlib.Path or None
        The run folder: sources and calibration files resolve against it, and the run
        name defaults to its name. None checks everything that does not need files
        (calibration files are not read then).
    label : str
        How the file is named in messages.
    path : pathlib.Path, optional
        The scene file (default ``folder / "scene.toml"``).

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        Unknown or missing keys, wrong types, impossible values; the message names
        ``label``, the key path and what was expected.
    """
    ck = _Checker(label)
    if not isinstance(data, dict):
        ck.fail("", "expected a TOML document")
    ck.keys(data, _TOP_KEYS, "")
    if "schema" not in data:
        ck.fail("schema", f"is required: write schema = {SCHEMA} as the first line")
    if isinstance(data["schema"], bool) or data["schema"] != SCHEMA:
        ck.fail("schema", f"must be {SCHEMA} (this vidtrack reads scene.toml schema {SCHEMA}), "
                f"got {_show(data['schema'])}")
    folder = Path(folder) if folder is not None else None

    run = ck.table(data, "run", "run") or {}
    ck.keys(run, ("name",), "run")
    default_name = folder.resolve().name if folder is not None else ""
    run_name = ck.string(run, "name", "run.name", default=default_name)

    factors = _parse_factors(ck, data)

    phys = ck.table(data, "physics", "physics") or {}
    ck.keys(phys, ("gravity_m_s2", "air_density_kg_m3"), "physics")
    physics = Physics(
        gravity_m_s2=ck.number(phys, "gravity_m_s2", "physics.gravity_m_s2",
                               default=GRAVITY_M_S2, gt=0,
                               within=(*GRAVITY_RANGE_M_S2, "m/s^2")),
        air_density_kg_m3=ck.number(phys, "air_density_kg_m3", "physics.air_density_kg_m3",
                                    default=AIR_DENSITY_KG_M3, ge=0,
                                    within=(*AIR_DENSITY_RANGE_KG_M3, "kg/m^3")),
    )
    straw = _parse_straw(ck, data, physics)
    track = _parse_track(ck, data)

    machine = ck.table(data, "machine", "machine") or {}
    ck.keys(machine, ("speed_kmh",), "machine")
    speed = ck.number(machine, "speed_kmh", "machine.speed_kmh", ge=0,
                      within=(*SPEED_RANGE_KMH, "km/h"))
    speed_from = "machine"
    if speed is None and "speed_kmh" in factors:
        speed = ck.number(factors, "speed_kmh", "factors.speed_kmh", ge=0,
                          within=(*SPEED_RANGE_KMH, "km/h"))
        speed_from = "factors"
    if speed is None:
        speed, speed_from = 0.0, "default"

    views_table = ck.table(data, "views", "views")
    if views_table is None:
        ck.fail("views", "is required: a [views.front] and/or a [views.top] table")
    world = parse_world(ck, data)
    if world is None:
        for name, view in views_table.items():
            if isinstance(view, dict) and ("dlt" in view or "projection" in view):
                ck.fail("world", "is required with calibrated cameras (views."
                        f"{name} has {'dlt' if 'dlt' in view else 'projection'}): "
                        "[world] up = [x, y, z], the calibration frame's vertical")
    else:
        if len(views_table) < 2:
            ck.fail("views", "calibrated cameras need two or more views (one view cannot "
                    f"place a point in 3-D), got {len(views_table)}")
        for name in views_table:
            if not VIEW_NAME.fullmatch(name):
                ck.fail(f"views.{_show(name)}", "is not a usable view name: it names output "
                        "files (overlay_<view>.mp4) and columns; expected a letter or digit "
                        "then letters, digits, _ or - (at most 64), e.g. cam1")
        views = {name: parse_camera_view(ck, name, view, folder, fps_range=FPS_RANGE,
                                         frames_and_sync=_frames_and_sync)
                 for name, view in views_table.items()}
        check_parallax(ck, views)
    for name in (views_table if world is None else ()):
        if name not in VIEW_AXES:
            near = difflib.get_close_matches(name, list(VIEW_AXES), n=1)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            ck.fail(f"views.{name}", f"is not a view name{hint}; expected front or top")
    if not views_table:
        ck.fail("views", "must have a front or a top view (or both), got none")
    if world is None:
        views = {name: _parse_view(ck, name, views_table[name], folder)
                 for name in ("front", "top") if name in views_table}

    scene = Scene(path=Path(path) if path is not None else
                  (folder / SCENE_FILE if folder is not None else Path(SCENE_FILE)),
                  folder=folder if folder is not None else Path("."),
                  run_name=run_name, factors=factors, physics=physics, straw=straw,
                  machine_speed_kmh=speed, machine_speed_from=speed_from, views=views,
                  world=world, track=track)
    return dataclasses.replace(scene, hash=scene_digest(scene))


def scene_digest(scene):
    """The ``hash`` of a :class:`Scene`: sha256 of its content (:meth:`Scene.to_dict`) and
    of the calibration files its views name."""
    calib = {name: {"camera": v.camera.to_dict() if v.camera is not None else None,
                    "scale": v.scale.to_dict() if v.scale is not None else None}
             for name, v in scene.views.items()
             if v.calibration is not None and scene.world is None}
    # the scales' uncertainties change the fit's intervals, not the tracks: out of the hash
    # (the fit stage's key holds them), so stating one does not track the footage again
    return _canonical_hash({"scene": _without_uncertainties(scene.to_dict()),
                            "calibration": calib})


def _without_uncertainties(content):
    """``content`` (:meth:`Scene.to_dict`) without the keys of :data:`UNCERTAINTY_KEYS`."""
    if isinstance(content, dict):
        return {k: _without_uncertainties(v) for k, v in content.items()
                if k not in UNCERTAINTY_KEYS}
    return content


def _parse_track(ck, data):
    """``[track]``: the tracker (``engine``, a string) and its settings (numbers), as
    given; ``{}`` if absent. Which engines and settings exist is the tracker's to say
    (:func:`vidtrack.run.preflight.prepare_run` checks them before anything is tracked)."""
    table = ck.table(data, "track", "track")
    if not table:
        return {}
    for key, value in table.items():
        if key == "engine":
            if not isinstance(value, str):
                ck.fail("track.engine", f"must be a string (\"rules\" or \"flight\"), got "
                        f"{_show(value)}")
        elif isinstance(value, bool) or not isinstance(value, (int, float)):
            ck.fail(f"track.{key}", f"must be a number, got {_show(value)}")
    return dict(table)


def _scene_path(run_dir_or_toml):
    p = Path(run_dir_or_toml)
    if p.is_dir():
        toml = p / SCENE_FILE
        if not toml.is_file():
            raise SceneError(f"{p}: no {SCENE_FILE} in this run folder")
        return toml
    if not p.exists():
        raise SceneError(f"{p}: no such run folder or scene file")
    return p


def load_scene(run_dir_or_toml):
    """Read and validate a run's ``scene.toml`` (schema 1).

    Parameters
    ----------
    run_dir_or_toml : str or pathlib.Path
        The run folder (holding ``scene.toml``) or the scene file itself.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        A missing or unreadable file, invalid TOML, unknown or missing keys, wrong
        types, impossible values, a calibration file that is missing or invalid. The
        message names the file (as given), the key path and what was expected, e.g.
        ``run42/scene.toml: views.front.fps must be > 0, got 0``.

    Notes
    -----
    Sources are resolved against the run folder but not opened here (a run with
    ``throws/`` has its sources in each throw's folder: :meth:`ViewSpec.source_in`).
    Calibration files named by a view are read and validated here.
    """
    path = _scene_path(run_dir_or_toml)
    data = _read_toml(path)
    return parse_scene(data, folder=path.parent, label=str(path), path=path)
