"""``vidtrack frames`` through the real command line."""

import csv

import cv2
import numpy as np
import pytest

from vidtrack.footage.cine import write_cine


def read_csv(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def only_one_line(stderr):
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1, stderr
    assert "Traceback" not in stderr
    return lines[0]


def nothing_written(parent, out):
    assert not out.exists()
    assert [p.name for p in parent.iterdir() if p.name.startswith(".")] == []


@pytest.fixture
def cine12(tmp_path):
    rng = np.random.default_rng(12)
    frames = rng.integers(0, 4096, size=(9, 24, 32)).astype(np.uint16)
    stamps = (-4 + np.arange(9)) / 5000 + rng.uniform(-1e-6, 1e-6, 9)
    path = write_cine(tmp_path / "shot.cine", frames, fps=5000, bit_depth=12,
                      first_image_no=-4, timestamps_s=stamps)
    return path, frames, stamps


@pytest.mark.parametrize("fmt,ending", [("png", ".png"), ("tiff", ".tiff")])
def test_cine_to_16_bit_images_with_times(vidtrack_cli, tmp_path, cine12, fmt, ending):
    path, frames, stamps = cine12
    out = tmp_path / "out"
    res = vidtrack_cli("frames", path, out, "--format", fmt)
    assert res.returncode == 0, res.stderr
    assert "wrote 9 frames" in res.stdout and "12 significant bits" in res.stdout
    rows = read_csv(out / "frames.csv")
    assert list(rows[0]) == ["frame", "t_s", "file"]
    assert [int(r["frame"]) for r in rows] == list(range(9))
    np.testing.assert_allclose([float(r["t_s"]) for r in rows], stamps - stamps[0], atol=1e-9)
    for r in rows:
        assert r["file"] == f"frame_{int(r['frame']):06d}{ending}"
        image = cv2.imread(str(out / r["file"]), cv2.IMREAD_UNCHANGED)
        assert image.dtype == np.uint16  # bit depth kept, values as stored
        np.testing.assert_array_equal(image, frames[int(r["frame"])])
    assert sorted(p.name for p in out.iterdir()) == sorted([r["file"] for r in rows]
                                                            + ["frames.csv"])


def test_video_range_every_and_capture_rate(vidtrack_cli, tmp_path):
    frames = np.random.default_rng(1).integers(0, 256, (30, 24, 32)).astype(np.uint8)
    video = tmp_path / "front.avi"
    w = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"FFV1"), 30.0, (32, 24), False)
    for f in frames:
        w.write(f)
    w.release()
    out = tmp_path / "o"
    res = vidtrack_cli("frames", video, out, "--range", "5:20", "--every", "4", "--fps", "1200",
                       "--format", "jpg")
    assert res.returncode == 0, res.stderr
    assert "container claims 30 fps" in res.stderr  # a note, not an error
    rows = read_csv(out / "frames.csv")
    assert [int(r["frame"]) for r in rows] == [5, 9, 13, 17]
    np.testing.assert_allclose([float(r["t_s"]) for r in rows], np.array([5, 9, 13, 17]) / 1200)
    for r in rows:
        image = cv2.imread(str(out / r["file"]), cv2.IMREAD_UNCHANGED)
        assert image.dtype == np.uint8 and image.shape == (24, 32)
    quiet = vidtrack_cli("frames", video, tmp_path / "q", "--range", "25:", "--quiet")
    assert quiet.returncode == 0 and quiet.stderr == ""
    assert [int(r["frame"]) for r in read_csv(tmp_path / "q" / "frames.csv")] == [25, 26, 27,
                                                                                 28, 29]


