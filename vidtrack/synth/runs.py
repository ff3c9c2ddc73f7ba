"""Synthetic runs with known truth: ``vidtrack synth``.

:func:`render_run` renders a run folder as SPEC.md describes it (``scene.toml``, the
footage of a ``front`` and/or ``top`` view, optionally ``throws/01 ..``) and writes
``truth.json``: every parameter, and for every frame of every view the time, the world
position of the straw and the true pixel centroid of its silhouette, with flags.

What is rendered, per view (orthographic cameras, SPEC "Views"):

- a static scene: a smooth random texture with a gentle illumination fall-off, the
  machine's housing and the rotor's hood (dark boxes), a ruler along world X with
  ticks, whose two end ticks are the points ``scene.toml``'s ``ruler`` names;
- the rotor: two knife teeth turning about the shaft (front: bars through the origin;
  top: their projections, bars along X) and the hub (front) or shaft (top);
- the straw: a rod of length L and diameter D with rounded ends (a capsule: its
  silhouette in any orthographic view is again a capsule, centrally symmetric, so
  the centroid of the silhouette is the projected rod centre), opaque, of grey
  level ``straw_grey``, spinning about a fixed axis. Before release (t < 0) it rides
  a tooth, sliding outward; at t = 0 it leaves at the release state and flies on the
  throw model of :func:`fits.throw.position`;
- optionally a second straw, drawn behind the first, crossing it at a given time;
- motion blur: each frame is the mean of ``exposure_samples`` renders spread evenly
  over the exposure (``exposure_fraction / fps`` seconds centred on the frame's time);
- exact anti-aliasing: pixel coverage from :mod:`vidtrack.synth._raster` (1/256 resolution
  on edges, exact elsewhere);
- sensor noise (Gaussian read noise, optional Poisson shot noise), quantisation to
  the output bit depth, and compression (MJPG AVI at a quality, or lossless FFV1 /
  raw AVI, png folders, Phantom .cine).

Frame i of a view is at ``t_s = (i - release_frame) / fps + delay_s`` (``delay_s`` is
0 for the front view and ``top_delay_s`` for the top view), the middle of its
exposure. AVI files carry ``playback_fps`` (30) in the container, as exported
high-speed videos do; ``scene.toml`` carries the capture rate.

Everything is rendered and written frame by frame; memory does not grow with the
number of frames.
"""

import json
import math
import os
import re
import shutil
import tempfile
import time
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

from vidtrack.synth import _raster
from vidtrack.errors import VidtrackError

__all__ = ["SynthSpec", "SynthRun", "render_run", "VIEW_NAMES", "FORMATS", "CODECS",
           "TRUTH_FILE", "TRUTH_SCHEMA", "straw_pose", "second_straw_state"]

VIEW_NAMES = ("front", "top")
FORMATS = ("avi", "png", "cine")
CODECS = ("mjpg", "ffv1", "raw")
TRUTH_FILE = "truth.json"
TRUTH_SCHEMA = 1
#: World axes seen by each view, as indices into (x, y, z).
_VIEW_INDEX = {"front": (0, 1), "top": (0, 2)}
_AXIS_INDEX = {"x": 0, "y": 1, "z": 2}
_NICE_RULERS_M = (2.0, 1.0, 0.5, 0.25, 0.2, 0.1, 0.05, 0.02)
# Machine dressing, in m and grey levels (fractions of full scale).
_TOOTH_HALF_WIDTH_M = 0.012       # front view: the tooth is a bar 24 mm wide
_TOOTH_HALF_BREADTH_M = 0.03      # top view: the tooth is 60 mm broad along Z
_HUB_RADIUS_M = 0.045
_SHAFT_HALF_WIDTH_M = 0.025
_SHAFT_HALF_LENGTH_M = 0.45
# The second straw starts out of the XOY plane and tumbles about a tilted axis, so that
# it crosses the main straw at an angle in both views.
_SECOND_DIRECTION = np.array([0.35, 0.45, 0.82])
_SECOND_AXIS = np.array([0.2, 0.9, 0.4])
_GREY = {"tooth": 0.30, "hub": 0.12, "housing": 0.16, "hood": 0.20,
         "ruler": 0.82, "tick": 0.10}


def _fail(message):
    raise VidtrackError(message)


