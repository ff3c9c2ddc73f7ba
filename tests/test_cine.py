"""The Phantom .cine reader on a real recording, and on every variant the writer makes."""

import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vidtrack.footage.cine import (CineSource, pack_10bit, pack_12bit, unpack_10bit, unpack_12bit,
                           write_cine)
from vidtrack.errors import SourceError
from vidtrack.footage import open_source
from vidtrack.footage.timebase import check_time_base, check_time_stamps

#: PIMS's test file, a real Phantom recording (tests/data/cine/SOURCE.md, BSD licence)
REAL = Path(__file__).resolve().parent / "data" / "cine" / "cine_legacy.cine"


@pytest.fixture(scope="module")
def real():
    with CineSource(REAL) as src:
        yield src


# ---------------------------------------------------------------------------------------
# The real file (facts from tests/data/cine/SOURCE.md and the file's own headers)
# ---------------------------------------------------------------------------------------
def test_real_file_header(real):
    assert len(real) == 97
    assert real.shape == (128, 128)
    assert real.dtype == np.uint16
    assert real.first_image_no == -7722
    np.testing.assert_array_equal(real.image_numbers, np.arange(-7722, -7722 + 97))
    assert real.fps_container == 35087
    assert real.header["compression"] == 0 and real.bitmap["compression"] == 0
    assert real.bitmap["height"] > 0  # stored bottom-up
    assert real.setup["cfa"] == 0


def test_real_file_pixels(real):
    lo, hi = 65535, 0
    for f in real:
        lo, hi = min(lo, int(f.min())), max(hi, int(f.max()))
    assert (lo, hi) == (0, 6382)
    # 6382 needs more than 12 bits: the setup's RealBPP (14) is the significant depth
    assert real.bit_depth == 14 and 4095 < hi < 2 ** 14


def test_real_file_rows_are_flipped_to_top_down(real):
    """Decode frames straight from the bytes (offset table, annotation) and flip them."""
    data = REAL.read_bytes()
    off_offsets, count = struct.unpack_from("<I", data, 32)[0], 97
    offsets = struct.unpack_from(f"<{count}q", data, off_offsets)
    for k in (0, 48, 96):
        ann = struct.unpack_from("<I", data, offsets[k])[0]
        size = struct.unpack_from("<I", data, offsets[k] + ann - 4)[0]
        assert size == 128 * 128 * 2
        raw = np.frombuffer(data, "<u2", 128 * 128, offsets[k] + ann).reshape(128, 128)
        np.testing.assert_array_equal(real[k], raw[::-1])


def test_real_file_time_stamps(real):
    assert real.time_source == "time stamps"
    steps = np.diff(real.times_s)
    # stamps are quantised to 1 us in this file: single intervals are 28 or 29 us
    assert steps.min() >= 27.9e-6 and steps.max() <= 29.1e-6
    assert np.mean(steps) == pytest.approx(1 / 35087, rel=2e-4)
    assert real.fps == pytest.approx(35087, rel=2e-4)
    check = check_time_stamps(real.trigger_times_s, nominal_fps=real.fps_container)
    assert check.decimation == 1 and check.dropped == () and check.warnings == ()
    # the stamps agree with the image numbers: image n was taken n / rate after the trigger
    np.testing.assert_allclose(real.trigger_times_s, real.image_numbers / 35087, atol=2 / 35087)
    assert real.exposures_s is not None
    assert np.all((real.exposures_s > 0) & (real.exposures_s < steps.min()))
    assert real.trigger_time.year == 2008


def test_real_file_range():
    with open_source(REAL, frames=(10, 20)) as src:
        np.testing.assert_array_equal(src.image_numbers, np.arange(-7712, -7702))
        with CineSource(REAL) as full:
            np.testing.assert_array_equal(src[0], full[10])
            assert src.time_s(0) == full.time_s(10)


def test_real_file_without_stamps_uses_the_setup_rate():
    with open_source(REAL, use_time_stamps=False) as src:
        assert src.time_source == "container" and src.fps == 35087
        assert src.time_s(10) == pytest.approx(10 / 35087)
    with open_source(REAL, fps=35000, use_time_stamps=False) as src:
        assert src.time_source == "fps" and src.time_s(10) == pytest.approx(10 / 35000)


