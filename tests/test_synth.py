"""vidtrack synth: the truth is self-consistent and independent of the renderer.

- world positions against fits.throw.position at the frame times, pixels against the
  orthographic mapping written out by hand from the scene's axes, origin and scale;
- the rasteriser's coverage against brute-force dense point sampling;
- a rendered frame's coverage-weighted centroid (straw alone: flat background, no
  noise, 16-bit png) against the truth centroid;
- every output format read back through vidtrack.footage with the right length, shape
  and time base; lossless formats agree pixel for pixel;
- scene.toml loads and describes the mapping the footage was rendered with;
- options: one view, second straw, leaving the frame, replicate throws, top delay;
- the CLI as a subprocess, including bad options (exit 2, nothing written).
"""

import json
import math

import numpy as np
import pytest

from fits.throw import position
from vidtrack.synth._raster import (Box, Capsule, Roi, box_coverage, capsule_coverage,
                                    shape_roi)
from vidtrack.errors import VidtrackError
from vidtrack.footage import open_source
from vidtrack.scene import find_throw_dirs, load_scene
from vidtrack.synth import SynthSpec, render_run

SMALL = dict(size_px=(160, 96), flight_s=0.02, release_frame=4, exposure_samples=4,
             straw_length_m=0.10, straw_diameter_m=0.025)
CLEAN = dict(texture_amplitude=0.0, vignetting=0.0, draw_machine=False, draw_ruler=False,
             scale_in_scene="m_per_px", read_noise_dn=0.0)


def load_truth(folder):
    return json.loads((folder / "truth.json").read_text())


def frame_table(truth, view):
    return {k: np.asarray(v) for k, v in truth["views"][view]["per_frame"].items()}


# ---------------------------------------------------------------------------- rasteriser

def dense_coverage(a, b, r, shape, s=96):
    """Reference coverage: fraction of an s x s point grid per pixel inside the capsule."""
    offs = (np.arange(s) + 0.5) / s - 0.5
    out = np.zeros(shape)
    a, b = np.asarray(a, float), np.asarray(b, float)
    ab = b - a
    L2 = ab @ ab
    for ov in offs:
        v = np.arange(shape[0])[:, None, None] + ov
        u = np.arange(shape[1])[None, :, None] + offs[None, None, :]
        qu, qv = u - a[0], v - a[1]
        t = np.clip((qu * ab[0] + qv * ab[1]) / L2, 0, 1) if L2 > 0 else 0.0
        d = np.hypot(qu - t * ab[0], qv - t * ab[1])
        out += (d <= r).mean(axis=2)
    return out / s


@pytest.mark.parametrize("seed", range(6))
def test_capsule_coverage_matches_dense_sampling(seed):
    rng = np.random.default_rng(seed)
    a = rng.uniform(12, 24, 2)
    ang, L, r = rng.uniform(0, np.pi), rng.uniform(0, 14), rng.uniform(0.6, 4.0)
    b = a + L * np.array([np.cos(ang), np.sin(ang)])
    cov = capsule_coverage(Capsule(tuple(a), tuple(b), r), Roi(0, 40, 0, 40))
    ref = dense_coverage(a, b, r, (40, 40))
    assert np.abs(cov - ref).max() < 0.04          # 16x16 sampling on the rounded ends
    area = np.pi * r * r + 2 * r * L
    assert cov.sum() == pytest.approx(area, rel=2e-3)
    # the coverage-weighted centroid sits on the capsule's centre
    cu = (cov * np.arange(40)[None, :]).sum() / cov.sum()
    cv = (cov * np.arange(40)[:, None]).sum() / cov.sum()
    tol = 0.02 if r >= 1.5 else 0.05
    assert abs(cu - 0.5 * (a[0] + b[0])) < tol and abs(cv - 0.5 * (a[1] + b[1])) < tol