# ---------------------------------------------------------------------------------------
# The specification
# ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SynthSpec:
    """Every parameter of a synthetic run (units in the names; defaults in brackets).

    Throw (SPEC "World frame"; :func:`fits.throw.position`)
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
        k1..k4 between replicate throws (not applied with one throw) [0.03]; ``seed``
        [42]; ``run_name`` None = the output folder's name [None]; ``scale_in_scene``
        "ruler" | "m_per_px" ["ruler"]; ``sync_in_scene`` write each view's release
        frame as ``sync_frame`` (else "auto") [False].
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
    seed: int = 42
    run_name: str | None = None
    scale_in_scene: str = "ruler"
    sync_in_scene: bool = False

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

    def view_size(self, view):
        """(width, height) of ``view`` in pixels."""
        if view == "top" and self.top_size_px is not None:
            return tuple(int(v) for v in self.top_size_px)
        return tuple(int(v) for v in self.size_px)

    def view_axes(self, view):
        return tuple(self.front_axes if view == "front" else self.top_axes)

    def to_dict(self):
        """Every parameter, JSON-ready."""
        return {f.name: _jsonable(getattr(self, f.name)) for f in fields(self)}


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
    if np.any(k <= 0):
        _fail(f"k1..k4 must all be > 0, got {list(s.k)}")
    _number("cp_s_per_m", s.cp_s_per_m, ge=0)
    state = _vector("state (x0, y0, z0, vx0, vy0, vz0)", s.state, 6)
    if math.hypot(state[0], state[1]) < 0.02:
        _fail("the release point (x0, y0) must be at least 0.02 m from the shaft (the "
              f"straw leaves a tooth), got ({state[0]}, {state[1]})")
    _number("speed_kmh", s.speed_kmh, ge=0)
    if s.model not in MODELS:
        _fail(f"model must be one of {', '.join(MODELS)}, got {s.model!r}")
    _number("gravity_m_s2", s.gravity_m_s2, gt=0)
    _number("straw_length_m", s.straw_length_m, gt=0)
    _number("straw_diameter_m", s.straw_diameter_m, gt=0)
    if s.straw_diameter_m > s.straw_length_m:
        _fail(f"straw_diameter_m ({s.straw_diameter_m}) must not exceed straw_length_m "
              f"({s.straw_length_m})")
    if s.spin_rad_s is not None:
        _number("spin_rad_s", s.spin_rad_s)
    axis = _vector("spin_axis", s.spin_axis, 3)
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
        _number("blade_rpm", s.blade_rpm)
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
    _number("flight_s", s.flight_s, gt=0)
    if s.frames is not None:
        _number("frames", s.frames, ge=1, integer=True)
    if s.n_frames < 1:
        _fail("no frames to render: release_frame + flight_s * fps is 0")
    _number("top_delay_s", s.top_delay_s)
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
        _number("m_per_px", s.m_per_px, gt=0)
    _number("exposure_fraction", s.exposure_fraction, ge=0, le=1)
    _number("exposure_samples", s.exposure_samples, ge=1, le=256, integer=True)
    _number("supersample", s.supersample, ge=1, le=64, integer=True)
    _number("texture_amplitude", s.texture_amplitude, ge=0, le=0.5)
    _number("vignetting", s.vignetting, ge=0, le=0.5)
    _number("read_noise_dn", s.read_noise_dn, ge=0)
    if s.full_well_e is not None:
        _number("full_well_e", s.full_well_e, gt=0)
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
    _number("throw_spread", s.throw_spread, ge=0, le=0.3)
    _number("seed", s.seed, ge=0, integer=True)
    if s.scale_in_scene not in ("ruler", "m_per_px"):
        _fail(f"scale_in_scene must be ruler or m_per_px, got {s.scale_in_scene!r}")
    if s.scale_in_scene == "ruler" and not s.draw_ruler:
        _fail("scale_in_scene 'ruler' needs the ruler drawn (draw_ruler); use m_per_px")
    if s.run_name is not None and (not isinstance(s.run_name, str) or not s.run_name.strip()):
        _fail(f"run_name must be a non-empty string, got {s.run_name!r}")


# ---------------------------------------------------------------------------------------
# Kinematics: the throws, the straw's pose, the second straw
# ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Throw:
    """One throw: the release state, k, and the rotor and spin rates."""

    state: tuple
    k: tuple
    blade_rad_s: float
    spin_rad_s: float
    blade_radius_m: float

    @property
    def release_angle_rad(self):
        return math.atan2(self.state[1], self.state[0])

    @property
    def release_radius_m(self):
        return math.hypot(self.state[0], self.state[1])


def _matched_blade_rate(state):
    """Rotor rate (rad/s) at which the straw's tangential speed is continuous at release."""
    x0, y0, _, vx0, vy0, _ = state
    return (x0 * vy0 - y0 * vx0) / (x0 * x0 + y0 * y0)


def _make_throws(spec):
    rng = np.random.default_rng([spec.seed, 7])
    out = []
    for _ in range(spec.throws):
        state = np.asarray(spec.state, dtype=np.float64)
        k = np.asarray(spec.k, dtype=np.float64)
        if spec.throws > 1 and spec.throw_spread > 0:
            e = rng.standard_normal(6) * spec.throw_spread
            speed = math.hypot(state[3], state[4]) * (1.0 + e[0])
            angle = math.atan2(state[4], state[3]) + 0.5 * e[1]
            state[3], state[4] = speed * math.cos(angle), speed * math.sin(angle)
            k = k * np.clip(1.0 + e[2:], 0.2, None)
        state_t = tuple(float(v) for v in state)
        blade = (_matched_blade_rate(state_t) if spec.blade_rpm is None
                 else spec.blade_rpm * math.pi / 30.0)
        spin = blade if spec.spin_rad_s is None else float(spec.spin_rad_s)
        radius = (spec.blade_radius_m if spec.blade_radius_m is not None
                  else math.hypot(state_t[0], state_t[1]))
        out.append(_Throw(state=state_t, k=tuple(float(v) for v in k), blade_rad_s=blade,
                          spin_rad_s=spin, blade_radius_m=float(radius)))
    return out


def _rotate(d0, axis, angle):
    """Rodrigues: unit vector ``d0`` turned by ``angle`` (array) about unit ``axis``."""
    angle = np.asarray(angle, dtype=np.float64)[:, None]
    kx = np.cross(axis, d0)
    return (d0[None, :] * np.cos(angle) + kx[None, :] * np.sin(angle)
            + axis[None, :] * float(axis @ d0) * (1.0 - np.cos(angle)))


def straw_pose(t, throw_state, k, *, spec, blade_rad_s, spin_rad_s):
    """Centre (m) and unit direction of the main straw's rod at times ``t`` (s).

    Parameters
    ----------
    t : array_like
        Times relative to release (negative: before).
    throw_state, k : sequence
        Release state (x0, y0, z0, vx0, vy0, vz0) and (k1, k2, k3, k4).
    spec : SynthSpec, keyword-only
    blade_rad_s, spin_rad_s : float, keyword-only
        Rotor rate and spin rate after release, rad/s.

    Returns
    -------
    centre, direction : numpy.ndarray, shape (N, 3)
        World frame of SPEC.md; z relative to the machine.

    Notes
    -----
    t >= 0: :func:`fits.throw.position`. t < 0: the straw rides a tooth that turns at
    ``blade_rad_s`` about the shaft, lying along it, its centre at radius
    ``max(rho0 + v_r t, rho0 / 2)`` (rho0 the release radius, v_r the radial part of
    the release velocity), at z = z0; the pose is continuous at t = 0.
    """
    from fits.throw import position

    t = np.atleast_1d(np.asarray(t, dtype=np.float64)).ravel()
    state = np.asarray(throw_state, dtype=np.float64)
    centre = np.empty((t.size, 3))
    direction = np.empty((t.size, 3))
    phi0 = math.atan2(state[1], state[0])
    d0 = np.array([math.cos(phi0), math.sin(phi0), 0.0])
    after = t >= 0
    if np.any(after):
        centre[after] = position(t[after], state, k, spec.cp_s_per_m, g=spec.gravity_m_s2,
                                 v1=spec.v1_m_s, model=spec.model)
        axis = np.asarray(spec.spin_axis, dtype=np.float64)
        axis = axis / np.linalg.norm(axis)
        direction[after] = _rotate(d0, axis, spin_rad_s * t[after])
    before = ~after
    if np.any(before):
        rho0 = math.hypot(state[0], state[1])
        v_r = (state[0] * state[3] + state[1] * state[4]) / rho0
        tb = t[before]
        rho = np.maximum(rho0 + v_r * tb, 0.5 * rho0)
        phi = phi0 + blade_rad_s * tb
        centre[before] = np.column_stack([rho * np.cos(phi), rho * np.sin(phi),
                                          np.full(tb.size, state[2])])
        direction[before] = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(tb.size)])
    return centre, direction


