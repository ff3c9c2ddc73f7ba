"""Pinhole cameras of ``vidtrack synth``: perspective at an angle, or square to the axes.

``cameras = "perspective"``: two cameras ``cam1`` and ``cam2`` at ``camera_distance_m``
from the middle of the flight (the centre of the box around the straw's path and the
rotor), their optical axes ``camera_angle_deg`` apart, both perpendicular to world X and
symmetric about the direction 45 degrees above +Z (at 90 degrees: cam1 looks along -Z as
the front view does, cam2 straight down as the top view does). Image columns run along
+X in both. The scene is written in a calibration frame of its own (Z up, turned 30
degrees about the vertical, its origin near the flight), as a lab's wand calibration
would give it: ``[world] up`` and ``forward``, cam1 as ``projection`` (with
``intrinsics`` and ``distortion`` when a lens is given), cam2 as an 11-parameter
``dlt`` with ``pixel_origin = "bottom-left"`` (``dlt_views``).

``cameras = "square"``: the ``front`` and ``top`` views of the orthogonal rig filmed by
pinhole cameras looking square onto the planes Z = 0 and Y = 0 (image axes
``front_axes`` / ``top_axes``, the camera looking along u x v) from
``camera_distance_m`` beyond them, the principal point at the image centre. The scale
holds at that plane: ``m_per_px = distance / focal length``, the ruler lies in it, and
the world origin's pixel is ``origin_px``; the scene is a front/top scene with the
camera's distance (``camera_distance_m``) for the world stage's perspective correction.

The straw, a capsule in 3-D, is drawn as the capsule between its projected end points
with the radius scaled by focal length / depth at its centre: to well under a pixel at
these distances the silhouette of a capsule in perspective (its far end is drawn a
little too wide, the near end a little too narrow). The rotor's teeth, hub and shaft are
drawn the same way (capsules in 3-D); the housing is not drawn. With a lens the frame is
rendered on an ideal pinhole canvas large enough for every output pixel and remapped
through the distortion (``cv2.remap``, bilinear), after the exposure's renders are
averaged and before the sensor noise.
"""

import math
from dataclasses import dataclass

import numpy as np

from vidtrack.synth import _raster
from vidtrack.synth._renderer import _ViewRenderer
from vidtrack.synth._views import (_GREY, _HUB_RADIUS_M, _SHAFT_HALF_LENGTH_M,
                                   _SHAFT_HALF_WIDTH_M, _TOOTH_HALF_WIDTH_M, _frame_times,
                                   _nice_up, _place_ruler, _ruler_boxes)
from vidtrack.synth.motion import _second_pose, straw_pose
from vidtrack.synth.spec import CAMERA_VIEW_NAMES, VIEW_NAMES, _fail

_UNIT = {"x": 0, "y": 1, "z": 2}
#: The calibration frame of a perspective scene: Z up (world Y), turned about the
#: vertical by this much, its origin this far from the middle of the flight (world frame).
_CAL_HEADING_DEG = 30.0
_CAL_ORIGIN_FROM_TARGET_M = (0.1, -0.2, 0.05)
#: Nothing the camera frames may come nearer to it than this (m).
_MIN_DEPTH_M = 0.2
#: The direction the perspective cameras are symmetric about: 45 degrees above +Z.
_BISECTOR_DEG = 45.0


def _axis_vector(name):
    e = np.zeros(3)
    e[_UNIT[name[1]]] = 1.0 if name[0] == "+" else -1.0
    return e


def _round_down_3(x):
    e = math.floor(math.log10(x))
    step = 10.0 ** (e - 2)
    return round(math.floor(x / step + 1e-9) * step, 12)