def test_straight_sides_are_exact():
    # a horizontal bar: coverage along a column is the exact overlap of [v0, v1] with pixels
    cov = capsule_coverage(Capsule((5.0, 10.3), (30.0, 10.3), 2.2), Roi(0, 20, 0, 36))
    col = cov[:, 17]
    lo, hi = 10.3 - 2.2, 10.3 + 2.2
    rows = np.arange(20)
    expect = np.clip(np.minimum(hi, rows + 0.5) - np.maximum(lo, rows - 0.5), 0, 1)
    np.testing.assert_allclose(col, expect, atol=1e-12)


def _random_capsules(seed, n):
    """Capsules of every kind the rasteriser meets: random ends and directions, radii
    0.3-25 px, zero-length (discs), horizontal and vertical ones, ends and radii on
    pixel centres, half-pixels and sub-grid steps (1/32 px: on the 16 x 16 grid's lines)."""
    rng = np.random.default_rng(seed)
    snaps = (None, 1.0, 2.0, 32.0)
    for i in range(n):
        snap = snaps[i % 4]
        rounded = (lambda x: x) if snap is None else (lambda x, k=snap: np.round(x * k) / k)
        a = rounded(rng.uniform(-3.0, 45.0, 2))
        length, ang = rng.uniform(0.0, 40.0), rng.uniform(0.0, 2 * np.pi)
        kind = i % 5
        step = {0: (0.0, 0.0), 1: (length, 0.0), 2: (0.0, length)}.get(
            kind, (length * np.cos(ang), length * np.sin(ang)))
        b = rounded(a + np.array(step)) if kind > 0 else a.copy()
        r = rounded(rng.uniform(0.3, 25.0)) if rng.random() < 0.5 else rng.uniform(0.3, 25.0)
        yield Capsule(tuple(map(float, a)), tuple(map(float, b)), float(max(r, 0.3)))


def _brute_force_inside(cap, pu, pv):
    """Grid points (pu, pv) inside ``cap``, and their distance to its boundary (written
    here, apart from the module: closest point ``a + t (b - a)``, ``t`` clipped)."""
    a, b = np.asarray(cap.a_px), np.asarray(cap.b_px)
    ab = b - a
    L2 = float(ab @ ab)
    t = np.clip(((pu - a[0]) * ab[0] + (pv - a[1]) * ab[1]) / L2, 0, 1) if L2 > 0 else 0.0
    dist = np.hypot(pu - (a[0] + t * ab[0]), pv - (a[1] + t * ab[1]))
    return dist <= cap.radius_px, np.abs(dist - cap.radius_px)


def test_sampled_pixels_count_the_same_grid_points_as_brute_force():
    """The sub-row counting (every pixel of the roi put through it, not only the rounded
    ends' ones) against all 256 points tested one by one: equal, but where a point lies
    within 1e-9 px of the boundary (the two computations may round it either way)."""
    from vidtrack.synth import _capsules

    s = 16
    offs = (np.arange(s) + 0.5) / s - 0.5
    pixels = ties = 0
    for cap in _random_capsules(7, 120):
        roi = shape_roi(cap.extent_px()).clip((48, 52))
        if roi.empty:
            continue
        rr, cc = np.nonzero(np.ones(roi.shape, dtype=bool))
        own = np.zeros(rr.size, dtype=np.int64)
        got = _capsules._sampled_coverage(rr + roi.r0, cc + roi.c0, own,
                                          _capsules._Segments.of([cap]).take(own), s, [roi])
        pu = (cc + roi.c0)[:, None, None] + offs[None, None, :]
        pv = (rr + roi.r0)[:, None, None] + offs[None, :, None]
        inside, margin = _brute_force_inside(cap, pu, pv)
        expect = inside.reshape(rr.size, -1).mean(axis=1)
        differ = got != expect
        pixels += rr.size
        if differ.any():
            near = (margin.reshape(rr.size, -1) < 1e-9).any(axis=1)
            assert near[differ].all(), (cap, roi, np.nonzero(differ & ~near))
            ties += int(differ.sum())
    assert pixels > 30_000
    print(f"{pixels} pixels, {ties} differing by a point within 1e-9 px of the boundary")