def test_image_folder_needs_fps_and_output_outside_it(vidtrack_cli, tmp_path):
    folder = tmp_path / "imgs"
    folder.mkdir()
    for k in range(12):
        cv2.imwrite(str(folder / f"img{k}.tif"), np.full((8, 8), 1000 * k, np.uint16))
    out = tmp_path / "o"
    res = vidtrack_cli("frames", folder, out)
    assert res.returncode == 2
    assert "no frame rate" in only_one_line(res.stderr)
    nothing_written(tmp_path, out)
    res = vidtrack_cli("frames", folder, folder / "out", "--fps", "500")
    assert res.returncode == 2 and "inside the input image folder" in only_one_line(res.stderr)
    assert sorted(p.name for p in folder.iterdir()) == sorted(f"img{k}.tif" for k in range(12))
    res = vidtrack_cli("frames", folder, out, "--fps", "500")
    assert res.returncode == 0, res.stderr
    rows = read_csv(out / "frames.csv")
    assert [r["file"] for r in rows][:3] == ["frame_000000.png", "frame_000001.png",
                                             "frame_000002.png"]
    last = cv2.imread(str(out / rows[11]["file"]), cv2.IMREAD_UNCHANGED)  # img11, not img2
    assert last.dtype == np.uint16 and int(last[0, 0]) == 11000


def test_existing_output_folder_keeps_other_files(vidtrack_cli, tmp_path, cine12):
    path, _, _ = cine12
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    res = vidtrack_cli("frames", path, out, "--range", "0:2")
    assert res.returncode == 0, res.stderr
    assert (out / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in out.iterdir()) == ["frame_000000.png", "frame_000001.png",
                                                    "frames.csv", "notes.txt"]


def test_jpg_of_a_16_bit_source_is_refused(vidtrack_cli, tmp_path, cine12):
    path, _, _ = cine12
    out = tmp_path / "out"
    res = vidtrack_cli("frames", path, out, "--format", "jpg")
    assert res.returncode == 2
    line = only_one_line(res.stderr)
    assert line.startswith("vidtrack frames: error:") and "jpg holds 8-bit" in line
    nothing_written(tmp_path, out)


def test_truncated_video_writes_nothing(vidtrack_cli, tmp_path):
    frames = np.random.default_rng(2).integers(0, 256, (20, 24, 32)).astype(np.uint8)
    video = tmp_path / "v.avi"
    w = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (32, 24), False)
    for f in frames:
        w.write(f)
    w.release()
    data = video.read_bytes()
    video.write_bytes(data[: len(data) * 2 // 3])
    out = tmp_path / "out"
    res = vidtrack_cli("frames", video, out, "--fps", "1200")
    assert res.returncode == 2
    assert "could not be decoded" in only_one_line(res.stderr)
    nothing_written(tmp_path, out)


def test_truncated_cine_names_the_frame(vidtrack_cli, tmp_path, cine12):
    path, _, _ = cine12
    data = path.read_bytes()
    path.write_bytes(data[:-3 * (8 + 24 * 32 * 2)])
    out = tmp_path / "out"
    res = vidtrack_cli("frames", path, out)
    assert res.returncode == 2
    assert "truncated: frame 6 (image number 2)" in only_one_line(res.stderr)
    nothing_written(tmp_path, out)


@pytest.mark.parametrize("args,match", [
    (["missing.avi"], "no such file or folder"),
    (["shot.cine", "--range", "5"], "--range must be A:B"),
    (["shot.cine", "--range", "7:3"], "--range must be A:B with 0 <= A < B"),
    (["shot.cine", "--range", "50:60"], "selects nothing"),
    (["shot.cine", "--every", "0"], "--every must be >= 1"),
    (["shot.cine", "--fps", "0"], "fps must be"),
])
def test_bad_input_exits_2_with_one_line(vidtrack_cli, tmp_path, cine12, args, match):
    out = tmp_path / "out"
    res = vidtrack_cli("frames", tmp_path / args[0], out, *args[1:])
    assert res.returncode == 2
    assert match in only_one_line(res.stderr)
    nothing_written(tmp_path, out)


def test_listed_in_help(vidtrack_cli):
    res = vidtrack_cli("--help")
    assert res.returncode == 0 and "frames" in res.stdout
    res = vidtrack_cli("frames", "--help")
    assert res.returncode == 0 and "--range" in res.stdout and "example" in res.stdout
