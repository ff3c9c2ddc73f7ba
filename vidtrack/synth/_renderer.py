"""Rendering the frames of one view of one throw, over the view's static image.

``_ViewTrack`` holds, in pixels, the poses of what moves at every frame and exposure
sample:

- the rotor: two knife teeth turning about the shaft (front: bars through the origin;
  top: their projections, bars along X) and the hub (front) or shaft (top);
- the straw: a rod of length L and diameter D with rounded ends (a capsule: its
  silhouette in any orthographic view is again a capsule, centrally symmetric, so
  the centroid of the silhouette is the projected rod centre), opaque, of grey
  level ``straw_grey``;
- optionally a second straw, drawn behind the first;
- optionally the distractors of :mod:`vidtrack.synth._distractors` (a shadow under
  everything that moves, a rider behind the straw, a highlight on it, a person at the
  side).

``_ViewRenderer`` draws frame i:

- motion blur: each frame is the mean of ``exposure_samples`` renders spread evenly
  over the exposure (``exposure_fraction / fps`` seconds centred on the frame's time);
- exact anti-aliasing: pixel coverage from :mod:`vidtrack.synth._raster` (1/256 resolution
  on edges, exact elsewhere), only in the boxes the moving parts reach;
- sensor noise (Gaussian read noise, optional Poisson shot noise) and quantisation to
  the output bit depth.

It also records, per frame, the straw's coverage and its overlaps with the blade and the
second straw, for the truth file. Frames are rendered one at a time, deterministically,
in any order.
"""

import math

import numpy as np

from vidtrack.synth import _distractors, _raster
from vidtrack.synth._views import (_GREY, _HUB_RADIUS_M, _SHAFT_HALF_LENGTH_M,
                                   _SHAFT_HALF_WIDTH_M, _TOOTH_HALF_BREADTH_M,
                                   _TOOTH_HALF_WIDTH_M, _frame_times, post_box,
                                   post_speed)

