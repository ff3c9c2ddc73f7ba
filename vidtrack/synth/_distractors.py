"""What real footage puts beside the straw: the distractors of ``vidtrack synth``.

All off by default (a run without them renders byte for byte as before they existed):

- **shadow** (``SynthSpec.shadow = (offset_px, darken, blur_px)``): the straw's
  silhouette moved ``offset_px`` down and to the right (45 degrees: light from the upper
  left), blurred by a Gaussian of ``blur_px`` and darkening what it falls on (the
  static background: wall, housing, ruler) by the fraction ``darken``; it is under
  everything that moves. Both views have a background for it to fall on (the front
  view's backdrop, the top view's ground), so it is drawn in both, at the same offset.
- **rider** (``rider = "riding" | "crossing"``): a rod 0.6 times the straw's length and
  half its diameter, of half the straw's contrast, flying with the straw from the release
  (world frame, so both views see the same object), drawn behind it. ``riding``: side by
  side with the straw, turning with it (a rigid offset perpendicular to the rod, half in
  the spin plane and half along the spin axis, so it shows beside the straw in both
  views; the rods' axes 1.35 straw diameters apart), sliding along it from 0.3 L behind
  its centre to 0.3 L ahead over the flight. ``crossing``: its centre moves from 0.6 L
  off the straw's centre (along world (0, 1, 1) / sqrt 2, so up in the front view and
  down in the top view) through it at mid-flight to 0.6 L on the other side, at 40
  degrees to the straw (turned about the spin axis), spinning with it.
- **polarity and highlight** (``straw_polarity``, ``highlight_grey``): the straw's level
  is :attr:`SynthSpec.straw_level`; the highlight is a stripe of radius 0.3 r along the
  middle 70 % of the rod, 0.45 r off its axis towards the upper left (the same light),
  inside the silhouette, which it does not change.
- **person** (``person_at_side``): a body (a fat upright capsule), a head and an arm
  swinging from the shoulder, textured with both polarities round the background's
  level, swaying; placed in the largest rectangle of the view that the straw's path
  (every exposure sample, the rider's too), the rotor and the ruler leave free by a
  margin of 8 px, and never leaving it. A view without a free rectangle 24 px on a
  side gets no person (truth.json says so).
- **shake** (``shake = (amplitude_px, freq_hz)``): each camera vibrates: its whole
  image (background, machine, straw) is moved by :func:`camera_shift` (bicubic, the
  border reflected) before the sensor noise. Every other position in truth.json is
  where a still camera shows it; ``camera_du_px``, ``camera_dv_px`` say how far the
  frame's content lies from there.

Every position is computed from the geometry here, never from the rendered images.
"""

import math

import numpy as np

from vidtrack.synth import _raster
from vidtrack.synth.motion import _rotate

#: Light from the upper left in the image: the shadow falls the other way.
_LIGHT_DIR = np.array([-1.0, -1.0]) / math.sqrt(2.0)
_RIDER_LENGTH = 0.6
_RIDER_DIAMETER = 0.5
_RIDER_CONTRAST = 0.5
_RIDER_AXIS_GAP_D = 1.35          # riding: distance of the axes, in straw diameters
_RIDER_CROSS_ANGLE = math.radians(40.0)
_RIDER_CROSS_START_L = 0.6
_HIGHLIGHT_RADIUS = 0.3
_HIGHLIGHT_OFFSET = 0.45
_HIGHLIGHT_SPAN = 0.7
_PERSON_MARGIN_PX = 8.0
_PERSON_MIN_PX = 24.0


def shadow_offset_px(spec):
    """The shadow's offset (du, dv) in pixels."""
    return -float(spec.shadow[0]) * _LIGHT_DIR


def rider_level(spec):
    return spec.background_grey + _RIDER_CONTRAST * (spec.straw_level - spec.background_grey)


