"""The parameters of a synthetic run: :class:`SynthSpec`, checked when it is made.

Also the names every part of ``vidtrack synth`` shares: the views (``VIEW_NAMES``), the
footage formats (``FORMATS``), the AVI codecs (``CODECS``), and ``_fail``, which raises
the :class:`~vidtrack.errors.VidtrackError` of an impossible request.
"""

import math
from dataclasses import dataclass, fields

import numpy as np

from calibration.scale import M_PER_PX_RANGE
from vidtrack.errors import VidtrackError
from vidtrack.scene.model import FPS_RANGE

__all__ = ["SynthSpec", "VIEW_NAMES", "FORMATS", "CODECS", "CAMERA_MODELS",
           "CAMERA_VIEW_NAMES", "RIDER_MODES", "POLARITIES"]

VIEW_NAMES = ("front", "top")
#: How the views are imaged: ideal orthographic cameras square to the axes (default),
#: pinhole cameras at an angle (``perspective``, a calibrated scene), or pinhole cameras
#: square to the axes (``square``, a front/top scene with a scale at the plane Z = 0 or
#: Y = 0 and the camera's distance).
CAMERA_MODELS = ("orthographic", "perspective", "square")
#: The views of ``cameras = "perspective"``.
CAMERA_VIEW_NAMES = ("cam1", "cam2")
#: The SynthSpec fields of the pinhole cameras: left out of ``to_dict`` (and so of
#: truth.json) for orthographic cameras, which they do not concern.
CAMERA_FIELDS = ("cameras", "camera_distance_m", "camera_angle_deg", "distortion",
                 "dlt_views", "camera_distance_in_scene")
#: The distractors real footage taught (docs/synth.md, "Distractors"): off by default and
#: then left out of ``to_dict`` (and so of truth.json), so that a run without them is
#: rendered and described byte for byte as before they existed.
DISTRACTOR_FIELDS = ("shadow", "rider", "straw_polarity", "highlight_grey", "person_at_side",
                     "shake", "post")
#: SynthSpec fields left out of ``to_dict`` (and so of truth.json) while None: a run
#: without them is described byte for byte as before they existed.
OPTIONAL_FIELDS = ("k_spread",)
#: Largest relative spread of a k between throws (``k_spread``, ``throw_spread``).
MAX_RELATIVE_SPREAD = 0.3
#: How the rider (a thinner, dimmer rod flying with the straw) moves: ``riding`` side by
#: side with the straw, turning with it and sliding along it; ``crossing`` drifting
#: across it at an angle, centres coinciding at mid-flight.
RIDER_MODES = ("riding", "crossing")
POLARITIES = ("bright", "dark")
#: Most frames rendered per view (and most frames of release and delay): 83 s at
#: 1200 fps, far beyond any throw; a larger count is a typo that would fill the disk.
MAX_FRAMES = 100_000
FORMATS = ("avi", "png", "cine")
CODECS = ("mjpg", "ffv1", "raw")


def _fail(message):
    raise VidtrackError(message)