def test_capsule_coverage_rounded_ends_are_brute_force_counts():
    """capsule_coverage's own sampled pixels (near a rounded end: centre within half a
    diagonal of the boundary, not wholly beside the segment) are the brute-force count."""
    s = 16
    offs = (np.arange(s) + 0.5) / s - 0.5
    half_diag = 0.5 * np.sqrt(2.0) + 1e-9
    checked = 0
    for cap in _random_capsules(11, 300):
        roi = shape_roi(cap.extent_px()).clip((48, 52))
        if roi.empty:
            continue
        cov = capsule_coverage(cap, roi, supersample=s)
        rows = np.arange(roi.r0, roi.r1)[:, None]
        cols = np.arange(roi.c0, roi.c1)[None, :]
        a, b = np.asarray(cap.a_px), np.asarray(cap.b_px)
        inside_c, margin_c = _brute_force_inside(cap, cols + 0.0, rows + 0.0)
        edge = margin_c < half_diag - 1e-6           # clear of the classification's edge
        length = float(np.hypot(*(b - a)))
        if length > 0:
            tu, tv = (b - a) / length
            along = (cols - a[0]) * tu + (rows - a[1]) * tv
            half = 0.5 * (abs(tu) + abs(tv))
            edge &= (along < half - 1e-6) | (along > length - half + 1e-6)
        er, ec = np.nonzero(edge)
        pu = (ec + roi.c0)[:, None, None] + offs[None, None, :]
        pv = (er + roi.r0)[:, None, None] + offs[None, :, None]
        inside, margin = _brute_force_inside(cap, pu, pv)
        expect = inside.reshape(er.size, -1).mean(axis=1)
        differ = cov[er, ec] != expect
        near = (margin.reshape(er.size, -1) < 1e-9).any(axis=1)
        assert not (differ & ~near).any(), cap
        checked += er.size
    assert checked > 10_000


def test_disc_coverage_sums_to_its_area():
    """A disc (a zero-length capsule) is all rounded end: its coverage sums to pi r^2
    within the grid's resolution (the 1/256 px^2 cells the circle crosses, at most
    4 (2 r s + 2) of them), and without bias over many centres."""
    rng = np.random.default_rng(5)
    s, errors = 16, []
    for i in range(300):
        c = rng.uniform(30.0, 40.0, 2)
        c = np.round(c * 2) / 2 if i % 3 == 0 else c
        r = float(rng.uniform(0.3, 25.0))
        cap = Capsule(tuple(c), tuple(c), r)
        cov = capsule_coverage(cap, shape_roi(cap.extent_px()), supersample=s)
        err = cov.sum() - np.pi * r * r
        assert abs(err) <= 4 * (2 * r * s + 2) / s ** 2, (cap, err)
        errors.append(err / (2 * np.pi * r))
    assert abs(np.mean(errors)) < 1e-3          # per px of perimeter: no bias


def test_shot_noise_is_poisson():
    from vidtrack.synth._raster import add_sensor_noise

    rng = np.random.default_rng(3)
    level, well = 0.4, 5000.0
    out = add_sensor_noise(np.full((200, 200), level), rng, read_noise=0.0, full_well_e=well)
    assert out.mean() == pytest.approx(level, rel=2e-3)
    assert out.var() == pytest.approx(level / well, rel=0.05)


def test_box_coverage_exact():
    cov = box_coverage(Box(2.25, 7.75, 1.0, 3.5), Roi(0, 6, 0, 10))
    assert cov.sum() == pytest.approx(5.5 * 2.5)
    assert cov[2, 5] == 1.0 and cov[1, 2] == pytest.approx(0.5 * 0.25)


# ---------------------------------------------------------------------------- a clean run

@pytest.fixture(scope="module")
def clean_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("synth") / "clean"
    spec = SynthSpec(**SMALL, **CLEAN, output_format="png", bit_depth=16)
    return out, spec, render_run(out, spec)


