"""``vidtrack overlay RUN`` end to end, and the fitted path in a view's pixels.

Truth the code did not produce: the footage's own frame count and size (read by OpenCV),
tracks.csv (the tracker's numbers, written by ``vidtrack fit``) and truth.json (the
renderer's projected straw centre). The overlay is read back with cv2.VideoCapture and
its markers found by their colour.
"""

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from rod_render import read_video

cv2 = pytest.importorskip("cv2")

REPO = Path(__file__).resolve().parents[1]
RUN42 = REPO / "datasets" / "run42"

#: The colours docs/fit-outputs.md gives (B, G, R): unflagged, then by lowest flag bit.
PALETTE = {0: (0, 255, 0), 1: (0, 140, 255), 2: (0, 0, 255), 4: (255, 0, 255),
           16: (0, 255, 255), 32: (255, 128, 0), 64: (128, 0, 255), 128: (255, 255, 0)}


def expected_colour(flags):
    flags = int(flags)
    return PALETTE[flags & -flags] if flags else PALETTE[0]


def copy_run(dst):
    shutil.copytree(RUN42, dst, ignore=shutil.ignore_patterns("vidtrack"))
    return dst


def fitted_copy(drawn, dst):
    """run42 copied with the module's fit of it (``drawn``'s vidtrack/ without its
    overlays): a fit of the copy reuses its stages."""
    run = copy_run(dst)
    shutil.copytree(drawn[0] / "vidtrack", run / "vidtrack",
                    ignore=shutil.ignore_patterns("overlay_*"))
    return run


