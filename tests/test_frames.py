"""One behaviour suite run against every frame source: videos, image folders, .cine.

Every case is written from the same truth frames (a textured background, a bright disc
moving across, and a binary frame number in 8x8 blocks so that a frame read out of
place is seen even through lossy compression) and must give them back the same way.
"""

import tracemalloc

import cv2
import numpy as np
import pytest

from vidtrack.footage.cine import write_cine
from vidtrack.errors import SourceError
from vidtrack.footage import (ImageFolderSource, VideoSource, natural_key, open_source,
                              to_grey)

ROWS, COLS, N = 48, 64, 20
FPS = 1200.0          # the capture rate given by the user
CONTAINER_FPS = 30.0  # what an exported video claims


def scene(n=N, rows=ROWS, cols=COLS):
    """Truth frames in [0, 1]: texture, a moving disc, and the frame number in blocks."""
    yy, xx = np.mgrid[0:rows, 0:cols].astype(np.float64)
    background = 0.25 + 0.15 * np.sin(xx / 5.0) * np.cos(yy / 7.0) + 0.1 * xx / cols
    out = np.empty((n, rows, cols))
    for k in range(n):
        f = background.copy()
        cx, cy = 10 + 2.0 * k, 28 + 0.5 * k
        f[(xx - cx) ** 2 + (yy - cy) ** 2 < 36] = 0.9
        for bit in range(min(cols // 8, 8)):  # frame number, one 8x8 block per bit
            f[0:8, 8 * bit:8 * bit + 8] = 0.95 if (k >> bit) & 1 else 0.05
        out[k] = f
    return out


def quantise(frames, bits):
    dtype = np.uint8 if bits == 8 else np.uint16
    return np.round(frames * (2 ** bits - 1)).astype(dtype)


def write_video(path, frames, fourcc, fps=CONTAINER_FPS, colour=False):
    rows, cols = frames.shape[1:3]
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), fps, (cols, rows), colour)
    assert w.isOpened(), f"this OpenCV cannot write {fourcc}"
    for f in frames:
        w.write(f)
    w.release()
    return path


def write_folder(folder, frames, ending, names=None):
    folder.mkdir(parents=True, exist_ok=True)
    names = names or [f"img{k}{ending}" for k in range(len(frames))]
    for name, f in zip(names, frames):
        assert cv2.imwrite(str(folder / name), f)
    return folder


# name -> (builder(tmp) -> (path, truth), bit_depth, lossless, open kwargs, fps, container)
def _video(fourcc, ending):
    def build(tmp):
        truth = quantise(scene(), 8)
        return write_video(tmp / f"v{ending}", truth, fourcc), truth
    return build


def _folder(ending, bits):
    def build(tmp):
        truth = quantise(scene(), bits)
        return write_folder(tmp / "imgs", truth, ending), truth
    return build


def _cine(bits, **kw):
    def build(tmp):
        truth = quantise(scene(), bits)
        return write_cine(tmp / "c.cine", truth, fps=FPS, bit_depth=bits, first_image_no=-7,
                          **kw), truth
    return build


CASES = {
    "avi-mjpg": (_video("MJPG", ".avi"), 8, False, {"fps": FPS}, FPS, CONTAINER_FPS),
    "avi-ffv1": (_video("FFV1", ".avi"), 8, True, {"fps": FPS}, FPS, CONTAINER_FPS),
    "mp4-mp4v": (_video("mp4v", ".mp4"), 8, False, {"fps": FPS}, FPS, CONTAINER_FPS),
    "png8": (_folder(".png", 8), 8, True, {"fps": FPS}, FPS, None),
    "png16": (_folder(".png", 16), 16, True, {"fps": FPS}, FPS, None),
    "tif16": (_folder(".tif", 16), 16, True, {"fps": FPS}, FPS, None),
    "bmp8": (_folder(".bmp", 8), 8, True, {"fps": FPS}, FPS, None),
    "jpg8": (_folder(".jpg", 8), 8, False, {"fps": FPS}, FPS, None),
    "cine8": (_cine(8), 8, True, {}, FPS, FPS),
    "cine12": (_cine(12), 12, True, {}, FPS, FPS),
    "cine16-top-down": (_cine(16, bottom_up=False), 16, True, {}, FPS, FPS),
    "cine10-packed": (_cine(10, packed=True), 10, True, {}, FPS, FPS),
    "cine12-packed": (_cine(12, packed=True), 12, True, {}, FPS, FPS),
}


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request, tmp_path_factory):
    build, bits, lossless, kwargs, fps, container = CASES[request.param]
    path, truth = build(tmp_path_factory.mktemp(request.param))
    return {"name": request.param, "path": path, "truth": truth, "bits": bits,
            "lossless": lossless, "kwargs": kwargs, "fps": fps, "container": container}