def test_world_truth_is_the_throw_model(clean_run):
    out, spec, _ = clean_run
    truth = load_truth(out)
    for view in ("front", "top"):
        tab = frame_table(truth, view)
        t = tab["t_s"]
        np.testing.assert_allclose(t, (np.arange(spec.n_frames) - spec.release_frame) / 1200.0,
                                   rtol=0, atol=1e-15)
        fl = t >= 0
        xyz = position(t[fl], spec.state, spec.k, spec.cp_s_per_m, v1=7.2 / 3.6)
        np.testing.assert_allclose(np.column_stack([tab["x_m"], tab["y_m"], tab["z_m"]])[fl],
                                   xyz, rtol=0, atol=1e-12)
        assert int(truth["views"][view]["release_frame"]) == spec.release_frame
        assert list(tab["phase"][fl]) == ["flight"] * fl.sum()
        # before release the straw rides a tooth: inside the release radius, z = z0
        rho = np.hypot(tab["x_m"], tab["y_m"])
        assert np.all(rho[~fl] < math.hypot(*spec.state[:2]))
        np.testing.assert_allclose(tab["z_m"][~fl], spec.state[2], atol=1e-15)
    tr = truth["truth"]
    assert tr["k"] == {"k1": 2.2, "k2": 2.5, "k3": 4.6, "k4": 21.3}
    assert tr["cp_s_per_m"] == 0.115 and tr["v1_m_s"] == pytest.approx(2.0)


def test_pixel_truth_is_the_written_mapping(clean_run):
    out, spec, _ = clean_run
    truth = load_truth(out)
    scene = load_scene(out)
    for view, (col_axis, row_axis) in (("front", ("x_m", "y_m")), ("top", ("x_m", "z_m"))):
        info = truth["views"][view]
        tab = frame_table(truth, view)
        m = info["m_per_px"]
        ou, ov = info["origin_px"]
        sc = 1.0 if spec.view_axes(view)[0][0] == "+" else -1.0
        sr = 1.0 if spec.view_axes(view)[1][0] == "+" else -1.0
        np.testing.assert_allclose(tab["u_px"], ou + sc * tab[col_axis] / m, atol=1e-9)
        np.testing.assert_allclose(tab["v_px"], ov + sr * tab[row_axis] / m, atol=1e-9)
        vs = scene.views[view]
        assert vs.m_per_px == pytest.approx(m, rel=1e-12)
        assert vs.origin_px == pytest.approx((ou, ov), abs=1e-12)
        assert vs.fps == 1200.0 and tuple(vs.axes) == spec.view_axes(view)
        world = vs.mapping().pixel_to_world(np.column_stack([tab["u_px"], tab["v_px"]]))
        np.testing.assert_allclose(world, np.column_stack([tab[col_axis], tab[row_axis]]),
                                   atol=1e-12)


def test_coverage_centroid_of_rendered_frames_equals_truth(clean_run):
    out, spec, _ = clean_run
    truth = load_truth(out)
    bg, straw = spec.background_grey, spec.straw_grey
    checked = 0
    for view in ("front", "top"):
        tab = frame_table(truth, view)
        with open_source(out / view, fps=1200) as src:
            assert src.dtype == np.uint16 and src.bit_depth == 16
            for i in range(len(src)):
                if not tab["fully_in_view"][i]:
                    continue
                cov = (src[i] / 65535.0 - bg) / (straw - bg)
                cov[np.abs(cov) < 1e-3] = 0.0
                u = (cov * np.arange(cov.shape[1])[None, :]).sum() / cov.sum()
                v = (cov * np.arange(cov.shape[0])[:, None]).sum() / cov.sum()
                assert abs(u - tab["u_exposure_px"][i]) < 0.02, (view, i)
                assert abs(v - tab["v_exposure_px"][i]) < 0.02, (view, i)
                assert abs(u - tab["u_px"][i]) < 0.02 and abs(v - tab["v_px"][i]) < 0.02
                # the image is the coverage the truth reports
                assert abs(u - tab["u_coverage_px"][i]) < 1e-3
                assert abs(v - tab["v_coverage_px"][i]) < 1e-3
                # the pixel-centre bias of a coverage centroid stays within 1 / (8 w)
                w = 2.0 * truth["views"][view]["straw_radius_px"]
                assert abs(tab["u_coverage_px"][i] - tab["u_exposure_px"][i]) < 1 / (8 * w)
                assert abs(tab["v_coverage_px"][i] - tab["v_exposure_px"][i]) < 1 / (8 * w)
                assert cov.sum() == pytest.approx(tab["coverage_px"][i], rel=1e-3)
                assert cov.sum() == pytest.approx(tab["area_px"][i], rel=0.02)
                checked += 1
    assert checked >= 20
    # the straw is several pixels thick
    assert truth["views"]["front"]["straw_radius_px"] > 1.5