# ---------------------------------------------------------------------------------------
# The specification
# ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SynthSpec:
    """Every parameter of a synthetic run (units in the names; defaults in brackets).

    Throw (the world frame of docs/reference.md; :func:`fits.throw.position`)
        ``k`` (k1, k2, k3, k4) [2.2, 2.5, 4.6, 21.3]; ``cp_s_per_m`` drag parameter Cp in
        s/m [0.115]; ``state`` (x0, y0, z0, vx0, vy0, vz0) at release, m and m/s, vz0
        absolute [0.24, -0.05, 0, 7.3, 2.6, 2.0]; ``speed_kmh`` machine speed v1 [7.2];
        ``model`` "quadratic" | "linear" | "free" ["quadratic"]; ``gravity_m_s2``
        [9.80665].
    Straw
        ``straw_length_m`` end to end [0.10]; ``straw_diameter_m`` [0.006];
        ``spin_rad_s`` rate of the rod's spin after release, None = the rotor's rate
        (the rod's orientation turns on smoothly) [None]; ``spin_axis`` the fixed world
        axis it spins about [(0, 0, 1): tumbling in the XOY plane]; ``straw_grey``
        grey level, a fraction of full scale: above ``background_grey`` a bright
        straw, below it a dark one [0.85].
    Machine
        ``n_rpm``, ``blade_angle_deg`` factors written to scene.toml [550, 0];
        ``blade_rpm`` the rotor's rate in the footage, None = the rate at which the
        straw's velocity is continuous at release (its tangential speed at release
        divided by its radius) [None]; ``blade_radius_m`` tooth radius, None = the
        release radius sqrt(x0^2 + y0^2) [None]; ``release_frame`` frames before
        release (the straw rides the tooth) [12].
    Cameras
        ``views`` ["front", "top"]; ``size_px`` (width, height) of the front view (and
        of the top view unless ``top_size_px``) [(480, 360)]; ``top_size_px`` [None];
        ``fps`` capture rate [1200]; ``playback_fps`` the rate an AVI container states
        [30]; ``flight_s`` seconds of flight after release [0.4]; ``frames`` frames per
        view, None = release_frame + round(flight_s * fps) [None]; ``top_delay_s`` the
        top view's frames are this much later than the front view's [0];
        ``front_axes``, ``top_axes`` world axes along image column and row
        [("+x", "-y"), ("+x", "+z")]; ``m_per_px`` scale, None = fit the rotor and the
        whole flight into the image [None]; ``leave_frame`` fit only the first 55 % of
        the flight, so that the straw leaves the image [False];
        ``exposure_fraction`` exposure time / frame interval (0 = no blur) [0.5];
        ``exposure_samples`` renders averaged per frame [8]; ``supersample`` sub-pixel
        grid on edges [16].
    Scene dressing and sensor
        ``background_grey`` mean background level [0.45]; ``texture_amplitude``
        standard deviation of the background texture [0.06]; ``vignetting`` relative
        fall-off of the background's illumination towards the image corners [0.08];
        ``draw_machine``,
        ``draw_ruler`` [True, True]; ``read_noise_dn`` Gaussian read noise, sigma in
        8-bit grey levels (1/255 of full scale) [1.5]; ``full_well_e`` electrons at
        full scale for Poisson shot noise, None = no shot noise [None].
    Second straw
        ``second_straw`` [False]; ``second_cross_s`` the time (main straw's clock) at
        which both rod centres coincide [0.10]; ``second_flight_s`` how long the second
        straw has then been flying [0.35]. It leaves the same release point (so it is
        slower and steeper, falling as the main straw passes), tumbles about a tilted
        axis at 0.8 times the main straw's spin, and is drawn behind the main straw.
    Output
        ``output_format`` "avi" | "png" | "cine" ["avi"]; ``video_codec`` "mjpg"
        (lossy, ``jpeg_quality`` 0..100) | "ffv1" (lossless) | "raw" (uncompressed)
        ["mjpg"]; ``jpeg_quality`` [75]; ``bit_depth`` 8 (avi, png, cine), 16 (png,
        cine), 10 or 12 (cine) [8]; ``cine_packed`` pack 10/12-bit .cine pixels
        [False]; ``throws`` replicate throws (> 1 writes throws/01 ..) [1];
        ``throw_spread`` relative random spread of release speed, direction and
        k1..k4 between replicate throws (not applied with one throw) [0.03];
        ``k_spread`` relative standard deviations (k1, k2, k3, k4) of each throw's k
        about ``k``, drawn for every throw, a single one included; with it
        ``throw_spread`` spreads only the release speed and direction (None: k spread
        by ``throw_spread``) [None]; ``seed``
        [42]; ``run_name`` None = the output folder's name [None]; ``scale_in_scene``
        "ruler" | "m_per_px" ["ruler"]; ``sync_in_scene`` write each view's release
        frame as ``sync_frame`` (else "auto") [False].
    Distractors (docs/synth.md, "Distractors"; all off by default; orthographic cameras)
        ``shadow`` (offset_px, darken, blur_px): the straw's shadow on the background,
        a copy of its silhouette moved offset_px down and to the right (45 degrees,
        light from the upper left), darkening what it falls on by the fraction darken,
        blurred by a Gaussian of blur_px [None]; ``rider`` "riding" | "crossing": a
        rod 0.6 times as long and half as thick as the straw, half its contrast, flying
        with it from the release, drawn behind it [None]; ``straw_polarity`` "bright" |
        "dark": the straw's level mirrored about ``background_grey`` when
        ``straw_grey`` is on the other side (None: as ``straw_grey`` says) [None];
        ``highlight_grey`` grey level of a specular stripe along the straw's upper-left
        side, inside its silhouette (None: none) [None]; ``person_at_side`` a person
        (textured body, head and a swinging arm) swaying in the largest part of each
        view that the straw's path, the rotor and the ruler leave free [False];
        ``shake`` (amplitude_px, freq_hz): each camera vibrates, its whole image moved
        by ``amplitude_px * sin(2 pi freq_hz t + phase)`` across and 0.6 of that, a
        quarter turn later, down (truth.json: ``camera_du_px``, ``camera_dv_px``) [None];
        ``post`` (at, width_px[, speed_px]): a post (a part of the machine) in front of
        everything in the front view, upright, the view's whole height, ``width_px``
        wide, its centre at the fraction ``at`` of the view's width in the middle frame;
        standing, or moving ``speed_px`` a frame (rightwards when positive: a hand or an
        arm passing before the camera) (truth.json: ``post_hidden``, the share of the
        straw behind it; ``post_u_px`` when it moves) [None].
    Pinhole cameras (docs/synth.md, "Perspective cameras")
        ``cameras`` "orthographic" | "perspective" | "square" ["orthographic"]:
        "perspective" renders two pinhole cameras ``cam1``, ``cam2`` at
        ``camera_distance_m`` from the middle of the flight, ``camera_angle_deg`` apart
        (their optical axes; both perpendicular to X, symmetric about the direction
        45 degrees above +Z), and writes a calibrated scene (``[world]``, ``projection``
        or ``dlt``); "square" renders pinhole cameras looking square onto the ``front``
        and ``top`` planes (``front_axes``, ``top_axes``) from ``camera_distance_m``
        beyond the plane Z = 0 / Y = 0, and writes a front/top scene with the scale at
        that plane (ruler or ``m_per_px``) and, with ``camera_distance_in_scene``, the
        distance. ``camera_distance_m`` [2.0]; ``camera_angle_deg`` [90];
        ``distortion`` (k1, k2, p1, p2, k3) of the lens of the views written as
        ``projection`` (perspective only), None = no lens [None]; ``dlt_views`` the
        perspective views written as an 11-parameter DLT with ``pixel_origin =
        "bottom-left"`` (no lens) [("cam2",)]; ``camera_distance_in_scene`` [True].
        The focal length frames the flight in the image (and, with ``square``,
        ``m_per_px`` = distance / focal length at the scale plane when given).
    """

    k: tuple = (2.2, 2.5, 4.6, 21.3)
    cp_s_per_m: float = 0.115
    state: tuple = (0.24, -0.05, 0.0, 7.3, 2.6, 2.0)
    speed_kmh: float = 7.2
    model: str = "quadratic"
    gravity_m_s2: float = 9.80665
    straw_length_m: float = 0.10
    straw_diameter_m: float = 0.006
    spin_rad_s: float | None = None
    spin_axis: tuple = (0.0, 0.0, 1.0)
    straw_grey: float = 0.85
    n_rpm: float = 550.0
    blade_angle_deg: float = 0.0
    blade_rpm: float | None = None
    blade_radius_m: float | None = None
    release_frame: int = 12
    views: tuple = ("front", "top")
    size_px: tuple = (480, 360)
    top_size_px: tuple | None = None
    fps: float = 1200.0
    playback_fps: float = 30.0
    flight_s: float = 0.4
    frames: int | None = None
    top_delay_s: float = 0.0
    front_axes: tuple = ("+x", "-y")
    top_axes: tuple = ("+x", "+z")
    m_per_px: float | None = None
    leave_frame: bool = False
    exposure_fraction: float = 0.5
    exposure_samples: int = 8
    supersample: int = 16
    background_grey: float = 0.45
    texture_amplitude: float = 0.06
    vignetting: float = 0.08
    draw_machine: bool = True
    draw_ruler: bool = True
    read_noise_dn: float = 1.5
    full_well_e: float | None = None
    second_straw: bool = False
    second_cross_s: float = 0.10
    second_flight_s: float = 0.35
    output_format: str = "avi"
    video_codec: str = "mjpg"
    jpeg_quality: int = 75
    bit_depth: int = 8
    cine_packed: bool = False
    throws: int = 1
    throw_spread: float = 0.03
    k_spread: tuple | None = None
    seed: int = 42
    run_name: str | None = None
    scale_in_scene: str = "ruler"
    sync_in_scene: bool = False
    cameras: str = "orthographic"
    camera_distance_m: float = 2.0
    camera_angle_deg: float = 90.0
    distortion: tuple | None = None
    dlt_views: tuple = ("cam2",)
    camera_distance_in_scene: bool = True
    shadow: tuple | None = None
    rider: str | None = None
    straw_polarity: str | None = None
    highlight_grey: float | None = None
    person_at_side: bool = False
    shake: tuple | None = None
    post: tuple | None = None

    def __post_init__(self):
        _validate(self)

    @property
    def n_frames(self):
        """Frames per view."""
        if self.frames is not None:
            return int(self.frames)
        return int(self.release_frame) + int(round(self.flight_s * self.fps))

    @property
    def v1_m_s(self):
        """Machine speed v1 in m/s."""
        return self.speed_kmh / 3.6

    @property
    def view_names(self):
        """The views rendered: ``views`` (front, top), or cam1, cam2 with perspective
        cameras."""
        if self.cameras == "perspective":
            return CAMERA_VIEW_NAMES
        return tuple(v for v in VIEW_NAMES if v in self.views)

    def view_size(self, view):
        """(width, height) of ``view`` in pixels (cam2 as top, cam1 as front)."""
        if view in ("top", "cam2") and self.top_size_px is not None:
            return tuple(int(v) for v in self.top_size_px)
        return tuple(int(v) for v in self.size_px)

    @property
    def straw_level(self):
        """The straw's grey level as drawn: ``straw_grey``, mirrored about
        ``background_grey`` (and kept within 0.02 .. 0.98) when ``straw_polarity`` asks
        for the other side of the background."""
        g, b = float(self.straw_grey), float(self.background_grey)
        if (self.straw_polarity == "dark" and g > b) or (self.straw_polarity == "bright"
                                                         and g < b):
            return min(max(2.0 * b - g, 0.02), 0.98)
        return g

    @property
    def distractors(self):
        """Names of the distractors asked for, in a fixed order."""
        out = []
        if self.shadow is not None:
            out.append("shadow")
        if self.rider is not None:
            out.append("rider")
        if self.straw_polarity is not None:
            out.append("polarity")
        if self.highlight_grey is not None:
            out.append("highlight")
        if self.person_at_side:
            out.append("person")
        if self.shake is not None:
            out.append("shake")
        if self.post is not None:
            out.append("post")
        return tuple(out)

    def view_axes(self, view):
        return tuple(self.front_axes if view == "front" else self.top_axes)

    def to_dict(self):
        """Every parameter, JSON-ready (the pinhole cameras' only with such cameras)."""
        return {f.name: _jsonable(getattr(self, f.name)) for f in fields(self)
                if (self.cameras != "orthographic" or f.name not in CAMERA_FIELDS)
                and (f.name not in DISTRACTOR_FIELDS
                     or getattr(self, f.name) != f.default)
                and (f.name not in OPTIONAL_FIELDS or getattr(self, f.name) is not None)}