def assert_frame_is(frame, truth, k, lossless):
    """Frame equals truth[k] (lossless), or is close to it and closest of all (lossy)."""
    if lossless:
        np.testing.assert_array_equal(frame, truth[k])
        return
    err = np.abs(truth.astype(np.float64) - frame.astype(np.float64)).mean(axis=(1, 2))
    assert int(np.argmin(err)) == k, f"frame {k} looks like truth frame {int(np.argmin(err))}"
    assert err[k] < 0.03 * (2 ** (8 * truth.dtype.itemsize) - 1)


def test_length_shape_dtype_depth(case):
    with open_source(case["path"], **case["kwargs"]) as src:
        assert len(src) == src.len() == N
        assert src.shape == (ROWS, COLS)
        assert src.dtype == case["truth"].dtype
        assert src.bit_depth == case["bits"]


def test_iteration_gives_the_truth_in_order(case):
    with open_source(case["path"], **case["kwargs"]) as src:
        frames = list(src)
    assert len(frames) == N
    for k, f in enumerate(frames):
        assert f.shape == (ROWS, COLS) and f.dtype == case["truth"].dtype
        assert_frame_is(f, case["truth"], k, case["lossless"])


def test_random_access_equals_iteration(case):
    with open_source(case["path"], **case["kwargs"]) as src:
        seq = list(src)
        order = [7, 19, 0, 3, 18, 2, 11, 11, 5, -1, -20]
        for i in order:
            np.testing.assert_array_equal(src[i], seq[i])
        np.testing.assert_array_equal(src[np.int64(4)], seq[4])
        # iterating again after random access starts from the beginning
        np.testing.assert_array_equal(next(iter(src)), seq[0])


def test_index_errors(case):
    with open_source(case["path"], **case["kwargs"]) as src:
        with pytest.raises(IndexError):
            src[N]
        with pytest.raises(IndexError):
            src[-N - 1]
        with pytest.raises(TypeError):
            src[1.5]


def test_time_base(case):
    with open_source(case["path"], **case["kwargs"]) as src:
        assert src.fps == pytest.approx(case["fps"], rel=1e-6)
        assert src.fps_container == case["container"]
        np.testing.assert_allclose(src.times_s, np.arange(N) / case["fps"], rtol=0, atol=1e-9)
        assert src.time_s(5) == pytest.approx(5 / case["fps"], abs=1e-9)
        assert src.time_s(-1) == pytest.approx((N - 1) / case["fps"], abs=1e-9)
        expected = "time stamps" if case["name"].startswith("cine") else "fps"
        assert src.time_source == expected
        np.testing.assert_array_equal(src.frame_numbers, np.arange(N))


def test_range_keeps_file_numbering_and_clock(case):
    with open_source(case["path"], frames=(3, 11), **case["kwargs"]) as src:
        assert len(src) == 8
        np.testing.assert_array_equal(src.frame_numbers, np.arange(3, 11))
        np.testing.assert_allclose(src.times_s, np.arange(3, 11) / case["fps"], atol=1e-9)
        frames = list(src)
        assert len(frames) == 8
        for i, f in enumerate(frames):
            assert_frame_is(f, case["truth"], 3 + i, case["lossless"])
            np.testing.assert_array_equal(src[i], f)
    with open_source(case["path"], frames=(15, None), **case["kwargs"]) as src:
        assert len(src) == N - 15
    with open_source(case["path"], frames=(15, 99), **case["kwargs"]) as src:
        assert len(src) == N - 15 and any("past the last frame" in n for n in src.notes)