@dataclass(eq=False)
class _CameraView:
    """A pinhole camera of a synthetic run: world (throw frame) metres to pixels."""

    name: str
    index: int
    width: int
    height: int
    K: np.ndarray                 # 3x3, the ideal image's intrinsics (top-left pixels)
    R: np.ndarray                 # world -> camera; rows: camera x, y, z in the world
    centre_m: np.ndarray          # the camera's centre, world frame
    dist: tuple | None            # OpenCV's (k1, k2, p1, p2, k3) or None
    delay_s: float
    distance_m: float             # to the middle of the flight / to the scale plane
    written_as: str = "projection"
    pad: tuple = (0.0, 0.0)       # canvas pixel = ideal image pixel + pad
    canvas: tuple | None = None   # (width, height) of the ideal canvas
    remap: tuple | None = None    # (map_u, map_v): canvas position of each output pixel
    mapping: object = None        # square rig: the scale plane's ViewMapping
    ruler_length_m: float | None = None
    ruler_from_px: tuple | None = None
    ruler_to_px: tuple | None = None

    @property
    def focal_px(self):
        return float(self.K[0, 0])

    @property
    def m_per_px(self):
        """Metres per pixel at the scale plane (square) or at the flight's middle."""
        if self.mapping is not None:
            return self.mapping.m_per_px
        return self.distance_m / self.focal_px

    @property
    def lens(self):
        if self.dist is None:
            return None
        from calibration.camera import CameraCalibration

        return CameraCalibration(fx=float(self.K[0, 0]), fy=float(self.K[1, 1]),
                                 cx=float(self.K[0, 2]), cy=float(self.K[1, 2]),
                                 dist_coeffs=tuple(float(v) for v in self.dist))

    @property
    def projection(self):
        """P = K [R | -R C] in the world (throw) frame, top-left pixels."""
        return self.K @ np.hstack([self.R, (-self.R @ self.centre_m)[:, None]])

    def depth(self, xyz):
        """Depth along the optical axis (m)."""
        return (np.asarray(xyz, dtype=np.float64) - self.centre_m) @ self.R[2]

    def ideal(self, xyz):
        """World points (N, 3) -> ideal (distortion-free) image pixels; NaN behind."""
        cam = (np.asarray(xyz, dtype=np.float64) - self.centre_m) @ self.R.T
        with np.errstate(invalid="ignore", divide="ignore"):
            uv = cam[:, :2] / cam[:, 2:3]
        uv[~(cam[:, 2] > 1e-9)] = np.nan
        return uv @ self.K[:2, :2].T + self.K[:2, 2]

    def canvas_px(self, xyz):
        return self.ideal(xyz) + np.asarray(self.pad)

    def distort(self, uv_ideal):
        """Ideal image pixels -> observed pixels (the lens applied)."""
        uv = np.asarray(uv_ideal, dtype=np.float64).reshape(-1, 2)
        lens = self.lens
        return uv.copy() if lens is None else lens.distort_points(uv)

    def observed(self, xyz):
        """World points (N, 3) -> observed image pixels (lens included)."""
        return self.distort(self.ideal(xyz))

    def capsule(self, a3, b3, radius_m):
        """The capsule a3-b3 of radius ``radius_m`` (m) on the canvas, or None."""
        pts = np.array([a3, b3], dtype=np.float64)
        mid = 0.5 * (pts[0] + pts[1])
        depth = float(self.depth(mid[None, :])[0])
        if not depth > _MIN_DEPTH_M * 0.25:
            return None
        uv = self.canvas_px(pts)
        if not np.all(np.isfinite(uv)):
            return None
        return _raster.Capsule(tuple(uv[0]), tuple(uv[1]), radius_m * self.focal_px / depth)

    def to_image(self, canvas_image):
        """The canvas (ideal image plus margins) -> the output image (lens applied)."""
        if self.remap is None:
            pu, pv = int(round(self.pad[0])), int(round(self.pad[1]))
            return canvas_image[pv:pv + self.height, pu:pu + self.width]
        import cv2

        return cv2.remap(canvas_image, self.remap[0], self.remap[1], cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REPLICATE)


# ------------------------------------------------------------------------------ framing

