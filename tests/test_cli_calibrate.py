"""``vidtrack calibrate`` through the real command line (a subprocess)."""

import re

import cv2
import numpy as np
import pytest

from calibration.calibration_file import load_calibration
from checkerboard_render import (
    PATTERN,
    PLANE_POSE,
    POSES,
    SIZE,
    SQUARE_M,
    TRUE_D,
    TRUE_K,
    render_board,
)
from vidtrack.scene import load_scene


@pytest.fixture(scope="module")
def board_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("board")
    for k, (r, t) in enumerate(POSES[:6]):
        cv2.imwrite(str(folder / f"view{k + 1}.png"),
                    render_board(TRUE_K, TRUE_D, r, t, SIZE, PATTERN, SQUARE_M))
    plane = tmp_path_factory.mktemp("plane") / "in_plane.png"
    cv2.imwrite(str(plane), render_board(TRUE_K, TRUE_D, *PLANE_POSE, SIZE, PATTERN, SQUARE_M))
    return folder, plane


def assert_bad_input(proc, *fragments):
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    assert "Traceback" not in proc.stderr
    for f in fragments:
        assert f in proc.stderr, proc.stderr


def test_ruler_writes_a_file_a_scene_can_name(vidtrack_cli, tmp_path):
    out = tmp_path / "run" / "calibration" / "front.toml"
    proc = vidtrack_cli("calibrate", "ruler", "--length-m", "0.5", "--from", "80,482",
                        "--to", "205,482", "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert "k = 0.004 m/px" in proc.stdout and "125 px" in proc.stdout
    scale = load_calibration(out).scale
    assert scale.m_per_px == 0.004 and scale.method == "ruler"
    (tmp_path / "run" / "scene.toml").write_text(
        'schema = 1\n[views.front]\nsource = "front.avi"\nfps = 1200\naxes = ["+x", "-y"]\n'
        'origin_px = [40.0, 330.0]\ncalibration = "calibration/front.toml"\n')
    scene = load_scene(tmp_path / "run")
    assert scene.views["front"].m_per_px == 0.004


def test_ruler_without_output_only_prints(vidtrack_cli, tmp_path):
    proc = vidtrack_cli("calibrate", "ruler", "--length-m", "1", "--from", "10,20",
                        "--to", "40,60", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert re.search(r"k = 0\.02 m/px", proc.stdout)      # 1 m over a 3-4-5 50 px
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args,fragment", [
    (["--length-m", "0", "--from", "80,482", "--to", "205,482"], "--length-m must be"),
    (["--length-m", "abc", "--from", "80,482", "--to", "205,482"], "--length-m must be a number"),
    (["--length-m", "0.5", "--from", "80", "--to", "205,482"], "--from must be two numbers"),
    (["--length-m", "0.5", "--from", "80,482", "--to", "80,482"], "spans 0 pixels"),
    (["--length-m", "0.5", "--from", "80,482"], "--to"),
    (["--length-m", "0.5", "--from", "1,2", "--to", "3,4", "-o", "x.txt"],
     "expected a .toml file name"),
])
def test_ruler_bad_input(vidtrack_cli, tmp_path, args, fragment):
    if "-o" not in args:
        args = [*args, "-o", tmp_path / "out.toml"]
    proc = vidtrack_cli("calibrate", "ruler", *args, cwd=tmp_path)
    assert_bad_input(proc, fragment)
    assert list(tmp_path.iterdir()) == []


