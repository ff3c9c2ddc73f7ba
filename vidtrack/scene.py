"""``scene.toml`` (schema 1) and ``experiment.toml``: read, validate, write.

A run folder's ``scene.toml`` says where the footage is, at what capture rate, how its
pixels map to the world frame (axes, origin, scale), and what straw and machine the run
had (SPEC.md "scene.toml"). :func:`load_scene` reads and validates it into a frozen
:class:`Scene`; every bad value is refused with a :class:`~vidtrack.errors.SceneError`
that names the file, the key and what was expected::

    runs/07/scene.toml: views.front.fps must be > 0, got 0

:func:`write_scene` is the writer (used by ``vidtrack synth``): it validates the same
way before writing, so what is written is what the loader reads. :func:`load_experiment`
reads an experiment folder's ``experiment.toml``. Every key is documented in
``docs/scene.md``.
"""

import dataclasses
import difflib
import hashlib
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from calibration.errors import InputError
from calibration.views import parse_axes
from vidtrack.errors import SceneError

__all__ = [
    "Scene", "ViewSpec", "Ruler", "Physics", "Straw", "Experiment", "Factor",
    "load_scene", "parse_scene", "scene_to_toml", "write_scene", "load_experiment",
    "find_throw_dirs", "SCENE_FILE", "EXPERIMENT_FILE", "SCHEMA", "VIEW_AXES",
]

SCENE_FILE = "scene.toml"
EXPERIMENT_FILE = "experiment.toml"
#: The scene.toml and experiment.toml schema this module reads and writes.
SCHEMA = 1
#: The world axes each view sees (SPEC "Views").
VIEW_AXES = {"front": ("x", "y"), "top": ("x", "z")}

GRAVITY_M_S2 = 9.80665
AIR_DENSITY_KG_M3 = 1.205
#: Largest relative difference accepted between a given Cp and the one computed from
#: the straw's mass, area and drag coefficient when both are in the file.
CP_TOLERANCE = 0.01

_TOP_KEYS = ("schema", "run", "factors", "physics", "straw", "machine", "views")
_VIEW_KEYS = ("source", "fps", "axes", "origin_px", "ruler", "m_per_px", "calibration",
              "frames", "sync_frame")


# --------------------------------------------------------------------------- results


@dataclass(frozen=True)
class Physics:
    """``[physics]``: gravity and air density.

    Attributes
    ----------
    gravity_m_s2 : float
        g in m/s^2 (default 9.80665).
    air_density_kg_m3 : float
        rho in kg/m^3 (default 1.205, air at 20 degC).
    """

    gravity_m_s2: float = GRAVITY_M_S2
    air_density_kg_m3: float = AIR_DENSITY_KG_M3

    def to_dict(self):
        """The ``[physics]`` table."""
        return {"gravity_m_s2": self.gravity_m_s2, "air_density_kg_m3": self.air_density_kg_m3}


@dataclass(frozen=True)
class Straw:
    """``[straw]``: what fixes the drag parameter Cp.

    Attributes
    ----------
    mass_kg, area_m2, drag_coefficient : float or None
        m (kg), the average characteristic area a_s (m^2) and C, as given.
    cp_given_s_per_m : float or None
        Cp as given directly (``cp_s_per_m`` in the file).
    gravity_m_s2, air_density_kg_m3 : float
        g and rho from ``[physics]``, which Cp depends on.
    """

    mass_kg: float | None = None
    area_m2: float | None = None
    drag_coefficient: float | None = None
    cp_given_s_per_m: float | None = None
    gravity_m_s2: float = GRAVITY_M_S2
    air_density_kg_m3: float = AIR_DENSITY_KG_M3

    @property
    def cp_computed_s_per_m(self):
        """Cp = sqrt(C a_s rho / (2 m g)) in s/m from the straw's data, or None."""
        if None in (self.mass_kg, self.area_m2, self.drag_coefficient):
            return None
        return math.sqrt(self.drag_coefficient * self.area_m2 * self.air_density_kg_m3
                         / (2.0 * self.mass_kg * self.gravity_m_s2))

    @property
    def cp_s_per_m(self):
        """The drag parameter Cp in s/m (MODEL.md section 1): given, else computed.

        None when neither ``cp_s_per_m`` nor all of mass, area and drag coefficient are
        in the file (see :attr:`cp_missing`).
        """
        if self.cp_given_s_per_m is not None:
            return self.cp_given_s_per_m
        return self.cp_computed_s_per_m

    @property
    def cp_missing(self):
        """Why Cp is unknown (a sentence), or None when it is known."""
        if self.cp_s_per_m is not None:
            return None
        lacking = [k for k, v in (("mass_kg", self.mass_kg), ("area_m2", self.area_m2),
                                  ("drag_coefficient", self.drag_coefficient)) if v is None]
        return ("Cp unknown: scene.toml gives neither straw.cp_s_per_m nor "
                + ", ".join(f"straw.{k}" for k in lacking))

    def to_dict(self):
        """The ``[straw]`` table: only the keys that were given."""
        out = {}
        for key, value in (("mass_kg", self.mass_kg), ("area_m2", self.area_m2),
                           ("drag_coefficient", self.drag_coefficient),
                           ("cp_s_per_m", self.cp_given_s_per_m)):
            if value is not None:
                out[key] = value
        return out


