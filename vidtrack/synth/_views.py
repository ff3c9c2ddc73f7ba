"""The views of a synthetic run: framing, the machine's dressing, the static scene.

Orthographic cameras square to the world axes (docs/reference.md). ``_frame_view``
chooses a view's scale and origin so that the rotor and the whole flight fit (with
``leave_frame``, only the first 55 % of the flight), and places a ruler along world X,
with ticks, in a band it keeps free; the ruler's two end ticks are the points
``scene.toml``'s ``ruler`` names.
``_static_image`` draws what does not move: a smooth random texture with a gentle
illumination fall-off, the machine's housing and the rotor's hood (dark boxes), and the
ruler. The sizes and grey levels of the machine's parts (teeth, hub, shaft) are set here.

Frame i of a view is at ``t_s = (i - release_frame) / fps + delay_s`` (``delay_s`` is
0 for the front view and ``top_delay_s`` for the top view), the middle of its
exposure (``_frame_times``).
"""

import math
from dataclasses import dataclass

import numpy as np

from vidtrack.synth import _raster
from vidtrack.synth.motion import straw_pose
from vidtrack.synth.spec import VIEW_NAMES

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
_GREY = {"tooth": 0.30, "hub": 0.12, "housing": 0.16, "hood": 0.20,
         "ruler": 0.82, "tick": 0.10, "post": 0.25}


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
    post = post_box(spec, view)
    if post is not None and post_speed(spec) == 0.0:      # a moving one is drawn per frame
        paint.append(post)
    for shape, grey in paint:
        cov = _raster.box_coverage(shape, whole)
        img += (grey - img) * cov
    return img


def post_speed(spec):
    """The post's speed (px a frame, rightwards; 0: it stands) (``SynthSpec.post``)."""
    return 0.0 if spec.post is None or len(spec.post) < 3 else float(spec.post[2])


def post_box(spec, view, t=None):
    """The post in front of everything (``SynthSpec.post``) as (Box, grey) at the time
    ``t`` (s, the frames' clock; the middle frame's when None): the front view's whole
    height; None in the other views or without one. Its centre is at the fraction
    ``at`` of the view's width in the middle frame, and moves ``speed`` px a frame."""
    if spec.post is None or view.name != "front":
        return None
    at, width = float(spec.post[0]), float(spec.post[1])
    u = at * (view.width - 1.0)
    if t is not None:
        frame = (t - view.delay_s) * spec.fps + spec.release_frame
        u += post_speed(spec) * (frame - 0.5 * (spec.n_frames - 1))
    return _raster.Box(u - 0.5 * width, u + 0.5 * width, -0.5, view.height - 0.5), _GREY["post"]


def _machine_radius(spec):
    radius = spec.blade_radius_m
    if radius is None:
        radius = math.hypot(spec.state[0], spec.state[1])
    return radius