def _content_points(spec, throws, delays):
    """World points the cameras must frame: the straw's ends over the frames, the rotor."""
    pts = []
    half = 0.5 * spec.straw_length_m
    for delay in delays:
        t = _frame_times(spec, delay)
        if spec.leave_frame:
            t = t[t <= 0.55 * max(t.max(), 0.0)]
        for th in throws:
            c, d = straw_pose(t, th.state, th.k, spec=spec, blade_rad_s=th.blade_rad_s,
                              spin_rad_s=th.spin_rad_s)
            pts += [c - half * d, c + half * d]
    reach = max(th.blade_radius_m for th in throws) + _TOOTH_HALF_WIDTH_M
    ang = np.linspace(0.0, 2.0 * np.pi, 36, endpoint=False)
    pts.append(np.column_stack([reach * np.cos(ang), reach * np.sin(ang), np.zeros_like(ang)]))
    pts = np.vstack(pts)
    return pts[np.all(np.isfinite(pts), axis=1)]


def _check_depth(name, depth, spec):
    if depth.min() < _MIN_DEPTH_M:
        _fail(f"camera_distance_m = {spec.camera_distance_m:g} m puts {name} within "
              f"{max(depth.min(), 0.0):.2g} m of the flight (or behind it); expected a "
              f"distance that keeps the straw and the rotor at least {_MIN_DEPTH_M:g} m "
              "in front of the camera")


def _perspective_cameras(spec, throws):
    names = CAMERA_VIEW_NAMES
    delays = {names[0]: 0.0, names[1]: spec.top_delay_s}
    pts = _content_points(spec, throws, delays.values())
    target = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    half = math.radians(0.5 * spec.camera_angle_deg)
    views = []
    for i, name in enumerate(names):
        theta = math.radians(_BISECTOR_DEG) + (-half if i == 0 else half)
        direction = np.array([0.0, math.sin(theta), math.cos(theta)])
        centre = target + spec.camera_distance_m * direction
        z = -direction
        x = np.array([1.0, 0.0, 0.0])
        R = np.vstack([x, np.cross(z, x), z])
        width, height = spec.view_size(name)
        cam = (pts - centre) @ R.T
        _check_depth(name, cam[:, 2], spec)
        xn, yn = cam[:, 0] / cam[:, 2], cam[:, 1] / cam[:, 2]
        mu, mv = max(4.0, 0.03 * width), max(4.0, 0.03 * height)
        f = min((0.5 * width - mu) / max(np.abs(xn).max(), 1e-9),
                (0.5 * height - mv) / max(np.abs(yn).max(), 1e-9))
        f = _round_down_3(f)
        lens = name not in spec.dlt_views and spec.distortion is not None
        dist = tuple(float(v) for v in spec.distortion) if lens else None
        for _ in range(40):
            K = np.array([[f, 0.0, 0.5 * (width - 1)], [0.0, f, 0.5 * (height - 1)],
                          [0.0, 0.0, 1.0]])
            view = _CameraView(name=name, index=i, width=width, height=height, K=K, R=R,
                               centre_m=centre, dist=dist, delay_s=delays[name],
                               distance_m=spec.camera_distance_m,
                               written_as="dlt" if name in spec.dlt_views else "projection")
            if dist is None:
                break
            uv = view.observed(pts)
            inside = (np.all(np.isfinite(uv), axis=1) & (uv[:, 0] >= mu)
                      & (uv[:, 0] <= width - 1 - mu) & (uv[:, 1] >= mv)
                      & (uv[:, 1] <= height - 1 - mv))
            if inside.all():
                break
            f = _round_down_3(0.95 * f)
        else:
            _fail(f"distortion {list(spec.distortion)} folds the image: the flight cannot "
                  f"be framed in {name}; expected a milder lens")
        views.append(_with_canvas(view))
    return views