@dataclass(frozen=True)
class Ruler:
    """A ruler in a view: ``length_m`` spans ``from_px`` .. ``to_px`` (raw pixels)."""

    length_m: float
    from_px: tuple
    to_px: tuple

    def to_dict(self):
        """The ``ruler`` inline table."""
        return {"length_m": self.length_m, "from_px": list(self.from_px),
                "to_px": list(self.to_px)}


@dataclass(frozen=True)
class ViewSpec:
    """One ``[views.NAME]`` table, validated.

    Attributes
    ----------
    name : str
        ``"front"`` (sees X, Y) or ``"top"`` (sees X, Z).
    source : pathlib.Path
        The footage (video file, image folder or .cine), resolved against the run
        folder.
    source_text : str
        ``source`` as written in the file (relative paths resolve against the run
        folder, or against a throw folder: :meth:`source_in`).
    fps : float
        Capture rate in frames/s (> 0); wins over any rate the container states.
    axes : tuple of str
        World axis along increasing image column, then row (``("+x", "-y")``).
    origin_px : tuple of float
        Pixel (u, v) of the world origin O in the raw image.
    ruler : Ruler or None
        The ruler, when the scale is given by one.
    m_per_px_given : float or None
        ``m_per_px`` as written, when the scale is given directly.
    calibration : pathlib.Path or None
        The calibration file named, resolved against the run folder.
    camera : calibration.CameraCalibration or None
        Intrinsics and distortion from that file, when it has a ``[camera]`` table.
    scale : calibration.Scale
        The scale in effect (from the ruler, ``m_per_px`` or the calibration file). A
        ruler is measured in undistorted pixels when there is a camera.
    frames : tuple of int or None
        Half-open range ``(first, end)`` of 0-based frame indices to use; None: all.
    sync_frame : int or str
        Frame of this view at which t = 0, or ``"auto"`` (find it).
    """

    name: str
    source: Path
    source_text: str
    fps: float
    axes: tuple
    origin_px: tuple
    scale: object
    ruler: Ruler | None = None
    m_per_px_given: float | None = None
    calibration: Path | None = None
    calibration_text: str | None = None
    camera: object = None
    frames: tuple | None = None
    sync_frame: object = "auto"

    @property
    def m_per_px(self):
        """Metres per (undistorted) pixel on the view's world plane."""
        return self.scale.m_per_px

    @property
    def world_axes(self):
        """The two world axes this view sees, in world order (``("x", "y")``)."""
        return VIEW_AXES[self.name]

    def mapping(self):
        """The view's pixel <-> world mapping (:class:`calibration.ViewMapping`)."""
        from calibration.views import ViewMapping

        return ViewMapping(axes=self.axes, origin_px=self.origin_px,
                           m_per_px=self.m_per_px, camera=self.camera)

    def source_in(self, folder):
        """The source of this view inside ``folder`` (a throw's subfolder).

        Parameters
        ----------
        folder : str or pathlib.Path
            A throw folder (``<run>/throws/01``) or the run folder.

        Returns
        -------
        pathlib.Path
            ``folder / source_text`` (an absolute ``source_text`` is kept as it is).
        """
        return Path(folder) / self.source_text

    def to_dict(self):
        """The ``[views.NAME]`` table as it would be written."""
        out = {"source": self.source_text, "fps": self.fps, "axes": list(self.axes),
               "origin_px": list(self.origin_px)}
        if self.ruler is not None:
            out["ruler"] = self.ruler.to_dict()
        if self.m_per_px_given is not None:
            out["m_per_px"] = self.m_per_px_given
        if self.calibration_text is not None:
            out["calibration"] = self.calibration_text
        if self.frames is not None:
            out["frames"] = list(self.frames)
        out["sync_frame"] = self.sync_frame
        return out