# ---------------------------------------------------------------------------------------
# Packed pixels: bit layout (worked by hand) and round trips
# ---------------------------------------------------------------------------------------
def test_packed_bit_layout():
    # 1111111111 0000000000 0101010101 1010101010 -> FF C0 05 56 AA
    assert pack_10bit([0x3FF, 0x000, 0x155, 0x2AA]).tobytes() == bytes.fromhex("ffc00556aa")
    # 101010111100 000100100011 -> AB C1 23
    assert pack_12bit([0xABC, 0x123]).tobytes() == bytes.fromhex("abc123")
    np.testing.assert_array_equal(unpack_10bit(bytes.fromhex("ffc00556aa")),
                                  [0x3FF, 0, 0x155, 0x2AA])
    np.testing.assert_array_equal(unpack_12bit(bytes.fromhex("abc123")), [0xABC, 0x123])


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(0, 1023), min_size=4, max_size=64).filter(lambda v: len(v) % 4 == 0),
       st.lists(st.integers(0, 4095), min_size=2, max_size=64).filter(lambda v: len(v) % 2 == 0))
def test_packing_round_trips(ten, twelve):
    np.testing.assert_array_equal(unpack_10bit(pack_10bit(ten)), ten)
    np.testing.assert_array_equal(unpack_12bit(pack_12bit(twelve)), twelve)


# ---------------------------------------------------------------------------------------
# Writer round trips: every supported variant
# ---------------------------------------------------------------------------------------
VARIANTS = [
    (8, False, True), (8, False, False), (10, False, True), (12, False, True),
    (16, False, True), (16, False, False), (10, True, True), (12, True, True),
    (10, True, False), (12, True, False),
]


@pytest.mark.parametrize("bits,packed,bottom_up", VARIANTS)
def test_writer_round_trip_is_exact(tmp_path, bits, packed, bottom_up):
    rng = np.random.default_rng(bits * 10 + packed * 2 + bottom_up)
    frames = rng.integers(0, 2 ** bits, size=(7, 12, 20), dtype=np.uint32)
    frames[:, 0, :] = 2 ** bits - 1  # full-scale top row: orientation and range
    frames = frames.astype(np.uint8 if bits == 8 else np.uint16)
    stamps = -0.01 + np.cumsum(rng.uniform(0.9e-3, 1.1e-3, 7))
    path = write_cine(tmp_path / "x.cine", frames, fps=1000, bit_depth=bits, packed=packed,
                      first_image_no=-3, timestamps_s=stamps, bottom_up=bottom_up)
    with open_source(path) as src:
        assert len(src) == 7 and src.shape == (12, 20) and src.bit_depth == bits
        assert src.dtype == frames.dtype
        for k in range(7):
            np.testing.assert_array_equal(src[k], frames[k])
        np.testing.assert_array_equal(np.array(list(src)), frames)
        np.testing.assert_array_equal(src.image_numbers, np.arange(-3, 4))
        np.testing.assert_allclose(src.trigger_times_s, stamps, rtol=0, atol=2.0 ** -32)
        np.testing.assert_allclose(src.times_s, stamps - stamps[0], rtol=0, atol=2.0 ** -31)
        assert src.fps_container == 1000
        assert src.exposures_s == pytest.approx(np.full(7, 0.5e-3), abs=1e-9)
        d = src.to_dict()
        assert d["layout"] == ({10: "p10", 12: "p12"}[bits] if packed
                               else ("u8" if bits == 8 else "u16"))
        assert d["bottom_up"] == (bottom_up and not packed)


@settings(max_examples=15, deadline=None)
@given(st.integers(1, 6), st.integers(1, 9), st.integers(1, 9), st.sampled_from([8, 12, 16]),
       st.integers(-10_000, 10_000), st.integers(0, 2 ** 32 - 1))
def test_writer_round_trip_property(tmp_path_factory, n, rows, cols, bits, first, seed):
    frames = np.random.default_rng(seed).integers(0, 2 ** bits, (n, rows, cols))
    path = tmp_path_factory.mktemp("prop") / "p.cine"
    write_cine(path, frames.astype(np.uint16), fps=2500, bit_depth=bits, first_image_no=first)
    with open_source(path) as src:
        np.testing.assert_array_equal(np.array(list(src)), frames)
        np.testing.assert_array_equal(src.image_numbers, first + np.arange(n))
        np.testing.assert_allclose(src.trigger_times_s, (first + np.arange(n)) / 2500,
                                   atol=2.0 ** -32)


def test_writer_accepts_a_list_and_a_generator(tmp_path):
    frames = [np.full((4, 4), k, dtype=np.uint8) for k in range(5)]
    write_cine(tmp_path / "a.cine", frames, fps=100)
    write_cine(tmp_path / "b.cine", (f for f in frames), fps=100)
    assert (tmp_path / "a.cine").read_bytes() == (tmp_path / "b.cine").read_bytes()