def test_scene_ruler_describes_the_rendered_scale(tmp_path):
    spec = SynthSpec(**SMALL, views=("front",), output_format="png", read_noise_dn=0.0)
    render_run(tmp_path / "r", spec)
    scene = load_scene(tmp_path / "r")
    truth = load_truth(tmp_path / "r")
    ruler = scene.views["front"].ruler
    span = math.dist(ruler.from_px, ruler.to_px)
    assert ruler.length_m / span == pytest.approx(truth["views"]["front"]["m_per_px"],
                                                  rel=1e-12)
    # the ruler's end ticks are dark in the image, at the named points
    with open_source(tmp_path / "r" / "front", fps=1200) as src:
        img = src[0].astype(float)
    for u, v in (ruler.from_px, ruler.to_px):
        assert img[int(round(v)), int(round(u))] < 0.3 * 255


# ---------------------------------------------------------------------------- formats

def test_formats_read_back_with_their_time_base(tmp_path):
    base = dict(SMALL, views=("front",), frames=10, exposure_samples=2)
    png = render_run(tmp_path / "png", SynthSpec(**base, output_format="png"))
    ffv1 = render_run(tmp_path / "ffv1", SynthSpec(**base, video_codec="ffv1"))
    raw = render_run(tmp_path / "raw", SynthSpec(**base, video_codec="raw"))
    mjpg = render_run(tmp_path / "mjpg", SynthSpec(**base, jpeg_quality=90))
    cine = render_run(tmp_path / "cine", SynthSpec(**base, output_format="cine", bit_depth=12,
                                                   cine_packed=True))
    w, h = SMALL["size_px"]
    truth_t = frame_table(load_truth(tmp_path / "png"), "front")["t_s"]
    with open_source(tmp_path / "png" / "front", fps=1200) as p, \
            open_source(tmp_path / "ffv1" / "front.avi", fps=1200) as f, \
            open_source(tmp_path / "raw" / "front.avi", fps=1200) as r, \
            open_source(tmp_path / "mjpg" / "front.avi", fps=1200) as m, \
            open_source(tmp_path / "cine" / "front.cine") as c:
        for src in (p, f, r, m, c):
            assert len(src) == 10 and src.shape == (h, w)
        for src in (f, r, m):
            assert src.fps_container == pytest.approx(30.0)        # the playback rate
            np.testing.assert_allclose(src.times_s, np.arange(10) / 1200.0)
        assert c.time_source == "time stamps" and c.bit_depth == 12
        np.testing.assert_allclose(c.trigger_times_s, truth_t, atol=1e-9)
        assert list(c.image_numbers) == list(range(-4, 6))
        for i in range(10):
            a = p[i]
            np.testing.assert_array_equal(f[i], a)                 # lossless
            np.testing.assert_array_equal(r[i], a)
            assert np.abs(m[i].astype(int) - a).mean() < 3.0        # lossy, close
            # the 12-bit frame is the same scene, finer
            assert np.abs(c[i] / 4095.0 - a / 255.0).max() < 0.03
        # read noise: two frames differ in a static corner by sqrt(2) x (1.5 DN, rounded)
        diff = p[0][:12, :12].astype(float) - p[9][:12, :12]
        assert diff.std() == pytest.approx(math.sqrt(2 * (1.5 ** 2 + 1 / 12)), rel=0.2)
    for res in (png, ffv1, raw, mjpg, cine):
        scene = load_scene(res.out_dir)
        assert scene.views["front"].fps == 1200.0
        assert scene.views["front"].source.exists()