def test_empty_range_is_refused(case):
    with pytest.raises(SourceError, match="selects nothing"):
        open_source(case["path"], frames=(N, N + 5), **case["kwargs"])
    for bad in [(5, 5), (7, 3), (-1, 4), (1.0, 4), "0:4", (1, 2, 3)]:
        with pytest.raises(SourceError, match="frames must"):
            open_source(case["path"], frames=bad, **case["kwargs"])


def test_context_manager_closes(case):
    with open_source(case["path"], **case["kwargs"]) as src:
        first = src[0]
    assert first.shape == (ROWS, COLS)
    with pytest.raises(SourceError, match="closed"):
        src[0]
    with pytest.raises(SourceError, match="closed"):
        next(iter(src))
    src.close()  # closing twice is harmless


def test_frames_are_independent_copies(case):
    with open_source(case["path"], **case["kwargs"]) as src:
        a = src[2]
        a[:] = 0
        assert src[2].any()


def test_to_dict_describes_the_source(case):
    import json

    with open_source(case["path"], **case["kwargs"]) as src:
        d = src.to_dict()
        json.dumps(d)
        assert d["frames"] == N and d["shape"] == [ROWS, COLS] and d["bit_depth"] == case["bits"]
        assert repr(src).startswith("<")


SLICES = [slice(10, 20), slice(None, None, 3), slice(-5, None), slice(15, 4, -2),
          slice(None, None, -1), slice(3, 3), [3, 7, -1, 7], np.array([19, 0]),
          np.arange(N) % 4 == 1]


@pytest.mark.parametrize("key", SLICES, ids=repr)
def test_slices_are_views_in_the_file_numbering(case, key):
    want = np.arange(N)[key]            # numpy's own indexing is the truth of which frames
    with open_source(case["path"], **case["kwargs"]) as src:
        view = src[key]
        assert len(view) == len(want) and view.shape == src.shape and view.dtype == src.dtype
        np.testing.assert_array_equal(view.frame_numbers, want)
        np.testing.assert_allclose(view.times_s, want / case["fps"], rtol=0, atol=1e-9)
        frames = list(view)
        assert len(frames) == len(want)
        for f, k in zip(frames, want):
            assert_frame_is(f, case["truth"], k, case["lossless"])
        for i in (0, -1) if len(want) else ():
            np.testing.assert_array_equal(view[i], frames[i])
            assert view.time_s(i) == pytest.approx(want[i] / case["fps"], abs=1e-9)


def test_a_view_slices_again_and_keeps_a_range_s_numbering(case):
    with open_source(case["path"], frames=(3, 17), **case["kwargs"]) as src:
        view = src[2:12][::2][1:]         # file frames 7, 9, 11, 13
        np.testing.assert_array_equal(view.frame_numbers, [7, 9, 11, 13])
        assert view.source is src
        for i, f in enumerate(view):
            assert_frame_is(f, case["truth"], 7 + 2 * i, case["lossless"])
        assert_frame_is(view[-1], case["truth"], 13, case["lossless"])
        with pytest.raises(IndexError):
            view[4]
        with pytest.raises(IndexError):
            src[[0, 14]]
        with pytest.raises(IndexError):
            src[np.ones(3, dtype=bool)]
        with pytest.raises(TypeError):
            view["1"]
        json_ready = view.to_dict()
        assert json_ready["frames"] == 4 and json_ready["frame_numbers"] == [7, 9, 11, 13]