def test_interpolated_colour_is_converted_to_luma(tmp_path):
    rng = np.random.default_rng(9)
    for bits in (8, 12):
        bgr = rng.integers(0, 2 ** bits, size=(3, 10, 14, 3)).astype(
            np.uint8 if bits == 8 else np.uint16)
        path = write_cine(tmp_path / f"c{bits}.cine", bgr, fps=500, bit_depth=bits)
        luma = 0.114 * bgr[..., 0] + 0.587 * bgr[..., 1] + 0.299 * bgr[..., 2]  # BT.601
        with open_source(path) as src:
            layout = "bgr8" if bits == 8 else "bgr16"
            assert src.shape == (10, 14) and src.to_dict()["layout"] == layout
            for k, f in enumerate(src):
                assert np.abs(f - luma[k]).max() <= 1.0


@pytest.mark.parametrize("bits", [10, 12])
@pytest.mark.parametrize("declared", ["16", "own"])
def test_packed_pixels_without_a_packed_compression_code(tmp_path, bits, declared):
    """Packed pixels whose bitmap header says biCompression 0 with 16 (or 10/12) bits."""
    frames = np.random.default_rng(2).integers(0, 2 ** bits, (4, 8, 10)).astype(np.uint16)
    path = write_cine(tmp_path / "p.cine", frames, fps=1000, bit_depth=bits, packed=True)
    data = bytearray(path.read_bytes())
    count = 16 if declared == "16" else bits
    struct.pack_into("<HI", data, 44 + 14, count, 0)  # biBitCount, biCompression = 0
    path.write_bytes(bytes(data))
    with open_source(path) as src:
        assert src.to_dict()["layout"] == f"p{bits}" and src.bit_depth == bits
        np.testing.assert_array_equal(np.array(list(src)), frames)


# ---------------------------------------------------------------------------------------
# Time stamps: decimation, missing or broken stamps
# ---------------------------------------------------------------------------------------
def test_decimated_recording_is_timed_by_its_stamps(tmp_path):
    """Setup FrameRate 90000, every 10th image saved (as PIMS's cine_781 sample)."""
    frames = np.zeros((12, 4, 4), dtype=np.uint8)
    stamps = np.arange(12) * 10 / 90000
    path = write_cine(tmp_path / "d.cine", frames, fps=90000, timestamps_s=stamps)
    with open_source(path) as src:
        assert src.fps_container == 90000
        assert src.fps == pytest.approx(9000, rel=1e-6)
        np.testing.assert_allclose(src.times_s, np.arange(12) / 9000, atol=1e-9)
        report = check_time_base(src, duplicates=False)
    assert report.decimation == 10
    assert any("decimated by 10" in w for w in report.warnings)


def test_stamps_with_a_gap_report_dropped_frames(tmp_path):
    kept = np.delete(np.arange(30), [12, 13, 20])
    path = write_cine(tmp_path / "g.cine", np.zeros((27, 4, 4), np.uint8), fps=2000,
                      timestamps_s=kept / 2000)
    with open_source(path) as src:
        np.testing.assert_allclose(src.times_s, kept / 2000, atol=1e-9)
        report = check_time_base(src, duplicates=False)
    assert report.dropped == ((12, 2), (18, 1))
    assert report.decimation == 1


def test_missing_stamps_time_by_the_setup_rate_or_the_given_fps(tmp_path):
    path = write_cine(tmp_path / "n.cine", np.zeros((5, 4, 4), np.uint8), fps=3000,
                      write_time_stamps=False)
    with open_source(path) as src:
        assert src.trigger_times_s is None and src.exposures_s is None
        assert src.time_source == "container" and src.time_s(3) == pytest.approx(1e-3)
    with open_source(path, fps=6000) as src:
        assert src.time_source == "fps" and src.time_s(3) == pytest.approx(0.5e-3)


def test_stamps_that_do_not_increase_are_not_used(tmp_path):
    stamps = np.array([0.0, 1e-3, 1e-3, 3e-3])
    path = write_cine(tmp_path / "s.cine", np.zeros((4, 4, 4), np.uint8), fps=1000,
                      timestamps_s=stamps)
    with open_source(path) as src:
        assert src.time_source == "container"
        assert any("do not increase at frame 2" in n for n in src.notes)
        np.testing.assert_allclose(src.times_s, np.arange(4) / 1000)


# ---------------------------------------------------------------------------------------
# Bad files: one clear message naming what and where
# ---------------------------------------------------------------------------------------
def _written(tmp_path, n=10, bits=16):
    frames = np.random.default_rng(0).integers(0, 2 ** bits, (n, 8, 12)).astype(np.uint16)
    return write_cine(tmp_path / "x.cine", frames, fps=1000, bit_depth=bits,
                      first_image_no=-4), frames


