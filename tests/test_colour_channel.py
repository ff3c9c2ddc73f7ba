"""A view's ``channel`` (scene.toml ``views.<v>.channel``): the grey image the tracker sees.

The footage is rendered here with exact coverage (``rod_render``): a reddish ball on a
ballistic path over a greenish board under mildly uneven light, the ball of the same
BT.601 luma as the board (0.299 R + 0.587 G + 0.114 B, computed here), about 1 grey level
of noise per channel. In the luma it is invisible; in its red channel it stands out by
about 110 levels, and in its chroma (max - min of R, G, B) by about 80. The truth (the
ball's centre) is never seen by the code under test.
"""

import json
import re

import cv2
import numpy as np
import pytest
from rod_render import disc_coverage, read_video, texture, write_avi

from vidtrack.errors import SceneError, SourceError, TrackError
from vidtrack.footage import open_source
from vidtrack.track.tracker import track

SHAPE = (180, 240)
N = 80
FPS = 500.0
#: BGR (OpenCV's order) of the board and of the ball.
BOARD = np.array([90.0, 150.0, 90.0])
BALL_RB = (200.0, 60.0)          # the ball's red and blue; its green gives the board's luma


def _luma(bgr):
    return 0.114 * bgr[..., 0] + 0.587 * bgr[..., 1] + 0.299 * bgr[..., 2]


def _ball():
    red, blue = BALL_RB
    green = (_luma(BOARD) - 0.299 * red - 0.114 * blue) / 0.587
    return np.array([blue, green, red])


def _path():
    t = np.arange(N, dtype=float)
    return np.column_stack([25.0 + 2.4 * t, 140.0 - 3.0 * t + 0.5 * 0.07 * t * t])


def _render(seed=3):
    rng = np.random.default_rng(seed)
    light = texture(SHAPE, rng=rng, mean=100.0, contrast=4.0, scale=12.0) / 100.0
    ball = _ball()
    frames = []
    for u, v in _path():
        cov = disc_coverage(SHAPE, u, v, 5.0)[..., None]
        img = (BOARD + cov * (ball - BOARD)) * light[..., None]
        img += rng.normal(0.0, 1.0, img.shape)
        frames.append(np.clip(np.rint(img), 0, 255).astype(np.uint8))
    return frames


@pytest.fixture(scope="module")
def colour(tmp_path_factory):
    frames = _render()
    path = write_avi(tmp_path_factory.mktemp("colour") / "colour.avi", frames)
    return path, frames


@pytest.fixture(scope="module")
def grey(tmp_path_factory):
    frames = [cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in _render(seed=4)]
    return write_avi(tmp_path_factory.mktemp("grey") / "grey.avi", frames)


def _track(path, channel):
    with open_source(path, fps=FPS, channel=channel) as src:
        return track(src, view="front"), src.notes, src.channel


def _check(tr):
    truth = _path()
    d = tr.data
    err = np.hypot(d["u_px"].to_numpy() - truth[:, 0], d["v_px"].to_numpy() - truth[:, 1])
    ok = tr.usable
    assert ok.sum() >= 0.8 * N, (int(ok.sum()), tr.flag_counts())
    assert np.all(err[ok] <= 0.5), np.round(err[ok].max(), 3)
    return err[ok].max()


# --------------------------------------------------------------------- the footage itself
def test_the_scene_hides_the_ball_in_the_luma_only():
    ball = _ball()
    assert abs(_luma(ball) - _luma(BOARD)) < 1e-9
    # rounded to 8 bits, the two stay within a grey level of each other
    assert abs(_luma(np.rint(ball)) - _luma(BOARD)) <= 1.0
    assert abs(ball[2] - BOARD[2]) >= 100 and abs(ball[1] - BOARD[1]) >= 40


def test_colour_footage_round_trips_losslessly(colour):
    path, frames = colour
    got = read_video(path)
    assert len(got) == N
    assert all(np.array_equal(a, b) for a, b in zip(got, frames))


# --------------------------------------------------------------------- what the sources give
@pytest.mark.parametrize("channel,index", [("blue", 0), ("green", 1), ("red", 2)])
def test_a_colour_channel_is_that_channel_of_the_bgr_frame(colour, channel, index):
    path, frames = colour
    with open_source(path, fps=FPS, channel=channel) as src:
        assert src.channel == channel and src.dtype == np.uint8 and src.shape == SHAPE
        np.testing.assert_array_equal(src[7], frames[7][:, :, index])
        np.testing.assert_array_equal(next(iter(src)), frames[0][:, :, index])
        assert src.to_dict()["channel"] == channel