def _jsonable(value):
    """Tuples to lists, numpy scalars to Python numbers."""
    if isinstance(value, (tuple, list, np.ndarray)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _number(name, value, *, gt=None, ge=None, le=None, integer=False):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        _fail(f"{name} must be a number, got {value!r}")
    if integer and float(value) != int(value):
        _fail(f"{name} must be a whole number, got {value!r}")
    if not math.isfinite(float(value)):
        _fail(f"{name} must be finite, got {value!r}")
    if gt is not None and not value > gt:
        _fail(f"{name} must be > {gt}, got {value!r}")
    if ge is not None and not value >= ge:
        _fail(f"{name} must be >= {ge}, got {value!r}")
    if le is not None and not value <= le:
        _fail(f"{name} must be <= {le}, got {value!r}")


def _vector(name, value, n):
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        _fail(f"{name} must be {n} numbers, got {value!r}")
    if arr.shape != (n,) or not np.all(np.isfinite(arr)):
        _fail(f"{name} must be {n} finite numbers, got {value!r}")
    return arr


def _validate(s):
    from calibration.errors import InputError
    from calibration.views import parse_axes
    from fits.throw import MODELS

    k = _vector("k", s.k, 4)
    if np.any(k <= 0) or np.any(k > 1e3):
        _fail(f"k1..k4 must all be > 0 and <= 1000, got {list(s.k)}")
    _number("cp_s_per_m", s.cp_s_per_m, ge=0, le=10)
    state = _vector("state (x0, y0, z0, vx0, vy0, vz0)", s.state, 6)
    if np.any(np.abs(state[:3]) > 100) or np.any(np.abs(state[3:]) > 1e3):
        _fail("state must be a release point within 100 m of the shaft and a velocity "
              f"within 1000 m/s in each axis, got {list(s.state)}")
    if math.hypot(state[0], state[1]) < 0.02:
        _fail("the release point (x0, y0) must be at least 0.02 m from the shaft (the "
              f"straw leaves a tooth), got ({state[0]}, {state[1]})")
    _number("speed_kmh", s.speed_kmh, ge=0, le=100)
    if s.model not in MODELS:
        _fail(f"model must be one of {', '.join(MODELS)}, got {s.model!r}")
    _number("gravity_m_s2", s.gravity_m_s2, gt=0)
    _number("straw_length_m", s.straw_length_m, gt=0)
    _number("straw_diameter_m", s.straw_diameter_m, gt=0)
    if s.straw_diameter_m > s.straw_length_m:
        _fail(f"straw_diameter_m ({s.straw_diameter_m}) must not exceed straw_length_m "
              f"({s.straw_length_m})")
    if s.spin_rad_s is not None:
        _number("spin_rad_s", s.spin_rad_s, ge=-1e5, le=1e5)
    axis = _vector("spin_axis", s.spin_axis, 3)
    if np.any(np.abs(axis) > 1e6):
        _fail(f"spin_axis must be a direction x,y,z with components within +-1e6, got "
              f"{list(s.spin_axis)}")
    if np.linalg.norm(axis) == 0:
        _fail("spin_axis must not be the zero vector")
    for name in ("straw_grey", "background_grey"):
        _number(name, getattr(s, name), ge=0, le=1)
    if abs(s.straw_grey - s.background_grey) < 0.05:
        _fail(f"straw_grey ({s.straw_grey}) must differ from background_grey "
              f"({s.background_grey}) by at least 0.05, or the straw is invisible")
    _number("n_rpm", s.n_rpm)
    _number("blade_angle_deg", s.blade_angle_deg)
    if s.blade_rpm is not None:
        _number("blade_rpm", s.blade_rpm, ge=-1e5, le=1e5)
    if s.blade_radius_m is not None:
        _number("blade_radius_m", s.blade_radius_m, gt=0)
    _number("release_frame", s.release_frame, ge=0, integer=True)
    if isinstance(s.views, str) or not s.views or len(set(s.views)) != len(s.views) \
            or any(v not in VIEW_NAMES for v in s.views):
        _fail(f"views must be front, top or both (no repeats), got {s.views!r}")
    for name in ("size_px", "top_size_px"):
        size = getattr(s, name)
        if size is None:
            continue
        if isinstance(size, str) or len(size) != 2 or any(
                isinstance(v, bool) or not isinstance(v, (int, np.integer)) for v in size):
            _fail(f"{name} must be two whole numbers (width, height), got {size!r}")
        if not (32 <= size[0] <= 8192 and 32 <= size[1] <= 8192):
            _fail(f"{name} must be between 32 and 8192 pixels each way, got {size!r}")
    _number("fps", s.fps, gt=0)
    _number("playback_fps", s.playback_fps, gt=0)
    low, high = FPS_RANGE
    for name in ("fps", "playback_fps"):
        if not low <= getattr(s, name) <= high:
            _fail(f"{name} must be between {low:g} and {high:g} frames/s, "
                  f"got {getattr(s, name)!r}")
    _number("flight_s", s.flight_s, gt=0)
    if s.frames is not None:
        _number("frames", s.frames, ge=1, le=MAX_FRAMES, integer=True)
    _number("release_frame", s.release_frame, le=MAX_FRAMES)
    if s.n_frames < 1:
        _fail("no frames to render: release_frame + flight_s * fps is 0")
    if s.n_frames > MAX_FRAMES:
        _fail(f"{s.n_frames:.6g} frames per view (release_frame + flight_s * fps); at most "
              f"{MAX_FRAMES} are rendered: give a shorter flight_s or a lower fps")
    _number("top_delay_s", s.top_delay_s)
    if abs(s.top_delay_s) * s.fps > MAX_FRAMES:
        _fail(f"top_delay_s = {s.top_delay_s!r} s is {abs(s.top_delay_s) * s.fps:g} frames "
              f"at {s.fps:g} fps; expected at most {MAX_FRAMES} frames")
    for name in ("front_axes", "top_axes"):
        view = name.split("_")[0]
        try:
            axes = parse_axes(getattr(s, name))
        except InputError as exc:
            _fail(f"{name}: {exc}")
        want = ("x", "y") if view == "front" else ("x", "z")
        if tuple(sorted(a[1] for a in axes)) != want:
            _fail(f"{name} must be the world axes {want[0]} and {want[1]} (the {view} view "
                  f"sees them), got {list(getattr(s, name))}")
    if s.m_per_px is not None:
        _number("m_per_px", s.m_per_px, ge=M_PER_PX_RANGE[0], le=M_PER_PX_RANGE[1])
    _number("exposure_fraction", s.exposure_fraction, ge=0, le=1)
    _number("exposure_samples", s.exposure_samples, ge=1, le=256, integer=True)
    _number("supersample", s.supersample, ge=1, le=64, integer=True)
    _number("texture_amplitude", s.texture_amplitude, ge=0, le=0.5)
    _number("vignetting", s.vignetting, ge=0, le=0.5)
    _number("read_noise_dn", s.read_noise_dn, ge=0, le=255)
    if s.full_well_e is not None:
        _number("full_well_e", s.full_well_e, ge=1, le=1e9)
    if s.second_straw:
        _number("second_cross_s", s.second_cross_s, gt=0)
        _number("second_flight_s", s.second_flight_s, gt=0)
    if s.output_format not in FORMATS:
        _fail(f"format must be one of {', '.join(FORMATS)}, got {s.output_format!r}")
    if s.video_codec not in CODECS:
        _fail(f"codec must be one of {', '.join(CODECS)}, got {s.video_codec!r}")
    _number("jpeg_quality", s.jpeg_quality, ge=1, le=100, integer=True)
    depths = {"avi": (8,), "png": (8, 16), "cine": (8, 10, 12, 16)}[s.output_format]
    if s.bit_depth not in depths:
        _fail(f"bit_depth {s.bit_depth!r} is not available for {s.output_format}; "
              f"expected one of {', '.join(map(str, depths))}")
    if s.cine_packed and not (s.output_format == "cine" and s.bit_depth in (10, 12)):
        _fail("cine_packed needs format cine with bit_depth 10 or 12")
    _number("throws", s.throws, ge=1, le=99, integer=True)
    _number("throw_spread", s.throw_spread, ge=0, le=MAX_RELATIVE_SPREAD)
    if s.k_spread is not None:
        spread = _vector("k_spread (relative sd of k1, k2, k3, k4)", s.k_spread, 4)
        if np.any(spread < 0) or np.any(spread > MAX_RELATIVE_SPREAD):
            _fail(f"k_spread must be 4 relative standard deviations in [0, "
                  f"{MAX_RELATIVE_SPREAD}], got {list(s.k_spread)}")
    _number("seed", s.seed, ge=0, integer=True)
    if s.scale_in_scene not in ("ruler", "m_per_px"):
        _fail(f"scale_in_scene must be ruler or m_per_px, got {s.scale_in_scene!r}")
    if s.scale_in_scene == "ruler" and not s.draw_ruler:
        _fail("scale_in_scene 'ruler' needs the ruler drawn (draw_ruler); use m_per_px")
    if s.run_name is not None and (not isinstance(s.run_name, str) or not s.run_name.strip()):
        _fail(f"run_name must be a non-empty string, got {s.run_name!r}")
    _validate_cameras(s)
    _validate_distractors(s)


def _validate_distractors(s):
    if s.shadow is not None:
        sh = _vector("shadow (offset_px, darken, blur_px)", s.shadow, 3)
        if not (0 < sh[0] <= 50 and 0 < sh[1] < 1 and 0 <= sh[2] <= 20):
            _fail("shadow must be offset_px in (0, 50], darken in (0, 1) and blur_px in "
                  f"[0, 20], got {list(s.shadow)}")
    if s.rider is not None and s.rider not in RIDER_MODES:
        _fail(f"rider must be one of {', '.join(RIDER_MODES)}, got {s.rider!r}")
    if s.straw_polarity is not None and s.straw_polarity not in POLARITIES:
        _fail(f"straw_polarity must be one of {', '.join(POLARITIES)}, got "
              f"{s.straw_polarity!r}")
    if s.straw_polarity is not None and abs(s.straw_level - s.background_grey) < 0.05:
        _fail(f"straw_polarity {s.straw_polarity}: the mirrored level {s.straw_level:.3g} is "
              f"within 0.05 of background_grey ({s.background_grey}); give a straw_grey "
              "with more contrast")
    if s.highlight_grey is not None:
        _number("highlight_grey", s.highlight_grey, ge=0, le=1)
        if abs(s.highlight_grey - s.straw_level) < 0.05:
            _fail(f"highlight_grey ({s.highlight_grey}) must differ from the straw's level "
                  f"({s.straw_level:.3g}) by at least 0.05, or the highlight is invisible")
    if not isinstance(s.person_at_side, (bool, np.bool_)):
        _fail(f"person_at_side must be true or false, got {s.person_at_side!r}")
    if s.shake is not None:
        sh = _vector("shake (amplitude_px, freq_hz)", s.shake, 2)
        if not (0 < sh[0] <= 20 and 0 < sh[1] <= 0.5 * s.fps):
            _fail(f"shake must be amplitude_px in (0, 20] and freq_hz in (0, fps/2 = "
                  f"{0.5 * s.fps:g}], got {list(s.shake)}")
    if s.post is not None:
        n = 3 if np.size(s.post) == 3 else 2
        po = _vector("post (at, width_px[, speed_px])", s.post, n)
        if not (0 < po[0] < 1 and 0 < po[1] <= 0.5 * s.view_size("front")[0]
                and (n == 2 or abs(po[2]) <= 0.5 * s.view_size("front")[0])):
            _fail(f"post must be at in (0, 1) (a fraction of the front view's width), "
                  f"width_px in (0, half the view's width = "
                  f"{0.5 * s.view_size('front')[0]:g}] and speed_px (a frame) at most that "
                  f"either way, got {list(s.post)}")
    if s.distractors and s.cameras != "orthographic":
        _fail(f"the distractors ({', '.join(s.distractors)}) are drawn in the orthographic "
              f"views only; cameras = {s.cameras} cannot have them")


#: Accepted camera distances (m) and angles between the cameras (degrees).
CAMERA_DISTANCE_RANGE_M = (0.3, 30.0)
CAMERA_ANGLE_RANGE_DEG = (20.0, 160.0)


def _validate_cameras(s):
    if s.cameras not in CAMERA_MODELS:
        _fail(f"cameras must be one of {', '.join(CAMERA_MODELS)}, got {s.cameras!r}")
    low, high = CAMERA_DISTANCE_RANGE_M
    _number("camera_distance_m", s.camera_distance_m, ge=low, le=high)
    low, high = CAMERA_ANGLE_RANGE_DEG
    _number("camera_angle_deg", s.camera_angle_deg, ge=low, le=high)
    if s.distortion is not None:
        d = _vector("distortion (k1, k2, p1, p2, k3)", s.distortion, 5)
        if np.any(np.abs(d) > 10):
            _fail(f"distortion coefficients must be within +-10, got {list(s.distortion)}")
    if isinstance(s.dlt_views, str) or any(v not in CAMERA_VIEW_NAMES for v in s.dlt_views) \
            or len(set(s.dlt_views)) != len(s.dlt_views):
        _fail(f"dlt_views must be some of {', '.join(CAMERA_VIEW_NAMES)} (no repeats), "
              f"got {s.dlt_views!r}")
    if s.cameras == "orthographic":
        if s.distortion is not None:
            _fail("distortion needs cameras = perspective (orthographic cameras have no lens)")
        return
    if tuple(s.views) != VIEW_NAMES:
        _fail(f"cameras = {s.cameras} renders two cameras: views must be front,top (the "
              f"default), got {','.join(s.views)}")
    if s.cameras == "square":
        if s.distortion is not None:
            _fail("distortion goes with cameras = perspective; the square rig's scene "
                  "(front/top with a scale) has no lens")
        return
    if s.m_per_px is not None:
        _fail("m_per_px goes with orthographic or square cameras; perspective cameras are "
              "framed by their focal length")
    if s.distortion is not None and len(s.dlt_views) == len(CAMERA_VIEW_NAMES):
        _fail("distortion is the lens of the views written as projection, but dlt_views "
              "names every view (a DLT has no lens); leave one view out of dlt_views")