def digests(folder):
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(Path(folder).rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def drawn(tmp_path_factory, ):
    """run42 without outputs: ``vidtrack overlay`` fits it first, then draws."""
    from conftest import run_vidtrack

    run = copy_run(tmp_path_factory.mktemp("overlay") / "run")
    res = run_vidtrack("overlay", run)
    assert res.returncode == 0, res.stderr
    return run, res


def ring(img, u, v, half=25, banner=None):
    """Centre and median colour of the saturated pixels within ``half`` px of (u, v)."""
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    mask = (hsv[..., 1] > 110) & (hsv[..., 2] > 110)
    if banner is not None:
        mask[:banner] = False
    r0, c0 = max(int(v) - half, 0), max(int(u) - half, 0)
    win = mask[r0:int(v) + half + 1, c0:int(u) + half + 1]
    rr, cc = np.nonzero(win)
    if rr.size < 10:
        return None, None
    colour = np.median(img[r0:, c0:][rr, cc].astype(float), axis=0)
    return (cc.mean() + c0, rr.mean() + r0), colour


def nearest(colour):
    cols = {k: np.array(c, float) for k, c in PALETTE.items()}
    return min(cols, key=lambda k: np.linalg.norm(cols[k] - colour))


def test_overlay_fits_first_and_writes_every_frame(drawn):
    run, res = drawn
    assert "fitting first" in res.stderr
    assert (run / "vidtrack" / "fit.json").is_file()
    for view in ("front", "top"):
        src = cv2.VideoCapture(str(run / f"{view}.avi"))
        n_src = len(read_video(run / f"{view}.avi"))
        w = int(src.get(cv2.CAP_PROP_FRAME_WIDTH))
        h = int(src.get(cv2.CAP_PROP_FRAME_HEIGHT))
        out = read_video(run / "vidtrack" / f"overlay_{view}.mp4")
        assert len(out) == n_src == 372
        assert out[0].shape == (h, w, 3)
    assert not list((run / "vidtrack").glob(".*part*"))      # no temporary file left


def test_marker_at_tracked_pixel_in_flag_colour(drawn):
    run, _ = drawn
    tracks = pd.read_csv(run / "vidtrack" / "tracks.csv")
    checked, colours = 0, set()
    for view in ("front", "top"):
        frames = read_video(run / "vidtrack" / f"overlay_{view}.mp4")
        rows = tracks[(tracks.view == view)].set_index("frame")
        sample = list(range(0, len(frames), 9)) + list(range(0, 30))   # flagged early
        for f in sorted(set(sample)):
            r = rows.loc[f]
            if not np.isfinite(r.u_px) or r.v_px < 45:    # lost, or under the banner
                continue
            centre, colour = ring(frames[f], r.u_px, r.v_px, banner=34)
            assert centre is not None, (view, f)
            err = np.hypot(centre[0] - r.u_px, centre[1] - r.v_px)
            assert err < 1.5, (view, f, centre, (r.u_px, r.v_px))
            flags = int(r["flags"])
            want = expected_colour(flags)
            assert PALETTE[nearest(colour)] == want, (view, f, flags, colour)
            colours.add(nearest(colour))
            checked += 1
    assert checked > 60
    assert 0 in colours and len(colours) >= 2         # unflagged and flagged frames seen


def test_options_every_scale_range(drawn, tmp_path, vidtrack_cli):
    run = fitted_copy(drawn, tmp_path / "run")
    assert vidtrack_cli("fit", run).returncode == 0
    res = vidtrack_cli("overlay", run, "--view", "top", "--every", "4", "--scale", "0.5",
                       "--range", "100:201")
    assert res.returncode == 0, res.stderr
    out = read_video(run / "vidtrack" / "overlay_top.mp4")
    assert len(out) == 26                             # frames 100, 104, ..., 200
    assert out[0].shape == (56, 200, 3)               # 400 x 112 footage halved
    assert not (run / "vidtrack" / "overlay_front.mp4").exists()
    tracks = pd.read_csv(run / "vidtrack" / "tracks.csv")
    r = tracks[(tracks.view == "top") & (tracks.frame == 160)].iloc[0]
    centre, _ = ring(out[15], (r.u_px + 0.5) * 0.5 - 0.5, (r.v_px + 0.5) * 0.5 - 0.5,
                     half=14)
    assert np.hypot(centre[0] - ((r.u_px + 0.5) * 0.5 - 0.5),
                    centre[1] - ((r.v_px + 0.5) * 0.5 - 0.5)) < 1.5


def _no_scene(run):
    (run / "scene.toml").unlink()


def _output_is_file(run):
    (run / "vidtrack").write_text("not a folder")


def _read_only(run):
    out = run / "vidtrack"
    out.mkdir()
    out.chmod(0o555)
    try:
        (out / ".probe").write_bytes(b"")
    except OSError:
        return
    (out / ".probe").unlink()
    out.chmod(0o755)
    pytest.skip("this process writes into a mode-555 folder (root): no read-only folder")


@pytest.mark.parametrize("args, setup, says", [
    (("--view", "side"), None, "--view side"),
    (("--every", "0"), None, "--every 0"),
    (("--scale", "0"), None, "--scale 0"),
    (("--scale", "nan"), None, "--scale nan"),
    (("--range", "9:3"), None, "--range 9:3"),
    (("--range", "x"), None, "--range x"),
    ((), _no_scene, "no scene.toml"),
    ((), _output_is_file, "vidtrack is a file"),
    ((), _read_only, "cannot write"),
])
def test_bad_input_exit_2_one_line_inputs_untouched(tmp_path, vidtrack_cli, args, setup,
                                                    says):
    run = copy_run(tmp_path / "run")
    if setup:
        setup(run)
    before = digests(run)
    try:
        res = vidtrack_cli("overlay", run, *args)
    finally:
        if (run / "vidtrack").is_dir():
            (run / "vidtrack").chmod(0o755)
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and says in lines[0], res.stderr
    assert digests(run) == before
    assert not list(run.rglob("overlay_*"))


def test_help_has_an_example(vidtrack_cli):
    res = vidtrack_cli("overlay", "--help")
    assert res.returncode == 0 and "vidtrack overlay runs/07" in res.stdout


# ------------------------------------------------------------ the path in pixels

def _path_errors(run):
    """Distance (px) of the projected fitted path from truth.json's u_px, v_px on
    unflagged frames of the flight, per view."""
    from vidtrack.report.view_path import view_paths
    from vidtrack.run.tracks_file import read_tracks
    from vidtrack.scene import load_scene

    scene = load_scene(run)
    record = json.loads((run / "vidtrack" / "fit.json").read_text())
    tf = read_tracks(run / "vidtrack" / "tracks.h5")
    truth = json.loads((run / "truth.json").read_text())
    world = {c: tf.world.data[c].to_numpy() for c in tf.world.data.columns}
    paths = view_paths(scene, record, world,
                       frame_shapes={n: t.frame_shape for n, t in tf.tracks.items()})
    out = {}
    for name, path in paths.items():
        d = tf.tracks[name].data
        pf = pd.DataFrame(truth["views"][name]["per_frame"]).set_index("frame")
        uv = path.at_frames(d["frame"].to_numpy(), d["t_s"].to_numpy())
        ok = (d["flags"].to_numpy() == 0) & np.isfinite(uv).all(axis=1)
        ok &= (pf.loc[d["frame"], "phase"] == "flight").to_numpy()
        true = pf.loc[d["frame"][ok], ["u_px", "v_px"]].to_numpy(float)
        out[name] = (np.hypot(*(uv[ok] - true).T), int(ok.sum()))
    return out


def test_projected_path_on_truth_orthogonal(drawn):
    run, _ = drawn
    errs = _path_errors(run)
    assert set(errs) == {"front", "top"}
    for name, (e, n) in errs.items():
        assert n > 300 and e.max() < 0.5, (name, n, e.max())


def test_projected_path_on_truth_perspective(tmp_path, vidtrack_cli):
    # cam1 with a lens (projection), cam2 a DLT counted from the bottom-left. The motion
    # blur averaged over 2 renders a frame, not 8 (measured: the path within 0.061 and
    # 0.066 px of truth at most on 226 and 227 frames, 0.063 and 0.066 with 8; the scene
    # given no lens distortion: 1.9 and 1.2 px)
    run = tmp_path / "persp"
    r = vidtrack_cli("synth", run, "--cameras", "perspective", "--camera-distance-m", "1.5",
                     "--camera-angle-deg", "80", "--distortion=-0.12,0.03,0.0005,-0.0003,0",
                     "--size", "320x240", "--flight-s", "0.2", "--straw-diameter-m", "0.02",
                     "--exposure-samples", "2")
    assert r.returncode == 0, r.stderr
    r = vidtrack_cli("overlay", run, "--every", "10")
    assert r.returncode == 0, r.stderr
    assert len(read_video(run / "vidtrack" / "overlay_cam2.mp4")) == 26
    errs = _path_errors(run)
    assert set(errs) == {"cam1", "cam2"}
    for name, (e, n) in errs.items():
        assert n > 150 and e.max() < 0.5, (name, n, e.max())


# ------------------------------------------------ H.264, the trail and the scene

def fourcc(path):
    cap = cv2.VideoCapture(str(path))
    try:
        code = int(cap.get(cv2.CAP_PROP_FOURCC))
    finally:
        cap.release()
    return code.to_bytes(4, "little").decode("latin-1").lower()


def top_level_boxes(path):
    """The MP4's top-level box types in file order (ISO/IEC 14496-12: size, type)."""
    data = Path(path).read_bytes()
    boxes, at = [], 0
    while at + 8 <= len(data):
        size = int.from_bytes(data[at:at + 4], "big")
        kind = data[at + 4:at + 8].decode("latin-1")
        if size == 1:
            size = int.from_bytes(data[at + 8:at + 16], "big")
        boxes.append(kind)
        if size < 8:
            break
        at += size
    return boxes


def ffmpeg_says(path):
    """What the bundled ffmpeg reports about a file's video stream (``ffmpeg -i``)."""
    import subprocess

    import imageio_ffmpeg

    res = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(path)],
                         capture_output=True, text=True)
    return next(line for line in res.stderr.splitlines() if "Video:" in line)