def test_slicing_decodes_nothing(case):
    # a view made while the source is open and read after it is closed: had the slice
    # decoded its frames, they would be there; they are read only when asked for
    with open_source(case["path"], **case["kwargs"]) as src:
        view = src[5:15]
        everything = src[:]
    assert len(everything) == N and len(view) == 10
    np.testing.assert_array_equal(view.frame_numbers, np.arange(5, 15))
    with pytest.raises(SourceError, match="closed"):
        view[0]
    with pytest.raises(SourceError, match="closed"):
        next(iter(view))


# Slices as a Python list slices them: bounds past either end clipped, any step but 0
LIST_SLICES = [slice(5, 100), slice(100, None), slice(-100, 3), slice(-100, -50),
               slice(18, -100, -3), slice(None, None, -7), slice(None, 100, 6), slice(7, 2)]


@pytest.mark.parametrize("key", LIST_SLICES, ids=repr)
def test_a_slice_selects_the_frames_a_list_slice_does(case, key):
    with open_source(case["path"], frames=(2, 18), **case["kwargs"]) as src:
        file_frames = list(range(2, 18))             # a list of the range's file frames
        view = src[key]
        assert len(view) == len(file_frames[key])
        assert view.frame_numbers.tolist() == file_frames[key]
        assert view[::-1].frame_numbers.tolist() == file_frames[key][::-1]
        assert view[1::2].frame_numbers.tolist() == file_frames[key][1::2]


def test_a_view_gives_exactly_what_integer_indexing_gives(case):
    with open_source(case["path"], **case["kwargs"]) as src:
        by_index = [src[k] for k in range(N)]        # the same decoder, one frame at a time
        for key in (slice(3, 17, 2), slice(None, None, -3), slice(-6, None), [4, 4, 0, -1]):
            view = src[key]
            want = np.arange(N)[key]
            for f, k in zip(view, want):                            # iterated
                np.testing.assert_array_equal(f, by_index[k])
            for i in range(-len(view), len(view)):                  # indexed, both ends
                np.testing.assert_array_equal(view[i], by_index[want[i]])
            with pytest.raises(IndexError, match="out of range"):
                view[len(view)]
            with pytest.raises(IndexError, match="out of range"):
                view[-len(view) - 1]


@pytest.mark.parametrize("key", [1.5, None, "3", b"3", 2j, slice(1.5, 3), [1.0, 2.0]],
                         ids=repr)
def test_a_bad_index_type_is_a_type_error(case, key):
    with open_source(case["path"], **case["kwargs"]) as src:
        for seq in (src, src[2:9]):
            with pytest.raises(TypeError, match="integer"):
                seq[key]


def test_a_zero_step_is_refused_as_a_list_refuses_it(case):
    with open_source(case["path"], **case["kwargs"]) as src:
        for seq in (src, src[2:9], list(range(N))):
            with pytest.raises(ValueError, match="zero"):
                seq[::0]


# ---------------------------------------------------------------------------------------
# Streaming: memory does not grow with the length of the footage
# ---------------------------------------------------------------------------------------
LONG = 150