def _square_cameras(spec, throws):
    views = []
    d = spec.camera_distance_m
    for i, name in enumerate(VIEW_NAMES):
        delay = spec.top_delay_s if name == "top" else 0.0
        pts = _content_points(spec, throws, (delay,))
        axes = spec.view_axes(name)
        u_w, v_w = _axis_vector(axes[0]), _axis_vector(axes[1])
        look = np.cross(u_w, v_w)
        R = np.vstack([u_w, v_w, look])
        width, height = spec.view_size(name)
        a, b = pts @ u_w, pts @ v_w
        z_rel = pts @ look                       # camera depth = d + z_rel
        _check_depth(name, d + z_rel, spec)
        along_cols = axes[0][1] == "x"
        dims = {"col": width, "row": height}
        ruler_on = "row" if along_cols else "col"
        band = max(16.0, 0.09 * dims[ruler_on]) if spec.draw_ruler else 0.0
        margin = {k: max(4.0, 0.03 * v) for k, v in dims.items()}
        usable = {k: dims[k] - 2.0 * margin[k] - (band if k == ruler_on else 0.0)
                  for k in dims}
        target = {k: margin[k] - 0.5 + 0.5 * usable[k] for k in dims}
        cx, cy = 0.5 * (width - 1), 0.5 * (height - 1)
        c = np.array([0.5 * (a.min() + a.max()), 0.5 * (b.min() + b.max())])
        m = float(spec.m_per_px) if spec.m_per_px is not None else None
        for it in range(12):
            nu, nv = (a - c[0]) / (d + z_rel), (b - c[1]) / (d + z_rel)
            if m is None or (spec.m_per_px is None and it < 6):
                f_fit = min(usable["col"] / max(np.ptp(nu), 1e-12),
                            usable["row"] / max(np.ptp(nv), 1e-12))
                m = _nice_up(d / f_fit)
            f = d / m
            du = target["col"] - (cx + f * 0.5 * (nu.max() + nu.min()))
            dv = target["row"] - (cy + f * 0.5 * (nv.max() + nv.min()))
            c = c - np.array([du, dv]) * d / f
        # the world origin (on the scale plane) at a pixel rounded to 0.01
        origin = (round(cx - f * c[0] / d, 2), round(cy - f * c[1] / d, 2))
        c = np.array([(cx - origin[0]) * d / f, (cy - origin[1]) * d / f])
        centre = c[0] * u_w + c[1] * v_w - d * look
        K = np.array([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]])
        from calibration.views import ViewMapping

        mapping = ViewMapping(axes=axes, origin_px=origin, m_per_px=m)
        ruler = (None, None, None)
        if spec.draw_ruler:
            ruler = _place_ruler(mapping, width, height, along_cols, band, margin)
        views.append(_with_canvas(_CameraView(
            name=name, index=i, width=width, height=height, K=K, R=R, centre_m=centre,
            dist=None, delay_s=delay, distance_m=d, written_as="front/top", mapping=mapping,
            ruler_length_m=ruler[0], ruler_from_px=ruler[1], ruler_to_px=ruler[2])))
    return views


def _with_canvas(view):
    """The ideal canvas (and the remap) that the lens needs; the image itself without."""
    if view.dist is None:
        view.canvas = (view.width, view.height)
        return view
    lens = view.lens
    uu, vv = np.meshgrid(np.arange(view.width, dtype=np.float64),
                         np.arange(view.height, dtype=np.float64))
    ideal = lens.undistort_points(np.column_stack([uu.ravel(), vv.ravel()]))
    ok = np.all(np.isfinite(ideal), axis=1)
    # a canvas at most twice the image's size beyond each edge: farther rays (a lens
    # model far outside its range) show the canvas' edge
    lim_u = (-2.0 * view.width, 3.0 * view.width)
    lim_v = (-2.0 * view.height, 3.0 * view.height)
    iu = np.clip(np.where(ok, ideal[:, 0], 0.0), *lim_u)
    iv = np.clip(np.where(ok, ideal[:, 1], 0.0), *lim_v)
    pad_u = float(max(0, math.ceil(-iu.min())) + 3)
    pad_v = float(max(0, math.ceil(-iv.min())) + 3)
    view.pad = (pad_u, pad_v)
    view.canvas = (int(math.ceil(max(iu.max(), view.width - 1) + pad_u)) + 4,
                   int(math.ceil(max(iv.max(), view.height - 1) + pad_v)) + 4)
    view.remap = ((iu + pad_u).reshape(view.height, view.width).astype(np.float32),
                  (iv + pad_v).reshape(view.height, view.width).astype(np.float32))
    return view


def camera_views(spec, throws):
    """The views of a run with pinhole cameras (``spec.cameras`` not orthographic)."""
    if spec.cameras == "perspective":
        return _perspective_cameras(spec, throws)
    return _square_cameras(spec, throws)