def second_straw_state(spec, throw):
    """Release state and release time (main clock) of the second straw.

    It leaves the main straw's release point ``second_flight_s`` before
    ``second_cross_s`` with the velocity (found per axis by root finding on
    :func:`fits.throw.position`) that puts its centre on the main straw's centre at
    ``second_cross_s``.

    Returns
    -------
    state : tuple of 6 float
    t_release_s : float
    """
    from scipy.optimize import brentq

    from fits.throw import position

    target = position([spec.second_cross_s], throw.state, throw.k, spec.cp_s_per_m,
                      g=spec.gravity_m_s2, v1=spec.v1_m_s, model=spec.model)[0]
    dt = spec.second_flight_s
    x0, y0, z0 = throw.state[:3]
    vel = []
    for axis in range(3):
        def miss(v, axis=axis):
            st = [x0, y0, z0, 0.0, 0.0, spec.v1_m_s]
            st[3 + axis] = v
            p = position([dt], st, throw.k, spec.cp_s_per_m, g=spec.gravity_m_s2,
                         v1=spec.v1_m_s, model=spec.model)[0]
            return p[axis] - target[axis]
        lo, hi = -200.0, 200.0
        if miss(lo) > 0 or miss(hi) < 0:
            _fail(f"no second straw can reach the main straw at second_cross_s = "
                  f"{spec.second_cross_s} s after flying second_flight_s = {dt} s")
        vel.append(brentq(miss, lo, hi, xtol=1e-13, rtol=1e-14))
    return (x0, y0, z0, *vel), spec.second_cross_s - dt


def _second_pose(t, spec, throw, state2, t2):
    from fits.throw import position

    t = np.asarray(t, dtype=np.float64).ravel()
    centre = np.full((t.size, 3), np.nan)
    direction = np.full((t.size, 3), np.nan)
    live = t >= t2
    if np.any(live):
        tau = t[live] - t2
        centre[live] = position(tau, state2, throw.k, spec.cp_s_per_m, g=spec.gravity_m_s2,
                                v1=spec.v1_m_s, model=spec.model)
        d0 = _SECOND_DIRECTION / np.linalg.norm(_SECOND_DIRECTION)
        axis = _SECOND_AXIS / np.linalg.norm(_SECOND_AXIS)
        direction[live] = _rotate(d0, axis, -0.8 * throw.spin_rad_s * tau)
    return centre, direction


# ---------------------------------------------------------------------------------------
# Views: framing, static scene, ruler
# ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _View:
    name: str
    width: int
    height: int
    mapping: object                 # calibration.views.ViewMapping
    ruler_length_m: float | None
    ruler_from_px: tuple | None
    ruler_to_px: tuple | None
    delay_s: float

    @property
    def index(self):
        return _VIEW_INDEX[self.name]

    def to_px(self, points3):
        """World points (N, 3) -> pixels (N, 2); NaN rows stay NaN."""
        pts = np.asarray(points3, dtype=np.float64)[:, list(self.index)]
        return self.mapping.world_to_pixel(pts)

    def world_box(self, lo, hi):
        """The pixel Box of the world rectangle lo..hi (2 coords each, view's axes)."""
        corners = self.mapping.world_to_pixel(np.array([lo, hi], dtype=np.float64))
        return _raster.Box(corners[0, 0], corners[1, 0], corners[0, 1], corners[1, 1])


def _frame_times(spec, delay_s):
    return (np.arange(spec.n_frames) - spec.release_frame) / spec.fps + delay_s


def _nice_up(m):
    e = math.floor(math.log10(m))
    step = 10.0 ** (e - 2)
    return round(math.ceil(m / step - 1e-9) * step, 12)


def _frame_view(spec, name, throws):
    """Choose scale and origin of ``name`` so the rotor and the flight fit."""
    from calibration.views import ViewMapping

    width, height = spec.view_size(name)
    axes = spec.view_axes(name)
    delay = spec.top_delay_s if name == "top" else 0.0
    t = _frame_times(spec, delay)
    if spec.leave_frame:
        t = t[t <= 0.55 * max(t.max(), 0.0)]
    radius = max(th.blade_radius_m for th in throws)
    reach = radius + _TOOTH_HALF_WIDTH_M + 0.02
    # the rotor, and on the machine side the edge of the housing
    lo = {"x": -(reach + 0.12), "y": -reach, "z": -(_TOOTH_HALF_BREADTH_M + 0.03)}
    hi = {"x": reach, "y": reach, "z": _TOOTH_HALF_BREADTH_M + 0.03}
    pad = 0.5 * spec.straw_length_m + spec.straw_diameter_m
    for th in throws:
        c, _ = straw_pose(t, th.state, th.k, spec=spec, blade_rad_s=th.blade_rad_s,
                          spin_rad_s=th.spin_rad_s)
        for axis, i in _AXIS_INDEX.items():
            lo[axis] = min(lo[axis], float(np.nanmin(c[:, i])) - pad)
            hi[axis] = max(hi[axis], float(np.nanmax(c[:, i])) + pad)
    col, row = axes[0][1], axes[1][1]
    dims = {"col": width, "row": height}
    ruler_on = "row" if col == "x" else "col"           # the band across the ruler
    band = max(16.0, 0.09 * dims[ruler_on]) if spec.draw_ruler else 0.0
    margin = {k: max(4.0, 0.03 * v) for k, v in dims.items()}
    usable = {k: dims[k] - 2.0 * margin[k] - (band if k == ruler_on else 0.0) for k in dims}
    extent = {"col": hi[col] - lo[col], "row": hi[row] - lo[row]}
    if spec.m_per_px is not None:
        m = float(spec.m_per_px)
    else:
        m = _nice_up(max(extent["col"] / usable["col"], extent["row"] / usable["row"]))
    origin = []
    for key, (sign_name, axis) in (("col", axes[0]), ("row", axes[1])):
        sign = 1.0 if sign_name[0] == "+" else -1.0
        start = margin[key]
        if axis == "x" and extent[key] / m > usable[key]:
            # the content does not fit: keep the machine side in view
            anchor = lo["x"]
            target = start if sign > 0 else start + usable[key]
        else:
            anchor = 0.5 * (lo[axis] + hi[axis])
            target = start + 0.5 * usable[key]
        origin.append(round(target - sign * anchor / m, 2))
    mapping = ViewMapping(axes=axes, origin_px=tuple(origin), m_per_px=m)
    ruler = (None, None, None)
    if spec.draw_ruler:
        ruler = _place_ruler(mapping, width, height, col == "x", band, margin)
    return _View(name=name, width=width, height=height, mapping=mapping,
                 ruler_length_m=ruler[0], ruler_from_px=ruler[1], ruler_to_px=ruler[2],
                 delay_s=delay)