def test_overlay_is_h264_mp4_a_browser_plays(drawn):
    run, _ = drawn
    for view in ("front", "top"):
        out = run / "vidtrack" / f"overlay_{view}.mp4"
        assert fourcc(out) in ("h264", "avc1")
        stream = ffmpeg_says(out)
        assert "h264" in stream and "yuv420p" in stream, stream
        boxes = top_level_boxes(out)
        assert boxes[0] == "ftyp" and boxes.index("moov") < boxes.index("mdat"), boxes
        n_src = len(read_video(run / f"{view}.avi"))
        cap = cv2.VideoCapture(str(out))
        assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == n_src
        cap.release()


def test_odd_size_padded_to_even(drawn, tmp_path, vidtrack_cli):
    run = fitted_copy(drawn, tmp_path / "run")
    assert vidtrack_cli("fit", run, "-q").returncode == 0
    res = vidtrack_cli("overlay", run, "--view", "top", "--every", "20", "--scale", "0.37")
    assert res.returncode == 0, res.stderr
    assert "148 x 42 px, h264" in res.stdout                # 400 x 112 * 0.37 = 148 x 41
    out = read_video(run / "vidtrack" / "overlay_top.mp4")
    assert len(out) == 19 and out[0].shape == (42, 148, 3)


def test_origin_marker_at_origin_px(drawn):
    # scene.toml's origin_px: a circled cross of radius 5 px (the frame's shorter side
    # / 40, at least 5) in pale blue; on the circle the frame is lighter than the footage,
    # halfway to the centre (off the cross's arms and the axes) it is the footage
    from vidtrack.scene import load_scene

    run, _ = drawn
    scene = load_scene(run)
    for view in ("front", "top"):
        u0, v0 = scene.views[view].origin_px
        out = read_video(run / "vidtrack" / f"overlay_{view}.mp4")
        src = read_video(run / f"{view}.avi")
        for f in (0, 150, 300):
            diff = out[f].astype(int) - src[f].astype(int)
            for ang in (45, 135, 225, 315):
                a = np.radians(ang)
                on = diff[int(round(v0 + 5 * np.sin(a))), int(round(u0 + 5 * np.cos(a)))]
                off = diff[int(round(v0 + 2.5 * np.sin(a))), int(round(u0 + 2.5 * np.cos(a)))]
                assert on[0] > 60 and on[0] > on[2], (view, f, ang, on)     # pale blue
                assert np.abs(off).max() < 45, (view, f, ang, off)