def test_truncated_file_names_the_frame(tmp_path):
    path, frames = _written(tmp_path)
    data = path.read_bytes()
    image = 8 + 8 * 12 * 2
    cut = tmp_path / "cut.cine"
    cut.write_bytes(data[: len(data) - 3 * image - image // 2])  # frame 6 is cut in half
    with pytest.raises(SourceError, match=r"truncated: frame 6 \(image number 2\)"):
        open_source(cut)
    with open_source(cut, frames=(0, 6)) as src:  # the frames before the cut are readable
        np.testing.assert_array_equal(np.array(list(src)), frames[:6])


def test_damaged_annotation_names_the_frame(tmp_path):
    path, _ = _written(tmp_path)
    data = bytearray(path.read_bytes())
    off = struct.unpack_from("<I", data, 32)[0]
    frame3 = struct.unpack_from("<q", data, off + 3 * 8)[0]
    struct.pack_into("<I", data, frame3, 3)
    path.write_bytes(bytes(data))
    with open_source(path) as src:
        src[2]
        with pytest.raises(SourceError, match=r"frame 3 \(image number -1\): damaged annotation"):
            src[3]


def test_not_a_cine_file(tmp_path):
    bad = tmp_path / "bad.cine"
    bad.write_bytes(b"RIFF" + bytes(100))
    with pytest.raises(SourceError, match="not a Phantom .cine file"):
        open_source(bad)
    short = tmp_path / "short.cine"
    short.write_bytes(b"CI")
    with pytest.raises(SourceError, match="not a Phantom .cine file"):
        open_source(short)
    with pytest.raises(SourceError, match="no such file"):
        CineSource(tmp_path / "none.cine")


def _patched(path, fmt, offset, *values):
    data = bytearray(path.read_bytes())
    struct.pack_into(fmt, data, offset, *values)
    path.write_bytes(bytes(data))
    return path


def test_unsupported_variants_are_refused(tmp_path):
    path, _ = _written(tmp_path)
    setup = 84
    raw = _patched(tmp_path / "x.cine", "<H", 4, 2)  # Compression = 2 (uninterpolated) ...
    _patched(raw, "<I", setup + 808, 3)              # ... of a Bayer colour sensor
    with pytest.raises(SourceError, match="colour raw"):
        open_source(raw)
    path, _ = _written(tmp_path)
    with pytest.raises(SourceError, match="JPEG-compressed"):
        open_source(_patched(path, "<H", 4, 1))
    path, _ = _written(tmp_path)
    with pytest.raises(SourceError, match="image compression 7 is not supported"):
        open_source(_patched(path, "<I", 44 + 16, 7))
    path, _ = _written(tmp_path)
    with pytest.raises(SourceError, match="32-bit images are not supported"):
        open_source(_patched(path, "<H", 44 + 14, 32))
    path, _ = _written(tmp_path)
    with pytest.raises(SourceError, match="points past the end"):
        open_source(_patched(path, "<I", 32, 10 ** 9))


def test_grey_raw_from_a_grey_sensor_is_read(tmp_path):
    path, frames = _written(tmp_path)
    with open_source(_patched(path, "<H", 4, 2)) as src:  # uninterpolated, CFA none
        np.testing.assert_array_equal(src[5], frames[5])


@pytest.mark.parametrize("kwargs,match", [
    ({"bit_depth": 9}, "bit_depth"),
    ({"bit_depth": 8, "packed": True}, "packed"),
    ({"bit_depth": 16, "packed": True}, "packed"),
    ({"fps": 0}, "fps"),
    ({"fps": float("nan")}, "fps"),
    ({"timestamps_s": [0.0, 1.0]}, "timestamps_s"),
])
def test_writer_refuses_bad_arguments(tmp_path, kwargs, match):
    args = {"fps": 100, **kwargs}
    with pytest.raises(ValueError, match=match):
        write_cine(tmp_path / "x.cine", np.zeros((3, 4, 4), np.uint8), **args)
    assert not (tmp_path / "x.cine").exists()


def test_writer_refuses_bad_frames_and_leaves_nothing(tmp_path):
    good = np.zeros((4, 4), np.uint16)
    cases = [
        ([good, good, np.full((4, 4), 4096, np.uint16)], {"bit_depth": 12}, "do not fit 12 bits"),
        ([good, np.zeros((4, 5), np.uint16)], {"bit_depth": 16}, "shape"),
        ([good.astype(float)], {"bit_depth": 16}, "integer"),
        ([np.zeros((3, 3), np.uint16)], {"bit_depth": 10, "packed": True}, "divisible by 4"),
        ([], {}, "no frames"),
    ]
    for frames, kw, match in cases:
        with pytest.raises(ValueError, match=match):
            write_cine(tmp_path / "x.cine", frames, fps=100, **kw)
        assert list(tmp_path.iterdir()) == []
