"""The truth file of a synthetic run: ``truth.json``.

Every parameter, the throw (release state, k, apex, rotor and spin rates, the second
straw), and for every frame of every view the time, the world position of the straw and
the true pixel centroid of its silhouette (also the mean over the exposure and the
coverage-weighted centroid of the rendered image), with flags. The conventions are
stated in the file itself (``_CONVENTIONS``). Indented JSON with every list of plain
values on one line, at full precision.
"""

import json
import re

import numpy as np

from vidtrack.synth._views import _TOOTH_HALF_WIDTH_M, post_box, post_speed
from vidtrack.synth.spec import VIEW_NAMES

__all__ = ["TRUTH_FILE", "TRUTH_SCHEMA"]

TRUTH_FILE = "truth.json"
TRUTH_SCHEMA = 1


def _release_frame_of(t):
    idx = np.flatnonzero(t >= -1e-12)
    return int(idx[0]) if idx.size else None


def _json_list(arr):
    return [None if not np.isfinite(v) else float(v) for v in np.asarray(arr, dtype=float)]


def _exposure_extents(track, n, w, h):
    """Each frame's mean exposure centre (n, 2) and extents (n, 4: u min, u max, v min,
    v max), whether the straw lies wholly inside a ``w`` x ``h`` image, and whether it
    reaches within a pixel of its border."""
    mean_c, ext = zip(*(track.exposure_geometry(i) for i in range(n)))
    mean_c = np.array(mean_c)
    ext = np.array(ext)
    inside = ((ext[:, 0] >= -0.5) & (ext[:, 1] <= w - 0.5) & (ext[:, 2] >= -0.5)
              & (ext[:, 3] <= h - 0.5))
    reach_border = ((ext[:, 0] < 0.5) | (ext[:, 1] > w - 1.5) | (ext[:, 2] < 0.5)
                    | (ext[:, 3] > h - 1.5))
    return mean_c, ext, inside, reach_border


def _pose_columns(track, t):
    """truth.json's per-frame columns of time and pose (the rod centre in the world and
    in the image)."""
    return {
        "frame": list(range(len(t))),
        "t_s": _json_list(t),
        "phase": ["blade" if ti < 0 else "flight" for ti in t],
        "x_m": _json_list(track.centre_m[:, 0]),
        "y_m": _json_list(track.centre_m[:, 1]),
        "z_m": _json_list(track.centre_m[:, 2]),
        "u_px": _json_list(track.centre_px[:, 0]),
        "v_px": _json_list(track.centre_px[:, 1]),
    }


def _axis_columns(track):
    """truth.json's per-frame columns of the rod's attitude: its unit axis in the world
    frame (from end a to end b, the sense the synth turns it in), at t_s."""
    d = track.axis
    return {"axis_x": _json_list(d[:, 0]), "axis_y": _json_list(d[:, 1]),
            "axis_z": _json_list(d[:, 2])}