def _place_ruler(mapping, width, height, along_cols, band, margin):
    """A ruler along world X in the reserved band: (length_m, from_px, to_px)."""
    m = mapping.m_per_px
    dim = width if along_cols else height
    length = next((L for L in _NICE_RULERS_M if L / m <= 0.4 * dim), None)
    if length is None:
        length = _NICE_RULERS_M[-1]
    if along_cols:
        perp = height - margin["row"] - 0.5 * band
        start_px = np.array([0.5 * width, perp])
    else:
        perp = width - margin["col"] - 0.5 * band
        start_px = np.array([perp, 0.5 * height])
    w = mapping.pixel_to_world(start_px)
    ix = 0                                             # world x is column 0 of the view
    w[ix] = round(float(w[ix]), 2)
    end = w.copy()
    end[ix] += length
    p_end = mapping.world_to_pixel(end)
    if not (-0.5 <= p_end[0] <= width - 0.5 and -0.5 <= p_end[1] <= height - 0.5):
        end[ix] = w[ix] - length
    a, b = mapping.world_to_pixel(np.array([w, end]))
    return float(length), (float(a[0]), float(a[1])), (float(b[0]), float(b[1]))


def _ruler_boxes(view):
    """Bar and ticks of the ruler as (Box, grey) in pixels."""
    a, b = np.array(view.ruler_from_px), np.array(view.ruler_to_px)
    along_cols = abs(b[0] - a[0]) > abs(b[1] - a[1])
    i_al, i_pe = (0, 1) if along_cols else (1, 0)
    lo, hi = min(a[i_al], b[i_al]), max(a[i_al], b[i_al])
    perp = a[i_pe]
    half = 5.0

    def box(al0, al1, pe0, pe1):
        return (_raster.Box(al0, al1, pe0, pe1) if along_cols
                else _raster.Box(pe0, pe1, al0, al1))

    out = [(box(lo - 6.0, hi + 6.0, perp - half, perp + half), _GREY["ruler"])]
    span_px = hi - lo
    length = view.ruler_length_m
    n = 1
    for step in (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0):
        ticks = length / step
        if abs(ticks - round(ticks)) < 1e-9 and span_px / ticks >= 5.0:
            n = int(round(ticks))
            break
    for j in range(n + 1):
        pos = lo + span_px * j / n
        end = j in (0, n)
        major = j % 5 == 0
        w = 1.0 if end else 0.5
        depth = 2.0 * half if end else (0.7 * half if major else 0.4 * half)
        out.append((box(pos - w, pos + w, perp - half, perp - half + depth), _GREY["tick"]))
    return out


def _static_image(spec, view):
    """Background texture, housing, hood and ruler (float image in [0, 1])."""
    rng = np.random.default_rng([spec.seed, VIEW_NAMES.index(view.name), 1])
    h, w = view.height, view.width
    img = spec.background_grey + spec.texture_amplitude * _raster.smooth_texture((h, w), rng)
    rows = (np.arange(h) - 0.5 * (h - 1)) / (0.5 * h)
    cols = (np.arange(w) - 0.5 * (w - 1)) / (0.5 * w)
    img *= 1.0 - 0.5 * spec.vignetting * (rows[:, None] ** 2 + cols[None, :] ** 2)
    whole = _raster.Roi(0, h, 0, w)
    paint = []
    if spec.draw_machine:
        r = _machine_radius(spec)
        if view.name == "front":
            paint.append((view.world_box((-3.0, -0.40), (-(r + 0.08), 0.32)), _GREY["housing"]))
            paint.append((view.world_box((-(r + 0.08), r + 0.06), (0.06, r + 0.12)), _GREY["hood"]))
        else:
            paint.append((view.world_box((-3.0, -0.5), (-(r + 0.08), 0.5)), _GREY["housing"]))
    if spec.draw_ruler:
        paint.extend(_ruler_boxes(view))
    for shape, grey in paint:
        cov = _raster.box_coverage(shape, whole)
        img += (grey - img) * cov
    return img


def _machine_radius(spec):
    radius = spec.blade_radius_m
    if radius is None:
        radius = math.hypot(spec.state[0], spec.state[1])
    return radius