@dataclass(frozen=True)
class Scene:
    """A validated ``scene.toml`` (schema 1).

    Attributes
    ----------
    path : pathlib.Path
        The scene file.
    folder : pathlib.Path
        The run folder (the file's folder).
    run_name : str
        ``run.name``, default the folder's name.
    factors : dict
        ``[factors]``: free names to numbers or strings, in the file's order.
    physics : Physics
    straw : Straw
    machine_speed_kmh : float
        Travel speed v1 in km/h: ``machine.speed_kmh``, else ``factors.speed_kmh``,
        else 0.
    machine_speed_from : str
        Where it came from: ``"machine"``, ``"factors"`` or ``"default"``.
    views : dict of str to ViewSpec
        ``"front"`` and/or ``"top"``.
    hash : str
        sha256 (hex) of the scene's canonical content (:meth:`to_dict` as sorted JSON)
        and of the content of every calibration file it names: it changes exactly when
        something that affects the results changes, not with comments or layout.
    """

    path: Path
    folder: Path
    run_name: str
    factors: dict
    physics: Physics
    straw: Straw
    machine_speed_kmh: float
    machine_speed_from: str
    views: dict
    hash: str = field(default="", compare=False)

    @property
    def v1_m_s(self):
        """The machine's travel speed v1 in m/s (SPEC "World frame")."""
        return self.machine_speed_kmh / 3.6

    @property
    def cp_s_per_m(self):
        """The drag parameter Cp in s/m, or None when the scene does not fix it."""
        return self.straw.cp_s_per_m

    @property
    def view_names(self):
        """The views present, ``front`` before ``top``."""
        return tuple(v for v in ("front", "top") if v in self.views)

    def throw_dirs(self):
        """Replicate throws of this run; see :func:`find_throw_dirs`."""
        return find_throw_dirs(self.folder)

    def to_dict(self):
        """The scene as a schema-1 dict with defaults filled in.

        ``write_scene(folder, scene.to_dict())`` writes a file that loads back to an
        equal :class:`Scene`.
        """
        out = {"schema": SCHEMA, "run": {"name": self.run_name}}
        if self.factors:
            out["factors"] = dict(self.factors)
        out["physics"] = self.physics.to_dict()
        straw = self.straw.to_dict()
        if straw:
            out["straw"] = straw
        if self.machine_speed_from == "machine":
            out["machine"] = {"speed_kmh": self.machine_speed_kmh}
        out["views"] = {name: self.views[name].to_dict() for name in self.view_names}
        return out


@dataclass(frozen=True)
class Factor:
    """One factor of an experiment: coded = (natural - centre) / step."""

    letter: str
    name: str
    centre: float | None = None
    step: float | None = None

    def code(self, natural):
        """Coded level of a natural value (needs centre and step)."""
        if self.centre is None or self.step is None:
            raise SceneError(f"factor {self.letter} ({self.name}) has no centre/step to code by")
        return (natural - self.centre) / self.step

    def to_dict(self):
        """The ``[factors.LETTER]`` table."""
        out = {"name": self.name}
        if self.centre is not None:
            out["centre"] = self.centre
        if self.step is not None:
            out["step"] = self.step
        return out