def camera_static(spec, view):
    """Background texture (over the canvas) and, in the square rig, the ruler."""
    rng = np.random.default_rng([spec.seed, 10 + view.index, 1])
    cw, ch = view.canvas
    img = spec.background_grey + spec.texture_amplitude * _raster.smooth_texture((ch, cw), rng)
    rows = (np.arange(ch) - view.pad[1] - 0.5 * (view.height - 1)) / (0.5 * view.height)
    cols = (np.arange(cw) - view.pad[0] - 0.5 * (view.width - 1)) / (0.5 * view.width)
    img *= 1.0 - 0.5 * spec.vignetting * (rows[:, None] ** 2 + cols[None, :] ** 2)
    if view.mapping is not None and spec.draw_ruler:
        whole = _raster.Roi(0, ch, 0, cw)
        for shape, grey in _ruler_boxes(view):
            img += (grey - img) * _raster.box_coverage(shape, whole)
    return img


# ------------------------------------------------------------------------------ frames

class _CameraTrack:
    """Poses of the straw(s) and the rotor in one pinhole view (as ``_ViewTrack``)."""

    def __init__(self, spec, view, throw, second):
        self.spec, self.view, self.throw = spec, view, throw
        exposure = spec.exposure_fraction / spec.fps
        n = spec.n_frames
        kk = self.kk = spec.exposure_samples if exposure > 0 else 1
        self.t = _frame_times(spec, view.delay_s)
        offs = ((np.arange(kk) + 0.5) / kk - 0.5) * exposure
        self.ts = self.t[:, None] + offs[None, :]
        self.r_m = r_m = 0.5 * spec.straw_diameter_m
        half = 0.5 * spec.straw_length_m - r_m
        f = view.focal_px
        pose = dict(spec=spec, blade_rad_s=throw.blade_rad_s, spin_rad_s=throw.spin_rad_s)
        c, d = straw_pose(self.t, throw.state, throw.k, **pose)
        self.centre_m = c
        self.axis = d
        self.depth_m = view.depth(c)
        self.centre_px = view.observed(c)
        self.centre_ideal_px = view.ideal(c)
        self.end_a_px = view.ideal(c - half * d)
        self.end_b_px = view.ideal(c + half * d)
        self.radius_frame_px = r_m * f / self.depth_m
        cs, ds = straw_pose(self.ts.ravel(), throw.state, throw.k, **pose)
        self.sub_a = view.canvas_px(cs - half * ds).reshape(n, kk, 2)
        self.sub_b = view.canvas_px(cs + half * ds).reshape(n, kk, 2)
        self.sub_r = (r_m * f / view.depth(cs)).reshape(n, kk)
        self.second = second is not None
        if self.second:
            state2, t2 = second
            c2, d2 = _second_pose(self.t, spec, throw, state2, t2)
            self.centre2_m = c2
            self.centre2_px = view.observed(c2)
            self.end2_a_px = view.ideal(c2 - half * d2)
            self.end2_b_px = view.ideal(c2 + half * d2)
            cs2, ds2 = _second_pose(self.ts.ravel(), spec, throw, state2, t2)
            self.sub2_a = view.canvas_px(cs2 - half * ds2).reshape(n, kk, 2)
            self.sub2_b = view.canvas_px(cs2 + half * ds2).reshape(n, kk, 2)
            with np.errstate(invalid="ignore", divide="ignore"):
                self.sub2_r = (r_m * f / view.depth(cs2)).reshape(n, kk)

    def layers(self, i, j):
        """Opaque layers of exposure sample j of frame i, back to front."""
        spec, view = self.spec, self.view
        out = []
        if spec.draw_machine:
            phi = self.throw.release_angle_rad + self.throw.blade_rad_s * self.ts[i, j]
            radius = self.throw.blade_radius_m
            origin = np.zeros(3)
            for key, ang in (("tooth0", phi), ("tooth1", phi + math.pi)):
                tip = np.array([radius * math.cos(ang), radius * math.sin(ang), 0.0])
                out.append((key, view.capsule(origin, tip, _TOOTH_HALF_WIDTH_M),
                            _GREY["tooth"]))
            out.append(("shaft", view.capsule((0.0, 0.0, -_SHAFT_HALF_LENGTH_M),
                                              (0.0, 0.0, _SHAFT_HALF_LENGTH_M),
                                              _SHAFT_HALF_WIDTH_M), _GREY["hub"]))
            out.append(("hub", view.capsule(origin, origin, _HUB_RADIUS_M), _GREY["hub"]))
        if self.second and np.all(np.isfinite(self.sub2_a[i, j])) \
                and np.isfinite(self.sub2_r[i, j]):
            out.append(("straw2", _raster.Capsule(tuple(self.sub2_a[i, j]),
                                                  tuple(self.sub2_b[i, j]),
                                                  float(self.sub2_r[i, j])), spec.straw_grey))
        out.append(("straw", _raster.Capsule(tuple(self.sub_a[i, j]), tuple(self.sub_b[i, j]),
                                             float(self.sub_r[i, j])), spec.straw_grey))
        return [layer for layer in out if layer[1] is not None]

    def exposure_geometry(self, i):
        """Area-weighted mean centre over the exposure (observed pixels) and the
        silhouette's extent (observed pixels)."""
        pad = np.asarray(self.view.pad)
        a, b, r = self.sub_a[i] - pad, self.sub_b[i] - pad, self.sub_r[i]
        seg = np.hypot(*(b - a).T)
        area = np.pi * r * r + 2.0 * r * seg
        centre = 0.5 * (a + b)
        mean = (area[:, None] * centre).sum(axis=0) / area.sum()
        mean = self.view.distort(mean[None, :])[0]
        ends = self.view.distort(np.vstack([a, b]))
        rr = np.concatenate([r, r])
        ext = ((ends[:, 0] - rr).min(), (ends[:, 0] + rr).max(),
               (ends[:, 1] - rr).min(), (ends[:, 1] + rr).max())
        return mean, ext