def _shape_columns(track, r, coverage, in_view, inside, reach_border, info):
    """truth.json's per-frame columns of the rod's image (its angle, length and area from
    its projected ends and radius ``r`` in px) and of what it covers and touches."""
    seg = track.end_b_px - track.end_a_px
    angle = np.arctan2(seg[:, 1], seg[:, 0])
    angle = np.where(angle > np.pi / 2, angle - np.pi, angle)
    angle = np.where(angle <= -np.pi / 2, angle + np.pi, angle)
    seg_len = np.hypot(seg[:, 0], seg[:, 1])
    return {
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


def _second_columns(track, vis2):
    """truth.json's per-frame columns of the second straw (``vis2``: in view)."""
    c2, p2 = track.centre2_m, track.centre2_px
    return {
        "x2_m": _json_list(c2[:, 0]), "y2_m": _json_list(c2[:, 1]),
        "z2_m": _json_list(c2[:, 2]),
        "u2_px": _json_list(p2[:, 0]), "v2_px": _json_list(p2[:, 1]),
        "in_view2": [bool(v) for v in vis2],
    }


def _header(spec, source, n, w, h):
    """truth.json's fields of a view's footage."""
    return {
        "source": source,
        "format": spec.output_format,
        "fps": spec.fps,
        "fps_container": spec.playback_fps if spec.output_format == "avi" else
        (float(round(spec.fps)) if spec.output_format == "cine" else None),
        "frames": n,
        "width_px": w,
        "height_px": h,
        "bit_depth": spec.bit_depth,
    }


def _view_truth(spec, view, track, renderer, source):
    n = spec.n_frames
    w, h = view.width, view.height
    mean_c, _, inside, reach_border = _exposure_extents(track, n, w, h)
    info = [renderer.info[i] for i in range(n)]
    coverage = np.array([f["coverage_px"] for f in info])
    in_view = coverage > 0
    safe = np.where(in_view, coverage, 1.0)
    cov_u = np.where(in_view, np.array([f["moment_u"] for f in info]) / safe, np.nan)
    cov_v = np.where(in_view, np.array([f["moment_v"] for f in info]) / safe, np.nan)
    r = track.radius_px
    t = track.t
    table = _pose_columns(track, t)
    table.update({
        "u_exposure_px": _json_list(mean_c[:, 0]),
        "v_exposure_px": _json_list(mean_c[:, 1]),
        "u_coverage_px": _json_list(cov_u),
        "v_coverage_px": _json_list(cov_v),
    })
    table.update(_shape_columns(track, r, coverage, in_view, inside, reach_border, info))
    if track.second:
        p2 = track.centre2_px
        a2, b2 = track.end2_a_px, track.end2_b_px
        with np.errstate(invalid="ignore"):
            vis2 = (np.isfinite(p2[:, 0]) & (np.maximum(a2[:, 0], b2[:, 0]) + r > -0.5)
                    & (np.minimum(a2[:, 0], b2[:, 0]) - r < w - 0.5)
                    & (np.maximum(a2[:, 1], b2[:, 1]) + r > -0.5)
                    & (np.minimum(a2[:, 1], b2[:, 1]) - r < h - 0.5))
        table.update(_second_columns(track, vis2))
    extra = (_distractor_truth(spec, track, info, t, VIEW_NAMES.index(view.name))
             if spec.distractors else None)
    if extra is not None:
        table.update(extra[0])
    table.update(_axis_columns(track))
    release = _release_frame_of(t)
    m = view.mapping
    out = _header(spec, source, n, w, h)
    out.update({
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
    })
    if extra is not None:
        out["distractors"] = extra[1]
    return out


def _distractor_truth(spec, track, info, t, view_index):
    """Per-frame columns and the view's description of the distractors drawn."""
    from vidtrack.synth import _distractors

    cols, about = {}, {}
    r = track.radius_px
    if spec.shadow is not None:
        du, dv = (float(x) for x in track.shadow_px)
        cols["shadow_u_px"] = _json_list(track.centre_px[:, 0] + du)
        cols["shadow_v_px"] = _json_list(track.centre_px[:, 1] + dv)
        about["shadow"] = {"offset_px": [du, dv], "darken": float(spec.shadow[1]),
                           "blur_px": float(spec.shadow[2]),
                           "falls_on": "the static background (wall or ground, housing, "
                                       "ruler), under everything that moves"}
    if spec.straw_polarity is not None or spec.highlight_grey is not None:
        about["straw"] = {"level": track.level,
                          "polarity": "bright" if track.level > spec.background_grey
                          else "dark",
                          "highlight_grey": spec.highlight_grey}
    if track.rider:
        a, b, rr = track.rider_a_px, track.rider_b_px, track.rider_radius_px
        gaps = [_distractors.capsule_gap(track.end_a_px[i], track.end_b_px[i], r, a[i], b[i],
                                         rr) for i in range(t.size)]
        cols.update({
            "rider_u_px": _json_list(track.rider_centre_px[:, 0]),
            "rider_v_px": _json_list(track.rider_centre_px[:, 1]),
            "rider_gap_px": _json_list(gaps),
            "rider_overlap": [bool(f["rider_overlap"]) for f in info],
        })
        half, _ = _distractors.rider_half_and_radius(spec, 1.0)
        about["rider"] = {"mode": spec.rider, "radius_px": rr,
                          "length_m": 2.0 * half + _distractors._RIDER_DIAMETER
                          * spec.straw_diameter_m,
                          "diameter_m": _distractors._RIDER_DIAMETER * spec.straw_diameter_m,
                          "grey": _distractors.rider_level(spec),
                          "drawn": "behind the straw, from the release"}
    if spec.person_at_side:
        p = track.person
        if p is None:
            about["person"] = {"drawn": False,
                               "reason": "no free rectangle of 24 px on a side beside the "
                                         "straw's path, the rotor and the ruler"}
        else:
            pu, pv, gap = [], [], []
            for i in range(t.size):
                parts = p.parts(float(t[i]))
                pu.append(parts[0][1].centre_px[0])
                pv.append(parts[0][1].centre_px[1])
                gap.append(min(_distractors.capsule_gap(
                    track.end_a_px[i], track.end_b_px[i], r, c.a_px, c.b_px, c.radius_px)
                    for _, c, _ in parts))
            ext = p.extent(track.ts.ravel())
            cols.update({"person_u_px": _json_list(pu), "person_v_px": _json_list(pv),
                         "person_gap_px": _json_list(gap),
                         "person_overlap": [bool(f["person_overlap"]) for f in info]})
            about["person"] = {"drawn": True, "box_px": [float(v) for v in p.box],
                               "extent_px": [float(v) for v in ext],
                               "height_px": float(p.scale)}
    if spec.post is not None:
        if track.post is None:
            about["post"] = {"drawn": False, "reason": "in the front view only"}
        else:
            box, grey = track.post
            cov = np.array([f["coverage_px"] for f in info])
            hidden = np.array([f["hidden_px"] for f in info])
            cols["post_hidden"] = _json_list(np.where(cov > 0, hidden / np.where(
                cov > 0, cov, 1.0), 0.0))
            about["post"] = {"drawn": True, "u_px": [box.u0, box.u1], "grey": grey,
                             "drawn_as": "in front of everything, the view's whole height; "
                                         "post_hidden: the share of the straw's coverage "
                                         "behind it"}
            if track.post_moves:
                # (u_px: its columns in the middle frame; post_u_px: its centre per frame)
                about["post"]["speed_px_per_frame"] = post_speed(spec)
                cols["post_u_px"] = _json_list(np.array(
                    [0.5 * (b.u0 + b.u1) for b, _ in
                     (post_box(spec, track.view, float(ti)) for ti in t)]))
    if spec.shake is not None:
        du, dv = _distractors.camera_shift(spec, view_index, t)
        cols.update({"camera_du_px": _json_list(du), "camera_dv_px": _json_list(dv)})
        about["shake"] = {"amplitude_px": float(spec.shake[0]), "freq_hz": float(spec.shake[1]),
                          "moves": "the whole image (every other position is where a still "
                                   "camera shows it)"}
    return cols, about


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
    if spec.distractors:
        out["distractors"] = list(spec.distractors)
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
    "world": "x_m, y_m, z_m: the rod centre in the world frame (docs/reference.md) at t_s "
             "(z relative to the machine); before release the straw rides a tooth",
    "attitude": "axis_x, axis_y, axis_z: the rod's unit axis in the world frame at t_s "
                "(from one end to the other; after release it turns about truth.spin_axis "
                "at truth.spin_rad_s, so it turns at spin_rad_s times the sine of its "
                "angle to spin_axis)",
}

#: Added to ``conventions`` only in a run with distractors.
DISTRACTOR_CONVENTIONS = {
    "distractors": "the truth is the straw's own silhouette, whatever else is drawn: "
                   "the shadow (shadow_u_px, shadow_v_px: where the straw's centre's "
                   "shadow falls), the rider (rider_u_px, rider_v_px its centre, "
                   "rider_gap_px the distance between the two rods' silhouettes at t_s, "
                   "negative when they overlap, rider_overlap: the rendered blurred "
                   "silhouettes share a pixel) and the person (person_u_px, person_v_px "
                   "the body's centre, person_gap_px its distance to the straw) are not "
                   "part of it; the highlight lies inside the straw's silhouette; the "
                   "post stands in front of it (post_hidden: the share of the straw's "
                   "coverage behind it). "
                   "views.<v>.distractors describes what each view drew",
}