def test_trail_follows_the_measured_points_and_fades(drawn, tmp_path, vidtrack_cli):
    # the same overlay without a trail: the difference is the trail alone
    from vidtrack.report.overlay import TRAIL_COLOUR

    run, _ = drawn
    bare = copy_run(tmp_path / "bare")
    shutil.copytree(run / "vidtrack", bare / "vidtrack",
                    ignore=shutil.ignore_patterns("overlay_*"))
    res = vidtrack_cli("overlay", bare, "--view", "front", "--trail", "0", "-q")
    assert res.returncode == 0, res.stderr
    assert "fitting first" not in res.stderr
    with_trail = read_video(run / "vidtrack" / "overlay_front.mp4")
    without = read_video(bare / "vidtrack" / "overlay_front.mp4")
    tracks = pd.read_csv(run / "vidtrack" / "tracks.csv")
    rows = tracks[tracks.view == "front"].set_index("frame")
    rows_ = np.arange(with_trail[0].shape[0])[:, None]
    cols_ = np.arange(with_trail[0].shape[1])[None, :]
    checked = 0
    for f in (120, 160, 200, 240):
        diff = np.abs(with_trail[f].astype(int) - without[f].astype(int)).max(axis=2)
        near = np.zeros(diff.shape, bool)
        for age in range(1, 31):
            r = rows.loc[f - age]
            if np.isfinite(r.u_px):
                near |= np.hypot(cols_ - r.u_px, rows_ - r.v_px) <= 4.5
        assert ((diff > 25) & near).sum() > 20, f
        strong = diff > 40                                # beyond the encoder's noise
        assert not (strong & ~near).any(), (f, np.argwhere(strong & ~near)[:5])
        # newer dots are more opaque than older ones (fading; the newest dozen lie
        # under the ring and the fitted cross, the path runs through their middles);
        # beyond 30 frames there are none. Opacity: the change over the change a full
        # dot would make
        colour = np.array(TRAIL_COLOUR, float)

        def opacity(age):
            r = rows.loc[f - age]
            win = np.hypot(cols_ - r.u_px, rows_ - r.v_px) <= 2
            full = np.abs(colour - without[f][win]).max(axis=1)
            return diff[win].sum() / max(full.sum(), 1)
        assert opacity(16) > opacity(28) + 0.15 and opacity(16) > 2 * opacity(30), f
        old = rows.loc[f - 45]
        far = np.hypot(cols_ - old.u_px, rows_ - old.v_px) <= 2
        if not (far & near).any():
            assert diff[far].max() < 25, f
        checked += 1
    assert checked == 4


def test_bad_trail_exit_2(tmp_path, vidtrack_cli):
    run = copy_run(tmp_path / "run")
    res = vidtrack_cli("overlay", run, "--trail", "-1")
    assert res.returncode == 2
    assert res.stderr.strip().splitlines() == [res.stderr.strip()] and "--trail -1" in res.stderr


def test_draw_rings_is_draw_marks_point_by_point():
    from vidtrack.report.overlay import FLAG_COLOURS, draw_marks, draw_rings

    rng = np.random.default_rng(3)
    points = rng.uniform(0, 60, (40, 2))
    points[[3, 17]] = np.nan                      # nothing measured: nothing drawn
    flags = rng.choice([0, *FLAG_COLOURS], 40)
    one = np.zeros((130, 130, 3), np.uint8)
    for p, f in zip(points, flags):
        draw_marks(one, measured=p, flags=int(f), scale=2.0, offset=(1.0, -2.0), radius=2.5)
    many = np.zeros_like(one)
    draw_rings(many, points, flags, scale=2.0, offset=(1.0, -2.0), radius=2.5)
    assert one.any() and np.array_equal(one, many)