@pytest.fixture(scope="module", params=["avi-ffv1", "png8", "cine16"])
def long_source(request, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("long-" + request.param)
    truth = quantise(scene(n=LONG, rows=96, cols=128), 16 if request.param == "cine16" else 8)
    if request.param == "avi-ffv1":
        return write_video(tmp / "long.avi", truth, "FFV1")
    if request.param == "png8":
        return write_folder(tmp / "imgs", truth, ".png")
    return write_cine(tmp / "long.cine", truth, fps=FPS, bit_depth=16)


def _peak_bytes(fn):
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_iteration_does_not_accumulate_frames(long_source):
    with open_source(long_source, fps=FPS) as src:
        frame_bytes = src[0].nbytes
        count = [0]

        def stream():
            for f in src:
                count[0] += int(f[0, 0] >= 0)

        streamed = _peak_bytes(stream)
        kept = _peak_bytes(lambda: list(src))
    assert count[0] == LONG
    # a handful of frames in flight (decode buffers, the grey conversion), not 150
    assert streamed < 8 * frame_bytes + 512 * 1024
    # the measurement does see frames that are kept: the bound above can fail
    assert kept > 0.9 * LONG * frame_bytes > streamed


# ---------------------------------------------------------------------------------------
# Videos
# ---------------------------------------------------------------------------------------
def test_a_view_of_long_footage_holds_no_frame(long_source):
    with open_source(long_source, fps=FPS) as src:
        frame_bytes = src[0].nbytes
        view = None

        def slice_all():
            nonlocal view
            view = src[::-1]

        assert _peak_bytes(slice_all) < frame_bytes
        np.testing.assert_array_equal(view[0], src[LONG - 1])


def test_a_view_s_size_does_not_grow_with_its_length(long_source):
    with open_source(long_source, fps=FPS) as src:
        views = []

        def view_bytes(key):
            # what making the view allocates, the view kept (a view of a view included)
            return _peak_bytes(lambda: views.append(src[key][::1]))

        short = view_bytes(slice(0, 2))
        for key in (slice(None), slice(None, None, -1), slice(1, None, 3)):
            # an int64 per frame would be 8 * 150 = 1200 bytes more
            assert view_bytes(key) < short + 256, key
        whole, backwards, every_third = views[1:]
        np.testing.assert_array_equal(whole.frame_numbers, np.arange(LONG))
        np.testing.assert_array_equal(backwards.frame_numbers, np.arange(LONG)[::-1])
        np.testing.assert_array_equal(every_third.frame_numbers, np.arange(1, LONG, 3))
        np.testing.assert_array_equal(every_third[-1], src[LONG - 2])


def test_video_container_rate_without_capture_rate(tmp_path):
    path = write_video(tmp_path / "v.avi", quantise(scene(), 8), "MJPG")
    with open_source(path) as src:
        assert src.fps == CONTAINER_FPS and src.time_source == "container"
        assert src.fps_given is None
        assert src.time_s(3) == pytest.approx(3 / CONTAINER_FPS)
    with open_source(path, fps=FPS) as src:
        assert src.fps == FPS and src.fps_container == CONTAINER_FPS


def test_colour_video_is_converted_to_luma(tmp_path):
    rng = np.random.default_rng(3)
    bgr = rng.integers(0, 256, size=(6, ROWS, COLS, 3), dtype=np.uint8)
    path = write_video(tmp_path / "colour.avi", bgr, "FFV1", colour=True)
    luma = 0.114 * bgr[..., 0] + 0.587 * bgr[..., 1] + 0.299 * bgr[..., 2]  # ITU-R BT.601
    with open_source(path, fps=FPS) as src:
        for k, f in enumerate(src):
            assert f.dtype == np.uint8 and f.shape == (ROWS, COLS)
            assert np.abs(f - luma[k]).max() <= 1.0


def _bgr_grey(path):
    """Every frame of a video as OpenCV's BGR decoding and BT.601 conversion give it."""
    cap = cv2.VideoCapture(str(path))
    out = []
    while True:
        ok, bgr = cap.read()
        if not ok:
            return np.array(out)
        out.append(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY))


def test_grey_mjpeg_is_read_as_its_luma_plane_with_the_frames_of_bgr_decoding(tmp_path):
    path = write_video(tmp_path / "grey.avi", quantise(scene(), 8), "MJPG")
    want = _bgr_grey(path)
    with open_source(path, fps=FPS) as src:
        assert src._luma                      # the fast path is taken...
        got = np.array(list(src))             # ...and every frame kept is its own
        np.testing.assert_array_equal(src[7], want[7])
    assert got.shape == want.shape
    assert np.abs(got.astype(int) - want).max() <= 1