@dataclass(frozen=True)
class Experiment:
    """A validated ``experiment.toml`` (SPEC "Experiment folder").

    Attributes
    ----------
    path, folder : pathlib.Path
        The file and the experiment folder.
    design : str
        ``"ccd"`` (central composite) or ``"orthogonal"`` (orthogonal array).
    responses : tuple of str
        Responses to analyse (``"k1"`` ...).
    runs : str
        Glob of the run folders, relative to the experiment folder.
    factors : dict of str to Factor
        By letter (``"A"``, ``"B"``, ...), in the file's order.
    hash : str
        sha256 of the canonical content.
    """

    path: Path
    folder: Path
    design: str
    responses: tuple
    runs: str
    factors: dict
    hash: str = field(default="", compare=False)

    def run_dirs(self):
        """The run folders the ``runs`` glob matches, in natural order (2 before 10).

        Raises
        ------
        SceneError
            The glob matches no folder, or a matched folder has no scene.toml.
        """
        found = sorted((p for p in self.folder.glob(self.runs) if p.is_dir()),
                       key=lambda p: _natural_key(str(p.relative_to(self.folder))))
        if not found:
            raise SceneError(f"{self.path}: runs = {self.runs!r} matches no run folder "
                             f"in {self.folder}")
        for p in found:
            if not (p / SCENE_FILE).is_file():
                raise SceneError(f"{self.path}: run folder {p} (matched by runs = "
                                 f"{self.runs!r}) has no {SCENE_FILE}")
        return found

    def to_dict(self):
        """The experiment as a schema-1 dict."""
        return {"schema": SCHEMA, "design": self.design, "responses": list(self.responses),
                "runs": self.runs,
                "factors": {k: f.to_dict() for k, f in self.factors.items()}}


# --------------------------------------------------------------------------- checks


def _natural_key(text):
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", text)]


def _show(value):
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, (list, dict)):
        return json.dumps(value, default=str)
    return repr(value)


def _type_name(value):
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
            list: "an array", dict: "a table"}.get(type(value), type(value).__name__)


class _Checker:
    """Validation helpers that raise SceneError with the file label and key path."""

    def __init__(self, label):
        self.label = label

    def fail(self, key, message):
        where = f"{key} " if key else ""
        raise SceneError(f"{self.label}: {where}{message}")

    def keys(self, table, allowed, path):
        for key in table:
            if key not in allowed:
                near = difflib.get_close_matches(key, allowed, n=1)
                hint = f" (did you mean {near[0]!r}?)" if near else ""
                full = f"{path}.{key}" if path else key
                self.fail(full, f"is not a known key{hint}; expected one of: "
                          + ", ".join(allowed))

    def table(self, data, key, path, *, required=False):
        if key not in data:
            if required:
                self.fail(path, "is required")
            return None
        value = data[key]
        if not isinstance(value, dict):
            self.fail(path, f"must be a table, got {_type_name(value)} {_show(value)}")
        return value

    def number(self, table, key, path, *, required=False, default=None, gt=None, ge=None,
               what=None):
        if key not in table:
            if required:
                self.fail(path, f"is required: {what}" if what else "is required")
            return default
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"must be a number, got {_type_name(value)} {_show(value)}")
        if not math.isfinite(value):
            self.fail(path, f"must be a finite number, got {value}")
        if gt is not None and not value > gt:
            self.fail(path, f"must be > {gt}, got {value}")
        if ge is not None and not value >= ge:
            self.fail(path, f"must be >= {ge}, got {value}")
        return float(value)

    def string(self, table, key, path, *, required=False, default=None, what=None):
        if key not in table:
            if required:
                self.fail(path, f"is required: {what}" if what else "is required")
            return default
        value = table[key]
        if not isinstance(value, str):
            self.fail(path, f"must be a string, got {_type_name(value)} {_show(value)}")
        if not value.strip():
            self.fail(path, "must not be empty")
        return value

    def pair(self, table, key, path, *, required=False, what="[u, v] in pixels"):
        if key not in table:
            if required:
                self.fail(path, f"is required: two numbers {what}")
            return None
        value = table[key]
        if not isinstance(value, list) or len(value) != 2 or any(
                isinstance(v, bool) or not isinstance(v, (int, float)) for v in value):
            self.fail(path, f"must be two numbers {what}, got {_show(value)}")
        if not all(math.isfinite(v) for v in value):
            self.fail(path, f"must be two finite numbers {what}, got {_show(value)}")
        return (float(value[0]), float(value[1]))