# ---------------------------------------------------------------------------------------
# Per-view kinematics in pixels, and the renderer
# ---------------------------------------------------------------------------------------
class _ViewTrack:
    """Poses of the straw(s) and the rotor at every frame and exposure sample of a view."""

    def __init__(self, spec, view, throw, second):
        self.spec, self.view, self.throw = spec, view, throw
        exposure = spec.exposure_fraction / spec.fps
        n = spec.n_frames
        kk = self.kk = spec.exposure_samples if exposure > 0 else 1
        self.t = _frame_times(spec, view.delay_s)
        offs = ((np.arange(kk) + 0.5) / kk - 0.5) * exposure
        self.ts = self.t[:, None] + offs[None, :]                     # (n, K)
        self.radius_px = 0.5 * spec.straw_diameter_m / view.mapping.m_per_px
        half = 0.5 * spec.straw_length_m - 0.5 * spec.straw_diameter_m
        c, d = straw_pose(self.t, throw.state, throw.k, spec=spec,
                          blade_rad_s=throw.blade_rad_s, spin_rad_s=throw.spin_rad_s)
        self.centre_m = c
        self.centre_px = view.to_px(c)
        self.end_a_px = view.to_px(c - half * d)
        self.end_b_px = view.to_px(c + half * d)
        cs, ds = straw_pose(self.ts.ravel(), throw.state, throw.k, spec=spec,
                            blade_rad_s=throw.blade_rad_s, spin_rad_s=throw.spin_rad_s)
        self.sub_a = view.to_px(cs - half * ds).reshape(n, kk, 2)
        self.sub_b = view.to_px(cs + half * ds).reshape(n, kk, 2)
        self.second = second is not None
        if self.second:
            state2, t2 = second
            c2, d2 = _second_pose(self.t, spec, throw, state2, t2)
            self.centre2_m = c2
            self.centre2_px = view.to_px(c2)
            self.end2_a_px = view.to_px(c2 - half * d2)
            self.end2_b_px = view.to_px(c2 + half * d2)
            cs2, ds2 = _second_pose(self.ts.ravel(), spec, throw, state2, t2)
            self.sub2_a = view.to_px(cs2 - half * ds2).reshape(n, kk, 2)
            self.sub2_b = view.to_px(cs2 + half * ds2).reshape(n, kk, 2)

    def blade_angles(self, i):
        return self.throw.release_angle_rad + self.throw.blade_rad_s * self.ts[i]

    def layers(self, i, j):
        """Opaque layers of exposure sample j of frame i, back to front."""
        spec, view = self.spec, self.view
        out = []
        if spec.draw_machine:
            phi = self.throw.release_angle_rad + self.throw.blade_rad_s * self.ts[i, j]
            radius = self.throw.blade_radius_m
            m = view.mapping.m_per_px
            for tooth, ang in (("tooth0", phi), ("tooth1", phi + math.pi)):
                tip = np.array([[radius * math.cos(ang), radius * math.sin(ang), 0.0]])
                if view.name == "front":
                    a, b = view.to_px(np.zeros((1, 3)))[0], view.to_px(tip)[0]
                    shape = _raster.Capsule(tuple(a), tuple(b), _TOOTH_HALF_WIDTH_M / m)
                else:
                    shape = view.world_box((min(0.0, tip[0, 0]), -_TOOTH_HALF_BREADTH_M),
                                           (max(0.0, tip[0, 0]), _TOOTH_HALF_BREADTH_M))
                out.append((tooth, shape, _GREY["tooth"]))
            if view.name == "front":
                o = view.to_px(np.zeros((1, 3)))[0]
                hub = _raster.Capsule(tuple(o), tuple(o), _HUB_RADIUS_M / m)
            else:
                hub = view.world_box((-_SHAFT_HALF_WIDTH_M, -_SHAFT_HALF_LENGTH_M),
                                     (_SHAFT_HALF_WIDTH_M, _SHAFT_HALF_LENGTH_M))
            out.append(("hub", hub, _GREY["hub"]))
        if self.second and np.all(np.isfinite(self.sub2_a[i, j])):
            out.append(("straw2", _raster.Capsule(tuple(self.sub2_a[i, j]),
                                                  tuple(self.sub2_b[i, j]), self.radius_px),
                        spec.straw_grey))
        out.append(("straw", _raster.Capsule(tuple(self.sub_a[i, j]), tuple(self.sub_b[i, j]),
                                             self.radius_px), spec.straw_grey))
        return out

    def exposure_geometry(self, i):
        """Area-weighted mean centre over the exposure and the silhouette's extent."""
        a, b = self.sub_a[i], self.sub_b[i]
        r = self.radius_px
        seg = np.hypot(*(b - a).T)
        area = np.pi * r * r + 2.0 * r * seg
        centre = 0.5 * (a + b)
        mean = (area[:, None] * centre).sum(axis=0) / area.sum()
        ext = (min(a[:, 0].min(), b[:, 0].min()) - r, max(a[:, 0].max(), b[:, 0].max()) + r,
               min(a[:, 1].min(), b[:, 1].min()) - r, max(a[:, 1].max(), b[:, 1].max()) + r)
        return mean, ext


def _merge_rois(rois):
    """Group layers whose pixel boxes intersect: [(Roi, set of keys)], disjoint boxes."""
    groups = [(roi, {key}) for key, roi in rois.items()]
    merged = True
    while merged:
        merged = False
        for a in range(len(groups)):
            for b in range(a + 1, len(groups)):
                if groups[a][0].intersects(groups[b][0]):
                    groups[a] = (groups[a][0].union(groups[b][0]), groups[a][1] | groups[b][1])
                    del groups[b]
                    merged = True
                    break
            if merged:
                break
    return groups


class _ViewRenderer:
    """Renders frame i of one view of one throw (deterministic, any order)."""

    def __init__(self, spec, view, track, throw_index, static):
        self.spec, self.view, self.track = spec, view, track
        self.throw_index = throw_index
        self.static = static
        self.info = {}
        self._cache = {}
        self.read_noise = spec.read_noise_dn / 255.0

    def frame_float(self, i):
        """The noiseless frame i (float, [0, 1]) and its coverage facts."""
        spec, track = self.spec, self.track
        shape = (self.view.height, self.view.width)
        kk = track.kk
        per_sample = [track.layers(i, j) for j in range(kk)]
        rois = {}
        for layers in per_sample:
            for key, s, _ in layers:
                roi = _raster.shape_roi(s.extent_px()).clip(shape)
                if not roi.empty:
                    rois[key] = rois[key].union(roi) if key in rois else roi
        groups = _merge_rois(rois)
        image = self.static.copy()
        facts = {"coverage_px": 0.0, "moment_u": 0.0, "moment_v": 0.0, "overlap": False,
                 "blade_overlap": False}
        for roi, keys in groups:
            base = self.static[roi.slices]
            acc = np.zeros(roi.shape)
            cov = {}
            for layers in per_sample:
                sel = [ly for ly in layers if ly[0] in keys]
                painted, covers = _raster.composite_box(base, sel, roi,
                                                        supersample=spec.supersample,
                                                        cache=self._cache)
                acc += painted
                for key, (sub, c) in covers.items():
                    name = "blade" if key in ("tooth0", "tooth1", "hub") else key
                    if name not in cov:
                        cov[name] = np.zeros(roi.shape)
                    cov[name][sub.slice_in(roi)] += c
            image[roi.slices] = acc / kk
            if "straw" in cov:
                straw = cov["straw"] / kk
                facts["coverage_px"] += float(straw.sum())
                facts["moment_u"] += float((straw.sum(axis=0) * np.arange(roi.c0, roi.c1)).sum())
                facts["moment_v"] += float((straw.sum(axis=1) * np.arange(roi.r0, roi.r1)).sum())
                if "straw2" in cov:
                    facts["overlap"] |= bool(np.any((straw > 0) & (cov["straw2"] > 0)))
                if "blade" in cov:
                    facts["blade_overlap"] |= bool(np.any((straw > 0) & (cov["blade"] > 0)))
        return image, facts

    def frame(self, i):
        """Frame i as written: noise added, quantised to ``bit_depth``."""
        image, facts = self.frame_float(i)
        self.info[i] = facts
        rng = np.random.default_rng([self.spec.seed, VIEW_NAMES.index(self.view.name),
                                     self.throw_index, i, 2])
        noisy = _raster.add_sensor_noise(image, rng, read_noise=self.read_noise,
                                         full_well_e=self.spec.full_well_e)
        return _raster.quantize(noisy, self.spec.bit_depth)