@pytest.mark.parametrize("fourcc, ending, colour", [
    ("MJPG", ".avi", True),     # saturated colour noise: luma and BGR grey differ
    ("mp4v", ".mp4", False),    # limited-range YUV: the plane is not the grey
    ("HFYU", ".avi", False),    # packed RGB: the raw frame is not a luma plane
])
def test_videos_whose_luma_plane_is_not_the_grey_are_converted_from_bgr(tmp_path, fourcc,
                                                                       ending, colour):
    rng = np.random.default_rng(4)
    if colour:
        frames = rng.integers(0, 256, size=(6, ROWS, COLS, 3), dtype=np.uint8)
    else:
        frames = quantise(scene(n=6), 8)
    path = write_video(tmp_path / f"v{ending}", frames, fourcc, colour=colour)
    with open_source(path, fps=FPS) as src:
        assert not src._luma
        np.testing.assert_array_equal(np.array(list(src)), _bgr_grey(path))


def test_truncated_video_names_the_frame(tmp_path):
    path = write_video(tmp_path / "v.avi", quantise(scene(), 8), "MJPG")
    data = path.read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(data[: len(data) // 2])
    with open_source(cut, fps=FPS) as src:
        assert len(src) == N  # the container's count
        with pytest.raises(SourceError, match=r"frame \d+ could not be decoded") as err:
            for _ in src:
                pass
        k = int(str(err.value).split("frame ")[1].split()[0])
        assert 0 < k < N
        with pytest.raises(SourceError, match=f"frame {N - 1} could not be read: frame {k} "
                                              "could not be decoded"):
            src[N - 1]


def test_unreadable_video_is_refused(tmp_path):
    junk = tmp_path / "junk.avi"
    junk.write_bytes(b"this is not a video" * 10)
    with pytest.raises(SourceError, match="cannot be opened as a video"):
        open_source(junk)
    empty = tmp_path / "empty.mp4"
    empty.write_bytes(b"")
    with pytest.raises(SourceError):
        open_source(empty)


class _InexactSeekVideo(VideoSource):
    """A container whose seeking lands one frame late (as some codecs' seeking does)."""

    def _read_seek(self, k):
        return super()._read_seek(min(k + 1, self._n_file - 1))


def test_inexact_seeking_falls_back_to_sequential_reading(tmp_path):
    truth = quantise(scene(n=120), 8)
    path = write_video(tmp_path / "v.avi", truth, "FFV1")
    with _InexactSeekVideo(path, fps=FPS) as src:
        for k in (100, 60, 110, 3, 90):
            np.testing.assert_array_equal(src[k], truth[k])
        assert src._seek_exact is False
        assert any("not frame-exact" in n for n in src.notes)
    with VideoSource(path, fps=FPS) as src:  # a real container that seeks exactly
        for k in (100, 60, 110, 3, 90):
            np.testing.assert_array_equal(src[k], truth[k])
        assert src._seek_exact is True
    with VideoSource(path, fps=FPS, frames=(70, 120)) as src:  # iteration starting late
        np.testing.assert_array_equal(np.array(list(src)), truth[70:120])


# ---------------------------------------------------------------------------------------
# Image folders
# ---------------------------------------------------------------------------------------
def test_natural_sort():
    names = ["img10.png", "img2.png", "img1.png", "IMG3.png", "img100.png", "img20b.png",
             "img20a.png"]
    assert sorted(names, key=natural_key) == ["img1.png", "img2.png", "IMG3.png", "img10.png",
                                              "img20a.png", "img20b.png", "img100.png"]


def test_image_folder_reads_in_natural_order(tmp_path):
    truth = quantise(scene(n=12), 8)
    names = [f"frame{k}.png" for k in range(12)]  # frame10 sorts after frame9, not frame1
    folder = write_folder(tmp_path / "imgs", truth, ".png", names)
    (folder / "notes.txt").write_text("ignored")
    (folder / ".hidden.png").write_bytes(b"ignored")
    (folder / "sub").mkdir()
    with open_source(folder, fps=FPS) as src:
        assert isinstance(src, ImageFolderSource)
        assert [p.name for p in src.files] == names
        np.testing.assert_array_equal(np.array(list(src)), truth)


def test_image_folder_of_mixed_sizes_names_the_first_offender(tmp_path):
    truth = quantise(scene(n=6), 8)
    folder = write_folder(tmp_path / "imgs", truth, ".png")
    cv2.imwrite(str(folder / "img4.png"), truth[4][:, :60])
    cv2.imwrite(str(folder / "img5.png"), truth[5][:40])
    with pytest.raises(SourceError, match=r"img4\.png.*60x48.*img0\.png.*64x48"):
        open_source(folder, fps=FPS)


@pytest.mark.parametrize("ending", [".png", ".tif"])
def test_image_folder_of_mixed_depths_is_refused(tmp_path, ending):
    truth = quantise(scene(n=5), 8)
    folder = write_folder(tmp_path / "imgs", truth, ending)
    cv2.imwrite(str(folder / f"img3{ending}"), truth[3].astype(np.uint16) * 257)
    with pytest.raises(SourceError, match=f"img3\\{ending}.*uint16.*img0\\{ending}.*uint8"):
        open_source(folder, fps=FPS)


def test_image_folder_mixed_formats_checked_by_decoding(tmp_path):
    truth = quantise(scene(n=4), 8)
    folder = write_folder(tmp_path / "imgs", truth, ".jpg")
    cv2.imwrite(str(folder / "img2.jpg"), cv2.resize(truth[2], (32, 24)))
    with pytest.raises(SourceError, match=r"img2\.jpg.*32x24"):
        open_source(folder, fps=FPS)


def test_colour_16bit_image_is_converted_to_luma(tmp_path):
    rng = np.random.default_rng(5)
    bgr = rng.integers(0, 65536, size=(3, ROWS, COLS, 3)).astype(np.uint16)
    folder = write_folder(tmp_path / "imgs", bgr, ".png")
    luma = 0.114 * bgr[..., 0] + 0.587 * bgr[..., 1] + 0.299 * bgr[..., 2]
    with open_source(folder, fps=FPS) as src:
        assert src.dtype == np.uint16 and src.bit_depth == 16
        for k, f in enumerate(src):  # OpenCV's fixed-point weights: within 3e-5 of full scale
            assert np.abs(f - luma[k]).max() <= 2.0
    assert to_grey(bgr[0][:, :, :1]).shape == (ROWS, COLS)


def test_image_folder_needs_a_rate_for_times(tmp_path):
    folder = write_folder(tmp_path / "imgs", quantise(scene(n=3), 8), ".png")
    with open_source(folder) as src:
        assert src.fps is None and src.fps_container is None and src.time_source == "none"
        assert src[1].shape == (ROWS, COLS)
        with pytest.raises(SourceError, match="no frame rate"):
            src.time_s(1)


def test_image_folder_errors(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(SourceError, match="no images"):
        open_source(empty)
    bad = tmp_path / "bad"
    write_folder(bad, quantise(scene(n=3), 8), ".png")
    (bad / "img1.png").write_bytes(b"\x89PNG\r\n\x1a\n truncated")
    with pytest.raises(SourceError, match=r"img1\.png: cannot be decoded"):
        open_source(bad)


# ---------------------------------------------------------------------------------------
# The opener
# ---------------------------------------------------------------------------------------
def test_missing_path(tmp_path):
    with pytest.raises(SourceError, match="no such file or folder"):
        open_source(tmp_path / "nothing.avi")


@pytest.mark.parametrize("fps", [0, -30, float("nan"), float("inf"), "fast"])
def test_bad_fps_is_refused(tmp_path, fps):
    folder = write_folder(tmp_path / "imgs", quantise(scene(n=2), 8), ".png")
    with pytest.raises(SourceError, match="fps must be"):
        open_source(folder, fps=fps)


def test_opener_picks_the_reader(tmp_path):
    truth = quantise(scene(n=3), 8)
    kinds = {
        "video": write_video(tmp_path / "v.avi", truth, "MJPG"),
        "image folder": write_folder(tmp_path / "imgs", truth, ".png"),
        "cine": write_cine(tmp_path / "c.CINE", truth, fps=FPS),
    }
    for kind, path in kinds.items():
        with open_source(path, fps=FPS) as src:
            assert src.kind == kind