def rider_pose(t, spec, throw, centre, direction):
    """Centre (m) and unit direction of the rider at ``t`` (NaN before the release).

    ``centre``, ``direction``: the straw's pose at ``t`` (:func:`~vidtrack.synth.motion.
    straw_pose`).
    """
    t = np.asarray(t, dtype=np.float64).ravel()
    n = t.size
    c_out = np.full((n, 3), np.nan)
    d_out = np.full((n, 3), np.nan)
    live = t >= 0
    if not np.any(live):
        return c_out, d_out
    axis = np.asarray(spec.spin_axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    d = direction[live]
    L, D = spec.straw_length_m, spec.straw_diameter_m
    flight = max(float(spec.flight_s), 1e-9)
    tau = np.clip(t[live] / flight, 0.0, 1.0)[:, None]
    if spec.rider == "riding":
        perp = np.cross(axis[None, :], d)
        norm = np.linalg.norm(perp, axis=1, keepdims=True)
        fallback = np.cross(np.array([0.0, 0.0, 1.0]), d)
        perp = np.where(norm > 1e-6, perp / np.maximum(norm, 1e-12),
                        fallback / np.maximum(np.linalg.norm(fallback, axis=1,
                                                             keepdims=True), 1e-12))
        side = (perp + axis[None, :]) / math.sqrt(2.0)
        gap = _RIDER_AXIS_GAP_D * D * math.sqrt(2.0)   # 1.35 D in each view
        c_out[live] = centre[live] + gap * side + (-0.3 + 0.6 * tau) * L * d
        d_out[live] = d
    else:
        e = np.array([0.0, 1.0, 1.0]) / math.sqrt(2.0)
        s = _RIDER_CROSS_START_L * L * (1.0 - 2.0 * tau)
        c_out[live] = centre[live] + s * e[None, :]
        phi0 = math.atan2(throw.state[1], throw.state[0])
        d0 = _rotate(np.array([math.cos(phi0), math.sin(phi0), 0.0]), axis,
                     np.array([_RIDER_CROSS_ANGLE]))[0]
        d_out[live] = _rotate(d0, axis, throw.spin_rad_s * t[live])
    return c_out, d_out


def rider_half_and_radius(spec, m_per_px):
    """Half the rider's segment (m) and its radius (px)."""
    length = _RIDER_LENGTH * spec.straw_length_m
    diameter = _RIDER_DIAMETER * spec.straw_diameter_m
    return 0.5 * (length - diameter), 0.5 * diameter / m_per_px


def highlight_capsule(a, b, radius):
    """The specular stripe inside the capsule a-b of ``radius`` (pixels)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    seg = b - a
    length = float(np.hypot(*seg))
    if length > 1e-9:
        normal = np.array([-seg[1], seg[0]]) / length
        if normal @ _LIGHT_DIR < 0:
            normal = -normal
    else:
        normal = _LIGHT_DIR
    shift = _HIGHLIGHT_OFFSET * radius * normal
    lo, hi = 0.5 * (1.0 - _HIGHLIGHT_SPAN), 0.5 * (1.0 + _HIGHLIGHT_SPAN)
    return _raster.Capsule(tuple(a + lo * seg + shift), tuple(a + hi * seg + shift),
                           _HIGHLIGHT_RADIUS * radius)


# --------------------------------------------------------------------------- the person

def _largest_free_rect(free):
    """(r0, r1, c0, c1) of the largest all-True rectangle of a boolean grid."""
    rows, cols = free.shape
    heights = np.zeros(cols, dtype=int)
    best, best_rect = 0, None
    for r in range(rows):
        heights = np.where(free[r], heights + 1, 0)
        stack = []
        for c in range(cols + 1):
            h = heights[c] if c < cols else 0
            start = c
            while stack and stack[-1][1] >= h:
                start, sh = stack.pop()
                # keep the person upright-ish: area of the part at most 1.2 x as wide as
                # tall
                width = c - start
                w_eff = min(width, int(1.2 * sh) + 1)
                area = w_eff * sh
                if area > best:
                    best = area
                    c0 = start + (width - w_eff) // 2
                    best_rect = (r - sh + 1, r + 1, c0, c0 + w_eff)
            stack.append((start, h))
    return best_rect


class Person:
    """A person swaying at the side of one view, in pixels (``None`` box: not drawn)."""

    def __init__(self, box, phase, factor=1.0):
        u0, u1, v0, v1 = box
        self.box = box
        w, h = u1 - u0, v1 - v0
        self.phase = phase
        s = factor * min(h, 1.2 * w)
        self.scale = s
        self.cu = 0.5 * (u0 + u1)
        self.top = v0 + 0.5 * (h - s)
        self.sway = 0.05 * s
        self.body_r = 0.17 * s
        self.head_r = 0.11 * s
        self.arm_r = 0.05 * s
        self.arm_len = 0.36 * s

    def parts(self, t):
        """[(key, Capsule, grey callable)] at time t (s)."""
        s = self.scale
        du = self.sway * math.sin(2.0 * math.pi * 1.1 * t + self.phase)
        dv = 0.02 * s * math.sin(2.0 * math.pi * 2.2 * t + self.phase)
        cu = self.cu + du
        head = (cu, self.top + self.head_r + dv)
        body_a = (cu, self.top + 2.0 * self.head_r + self.body_r + 0.02 * s + dv)
        body_b = (cu, self.top + s - self.body_r + dv)
        shoulder = (cu + 0.6 * self.body_r, body_a[1])
        ang = 0.9 * math.sin(2.0 * math.pi * 2.3 * t + 2.0 * self.phase)
        hand = (shoulder[0] + self.arm_len * math.sin(ang),
                shoulder[1] + self.arm_len * math.cos(ang))
        ou, ov = cu, self.top + dv

        def shirt(sub, ou=ou, ov=ov):
            u = np.arange(sub.c0, sub.c1)[None, :] - ou
            v = np.arange(sub.r0, sub.r1)[:, None] - ov
            return (0.42 + 0.22 * np.sin(2 * math.pi * u / 7.0) * np.sin(2 * math.pi * v / 9.0)
                    + 0.06 * np.sin(2 * math.pi * (u + v) / 3.3))

        def skin(sub, ou=ou, ov=ov):
            u = np.arange(sub.c0, sub.c1)[None, :] - ou
            v = np.arange(sub.r0, sub.r1)[:, None] - ov
            return 0.62 + 0.08 * np.sin(2 * math.pi * u / 5.0) * np.cos(2 * math.pi * v / 6.0)

        def sleeve(sub, ou=ou, ov=ov):
            u = np.arange(sub.c0, sub.c1)[None, :] - ou
            v = np.arange(sub.r0, sub.r1)[:, None] - ov
            return 0.30 + 0.18 * (np.sin(2 * math.pi * (u - v) / 4.0) > 0)

        return [("person_body", _raster.Capsule(body_a, body_b, self.body_r), shirt),
                ("person_head", _raster.Capsule(head, head, self.head_r), skin),
                ("person_arm", _raster.Capsule(shoulder, hand, self.arm_r), sleeve)]

    def extent(self, times):
        ext = np.array([p.extent_px() for t in times for _, p, _ in self.parts(t)])
        return (ext[:, 0].min(), ext[:, 1].max(), ext[:, 2].min(), ext[:, 3].max())


def place_person(spec, view, track, blade_radius_px, rider_ends=None):
    """The :class:`Person` of ``view`` or None (no room): see the module's docstring."""
    import cv2

    w, h = view.width, view.height
    cell = 2
    gw, gh = (w + cell - 1) // cell, (h + cell - 1) // cell
    mask = np.zeros((gh, gw), dtype=np.uint8)
    margin = _PERSON_MARGIN_PX

    def rod(a, b, r):
        for (ua, va), (ub, vb) in zip(a, b):
            if not (np.isfinite(ua) and np.isfinite(ub)):
                continue
            cv2.line(mask, (int(round(ua / cell)), int(round(va / cell))),
                     (int(round(ub / cell)), int(round(vb / cell))), 1,
                     thickness=max(1, int(math.ceil(2.0 * (r + margin) / cell)) + 1))

    rod(track.sub_a.reshape(-1, 2), track.sub_b.reshape(-1, 2), track.radius_px)
    if rider_ends is not None:
        rod(*rider_ends)
    o = view.mapping.origin_px
    reach = blade_radius_px + margin
    if spec.draw_machine:
        if view.name == "front":
            cv2.circle(mask, (int(round(o[0] / cell)), int(round(o[1] / cell))),
                       int(math.ceil(reach / cell)) + 1, 1, thickness=-1)
        else:
            c0 = int(math.floor((o[0] - reach) / cell))
            c1 = int(math.ceil((o[0] + reach) / cell)) + 1
            mask[:, max(c0, 0):max(c1, 0)] = 1
        # the machine's side (housing) is not where a person stands
        c1 = int(math.ceil((o[0] - blade_radius_px) / cell))
        mask[:, :max(c1, 0)] = 1
    if view.ruler_from_px is not None:
        a, b = np.array(view.ruler_from_px), np.array(view.ruler_to_px)
        lo = np.minimum(a, b) - 6.0 - margin
        hi = np.maximum(a, b) + 6.0 + margin
        r0, r1 = int(math.floor(lo[1] / cell)), int(math.ceil(hi[1] / cell)) + 1
        c0, c1 = int(math.floor(lo[0] / cell)), int(math.ceil(hi[0] / cell)) + 1
        mask[max(r0, 0):max(r1, 0), max(c0, 0):max(c1, 0)] = 1
    rect = _largest_free_rect(mask == 0)
    if rect is None:
        return None
    r0, r1, c0, c1 = rect
    box = (c0 * cell + 1.0, min(c1 * cell, w) - 2.0, r0 * cell + 1.0, min(r1 * cell, h) - 2.0)
    if min(box[1] - box[0], box[3] - box[2]) < _PERSON_MIN_PX:
        return None
    phase = 2.0 * math.pi * ((spec.seed * 0.618034) % 1.0)
    times = track.ts.ravel()[:: max(1, track.ts.size // 400)]
    factor = 1.0
    while True:                              # shrink until every pose stays in the box
        person = Person(box, phase, factor)
        if person.scale < _PERSON_MIN_PX:
            return None
        e = person.extent(times)
        if e[0] >= box[0] and e[1] <= box[1] and e[2] >= box[2] and e[3] <= box[3]:
            return person
        factor *= 0.9


# --------------------------------------------------------------------------- geometry

def _point_segment(p, a, b):
    ab = b - a
    L2 = float(ab @ ab)
    s = 0.0 if L2 == 0 else min(max(float((p - a) @ ab) / L2, 0.0), 1.0)
    return float(np.hypot(*(p - a - s * ab)))


def _segments_cross(a, b, c, d):
    def orient(p, q, r):
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
    o1, o2 = orient(a, b, c), orient(a, b, d)
    o3, o4 = orient(c, d, a), orient(c, d, b)
    return o1 * o2 < 0 and o3 * o4 < 0


def capsule_gap(a, b, r, c, d, s):
    """Distance (px) between the capsules a-b (radius r) and c-d (radius s); < 0: they
    overlap. NaN when either is undefined."""
    pts = [np.asarray(x, dtype=np.float64) for x in (a, b, c, d)]
    if not all(np.all(np.isfinite(p)) for p in pts):
        return float("nan")
    a, b, c, d = pts
    if _segments_cross(a, b, c, d):
        return -(r + s)
    dist = min(_point_segment(a, c, d), _point_segment(b, c, d), _point_segment(c, a, b),
               _point_segment(d, a, b))
    return dist - r - s


# --------------------------------------------------------------------------- the shake
def camera_shift(spec, view_index, t):
    """Where a shaking camera shows the scene at times ``t`` (s), against a still one:
    ``(du, dv)`` px arrays. Across: ``A sin(2 pi f t + 0.7 k)``; down: ``0.6 A sin(2 pi f t
    + 0.7 k + pi / 2)`` (``k`` the view's index: the cameras vibrate out of phase)."""
    amp, freq = (float(x) for x in spec.shake)
    phase = 2.0 * math.pi * freq * np.asarray(t, dtype=np.float64) + 0.7 * view_index
    return amp * np.sin(phase), 0.6 * amp * np.sin(phase + 0.5 * math.pi)