def test_checkerboard(vidtrack_cli, tmp_path, board_folder):
    folder, plane = board_folder
    out = tmp_path / "cam.toml"
    proc = vidtrack_cli("calibrate", "checkerboard", folder, "--pattern", "9x6",
                        "--square-m", str(SQUARE_M), "--plane-image", plane, "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert "found in 6 of 6 images" in proc.stdout
    rms = float(re.search(r"reprojection error: ([0-9.]+) px RMS", proc.stdout).group(1))
    assert rms < 0.1                                            # measured 0.05
    assert len(re.findall(r"px  .*view\d\.png", proc.stdout)) == 6
    content = load_calibration(out)
    cam = content.camera
    assert cam.fx == pytest.approx(TRUE_K[0, 0], rel=3e-3)
    assert cam.fy == pytest.approx(TRUE_K[1, 1], rel=3e-3)
    assert cam.cx == pytest.approx(TRUE_K[0, 2], abs=1.5)
    assert cam.cy == pytest.approx(TRUE_K[1, 2], abs=1.5)
    assert cam.rms_px == pytest.approx(rms, abs=1e-4)
    assert content.scale.m_per_px == pytest.approx(PLANE_POSE[1][2] / TRUE_K[0, 0], rel=3e-3)
    # A scene naming it gets the camera and the plane scale.
    (tmp_path / "scene.toml").write_text(
        'schema = 1\n[views.top]\nsource = "top.avi"\nfps = 1000\naxes = ["+x", "+z"]\n'
        'origin_px = [40.0, 300.0]\ncalibration = "cam.toml"\n')
    top = load_scene(tmp_path).views["top"]
    assert top.camera == cam and top.m_per_px == content.scale.m_per_px


def test_checkerboard_image_list_and_k3(vidtrack_cli, tmp_path, board_folder):
    folder, _ = board_folder
    files = sorted(folder.glob("*.png"))[:4]
    proc = vidtrack_cli("calibrate", "checkerboard", *files, "--pattern", "9x6",
                        "--square-m", "0.025", "--fix-k3", "-o", tmp_path / "c.toml")
    assert proc.returncode == 0, proc.stderr
    cam = load_calibration(tmp_path / "c.toml").camera
    assert cam.dist_coeffs[4] == 0.0 and len(cam.images) == 4
    assert load_calibration(tmp_path / "c.toml").scale is None


def test_checkerboard_bad_input(vidtrack_cli, tmp_path, board_folder):
    folder, _ = board_folder
    blank = tmp_path / "blank"
    blank.mkdir()
    for k in range(3):
        cv2.imwrite(str(blank / f"b{k}.png"), np.full((120, 160), 128, np.uint8))
    out = tmp_path / "out.toml"
    proc = vidtrack_cli("calibrate", "checkerboard", blank, "--pattern", "9x6",
                        "--square-m", "0.025", "-o", out)
    assert_bad_input(proc, "found in 0 of 3 images")
    proc = vidtrack_cli("calibrate", "checkerboard", folder, "--pattern", "9", "--square-m",
                        "0.025", "-o", out)
    assert_bad_input(proc, "pattern must be inner corners per row x per column")
    proc = vidtrack_cli("calibrate", "checkerboard", folder, "--pattern", "9x6", "--square-m",
                        "-1", "-o", out)
    assert_bad_input(proc, "--square-m must be a finite number > 0")
    proc = vidtrack_cli("calibrate", "checkerboard", tmp_path / "nope", "--pattern", "9x6",
                        "--square-m", "0.025", "-o", out)
    assert_bad_input(proc, "no such image file")
    (tmp_path / "junk.png").write_bytes(b"nothing")
    proc = vidtrack_cli("calibrate", "checkerboard", tmp_path / "junk.png", "--pattern", "9x6",
                        "--square-m", "0.025", "-o", out)
    assert_bad_input(proc, "junk.png: not an image OpenCV can read")
    proc = vidtrack_cli("calibrate", "checkerboard", folder, "--pattern", "9x6",
                        "--square-m", "0.025", "--plane-image", blank / "b0.png", "-o", out)
    assert_bad_input(proc, "plane image is 160x120 px")
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blank", "junk.png"]


def test_help(vidtrack_cli):
    for args in (["calibrate", "--help"], ["calibrate", "ruler", "--help"],
                 ["calibrate", "checkerboard", "--help"]):
        proc = vidtrack_cli(*args)
        assert proc.returncode == 0 and "vidtrack calibrate" in proc.stdout
    assert "--length-m 0.5" in vidtrack_cli("calibrate", "ruler", "--help").stdout