def _resolve(folder, text):
    p = Path(text)
    return p if p.is_absolute() else Path(folder) / p


# --------------------------------------------------------------------------- scene


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
        out[key] = value
    return out


def _parse_straw(ck, data, physics):
    table = ck.table(data, "straw", "straw")
    if table is None:
        return Straw(gravity_m_s2=physics.gravity_m_s2,
                     air_density_kg_m3=physics.air_density_kg_m3)
    ck.keys(table, ("mass_kg", "area_m2", "drag_coefficient", "cp_s_per_m"), "straw")
    straw = Straw(
        mass_kg=ck.number(table, "mass_kg", "straw.mass_kg", gt=0),
        area_m2=ck.number(table, "area_m2", "straw.area_m2", gt=0),
        drag_coefficient=ck.number(table, "drag_coefficient", "straw.drag_coefficient", ge=0),
        cp_given_s_per_m=ck.number(table, "cp_s_per_m", "straw.cp_s_per_m", ge=0),
        gravity_m_s2=physics.gravity_m_s2, air_density_kg_m3=physics.air_density_kg_m3,
    )
    given, computed = straw.cp_given_s_per_m, straw.cp_computed_s_per_m
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
        ck.keys(r, ("length_m", "from_px", "to_px"), rp)
        ruler = Ruler(length_m=ck.number(r, "length_m", f"{rp}.length_m", required=True, gt=0),
                      from_px=ck.pair(r, "from_px", f"{rp}.from_px", required=True),
                      to_px=ck.pair(r, "to_px", f"{rp}.to_px", required=True))
        if ruler.from_px == ruler.to_px:
            ck.fail(rp, f"spans 0 pixels: from_px {list(ruler.from_px)} equals to_px "
                    f"{list(ruler.to_px)}; expected two different points")
    m_given = ck.number(view, "m_per_px", f"{path}.m_per_px", gt=0)
    calib_text = ck.string(view, "calibration", f"{path}.calibration")
    if ruler is not None and m_given is not None:
        ck.fail(path, "gives two scales (ruler and m_per_px); expected one of them")

    camera = file_scale = calib_path = None
    if calib_text is not None:
        calib_path = _resolve(folder, calib_text) if folder is not None else Path(calib_text)
        if folder is not None:
            from calibration.camera import load_calibration

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


def _parse_view(ck, name, view, folder):
    path = f"views.{name}"
    if not isinstance(view, dict):
        ck.fail(path, f"must be a table, got {_type_name(view)} {_show(view)}")
    ck.keys(view, _VIEW_KEYS, path)
    source_text = ck.string(view, "source", f"{path}.source", required=True,
                            what="the footage (video file, image folder or .cine), e.g. "
                                 f"\"{name}.avi\"")
    fps = ck.number(view, "fps", f"{path}.fps", required=True, gt=0,
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
    source = _resolve(folder, source_text) if folder is not None else Path(source_text)
    return ViewSpec(name=name, source=source, source_text=source_text, fps=fps, axes=axes,
                    origin_px=origin, scale=scale, ruler=ruler, m_per_px_given=m_given,
                    calibration=calib_path, calibration_text=calib_text, camera=camera,
                    frames=frames, sync_frame=sync)


def _example_axes(name):
    return '["+x", "-y"]' if name == "front" else '["+x", "+z"]'


def _canonical_hash(obj):
    text = json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


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
                               default=GRAVITY_M_S2, gt=0),
        air_density_kg_m3=ck.number(phys, "air_density_kg_m3", "physics.air_density_kg_m3",
                                    default=AIR_DENSITY_KG_M3, ge=0),
    )
    straw = _parse_straw(ck, data, physics)

    machine = ck.table(data, "machine", "machine") or {}
    ck.keys(machine, ("speed_kmh",), "machine")
    speed = ck.number(machine, "speed_kmh", "machine.speed_kmh", ge=0)
    speed_from = "machine"
    if speed is None and "speed_kmh" in factors:
        speed = ck.number(factors, "speed_kmh", "factors.speed_kmh", ge=0)
        speed_from = "factors"
    if speed is None:
        speed, speed_from = 0.0, "default"

    views_table = ck.table(data, "views", "views")
    if views_table is None:
        ck.fail("views", "is required: a [views.front] and/or a [views.top] table")
    for name in views_table:
        if name not in VIEW_AXES:
            near = difflib.get_close_matches(name, list(VIEW_AXES), n=1)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            ck.fail(f"views.{name}", f"is not a view name{hint}; expected front or top")
    if not views_table:
        ck.fail("views", "must have a front or a top view (or both), got none")
    views = {name: _parse_view(ck, name, views_table[name], folder)
             for name in ("front", "top") if name in views_table}

    scene = Scene(path=Path(path) if path is not None else
                  (folder / SCENE_FILE if folder is not None else Path(SCENE_FILE)),
                  folder=folder if folder is not None else Path("."),
                  run_name=run_name, factors=factors, physics=physics, straw=straw,
                  machine_speed_kmh=speed, machine_speed_from=speed_from, views=views)
    calib = {name: {"camera": v.camera.to_dict() if v.camera is not None else None,
                    "scale": v.scale.to_dict() if v.scale is not None else None}
             for name, v in views.items() if v.calibration is not None}
    digest = _canonical_hash({"scene": scene.to_dict(), "calibration": calib})
    return dataclasses.replace(scene, hash=digest)


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