# ---------------------------------------------------------------------------- options

def test_one_view_and_second_straw(tmp_path):
    spec = SynthSpec(size_px=(200, 120), views=("top",), release_frame=2, flight_s=0.06,
                     exposure_samples=2, second_straw=True, second_cross_s=0.03,
                     second_flight_s=0.1, straw_diameter_m=0.02, output_format="png",
                     sync_in_scene=True)
    render_run(tmp_path / "x", spec)
    scene = load_scene(tmp_path / "x")
    truth = load_truth(tmp_path / "x")
    assert scene.view_names == ("top",) and list(truth["views"]) == ["top"]
    assert scene.views["top"].sync_frame == truth["views"]["top"]["release_frame"] == 2
    tab = frame_table(truth, "top")
    i = int(np.argmin(np.abs(tab["t_s"] - 0.03)))
    assert tab["t_s"][i] == pytest.approx(0.03, abs=1e-12)
    # both centres coincide at the crossing, in world and pixels
    assert tab["x2_m"][i] == pytest.approx(tab["x_m"][i], abs=1e-9)
    assert tab["z2_m"][i] == pytest.approx(tab["z_m"][i], abs=1e-9)
    assert tab["u2_px"][i] == pytest.approx(tab["u_px"][i], abs=1e-6)
    assert tab["overlap"][i] and tab["in_view2"][i]
    assert not tab["overlap"][-1] and tab["overlap"].sum() < len(tab["overlap"])
    s2 = truth["truth"]["second_straw"]
    st2 = [s2["state"][k] for k in ("x0_m", "y0_m", "z0_m", "vx0_m_s", "vy0_m_s", "vz0_m_s")]
    p2 = position([0.03 - s2["release_t_s"]], st2, spec.k, spec.cp_s_per_m, v1=2.0)[0]
    assert p2[2] == pytest.approx(tab["z_m"][i], abs=1e-9)


def test_leaving_the_frame_is_flagged(tmp_path):
    spec = SynthSpec(size_px=(160, 96), views=("front",), release_frame=2, flight_s=0.3,
                     frames=150, exposure_samples=1, exposure_fraction=0.0,
                     straw_diameter_m=0.02, leave_frame=True, output_format="png",
                     read_noise_dn=0.0)
    render_run(tmp_path / "x", spec)
    tab = frame_table(load_truth(tmp_path / "x"), "front")
    assert load_scene(tmp_path / "x").views["front"].sync_frame == "auto"
    w, h = spec.size_px
    assert tab["fully_in_view"][:20].all()
    assert not tab["fully_in_view"][-1]
    # border_touch exactly where the silhouette reaches the outermost pixels
    touching = tab["border_touch"]
    assert touching.any() and not touching[:20].any()
    assert not np.any(touching & ~tab["in_view"])
    # out of view exactly where the whole silhouette is past the right or bottom edge
    gone = ~tab["in_view"]
    off = (tab["u_px"] - 0.5 * tab["length_px"] > w) | (tab["v_px"] - 0.5 * tab["length_px"] > h)
    assert off.any() and np.all(gone[off])
    assert np.all(tab["coverage_px"][gone] == 0)


def test_throws_and_top_delay(tmp_path):
    spec = SynthSpec(**dict(SMALL, frames=6, exposure_samples=1), throws=2,
                     top_delay_s=0.4 / 1200, output_format="png", read_noise_dn=0.0)
    render_run(tmp_path / "t", spec)
    run = tmp_path / "t"
    dirs = find_throw_dirs(run)
    assert [d.name for d in dirs] == ["01", "02"]
    scene = load_scene(run)
    root = load_truth(run)
    ks = []
    for d in dirs:
        for view in ("front", "top"):
            with open_source(scene.views[view].source_in(d), fps=1200) as src:
                assert len(src) == 6
        tr = load_truth(d)
        ks.append([tr["truth"]["k"][f"k{i}"] for i in range(1, 5)])
        front, top = frame_table(tr, "front"), frame_table(tr, "top")
        np.testing.assert_allclose(top["t_s"] - front["t_s"], 0.4 / 1200, atol=1e-15)
        assert tr["views"]["top"]["t0_frame"] == pytest.approx(SMALL["release_frame"] - 0.4)
        assert tr["views"]["top"]["release_frame"] == SMALL["release_frame"]
    assert ks[0] != ks[1]                                   # replicate throws differ
    np.testing.assert_allclose([root["k_mean"][f"k{i}"] for i in range(1, 5)],
                               np.mean(ks, axis=0))
    assert not (run / "front").exists() and (run / "scene.toml").is_file()