class _CameraRenderer(_ViewRenderer):
    """Frame i of a pinhole view: rendered on the ideal canvas, then through the lens."""

    def frame_float(self, i):
        image, facts = super().frame_float(i)
        pu, pv = self.view.pad
        facts["moment_u"] -= pu * facts["coverage_px"]
        facts["moment_v"] -= pv * facts["coverage_px"]
        return self.view.to_image(image), facts

    def frame(self, i):
        image, facts = self.frame_float(i)
        self.info[i] = facts
        rng = np.random.default_rng([self.spec.seed, 10 + self.view.index, self.throw_index,
                                     i, 2])
        noisy = _raster.add_sensor_noise(image, rng, read_noise=self.read_noise,
                                         full_well_e=self.spec.full_well_e)
        return _raster.quantize(noisy, self.spec.bit_depth)


# ------------------------------------------------------------------------------ truth and scene

def _calibration_frame(views):
    """(rotation, offset): calibration = rotation @ world + offset (Z up, turned)."""
    h = math.radians(_CAL_HEADING_DEG)
    turn = np.array([[math.cos(h), -math.sin(h), 0.0], [math.sin(h), math.cos(h), 0.0],
                     [0.0, 0.0, 1.0]])
    y_up = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])   # world Y -> Z
    rot = turn @ y_up
    # the middle of the flight: where the cameras' optical axes meet
    c = [v.centre_m for v in views]
    target = c[0] + views[0].distance_m * views[0].R[2] if views[0].mapping is None else \
        np.mean(c, axis=0)
    origin_world = target + np.asarray(_CAL_ORIGIN_FROM_TARGET_M)
    return rot, -rot @ origin_world


def _in_calibration(view, rot, offset):
    """P, R, t, rvec and the centre of ``view`` in the calibration frame."""
    import cv2

    R = view.R @ rot.T
    centre = rot @ view.centre_m + offset
    t = -R @ centre
    return {"projection": (view.K @ np.hstack([R, t[:, None]])).tolist(),
            "R": R.tolist(), "t": t.tolist(),
            "rvec": cv2.Rodrigues(R)[0].ravel().tolist(), "centre_m": centre.tolist()}