# ---------------------------------------------------------------------------------------
# Writers
# ---------------------------------------------------------------------------------------
def _source_name(spec, view):
    return {"avi": f"{view}.avi", "png": view, "cine": f"{view}.cine"}[spec.output_format]


def _write_avi(path, renderer, n, spec, tick):
    import cv2

    from vidtrack._atomic import atomic_path

    w, h = renderer.view.width, renderer.view.height
    with atomic_path(path) as tmp:
        video = tmp.with_name(tmp.name + ".avi")
        try:
            if spec.video_codec == "mjpg":
                # OpenCV's own MJPEG writer honours the quality; it needs 3 channels.
                writer = cv2.VideoWriter(str(video), cv2.CAP_OPENCV_MJPEG,
                                         cv2.VideoWriter_fourcc(*"MJPG"), spec.playback_fps,
                                         (w, h), [cv2.VIDEOWRITER_PROP_IS_COLOR, 1])
                colour = True
            else:
                fourcc = cv2.VideoWriter_fourcc(*("FFV1" if spec.video_codec == "ffv1"
                                                  else "Y800"))
                writer = cv2.VideoWriter(str(video), cv2.CAP_FFMPEG, fourcc, spec.playback_fps,
                                         (w, h), [cv2.VIDEOWRITER_PROP_IS_COLOR, 0])
                colour = False
            if not writer.isOpened():
                raise VidtrackError(f"{path}: this OpenCV cannot write "
                                    f"{spec.video_codec.upper()} AVI files; use --codec or "
                                    "--format png|cine")
            if spec.video_codec == "mjpg":
                writer.set(cv2.VIDEOWRITER_PROP_QUALITY, float(spec.jpeg_quality))
            try:
                for i in range(n):
                    frame = renderer.frame(i)
                    writer.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR) if colour else frame)
                    tick()
            finally:
                writer.release()
            os.replace(video, tmp)
        finally:
            if video.exists():
                video.unlink()


def _write_png(folder, renderer, n, spec, tick):
    import cv2

    from vidtrack._atomic import write_bytes

    folder.mkdir(parents=True, exist_ok=False)
    for i in range(n):
        frame = renderer.frame(i)
        ok, data = cv2.imencode(".png", frame)
        if not ok:
            raise VidtrackError(f"{folder}: png encoding of frame {i} failed")
        write_bytes(folder / f"frame_{i:06d}.png", data.tobytes())
        tick()


class _LazyFrames:
    """A sequence of rendered frames for write_cine (renders on demand, keeps the last)."""

    def __init__(self, renderer, n, tick):
        self.renderer, self.n, self.tick = renderer, n, tick
        self._last = (None, None)

    def __len__(self):
        return self.n

    def __getitem__(self, k):
        if self._last[0] != k:
            self._last = (k, self.renderer.frame(k))
            self.tick()
        return self._last[1]


def _write_cine(path, renderer, n, spec, release_frame, tick):
    from vidtrack.footage.cine import write_cine

    write_cine(path, _LazyFrames(renderer, n, tick), fps=spec.fps, bit_depth=spec.bit_depth,
               packed=spec.cine_packed, first_image_no=-int(release_frame),
               timestamps_s=renderer.track.t)


# ---------------------------------------------------------------------------------------
# Truth
# ---------------------------------------------------------------------------------------
def _release_frame_of(t):
    idx = np.flatnonzero(t >= -1e-12)
    return int(idx[0]) if idx.size else None


def _json_list(arr):
    return [None if not np.isfinite(v) else float(v) for v in np.asarray(arr, dtype=float)]