def test_chroma_is_the_largest_minus_the_smallest_channel(colour, tmp_path):
    from vidtrack.footage import write_cine

    path, frames = colour
    want = [f.max(axis=2) - f.min(axis=2) for f in frames]
    with open_source(path, fps=FPS, channel="chroma") as src:
        assert src.channel == "chroma" and src.dtype == np.uint8 and src.notes == ()
        np.testing.assert_array_equal(src[7], want[7])
        assert all(np.array_equal(a, b) for a, b in zip(src, want))
    # board (90, 150, 90) BGR: 60; the ball (60, 99.8, 200): 140 (both under the light)
    assert 55 <= np.median(want[0]) <= 65
    # 12-bit colour keeps its depth
    deep = [(f.astype(np.uint16) * 16) for f in frames[:3]]
    cine = write_cine(tmp_path / "deep.cine", deep, fps=FPS, bit_depth=12)
    with open_source(cine, fps=FPS, channel="chroma") as src:
        assert src.dtype == np.uint16
        np.testing.assert_array_equal(src[1], deep[1].max(axis=2) - deep[1].min(axis=2))


def test_luma_is_the_default_and_unchanged(colour):
    path, frames = colour
    with open_source(path, fps=FPS) as src, open_source(path, fps=FPS, channel="luma") as lum:
        assert src.channel == "luma" and src.notes == ()
        for k in (0, 41):
            want = cv2.cvtColor(frames[k], cv2.COLOR_BGR2GRAY)
            np.testing.assert_array_equal(src[k], want)
            np.testing.assert_array_equal(lum[k], want)


def test_image_folders_and_cine_files_give_a_channel_too(colour, tmp_path):
    from vidtrack.footage import write_cine

    _, frames = colour
    folder = tmp_path / "pngs"
    folder.mkdir()
    for k, f in enumerate(frames[:6]):
        cv2.imwrite(str(folder / f"img{k}.png"), f)
    cine = write_cine(tmp_path / "c.cine", frames[:6], fps=FPS)
    for path in (folder, cine):
        with open_source(path, fps=FPS, channel="red") as src:
            np.testing.assert_array_equal(src[4], frames[4][:, :, 2])
        with open_source(path, fps=FPS, channel="auto") as src:
            assert src.channel in ("red", "green", "blue", "luma")


# --------------------------------------------------------------------- tracking
def test_in_the_luma_the_ball_cannot_be_tracked(colour):
    try:
        tr, _, _ = _track(colour[0], "luma")
    except TrackError:
        return
    assert tr.usable.sum() < 0.2 * N, tr.flag_counts()


@pytest.mark.parametrize("channel", ["red", "green", "chroma"])
def test_in_a_channel_where_it_differs_it_is_tracked_to_half_a_pixel(colour, channel):
    tr, notes, got = _track(colour[0], channel)
    assert got == channel and notes == ()
    _check(tr)


def test_a_ball_darker_by_a_shadows_factor_is_taken_when_nothing_else_flies(colour):
    """In the green channel the ball darkens the plain board by a factor of 0.67, as a
    shadow would, with no texture under it to tell: with nothing else in flight to cast
    it, the flight tracker takes it for the object and says why (it stopped before:
    "never appears in flight")."""
    with open_source(colour[0], fps=FPS, channel="green") as src:
        tr = track(src, view="front", engine="flight")
    assert any(n.startswith("shadow-like:") for n in tr.notes), tr.notes
    _check(tr)


def test_auto_chooses_red_and_says_why(colour):
    path, frames = colour
    tr, notes, got = _track(path, "auto")
    assert got == "red"
    said = [n for n in notes if n.startswith("channel auto:")]
    assert len(said) == 1 and said[0].startswith("channel auto: red ("), notes
    scores = {c: float(s) for c, s in re.findall(r"(luma|red|green|blue) ([0-9.]+)", said[0])}
    assert set(scores) == {"luma", "red", "green", "blue"}
    assert max(scores, key=scores.get) == "red" and min(scores, key=scores.get) == "luma"
    assert scores["red"] > 10 * scores["luma"]
    _check(tr)
    # deterministic: the same choice and the same scores on every opening
    with open_source(path, fps=FPS, channel="auto") as a, \
            open_source(path, fps=FPS, channel="auto") as b:
        assert a.channel_scores == b.channel_scores and a.notes == b.notes
        assert a.channel_scores["red"] == pytest.approx(scores["red"], rel=0.01)
        np.testing.assert_array_equal(a[10], frames[10][:, :, 2])


def test_auto_samples_the_range_used(colour):
    with open_source(colour[0], fps=FPS, frames=(10, 30), channel="auto") as src:
        assert src.channel == "red" and "over 20 frames" in src.notes[-1]
        assert len(src) == 20 and src.frame_numbers[0] == 10


# --------------------------------------------------------------------- grey footage
def test_auto_reads_grey_footage_as_luma(grey):
    with open_source(grey, fps=FPS) as lum, open_source(grey, fps=FPS, channel="auto") as auto:
        assert auto.channel == "luma"
        assert auto.notes == ("channel auto: the footage is grey; read as luma",)
        assert all(np.array_equal(a, b) for a, b in zip(lum, auto))