def _dlt_bottom_left(P, height):
    """The 11 DLT coefficients of P for pixels counted up from the bottom edge."""
    F = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, float(height)], [0.0, 0.0, 1.0]])
    Pb = F @ np.asarray(P, dtype=np.float64)
    if abs(Pb[2, 3]) < 1e-9 * np.abs(Pb).max():
        _fail("the calibration frame's origin lies in a camera's focal plane: no DLT")
    return (Pb / Pb[2, 3]).ravel()[:11].tolist()


def camera_truth(view, frame=None):
    """The camera of ``view`` for truth.json."""
    P = view.projection
    out = {"model": "pinhole", "focal_px": view.focal_px, "distance_m": view.distance_m,
           "K": view.K.tolist(), "dist": None if view.dist is None else list(view.dist),
           "R": view.R.tolist(), "t": (-view.R @ view.centre_m).tolist(),
           "centre_m": view.centre_m.tolist(), "P": (P / np.linalg.norm(P[2, :3])).tolist(),
           "written_as": view.written_as,
           "pixel_origin": "bottom-left" if view.written_as == "dlt" else "top-left"}
    if frame is not None:
        out["calibration"] = _in_calibration(view, *frame)
    return out


def calibration_truth(views):
    """truth.json's ``calibration_frame`` of a perspective run."""
    rot, offset = _calibration_frame(views)
    return {"rotation": rot.tolist(), "offset_m": offset.tolist(),
            "up": (rot @ np.array([0.0, 1.0, 0.0])).tolist(),
            "forward": (rot @ np.array([1.0, 0.0, 0.0])).tolist(),
            "definition": "calibration = rotation @ world + offset_m (world: the throw frame "
                          "of docs/reference.md, z relative to the machine)"}


def camera_scene_views(spec, views, source_name, release, fmt_number):
    """``[world]`` and ``[views.*]`` of a scene with pinhole cameras."""
    out = {}
    world = None
    if spec.cameras == "perspective":
        frame = _calibration_frame(views)
        rot = frame[0]
        world = {"up": [float(v) for v in rot @ np.array([0.0, 1.0, 0.0])],
                 "forward": [float(v) for v in rot @ np.array([1.0, 0.0, 0.0])]}
    for view in views:
        entry = {"source": source_name(spec, view.name), "fps": fmt_number(spec.fps)}
        if spec.cameras == "perspective":
            cal = _in_calibration(view, *frame)
            if view.written_as == "dlt":
                entry["dlt"] = _dlt_bottom_left(cal["projection"], view.height)
                entry["pixel_origin"] = "bottom-left"
            else:
                entry["projection"] = cal["projection"]
                if view.dist is not None:
                    entry["intrinsics"] = view.K.tolist()
                    entry["distortion"] = list(view.dist)
        else:
            m = view.mapping
            entry.update({"axes": list(m.axes), "origin_px": list(m.origin_px)})
            if spec.scale_in_scene == "ruler":
                entry["ruler"] = {"length_m": view.ruler_length_m,
                                  "from_px": list(view.ruler_from_px),
                                  "to_px": list(view.ruler_to_px)}
            else:
                entry["m_per_px"] = m.m_per_px
            if spec.camera_distance_in_scene:
                entry["camera_distance_m"] = view.distance_m
        if spec.sync_in_scene and release[view.name] is not None:
            entry["sync_frame"] = release[view.name]
        out[view.name] = entry
    return world, out