def test_bad_spec_values_are_refused():
    for bad in (dict(k=(1, 2, 3)), dict(k=(1, 2, 3, -1)), dict(size_px=(10, 10)),
                dict(output_format="mp4"), dict(output_format="avi", bit_depth=16),
                dict(views=("side",)), dict(front_axes=("+x", "+z")),
                dict(straw_grey=0.46), dict(state=(0, 0, 0, 1, 1, 1)), dict(fps=0),
                dict(cine_packed=True)):
        with pytest.raises(VidtrackError):
            SynthSpec(**bad)


# ---------------------------------------------------------------------------- the CLI

def test_cli_writes_refuses_and_forces(tmp_path, vidtrack_cli):
    out = tmp_path / "run"
    args = ("synth", out, "--size", "96x64", "--flight-s", "0.005", "--release-frame", "2",
            "--exposure-samples", "2", "--views", "front")
    res = vidtrack_cli(*args)
    assert res.returncode == 0, res.stderr
    assert "wrote" in res.stdout and (out / "front.avi").is_file()
    assert load_scene(out).views["front"].fps == 1200.0
    again = vidtrack_cli(*args)
    assert again.returncode == 2
    assert "not empty" in again.stderr and "--force" in again.stderr
    assert "Traceback" not in again.stderr
    (out / "notes.txt").write_text("mine")
    forced = vidtrack_cli(*args[:-1], "top", "--format", "png", "--force")
    assert forced.returncode == 0, forced.stderr
    assert not (out / "front.avi").exists() and (out / "top").is_dir()
    assert (out / "notes.txt").read_text() == "mine"


@pytest.mark.parametrize("bad", [("--size", "12x12"), ("--bit-depth", "16"),
                                 ("--k", "1,2,3"), ("--views", "side"),
                                 ("--format", "mp4"), ("--state", "0,0,0,1,1,1")])
def test_cli_bad_options_exit_2_and_write_nothing(tmp_path, vidtrack_cli, bad):
    out = tmp_path / "nothing"
    res = vidtrack_cli("synth", out, *bad)
    assert res.returncode == 2
    assert "error" in res.stderr and "Traceback" not in res.stderr
    assert not out.exists()


# ---------------------------------------------------------------------------- datasets/run42

def test_sample_run_is_what_its_recorded_command_makes():
    import shlex
    from pathlib import Path

    from vidtrack.cli import build_parser
    from vidtrack.cli.synth import spec_from_args

    root = Path(__file__).resolve().parents[1]
    readme = (root / "datasets" / "README.md").read_text(encoding="utf-8")
    section = readme.split("## The sample run datasets/run42", 1)[1]
    line = next(ln for ln in section.splitlines() if ln.startswith("vidtrack synth "))
    args = build_parser().parse_args(shlex.split(line)[1:])
    run = root / args.out
    truth = load_truth(run)
    assert spec_from_args(args).to_dict() == truth["spec"]
    scene = load_scene(run)
    assert scene.run_name == "run42" and scene.view_names == ("front", "top")
    assert scene.cp_s_per_m == 0.115 and scene.v1_m_s == pytest.approx(2.0)
    spec = SynthSpec(**{k: tuple(v) if isinstance(v, list) else v
                        for k, v in truth["spec"].items()})
    for view in ("front", "top"):
        info = truth["views"][view]
        tab = frame_table(truth, view)
        vs = scene.views[view]
        assert vs.m_per_px == pytest.approx(info["m_per_px"], rel=1e-12)
        with open_source(vs.source, fps=vs.fps) as src:
            assert len(src) == info["frames"] == spec.n_frames == 372
            assert src.shape == (info["height_px"], info["width_px"])
            assert src.fps_container == pytest.approx(30.0) and src.fps == 1200.0
        fl = tab["t_s"] >= 0
        xyz = position(tab["t_s"][fl], spec.state, spec.k, spec.cp_s_per_m, v1=scene.v1_m_s)
        np.testing.assert_allclose(np.column_stack([tab["x_m"], tab["y_m"], tab["z_m"]])[fl],
                                   xyz, atol=1e-12)
        assert tab["fully_in_view"].all() and not tab["border_touch"].any()
    # the front view shows the ascent and a descent
    y = frame_table(truth, "front")["y_m"]
    top = int(np.argmax(y))
    assert 100 < top < 250 and y[-1] < y[top] - 0.3
    size = sum(p.stat().st_size for p in run.iterdir())
    assert size < 6e6