@pytest.mark.parametrize("channel", ["red", "green", "blue", "chroma"])
def test_a_colour_channel_of_grey_footage_is_refused(grey, tmp_path, channel):
    with pytest.raises(SourceError) as info:
        open_source(grey, fps=FPS, channel=channel)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{grey}: ")
    assert f'channel "{channel}"' in msg and "grey (three equal channels" in msg
    assert msg.endswith('expected channel = "luma" or "auto" for grey footage')
    folder = tmp_path / "pngs"                       # one-channel images
    folder.mkdir()
    for k in range(4):
        cv2.imwrite(str(folder / f"img{k}.png"), np.full((8, 9), 40 * k, np.uint8))
    with pytest.raises(SourceError, match=r"pngs: channel .* image folder is grey "
                                          r"\(one channel\)"):
        open_source(folder, fps=FPS, channel=channel)


def test_a_bad_channel_is_refused_when_opening():
    for bad in ("purple", 3, None):
        with pytest.raises(SourceError, match="channel must be one of luma, red, green, "
                                              "blue, chroma, auto"):
            open_source("nowhere.avi", channel=bad)


# --------------------------------------------------------------------- scene.toml
def _scene(view_extra=""):
    return ("schema = 1\n[run]\nname = \"r\"\n[views.front]\nsource = \"front.avi\"\nfps = 1200\n"
            "axes = [\"+x\", \"-y\"]\norigin_px = [10, 20]\nm_per_px = 0.001\n" + view_extra)


@pytest.mark.parametrize("value,shown", [('"purple"', "a string 'purple'"),
                                         ("3", "an integer 3"),
                                         ('"Red"', "a string 'Red' (did you mean 'red'?)")])
def test_a_bad_channel_in_scene_toml_is_one_line(tmp_path, value, shown):
    from vidtrack.scene import load_scene

    (tmp_path / "scene.toml").write_text(_scene(f"channel = {value}\n"))
    with pytest.raises(SceneError) as info:
        load_scene(tmp_path)
    assert str(info.value) == (
        f"{tmp_path / 'scene.toml'}: views.front.channel must be one of \"luma\", \"red\", "
        f"\"green\", \"blue\", \"chroma\", \"auto\", got {shown}")


def test_channel_is_read_written_and_in_the_hash(tmp_path):
    from vidtrack.scene import load_scene, write_scene

    hashes = {}
    for name, extra in (("none", ""), ("luma", 'channel = "luma"\n'),
                        ("red", 'channel = "red"\n'), ("auto", 'channel = "auto"\n')):
        run = tmp_path / name
        run.mkdir()
        (run / "scene.toml").write_text(_scene(extra))
        scene = load_scene(run)
        assert scene.views["front"].channel == ("luma" if name == "none" else name)
        table = scene.to_dict()["views"]["front"]
        assert table.get("channel") == (None if name in ("none", "luma") else name)
        again = load_scene(write_scene(tmp_path / f"{name}-copy", scene.to_dict()))
        assert again.views["front"].channel == scene.views["front"].channel
        hashes[name] = scene.hash
    # the default changes nothing (an earlier run's cache stays valid); a channel does
    assert hashes["none"] == hashes["luma"]
    assert len({hashes["none"], hashes["red"], hashes["auto"]}) == 3


# --------------------------------------------------------------------- the command line
def test_changing_the_channel_tracks_again(tmp_path, vidtrack_cli):
    """run42's footage is grey: "auto" reads it as luma, but the front view's channel
    changed, so that view is tracked again (and gives the same tracks; the top view's
    are reused); unchanged, both stages are reused."""
    import shutil
    from pathlib import Path

    run = tmp_path / "run"
    shutil.copytree(Path(__file__).resolve().parents[1] / "datasets" / "run42", run,
                    ignore=shutil.ignore_patterns("vidtrack"))

    def fit():
        res = vidtrack_cli("fit", run, "--json")
        assert res.returncode == 0, res.stderr
        return json.loads(res.stdout)

    fit()
    tracks = (run / "vidtrack" / "tracks.csv").read_bytes()
    assert fit()["stages_reused"] == ["tracks", "fit"]
    toml = run / "scene.toml"
    toml.write_text(toml.read_text().replace("[views.front]\n",
                                             "[views.front]\nchannel = \"auto\"\n", 1))
    record = fit()
    # the front view tracked again (the tracker reads its channel), the top view's reused
    assert record["stages_reused"] == ["views"]
    assert any(n.startswith("the tracks of the top view reused") for n in record["notes"])
    assert "front: channel auto: the footage is grey; read as luma" in record["notes"]
    assert (run / "vidtrack" / "tracks.csv").read_bytes() == tracks
    assert fit()["stages_reused"] == ["tracks", "fit"]


def test_frames_exports_a_channel(colour, tmp_path, vidtrack_cli):
    path, frames = colour
    res = vidtrack_cli("frames", path, tmp_path / "out", "--fps", "500", "--range", "0:3",
                       "--channel", "auto")
    assert res.returncode == 0, res.stderr
    assert "channel auto: red" in res.stderr
    got = cv2.imread(str(tmp_path / "out" / "frame_000002.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(got, frames[2][:, :, 2])
    res = vidtrack_cli("frames", path, tmp_path / "bad", "--channel", "purple")
    assert res.returncode == 2 and res.stderr.strip().count("\n") == 0
    assert "channel must be one of luma, red, green, blue, chroma, auto, got 'purple'" in \
        res.stderr