def _read_toml(path):
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise SceneError(f"{path}: cannot read ({exc.strerror or exc})") from None
    try:
        return tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: not valid TOML: {exc}") from None


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


def find_throw_dirs(run_dir):
    """The replicate-throw folders of a run: ``<run>/throws/*``, natural order.

    Parameters
    ----------
    run_dir : str or pathlib.Path

    Returns
    -------
    list of pathlib.Path
        Sub-folders of ``throws/`` (hidden ones skipped), 2 before 10; empty when the
        run has no ``throws/`` folder (then the run folder holds the one throw).

    Raises
    ------
    SceneError
        ``throws`` exists but is not a folder, or holds no throw folder.
    """
    throws = Path(run_dir) / "throws"
    if not throws.exists():
        return []
    if not throws.is_dir():
        raise SceneError(f"{throws}: expected a folder of replicate throws (throws/01, "
                         "throws/02, ...), got a file")
    dirs = sorted((p for p in throws.iterdir() if p.is_dir() and not p.name.startswith(".")),
                  key=lambda p: _natural_key(p.name))
    if not dirs:
        raise SceneError(f"{throws}: no throw folders in it (expected throws/01, throws/02, "
                         "... each with its own sources)")
    return dirs


# --------------------------------------------------------------------------- writing


def _plain(obj, path="scene"):
    """Numpy scalars, tuples and paths to what TOML can hold; None entries dropped."""
    if isinstance(obj, dict):
        return {str(k): _plain(v, f"{path}.{k}") for k, v in obj.items() if v is not None}
    if isinstance(obj, (list, tuple)):
        return [_plain(v, path) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_plain(v, path) for v in obj.tolist()]
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return obj.as_posix()
    return obj


def scene_to_toml(scene_dict):
    """Validate a scene dict and return its ``scene.toml`` text.

    Parameters
    ----------
    scene_dict : dict
        Schema-1 content (as :meth:`Scene.to_dict` gives it). Numpy scalars and arrays,
        tuples and paths are accepted; keys whose value is None are left out.

    Returns
    -------
    str
        TOML text (written with ``tomli_w``) that :func:`load_scene` reads back to the
        same content.

    Raises
    ------
    SceneError
        The dict is not a valid scene (same checks and messages as the loader;
        calibration files are not opened: :func:`write_scene` does that).
    """
    import tomli_w

    data = _plain(scene_dict)
    parse_scene(data, folder=None, label="scene (to write)")
    ordered = {k: data[k] for k in _TOP_KEYS if k in data}
    from calibration.camera import compact_toml

    return "# vidtrack scene, schema 1 (docs/scene.md)\n" + compact_toml(tomli_w.dumps(ordered))