from vidtrack.synth.motion import _second_pose, straw_pose
from vidtrack.synth.spec import VIEW_NAMES

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
        self.axis = d
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
        self._distractors(spec, view, throw, c, d, cs, ds)
        self.machine = self._machine(spec, view, throw) if spec.draw_machine else None

    def _machine(self, spec, view, throw):
        """The rotor's layers at every frame and exposure sample, [i][j] -> list, each
        shape mapped to pixels once here (the same arithmetic as one at a time)."""
        m = view.mapping.m_per_px
        phi = throw.release_angle_rad + throw.blade_rad_s * self.ts          # (n, K)
        ang = np.stack([phi, phi + math.pi], axis=-1).ravel()                 # (n K 2,)
        radius = throw.blade_radius_m
        tip = np.array([[radius * math.cos(a), radius * math.sin(a), 0.0] for a in ang])
        if view.name == "front":
            a = view.to_px(np.zeros((1, 3)))[0]
            teeth = [_raster.Capsule(tuple(a), tuple(b), _TOOTH_HALF_WIDTH_M / m)
                     for b in view.to_px(tip)]
            hub = _raster.Capsule(tuple(a), tuple(a), _HUB_RADIUS_M / m)
        else:
            x = tip[:, 0]
            corners = view.mapping.world_to_pixel(np.column_stack([
                np.minimum(0.0, x), np.full(x.size, -_TOOTH_HALF_BREADTH_M),
                np.maximum(0.0, x), np.full(x.size, _TOOTH_HALF_BREADTH_M)]).reshape(-1, 2))
            teeth = [_raster.Box(c[0, 0], c[1, 0], c[0, 1], c[1, 1])
                     for c in corners.reshape(-1, 2, 2)]
            hub = view.world_box((-_SHAFT_HALF_WIDTH_M, -_SHAFT_HALF_LENGTH_M),
                                 (_SHAFT_HALF_WIDTH_M, _SHAFT_HALF_LENGTH_M))
        n, kk = self.ts.shape
        return [[[("tooth0", teeth[2 * (i * kk + j)], _GREY["tooth"]),
                  ("tooth1", teeth[2 * (i * kk + j) + 1], _GREY["tooth"]),
                  ("hub", hub, _GREY["hub"])] for j in range(kk)] for i in range(n)]

    def _distractors(self, spec, view, throw, c, d, cs, ds):
        """Poses of the distractors asked for (docs/synth.md, "Distractors")."""
        n, kk = self.t.size, self.kk
        self.level = spec.straw_level
        self.post = post_box(spec, view)
        self.post_moves = self.post is not None and post_speed(spec) != 0.0
        self.shadow_px = (None if spec.shadow is None
                          else _distractors.shadow_offset_px(spec))
        self.rider = spec.rider is not None
        rider_ends = None
        if self.rider:
            rhalf, self.rider_radius_px = _distractors.rider_half_and_radius(
                spec, view.mapping.m_per_px)
            cr, dr = _distractors.rider_pose(self.t, spec, throw, c, d)
            self.rider_centre_m = cr
            self.rider_centre_px = view.to_px(cr)
            self.rider_a_px = view.to_px(cr - rhalf * dr)
            self.rider_b_px = view.to_px(cr + rhalf * dr)
            crs, drs = _distractors.rider_pose(self.ts.ravel(), spec, throw, cs, ds)
            self.subr_a = view.to_px(crs - rhalf * drs).reshape(n, kk, 2)
            self.subr_b = view.to_px(crs + rhalf * drs).reshape(n, kk, 2)
            rider_ends = (self.subr_a.reshape(-1, 2), self.subr_b.reshape(-1, 2),
                          self.rider_radius_px)
        self.person = None
        if spec.person_at_side:
            blade_px = ((throw.blade_radius_m + _TOOTH_HALF_WIDTH_M) / view.mapping.m_per_px
                        if view.name == "front" else
                        throw.blade_radius_m / view.mapping.m_per_px)
            self.person = _distractors.place_person(spec, view, self, blade_px, rider_ends)

    def shadow_capsule(self, i, j):
        """The straw's silhouette moved to where its shadow falls (before the blur)."""
        du, dv = self.shadow_px
        a, b = self.sub_a[i, j], self.sub_b[i, j]
        return _raster.Capsule((a[0] + du, a[1] + dv), (b[0] + du, b[1] + dv),
                               self.radius_px)

    def blade_angles(self, i):
        return self.throw.release_angle_rad + self.throw.blade_rad_s * self.ts[i]

    def layers(self, i, j):
        """Opaque layers of exposure sample j of frame i, back to front."""
        spec, view = self.spec, self.view
        out = []
        if self.machine is not None:
            out.extend(self.machine[i][j])
        if self.person is not None:
            out.extend(self.person.parts(float(self.ts[i, j])))
        if self.second and np.all(np.isfinite(self.sub2_a[i, j])):
            out.append(("straw2", _raster.Capsule(tuple(self.sub2_a[i, j]),
                                                  tuple(self.sub2_b[i, j]), self.radius_px),
                        self.level))
        if self.rider and np.all(np.isfinite(self.subr_a[i, j])):
            out.append(("rider", _raster.Capsule(tuple(self.subr_a[i, j]),
                                                 tuple(self.subr_b[i, j]), self.rider_radius_px),
                        _distractors.rider_level(spec)))
        out.append(("straw", _raster.Capsule(tuple(self.sub_a[i, j]), tuple(self.sub_b[i, j]),
                                             self.radius_px), self.level))
        if spec.highlight_grey is not None:
            out.append(("highlight", _distractors.highlight_capsule(
                self.sub_a[i, j], self.sub_b[i, j], self.radius_px), spec.highlight_grey))
        if self.post_moves:
            # in front of everything, where it is at this sample of the exposure
            out.append(("post",) + post_box(spec, view, float(self.ts[i, j])))
        elif self.post is not None:
            # in front of everything: the static image has it; drawn again over what
            # moves behind it (the part of it beside that, with a margin)
            box, grey = self.post
            vs = [e[2:] for e in (shape.extent_px() for _, shape, _ in out)
                  if e[1] >= box.u0 - 1.0 and e[0] <= box.u1 + 1.0]
            if vs:
                v0 = max(box.v0, min(v[0] for v in vs) - 3.0)
                v1 = min(box.v1, max(v[1] for v in vs) + 3.0)
                out.append(("post", _raster.Box(box.u0, box.u1, v0, v1), grey))
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
        shape = self.static.shape
        kk = track.kk
        per_sample = [track.layers(i, j) for j in range(kk)]
        rois = {}
        for layers in per_sample:
            for key, s, _ in layers:
                roi = _raster.shape_roi(s.extent_px()).clip(shape)
                if not roi.empty:
                    rois[key] = rois[key].union(roi) if key in rois else roi
        shadows = None
        if getattr(track, "shadow_px", None) is not None:       # pinhole tracks have none
            shadows = [track.shadow_capsule(i, j) for j in range(kk)]
            pad = math.ceil(4.0 * float(spec.shadow[2])) + 2
            for sh in shadows:
                u0, u1, v0, v1 = sh.extent_px()
                roi = _raster.shape_roi((u0 - pad, u1 + pad, v0 - pad, v1 + pad)).clip(shape)
                if not roi.empty:
                    rois["shadow"] = rois["shadow"].union(roi) if "shadow" in rois else roi
        groups = _merge_rois(rois)
        image = self.static.copy()
        facts = {"coverage_px": 0.0, "moment_u": 0.0, "moment_v": 0.0, "overlap": False,
                 "blade_overlap": False, "rider_overlap": False, "person_overlap": False,
                 "hidden_px": 0.0}
        for roi, keys in groups:
            base = self.static[roi.slices]
            acc = np.zeros(roi.shape)
            cov = {}
            bases = [base] * kk
            if "shadow" in keys:
                bases = [base * (1.0 - float(spec.shadow[1]) * shadow)
                         for shadow in self._shadows(shadows, roi)]
            painted_samples = _raster.composite_boxes(
                bases, [[ly for ly in layers if ly[0] in keys] for layers in per_sample], roi,
                supersample=spec.supersample, cache=self._cache)
            for layers, (painted, covers) in zip(per_sample, painted_samples):
                acc += painted
                if getattr(track, "post_moves", False) and "straw" in covers:
                    # (the straw behind the post where it is at this sample)
                    sub, c = covers["straw"]
                    box = next(ly[1] for ly in layers if ly[0] == "post")
                    facts["hidden_px"] += float((c * _raster.box_coverage(box, sub)).sum()) / kk
                for key, (sub, c) in covers.items():
                    name = "blade" if key in ("tooth0", "tooth1", "hub", "shaft") else key
                    if name not in cov:
                        cov[name] = np.zeros(roi.shape)
                    cov[name][sub.slice_in(roi)] += c
            image[roi.slices] = acc / kk
            if "straw" in cov:
                straw = cov["straw"] / kk
                facts["coverage_px"] += float(straw.sum())
                if getattr(track, "post", None) is not None and not track.post_moves:
                    facts["hidden_px"] += float(
                        (straw * _raster.box_coverage(track.post[0], roi)).sum())
                facts["moment_u"] += float((straw.sum(axis=0) * np.arange(roi.c0, roi.c1)).sum())
                facts["moment_v"] += float((straw.sum(axis=1) * np.arange(roi.r0, roi.r1)).sum())
                if "straw2" in cov:
                    facts["overlap"] |= bool(np.any((straw > 0) & (cov["straw2"] > 0)))
                if "blade" in cov:
                    facts["blade_overlap"] |= bool(np.any((straw > 0) & (cov["blade"] > 0)))
                if "rider" in cov:
                    facts["rider_overlap"] |= bool(np.any((straw > 0) & (cov["rider"] > 0)))
                person = sum(cov[k] for k in cov if k.startswith("person"))
                if not np.isscalar(person):
                    facts["person_overlap"] |= bool(np.any((straw > 0) & (person > 0)))
        return image, facts

    def _shadows(self, capsules, roi):
        """The shadows' blurred coverages over ``roi`` (0 .. 1), one a capsule."""
        import cv2

        covs = _raster.capsule_coverages(capsules, [roi] * len(capsules),
                                         supersample=self.spec.supersample)
        sigma = float(self.spec.shadow[2])
        if sigma > 0:
            covs = [cv2.GaussianBlur(cov, (0, 0), sigmaX=sigma, sigmaY=sigma,
                                     borderType=cv2.BORDER_CONSTANT) for cov in covs]
        return covs

    def _shaken(self, i, image):
        """The noiseless frame i as the shaking camera shows it (whole image moved)."""
        import cv2

        du, dv = _distractors.camera_shift(self.spec, VIEW_NAMES.index(self.view.name),
                                           self.track.t[i])
        w = np.array([[1.0, 0.0, float(du)], [0.0, 1.0, float(dv)]])
        rows, cols = image.shape
        return cv2.warpAffine(image, w, (cols, rows), flags=cv2.INTER_CUBIC,
                              borderMode=cv2.BORDER_REFLECT_101)

    def frame(self, i):
        """Frame i as written: noise added, quantised to ``bit_depth``."""
        image, facts = self.frame_float(i)
        self.info[i] = facts
        if self.spec.shake is not None:
            image = self._shaken(i, image)
        rng = np.random.default_rng([self.spec.seed, VIEW_NAMES.index(self.view.name),
                                     self.throw_index, i, 2])
        noisy = _raster.add_sensor_noise(image, rng, read_noise=self.read_noise,
                                         full_well_e=self.spec.full_well_e)
        return _raster.quantize(noisy, self.spec.bit_depth)