def _view_truth(spec, view, track, renderer, source):
    n = spec.n_frames
    w, h = view.width, view.height
    mean_c, ext = zip(*(track.exposure_geometry(i) for i in range(n)))
    mean_c = np.array(mean_c)
    ext = np.array(ext)
    inside = ((ext[:, 0] >= -0.5) & (ext[:, 1] <= w - 0.5) & (ext[:, 2] >= -0.5)
              & (ext[:, 3] <= h - 0.5))
    reach_border = ((ext[:, 0] < 0.5) | (ext[:, 1] > w - 1.5) | (ext[:, 2] < 0.5)
                    | (ext[:, 3] > h - 1.5))
    info = [renderer.info[i] for i in range(n)]
    coverage = np.array([f["coverage_px"] for f in info])
    in_view = coverage > 0
    safe = np.where(in_view, coverage, 1.0)
    cov_u = np.where(in_view, np.array([f["moment_u"] for f in info]) / safe, np.nan)
    cov_v = np.where(in_view, np.array([f["moment_v"] for f in info]) / safe, np.nan)
    seg = track.end_b_px - track.end_a_px
    angle = np.arctan2(seg[:, 1], seg[:, 0])
    angle = np.where(angle > np.pi / 2, angle - np.pi, angle)
    angle = np.where(angle <= -np.pi / 2, angle + np.pi, angle)
    seg_len = np.hypot(seg[:, 0], seg[:, 1])
    r = track.radius_px
    t = track.t
    table = {
        "frame": list(range(n)),
        "t_s": _json_list(t),
        "phase": ["blade" if ti < 0 else "flight" for ti in t],
        "x_m": _json_list(track.centre_m[:, 0]),
        "y_m": _json_list(track.centre_m[:, 1]),
        "z_m": _json_list(track.centre_m[:, 2]),
        "u_px": _json_list(track.centre_px[:, 0]),
        "v_px": _json_list(track.centre_px[:, 1]),
        "u_exposure_px": _json_list(mean_c[:, 0]),
        "v_exposure_px": _json_list(mean_c[:, 1]),
        "u_coverage_px": _json_list(cov_u),
        "v_coverage_px": _json_list(cov_v),
        "angle_rad": _json_list(angle),
        "length_px": _json_list(seg_len + 2.0 * r),
        "area_px": _json_list(np.pi * r * r + 2.0 * r * seg_len),
        "coverage_px": _json_list(coverage),
        "in_view": [bool(v) for v in in_view],
        "fully_in_view": [bool(v) for v in inside],
        "border_touch": [bool(a and b) for a, b in zip(in_view, reach_border)],
        "blade_overlap": [bool(f["blade_overlap"]) for f in info],
        "overlap": [bool(f["overlap"]) for f in info],
    }
    if track.second:
        c2, p2 = track.centre2_m, track.centre2_px
        a2, b2 = track.end2_a_px, track.end2_b_px
        with np.errstate(invalid="ignore"):
            vis2 = (np.isfinite(p2[:, 0]) & (np.maximum(a2[:, 0], b2[:, 0]) + r > -0.5)
                    & (np.minimum(a2[:, 0], b2[:, 0]) - r < w - 0.5)
                    & (np.maximum(a2[:, 1], b2[:, 1]) + r > -0.5)
                    & (np.minimum(a2[:, 1], b2[:, 1]) - r < h - 0.5))
        table.update({
            "x2_m": _json_list(c2[:, 0]), "y2_m": _json_list(c2[:, 1]),
            "z2_m": _json_list(c2[:, 2]),
            "u2_px": _json_list(p2[:, 0]), "v2_px": _json_list(p2[:, 1]),
            "in_view2": [bool(v) for v in vis2],
        })
    release = _release_frame_of(t)
    m = view.mapping
    out = {
        "source": source,
        "format": spec.output_format,
        "fps": spec.fps,
        "fps_container": spec.playback_fps if spec.output_format == "avi" else
        (float(round(spec.fps)) if spec.output_format == "cine" else None),
        "frames": n,
        "width_px": w,
        "height_px": h,
        "bit_depth": spec.bit_depth,
        "axes": list(m.axes),
        "world_axes": list(m.world_axes),
        "origin_px": list(m.origin_px),
        "m_per_px": m.m_per_px,
        "ruler": None if view.ruler_length_m is None else {
            "length_m": view.ruler_length_m, "from_px": list(view.ruler_from_px),
            "to_px": list(view.ruler_to_px)},
        "delay_s": view.delay_s,
        "release_frame": release,
        "t0_frame": float(spec.release_frame - view.delay_s * spec.fps),
        "straw_radius_px": r,
        "blade": {"centre_px": list(m.origin_px),
                  "radius_px": (track.throw.blade_radius_m + _TOOTH_HALF_WIDTH_M) / m.m_per_px,
                  "rate_rad_s": track.throw.blade_rad_s},
        "per_frame": table,
    }
    return out


def _throw_truth(spec, throw, second):
    from fits.throw import apex

    ap = apex(throw.state, throw.k, spec.cp_s_per_m, g=spec.gravity_m_s2, model=spec.model)
    names = ("x0_m", "y0_m", "z0_m", "vx0_m_s", "vy0_m_s", "vz0_m_s")
    out = {
        "model": spec.model,
        "k": {f"k{i + 1}": v for i, v in enumerate(throw.k)},
        "cp_s_per_m": spec.cp_s_per_m,
        "state": dict(zip(names, throw.state)),
        "v1_m_s": spec.v1_m_s,
        "speed_kmh": spec.speed_kmh,
        "gravity_m_s2": spec.gravity_m_s2,
        "apex": None if ap is None else ap.to_dict(),
        "blade_rate_rad_s": throw.blade_rad_s,
        "blade_radius_m": throw.blade_radius_m,
        "spin_rad_s": throw.spin_rad_s,
        "spin_axis": list(spec.spin_axis),
        "straw": {"length_m": spec.straw_length_m, "diameter_m": spec.straw_diameter_m,
                  "shape": "capsule (cylinder with hemispherical ends), length end to end"},
    }
    if second is not None:
        out["second_straw"] = {"state": dict(zip(names, second[0])),
                               "release_t_s": second[1],
                               "cross_t_s": spec.second_cross_s,
                               "drawn": "behind the main straw"}
    return out


_FLAT_LIST = re.compile(r"\[[^\[\]{}]*\]")


def _truth_text(obj):
    """Indented JSON with every list of plain values on one line (full precision)."""
    text = json.dumps(obj, indent=1, allow_nan=False)
    return _FLAT_LIST.sub(lambda m: re.sub(r"\s*\n\s*", " ", m.group(0))
                          .replace("[ ", "[").replace(" ]", "]"), text) + "\n"


_CONVENTIONS = {
    "pixels": "u = column, v = row; the centre of pixel (row r, column c) is (u, v) = "
              "(c, r); the image spans [-0.5, width - 0.5] x [-0.5, height - 0.5]",
    "time": "t_s of frame i = (i - release_frame) / fps + delay_s, the middle of the "
            "frame's exposure; t = 0 is the release",
    "centroid": "u_px, v_px: the projected rod centre at t_s, which is the centroid of "
                "the straw's silhouette at t_s (the silhouette of a capsule is centrally "
                "symmetric about it)",
    "blur": "a frame is the mean of exposure_samples renders spread evenly over "
            "exposure_fraction / fps seconds centred on t_s; u_exposure_px, "
            "v_exposure_px is the area-weighted mean of those renders' centres, i.e. the "
            "centroid of the blurred silhouette's coverage; it differs from u_px, v_px by "
            "the trajectory's curvature over the exposure (far below 0.01 px)",
    "coverage_centroid": "u_coverage_px, v_coverage_px: the coverage-weighted mean of "
                         "pixel centres of the rendered blurred silhouette (inside the "
                         "image; null when out of view): what a perfect coverage-weighted "
                         "centroid measures. Even on an exact coverage image it differs "
                         "from the true centroid: a partly covered pixel counts at its "
                         "centre, not at the centre of its covered part. The difference "
                         "is largest for a straw aligned with the pixel grid, up to "
                         "1 / (8 w) px for a straw w px thick (0.03 px at 4 px), and far "
                         "smaller for a tilted one",
    "flags": "in_view: the rendered (blurred) silhouette covers some pixel; "
             "fully_in_view: it lies inside the image over the whole exposure; "
             "border_touch: in view and reaching the outermost pixel row or column; "
             "blade_overlap: shares a pixel with a tooth or the hub/shaft; overlap: "
             "shares a pixel with the second straw",
    "world": "x_m, y_m, z_m: the rod centre in the world frame of SPEC.md at t_s "
             "(z relative to the machine); before release the straw rides a tooth",
}