def camera_view_truth(spec, view, track, renderer, source, frame=None):
    """``views.<v>`` of truth.json for a pinhole view."""
    from vidtrack.synth.truth import (_axis_columns, _exposure_extents, _header, _json_list,
                                      _pose_columns, _release_frame_of, _second_columns,
                                      _shape_columns)

    n = spec.n_frames
    w, h = view.width, view.height
    mean_c, ext, inside, reach_border = _exposure_extents(track, n, w, h)
    touches = ((ext[:, 1] > -0.5) & (ext[:, 0] < w - 0.5) & (ext[:, 3] > -0.5)
               & (ext[:, 2] < h - 0.5))
    info = [renderer.info[i] for i in range(n)]
    coverage = np.array([f["coverage_px"] for f in info])
    in_view = (coverage > 0) & touches
    safe = np.where(coverage > 0, coverage, 1.0)
    cov_ideal = np.column_stack([np.array([f["moment_u"] for f in info]) / safe,
                                 np.array([f["moment_v"] for f in info]) / safe])
    cov = view.distort(cov_ideal)
    cov[~in_view] = np.nan
    r = track.radius_frame_px
    silhouette = view.distort(0.5 * (track.end_a_px + track.end_b_px))
    t = track.t
    table = _pose_columns(track, t)
    table.update({
        "u_ideal_px": _json_list(track.centre_ideal_px[:, 0]),
        "v_ideal_px": _json_list(track.centre_ideal_px[:, 1]),
        "u_silhouette_px": _json_list(silhouette[:, 0]),
        "v_silhouette_px": _json_list(silhouette[:, 1]),
        "u_exposure_px": _json_list(mean_c[:, 0]),
        "v_exposure_px": _json_list(mean_c[:, 1]),
        "u_coverage_px": _json_list(cov[:, 0]),
        "v_coverage_px": _json_list(cov[:, 1]),
        "depth_m": _json_list(track.depth_m),
        "radius_px": _json_list(r),
    })
    table.update(_shape_columns(track, r, coverage, in_view, inside, reach_border, info))
    if track.second:
        p2 = track.centre2_px
        with np.errstate(invalid="ignore"):
            vis2 = (np.isfinite(p2[:, 0]) & (p2[:, 0] > -0.5) & (p2[:, 0] < w - 0.5)
                    & (p2[:, 1] > -0.5) & (p2[:, 1] < h - 0.5))
        table.update(_second_columns(track, vis2))
    table.update(_axis_columns(track))
    out = _header(spec, source, n, w, h)
    out["camera"] = camera_truth(view, frame)
    if view.mapping is not None:
        m = view.mapping
        out.update({
            "axes": list(m.axes), "world_axes": list(m.world_axes),
            "origin_px": list(m.origin_px), "m_per_px": m.m_per_px,
            "camera_distance_m": view.distance_m,
            "ruler": None if view.ruler_length_m is None else {
                "length_m": view.ruler_length_m, "from_px": list(view.ruler_from_px),
                "to_px": list(view.ruler_to_px)}})
    out.update({
        "delay_s": view.delay_s,
        "release_frame": _release_frame_of(t),
        "t0_frame": float(spec.release_frame - view.delay_s * spec.fps),
        "per_frame": table,
    })
    return out


#: What truth.json's conventions add (or say otherwise) for pinhole cameras.
CONVENTIONS = {
    "cameras": "pinhole cameras: views.<v>.camera gives K (the ideal image's intrinsics, "
               "top-left pixels), dist (OpenCV's k1, k2, p1, p2, k3 or null), R and t "
               "(world -> camera: x_cam = R x_world + t), centre_m and P = K [R | t] "
               "(world frame, normalised so that P's third row has a unit left block), "
               "and with perspective cameras the same in the scene's calibration frame "
               "(calibration_frame); observed pixel = the lens applied to P's pixel "
               "(cv2.projectPoints with rvec = Rodrigues(R), t, K, dist)",
    "centroid": "u_px, v_px: the rod centre projected through the camera (lens included) "
                "at t_s, what a triangulation wants; u_ideal_px, v_ideal_px: the same "
                "without the lens; u_silhouette_px, v_silhouette_px: the midpoint of the "
                "projected rod ends (through the lens), the centroid of the rendered "
                "silhouette: it differs from u_px, v_px by the perspective of a rod "
                "slanted in depth, at most about f L^2 / (8 depth^2) px (f the focal "
                "length in px, L the length)",
    "blur": "a frame is the mean of exposure_samples renders spread evenly over "
            "exposure_fraction / fps seconds centred on t_s, rendered on the ideal "
            "pinhole image and then carried through the lens (cv2.remap, bilinear); "
            "u_exposure_px, v_exposure_px: the area-weighted mean of those renders' "
            "silhouette centres, through the lens",
    "coverage_centroid": "u_coverage_px, v_coverage_px: the coverage-weighted mean of "
                         "pixel centres of the blurred silhouette on the ideal image, "
                         "carried through the lens (exact without a lens)",
    "radius": "radius_px: the straw's radius in px at its centre's depth (depth_m), "
              "focal length x radius / depth",
}