def write_scene(path, scene_dict):
    """Validate a scene dict and write it as ``scene.toml``, atomically.

    Parameters
    ----------
    path : str or pathlib.Path
        A run folder (``scene.toml`` is written in it; created if missing) or the path
        of the file to write.
    scene_dict : dict
        Schema-1 content; see :func:`scene_to_toml`.

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    SceneError
        Not a valid scene (checked with the run folder, so calibration files named
        must already exist there). Nothing is written then.
    """
    from vidtrack._atomic import write_text

    p = Path(path)
    target = p if p.suffix.lower() == ".toml" else p / SCENE_FILE
    text = scene_to_toml(scene_dict)
    parse_scene(tomllib.loads(text), folder=target.parent, label=str(target), path=target)
    write_text(target, text)
    return target


# --------------------------------------------------------------------------- experiment


def load_experiment(exp_dir):
    """Read and validate an experiment folder's ``experiment.toml``.

    Parameters
    ----------
    exp_dir : str or pathlib.Path
        The experiment folder, or the ``experiment.toml`` file.

    Returns
    -------
    Experiment

    Raises
    ------
    SceneError
        Missing file, invalid TOML, unknown or missing keys, bad values (named with
        the file and key).

    Notes
    -----
    Keys (schema 1): ``schema``; ``design`` = ``"ccd"`` or ``"orthogonal"``;
    ``responses`` (non-empty list of distinct names); ``runs`` (glob of run folders,
    default ``"runs/*"``); ``[factors.LETTER]`` with ``name`` and, for ``ccd``
    (required there), ``centre`` and ``step`` (> 0): coded = (natural - centre) / step
    (Chen 2018, Table 1).
    """
    p = Path(exp_dir)
    if p.is_dir():
        path = p / EXPERIMENT_FILE
        if not path.is_file():
            raise SceneError(f"{p}: no {EXPERIMENT_FILE} in this experiment folder")
    elif p.exists():
        path = p
    else:
        raise SceneError(f"{p}: no such experiment folder or file")
    data = _read_toml(path)
    ck = _Checker(str(path))
    ck.keys(data, ("schema", "design", "responses", "runs", "factors"), "")
    if "schema" not in data:
        ck.fail("schema", f"is required: write schema = {SCHEMA} as the first line")
    if isinstance(data["schema"], bool) or data["schema"] != SCHEMA:
        ck.fail("schema", f"must be {SCHEMA}, got {_show(data['schema'])}")
    design = ck.string(data, "design", "design", required=True)
    if design not in ("ccd", "orthogonal"):
        ck.fail("design", f"must be \"ccd\" or \"orthogonal\", got {_show(design)}")
    if "responses" not in data:
        ck.fail("responses", "is required: a list like [\"k1\", \"k2\", \"k3\", \"k4\"]")
    resp = data["responses"]
    if not isinstance(resp, list) or not resp or any(
            not isinstance(r, str) or not r.strip() for r in resp):
        ck.fail("responses", f"must be a non-empty list of names, got {_show(resp)}")
    if len(set(resp)) != len(resp):
        dup = next(r for r in resp if resp.count(r) > 1)
        ck.fail("responses", f"names {dup!r} twice")
    runs = ck.string(data, "runs", "runs", default="runs/*")
    if Path(runs).is_absolute() or ".." in Path(runs).parts:
        ck.fail("runs", f"must be a glob inside the experiment folder, got {_show(runs)}")
    ftable = ck.table(data, "factors", "factors", required=design == "ccd")
    factors = {}
    for letter, f in (ftable or {}).items():
        fp = f"factors.{letter}"
        if not isinstance(f, dict):
            ck.fail(fp, f"must be a table with name, centre, step, got {_show(f)}")
        ck.keys(f, ("name", "centre", "step"), fp)
        need = design == "ccd"
        factors[letter] = Factor(
            letter=letter, name=ck.string(f, "name", f"{fp}.name", required=True),
            centre=ck.number(f, "centre", f"{fp}.centre", required=need),
            step=ck.number(f, "step", f"{fp}.step", required=need, gt=0))
    if design == "ccd" and not factors:
        ck.fail("factors", "must name at least one factor for a ccd design")
    names = [f.name for f in factors.values()]
    for n in names:
        if names.count(n) > 1:
            ck.fail("factors", f"name {n!r} is used by two factors")
    exp = Experiment(path=path, folder=path.parent, design=design, responses=tuple(resp),
                     runs=runs, factors=factors)
    return dataclasses.replace(exp, hash=_canonical_hash(exp.to_dict()))