# ---------------------------------------------------------------------------------------
# The run
# ---------------------------------------------------------------------------------------
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
        View -> scale.
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


def _scene_dict(spec, views, run_name, release):
    out = {"schema": 1, "run": {"name": run_name},
           "factors": {"n_rpm": _plain_number(spec.n_rpm),
                       "blade_angle_deg": _plain_number(spec.blade_angle_deg),
                       "speed_kmh": _plain_number(spec.speed_kmh)},
           "physics": {"gravity_m_s2": spec.gravity_m_s2},
           "straw": {"cp_s_per_m": spec.cp_s_per_m},
           "machine": {"speed_kmh": spec.speed_kmh},
           "views": {}}
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


def _check_out(out_dir, force):
    if out_dir.exists() and not out_dir.is_dir():
        _fail(f"{out_dir}: exists and is not a folder")
    if out_dir.is_dir():
        present = sorted(p.name for p in out_dir.iterdir())
        if present and not force:
            shown = ", ".join(present[:5]) + (", ..." if len(present) > 5 else "")
            _fail(f"{out_dir}: the folder is not empty (holds {shown}); choose a new or "
                  "empty folder, or pass --force to replace the synthetic run in it")


def _replaceable(names):
    """Top-level entries a previous synthetic run may have left (replaced with force)."""
    out = set(names) | {"scene.toml", TRUTH_FILE, "throws", "vidtrack"}
    for view in VIEW_NAMES:
        out |= {view, f"{view}.avi", f"{view}.cine"}
    return out


def _remove(path):
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()


def render_run(out_dir, spec=None, *, force=False, quiet=True):
    """Render a synthetic run folder with its ``truth.json``.

    Parameters
    ----------
    out_dir : str or pathlib.Path
        The run folder to write; created if missing. It must be empty unless
        ``force``.
    spec : SynthSpec, optional
        All parameters (default ``SynthSpec()``).
    force : bool, keyword-only
        Write into a non-empty folder: the outputs of a previous synthetic run
        (``scene.toml``, ``truth.json``, ``front``/``top`` footage in any format,
        ``throws/``) and ``vidtrack/`` (results computed from the old footage) are
        replaced; other files are left alone.
    quiet : bool, keyword-only
        No progress bar.

    Returns
    -------
    SynthRun

    Raises
    ------
    VidtrackError
        A non-empty ``out_dir`` without ``force``, an ``out_dir`` that is a file, or
        impossible parameters (checked by :class:`SynthSpec`).

    Notes
    -----
    Everything is rendered into a hidden staging folder inside ``out_dir`` and moved
    into place at the end; on any error the staging folder is removed and nothing of
    the run appears. Each file is written through :mod:`vidtrack._atomic`.
    Layout: ``scene.toml``, ``truth.json`` and the footage (``front.avi`` or
    ``front/frame_000000.png ..`` or ``front.cine``; likewise ``top``) at the root; with
    ``throws > 1`` the footage and a ``truth.json`` per throw in ``throws/01 ..``, and
    the root ``truth.json`` summarises the throws.
    """
    from vidtrack._atomic import write_text
    from vidtrack._progress import progress
    from vidtrack.scene import write_scene

    spec = SynthSpec() if spec is None else spec
    if not isinstance(spec, SynthSpec):
        raise TypeError(f"spec must be a SynthSpec, got {type(spec).__name__}")
    started = time.perf_counter()
    out_dir = Path(out_dir)
    _check_out(out_dir, force)
    run_name = spec.run_name or out_dir.resolve().name

    throws = _make_throws(spec)
    seconds = [second_straw_state(spec, th) if spec.second_straw else None for th in throws]
    views = [_frame_view(spec, name, throws) for name in VIEW_NAMES if name in spec.views]
    statics = {v.name: _static_image(spec, v) for v in views}
    n = spec.n_frames
    release = {v.name: _release_frame_of(_frame_times(spec, v.delay_s)) for v in views}

    created = not out_dir.exists()
    out_dir.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".synth-", suffix=".part", dir=out_dir))
    bar = progress(total=n * len(views) * len(throws), desc="synth", quiet=quiet,
                   unit="frame")
    from vidtrack import __version__

    head = {"schema": TRUTH_SCHEMA, "generator": "vidtrack synth",
            "vidtrack_version": __version__, "run": run_name, "spec": spec.to_dict(),
            "conventions": _CONVENTIONS}
    try:
        summaries = []
        for ti, (throw, second) in enumerate(zip(throws, seconds)):
            folder = stage if spec.throws == 1 else stage / "throws" / f"{ti + 1:02d}"
            folder.mkdir(parents=True, exist_ok=True)
            view_truth = {}
            for view in views:
                track = _ViewTrack(spec, view, throw, second)
                renderer = _ViewRenderer(spec, view, track, ti, statics[view.name])
                target = folder / _source_name(spec, view.name)
                if spec.output_format == "avi":
                    _write_avi(target, renderer, n, spec, bar.update)
                elif spec.output_format == "png":
                    _write_png(target, renderer, n, spec, bar.update)
                else:
                    _write_cine(target, renderer, n, spec, release[view.name], bar.update)
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
        write_scene(stage, _scene_dict(spec, views, run_name, release))
        names = sorted(p.name for p in stage.iterdir())
        for name in _replaceable(names):
            _remove(out_dir / name)
        for name in names:
            os.replace(stage / name, out_dir / name)
        stage.rmdir()
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        if created:
            shutil.rmtree(out_dir, ignore_errors=True)
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
                    m_per_px={v.name: v.mapping.m_per_px for v in views},
                    release_frame=release, files=tuple(files), bytes_written=total,
                    elapsed_s=time.perf_counter() - started, spec=spec)
