"""What a run's ``scene.toml`` (schema 1) holds: the frozen :class:`Scene` and its parts.

A run folder's ``scene.toml`` says where the footage is, at what capture rate, how its
pixels map to the world frame (axes, origin, scale), and what straw and machine the run
had (every key: docs/scene.md). A :class:`Scene` is that file validated: the run's name and
factors, :class:`Physics`, the :class:`Straw` (which fixes the drag parameter Cp), the
machine's speed and one :class:`ViewSpec` per view (with its :class:`Ruler` when a ruler
gives the scale). Here too are the schema's constants: the file name, the schema number,
the world axes each view sees, the default gravity and air density, the Cp tolerance and
the keys a file may have.

:mod:`vidtrack.scene.read` builds these; :mod:`vidtrack.scene.write` writes what
:meth:`Scene.to_dict` gives. Every key is documented in ``docs/scene.md``.
"""

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from vidtrack.scene.corrections import corrections_to_dict
from vidtrack.scene.folders import find_throw_dirs

SCENE_FILE = "scene.toml"
#: The scene.toml and experiment.toml schema this package reads and writes.
SCHEMA = 1
#: The world axes each view sees (docs/reference.md, "Views").
VIEW_AXES = {"front": ("x", "y"), "top": ("x", "z")}

GRAVITY_M_S2 = 9.80665
AIR_DENSITY_KG_M3 = 1.205
#: Largest relative difference accepted between a given Cp and the one computed from
#: the straw's mass, area and drag coefficient when both are in the file.
CP_TOLERANCE = 0.01
#: Capture rates accepted, frames/s: a frame every 10 s up to 10 million frames/s (the
#: fastest cameras film a few million); outside it a rate is a typo (1e-300, 1e300).
FPS_RANGE = (0.1, 1e7)
#: Camera distances accepted (``camera_distance_m``), m: a camera nearer than 1 cm or
#: farther than 100 km from the throw is a typo.
CAMERA_DISTANCE_RANGE_M = (0.01, 1e5)
#: Physical ranges of the other numbers of a scene; outside them a value is a typo
#: (1e308, 1e-300) that would overflow or divide by zero downstream.
#: Gravity, m/s^2 (the Moon 1.6, the Earth 9.8; a centrifuge is not a throw).
GRAVITY_RANGE_M_S2 = (0.01, 1000.0)
#: Air density, kg/m^3 (0: no drag from the air; air at sea level 1.2).
AIR_DENSITY_RANGE_KG_M3 = (0.0, 100.0)
#: The machine's travel speed, km/h (as ``vidtrack predict``).
SPEED_RANGE_KMH = (0.0, 100.0)
#: The straw's mass (kg), area (m^2) and drag coefficient.
MASS_RANGE_KG = (1e-9, 1e3)
AREA_RANGE_M2 = (1e-9, 1e3)
DRAG_COEFFICIENT_RANGE = (0.0, 100.0)
#: Largest drag parameter Cp, s/m (a straw: about 0.1; as ``vidtrack synth``).
CP_MAX_S_PER_M = 10.0
#: A calibrated view's name (it names files, overlay_<view>.mp4, and table columns):
#: no path separators, dots or spreadsheet formula characters.
VIEW_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")
#: A ruler end's pixel uncertainty when the scene gives none (``px_uncertainty``), px: half
#: a pixel, a careful reading of an end off a frame by eye.
RULER_PX_UNCERTAINTY = 0.5
#: Pixel uncertainties accepted for a ruler's ends, px.
PX_UNCERTAINTY_RANGE = (0.0, 100.0)
#: Largest relative uncertainty of a view's scale (from a ruler's ends, or stated with
#: ``m_per_px_rel_uncertainty``): beyond half, a scale is not known at all.
MAX_SCALE_REL_UNCERTAINTY = 0.5
#: The keys of a view that say how uncertain its scale is. They change the fit's
#: intervals, not the tracks, so they are left out of the scene's hash (the fit stage's
#: key holds them: :attr:`ViewSpec.scale_rel_uncertainty`).
UNCERTAINTY_KEYS = ("px_uncertainty", "m_per_px_rel_uncertainty")
#: Largest magnitude of a factor's value in natural units (as the ANOVA's bound).
MAX_ABS_FACTOR = 1e12
#: What a view's ``channel`` may be: the grey image the tracker sees (BT.601 luma, one
#: colour channel, the chroma ``max(R, G, B) - min(R, G, B)``, or ``"auto"``: the one of
#: luma, red, green and blue in which moving things stand out most).
CHANNELS = ("luma", "red", "green", "blue", "chroma", "auto")