# ---------------------------------------------------------------------------- k_spread

def test_k_spread_draws_each_throws_k_about_k():
    from vidtrack.synth.motion import _make_throws

    k = np.array((2.2, 2.5, 4.6, 21.3))
    spread = np.array((0.02, 0.0, 0.1, 0.05))
    ratios = np.array([[t.k for t in _make_throws(SynthSpec(k=tuple(k), throws=99, seed=s,
                                                            k_spread=tuple(spread)))]
                       for s in range(4)]).reshape(-1, 4) / k - 1.0
    assert np.all(ratios[:, 1] == 0)                        # a zero spread keeps k exactly
    sd = ratios.std(axis=0, ddof=1)
    # 396 draws: the sample sd within 20 % of the true one (about 5 of its own sds)
    np.testing.assert_allclose(sd[[0, 2, 3]], spread[[0, 2, 3]], rtol=0.2)
    assert abs(np.corrcoef(ratios[:, 0], ratios[:, 2])[0, 1]) < 0.25   # independent draws
    # a single throw is spread too; without k_spread it is rendered at k as before
    one = _make_throws(SynthSpec(k=tuple(k), k_spread=(0.05,) * 4))[0]
    assert np.all(np.array(one.k) != k)
    assert _make_throws(SynthSpec(k=tuple(k)))[0].k == tuple(k)
    # throw_spread still spreads the release speed and direction of replicate throws
    states = {t.state for t in _make_throws(SynthSpec(throws=3, k_spread=(0.0,) * 4))}
    assert len(states) == 3
    assert "k_spread" not in SynthSpec().to_dict()          # truth.json as before
    for bad in ((0.1, 0.1, 0.1), (0.1, 0.1, 0.1, -0.01), (0.5,) * 4):
        with pytest.raises(VidtrackError):
            SynthSpec(k_spread=bad)


def test_a_planned_run_folder_is_rendered_keeping_its_factors(tmp_path):
    from vidtrack.scene_template import plan_scene_text

    run = tmp_path / "runs" / "03"
    run.mkdir(parents=True)
    (run / "scene.toml").write_text(plan_scene_text({"n_rpm": 450.0, "vm_kmh": 3.6},
                                                    folder=run), encoding="utf-8")
    spec = SynthSpec(**dict(SMALL, frames=6, exposure_samples=1), views=("front",))
    render_run(run, spec)
    scene = load_scene(run)
    assert scene.factors == {"n_rpm": 450, "vm_kmh": 3.6} and scene.run_name == "03"
    assert "scene.toml" in (run / "vidtrack-synth.toml").read_text()
    # a planned folder holding anything else is not synth's to write into
    other = tmp_path / "runs" / "04"
    other.mkdir()
    (other / "scene.toml").write_text(plan_scene_text({"n_rpm": 650.0}, folder=other))
    (other / "front.avi").write_bytes(b"footage")
    with pytest.raises(VidtrackError, match="not empty"):
        render_run(other, spec)
    assert (other / "front.avi").read_bytes() == b"footage"