_TOP_KEYS = ("schema", "run", "factors", "physics", "straw", "machine", "world", "track",
             "views")
_VIEW_KEYS = ("source", "fps", "axes", "origin_px", "ruler", "m_per_px", "calibration",
              "camera_distance_m", "frames", "sync_frame", "channel", "target",
              "exclude_frames", "manual_points", "m_per_px_rel_uncertainty")


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
        """The drag parameter Cp in s/m (docs/throw-models.md): given, else computed.

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
    """A ruler in a view: ``length_m`` spans ``from_px`` .. ``to_px`` (raw pixels).

    ``px_uncertainty`` (px) is the standard uncertainty of each end's position, the two
    ends independent (default :data:`RULER_PX_UNCERTAINTY`).
    """

    length_m: float
    from_px: tuple
    to_px: tuple
    px_uncertainty: float = RULER_PX_UNCERTAINTY

    def to_dict(self):
        """The ``ruler`` inline table (``px_uncertainty`` only when not the default)."""
        out = {"length_m": self.length_m, "from_px": list(self.from_px),
               "to_px": list(self.to_px)}
        if self.px_uncertainty != RULER_PX_UNCERTAINTY:
            out["px_uncertainty"] = self.px_uncertainty
        return out


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
    channel : str
        The grey image tracked, one of :data:`CHANNELS`: ``"luma"`` (default: BT.601
        luma of colour footage), ``"red"``, ``"green"``, ``"blue"`` (that channel),
        ``"chroma"`` (``max(R, G, B) - min(R, G, B)``: a coloured object before grey
        surroundings, whatever its hues), or ``"auto"`` (chosen among luma, red, green
        and blue when the footage is opened; see docs/scene.md).
    camera_distance_m : float or None
        Distance (m) from the camera's centre to the plane where the scale holds (the
        plane through the world origin parallel to the image: Z = 0 for ``front``,
        Y = 0 for ``top``); with it the world stage corrects the perspective (a point
        nearer the camera looks larger) by the depth the other view measures. None:
        not corrected.
    target : (int, (float, float)) or None
        ``(frame, (u_px, v_px))``: the object to track is the moving one at that pixel
        of that 0-based file frame (``target = { frame = F, at_px = [u, v] }``); it is
        followed forwards and backwards from there. None: found automatically.
    exclude_frames : tuple of (int, int)
        Half-open ranges ``(first, end)`` of file frames never fitted: flagged EXCLUDED
        after tracking (docs/scene.md, "Correcting the tracker").
    manual_points : pathlib.Path or None
        A CSV ``frame,u_px,v_px`` of points placed by hand (resolved against the run
        folder; a throw's is :meth:`manual_points_in`): they replace the tracker's point
        in those frames and are fitted.
    manual_points_text : str or None
        ``manual_points`` as written.
    manual_points_read : vidtrack.scene.corrections.ManualPoints or None
        That file as the scene's reader read it (None: not read, a run with
        ``throws/`` reads each throw's own).
    m_per_px_rel_uncertainty : float or None
        The stated relative standard uncertainty of a scale given directly
        (``m_per_px``, or a calibration file's ``[scale]``); None: not stated.
    points : None
        Always None: an orthogonal view is tracked from its footage (a calibrated view,
        :class:`vidtrack.scene.cameras.CameraView`, may give points digitized elsewhere).
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
    channel: str = "luma"
    camera_distance_m: float | None = None
    target: tuple | None = None
    exclude_frames: tuple = ()
    manual_points: Path | None = None
    manual_points_text: str | None = None
    m_per_px_rel_uncertainty: float | None = None
    points: None = None
    manual_points_read: object = field(default=None, compare=False, repr=False)

    @property
    def scale_rel_uncertainty(self):
        """(relative standard uncertainty of the view's scale, where it comes from).

        A ruler of N px whose ends are each uncertain by sigma px (independent) has a
        length uncertain by sqrt(2) sigma along it: sqrt(2) sigma / N
        (:func:`calibration.scale.ruler_rel_uncertainty`). A scale given directly has
        its stated ``m_per_px_rel_uncertainty``; not stated, the uncertainty is None
        (the fit then takes the scale as exact and says so).
        """
        from calibration.scale import ruler_rel_uncertainty

        if self.ruler is not None and self.scale is not None and self.scale.span_px:
            r = self.ruler
            rel = ruler_rel_uncertainty(self.scale.span_px, r.px_uncertainty)
            return rel, (f"ruler of {self.scale.span_px:.4g} px, ends +- {r.px_uncertainty:g} "
                         f"px: sqrt(2) x {r.px_uncertainty:g} / {self.scale.span_px:.4g}")
        if self.m_per_px_rel_uncertainty is not None:
            return self.m_per_px_rel_uncertainty, "m_per_px_rel_uncertainty as stated"
        return None, "not stated (m_per_px_rel_uncertainty)"

    def manual_points_in(self, folder):
        """The manual points file for the run or throw folder ``folder`` (None: none)."""
        if self.manual_points_text is None:
            return None
        p = Path(self.manual_points_text)
        return p if p.is_absolute() else Path(folder) / p

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
                           m_per_px=self.m_per_px, camera=self.camera,
                           camera_distance_m=self.camera_distance_m)

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
        if self.m_per_px_rel_uncertainty is not None:
            out["m_per_px_rel_uncertainty"] = self.m_per_px_rel_uncertainty
        if self.calibration_text is not None:
            out["calibration"] = self.calibration_text
        if self.camera_distance_m is not None:
            out["camera_distance_m"] = self.camera_distance_m
        if self.frames is not None:
            out["frames"] = list(self.frames)
        out["sync_frame"] = self.sync_frame
        return corrections_to_dict(self, channel_to_dict(self, out))


def channel_to_dict(view, out):
    """Add a view's ``channel`` to ``out`` (its table as written) unless it is the default
    ``"luma"``: a scene that does not set it keeps its content and so its hash."""
    if view.channel != "luma":
        out["channel"] = view.channel
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
    views : dict of str to ViewSpec or vidtrack.scene.cameras.CameraView
        ``"front"`` and/or ``"top"``; with ``world``, calibrated views of any name.
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
    world: object = None
    track: dict = field(default_factory=dict)

    @property
    def v1_m_s(self):
        """The machine's travel speed v1 in m/s: the world frame rides on the machine along +Z."""
        return self.machine_speed_kmh / 3.6

    @property
    def cp_s_per_m(self):
        """The drag parameter Cp in s/m, or None when the scene does not fix it."""
        return self.straw.cp_s_per_m

    @property
    def calibrated(self):
        """True for calibrated cameras at any angle (a ``[world]`` table), False for the
        orthogonal ``front``/``top`` views with a scale."""
        return self.world is not None

    @property
    def view_names(self):
        """The views present: ``front`` before ``top``, or calibrated views in file order."""
        if self.calibrated:
            return tuple(self.views)
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
        if self.world is not None:
            out["world"] = self.world.to_dict()
        if self.track:
            out["track"] = dict(self.track)
        out["views"] = {name: self.views[name].to_dict() for name in self.view_names}
        return out
