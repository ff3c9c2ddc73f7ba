"""``vidtrack view``: the page's routes through Flask's test client, and the real command.

Truth the code did not produce: the pixels the test clicks (typed here), scene.toml and
the manual points CSV read back by the scene loader and by ``csv``, the footage's size read
by OpenCV, tracks.csv written by ``vidtrack fit`` (run as the page runs it), and the
axes worked out by hand for each click layout.
"""

import csv
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import urllib.request
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("flask", reason="vidtrack view needs Flask (pip install 'vidtrack[view]')")
cv2 = pytest.importorskip("cv2")

REPO = Path(__file__).resolve().parents[1]
RUN42 = REPO / "datasets" / "run42"


def copy_run(dst, *, views=("front.avi", "top.avi"), scene=True):
    dst.mkdir(parents=True)
    for name in views:
        shutil.copy2(RUN42 / name, dst / name)
    if scene:
        shutil.copy2(RUN42 / "scene.toml", dst / "scene.toml")
    return dst


def digests(folder):
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(Path(folder).rglob("*")) if p.is_file()}


def client(run):
    from vidtrack.view import create_app

    return create_app(run).test_client()


def edit(c, **body):
    body.setdefault("view", "front")
    return c.post("/api/edit", json=body)


def test_origin_ruler_axes_written_as_clicked_comments_kept(tmp_path):
    from vidtrack.scene import load_scene

    run = copy_run(tmp_path / "run")
    c = client(run)
    assert edit(c, set="origin", at_px=[120.25, 75.5]).status_code == 200
    assert edit(c, set="ruler", from_px=[10.0, 170.0], to_px=[110.0, 170.0],
                length_m=0.25).status_code == 200
    # +X clicked left of O, +Y below it: X grows leftwards, Y downwards
    r = edit(c, set="axes", first_px=[60.0, 80.0], second_px=[118.0, 150.0])
    assert r.status_code == 200 and r.json["scene_error"] is None
    view = load_scene(run).views["front"]
    assert view.origin_px == pytest.approx((120.25, 75.5))
    assert view.ruler.length_m == 0.25
    assert view.m_per_px == pytest.approx(0.25 / 100.0)
    assert tuple(view.axes) == ("-x", "+y")
    text = (run / "scene.toml").read_text()
    assert text.startswith("# vidtrack scene, schema 1")     # the file's comment stays
    assert "[views.top.ruler]" in text                        # the other view untouched
    assert load_scene(run).views["top"].origin_px == pytest.approx((87.82, 67.77))


@pytest.mark.parametrize("first, second, view, expected", [
    ((200, 70), (81, 10), "front", ["+x", "-y"]),
    ((81, 150), (10, 70), "front", ["-y", "+x"]),
    ((200, 70), (81, 120), "top", ["+x", "+z"]),
    ((10, 72), (81, 5), "top", ["-x", "-z"]),
])
def test_axes_from_clicks(first, second, view, expected):
    from vidtrack.view.edits import ORTHOGONAL_VIEWS, axes_from_clicks

    assert axes_from_clicks((81, 70), first, second, ORTHOGONAL_VIEWS[view]) == expected


def test_init_template_set_up_by_clicks(tmp_path, vidtrack_cli):
    """A scene.toml that vidtrack init wrote (values marked TODO(user)) filled in from
    the page: each edit written while the file does not load yet, the loader's message
    for what is still missing returned, the template's comments kept."""
    from vidtrack.scene import load_scene

    run = copy_run(tmp_path / "run", views=("front.avi",), scene=False)
    assert vidtrack_cli("init", run).returncode == 0
    c = client(run)
    assert "views.front.fps must be > 0" in c.get("/api/state").json["scene_error"]
    steps = [dict(set="origin", at_px=[80.5, 69.75]),
             dict(set="axes", first_px=[150.0, 70.0], second_px=[80.0, 10.0]),
             dict(set="ruler", from_px=[200.8, 170.2], to_px=[286.7, 170.2], length_m=0.5)]
    scale = c.get("/api/state").json["views"]["front"]["scale"]
    u, v = ((np.array([80.5, 69.75]) + 0.5) * scale - 0.5).round().astype(int)
    assert not bluish(frame_image(c, 5)).any()       # nothing of the scene given yet
    for body in steps:
        r = edit(c, **body)
        assert r.status_code == 200, r.json
        assert "views.front.fps must be > 0, got 0" in r.json["scene_error"]
        # the origin is drawn as soon as it is given, though the file does not load yet
        assert bluish(frame_image(c, 5)[v - 2:v + 3, u - 2:u + 3]).any()
    r = edit(c, set="fps", fps=1200)
    assert r.status_code == 200 and r.json["scene_error"] is None
    view = load_scene(run).views["front"]
    assert (view.fps, tuple(view.axes)) == (1200, ("+x", "-y"))
    assert view.origin_px == pytest.approx((80.5, 69.75))
    text = (run / "scene.toml").read_text()
    assert "the CAPTURE rate" in text and "the centre of the blade shaft" in text
    for line in text.splitlines():   # the lines given now lose their TODO(user) mark
        if re.match(r"(fps|axes|origin_px) =", line):
            assert "TODO(user)" not in line, line


def test_points_by_hand_and_excluded_frames(tmp_path):
    from vidtrack.scene import load_scene
    from vidtrack.scene.corrections import read_manual_points

    run = copy_run(tmp_path / "run")
    c = client(run)
    assert edit(c, set="point", frame=12, at_px=[150.5, 60.25]).status_code == 200
    assert edit(c, set="point", frame=3, at_px=[101.0, 80.0]).status_code == 200
    with open(run / "front_manual.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [(int(r["frame"]), float(r["u_px"]), float(r["v_px"])) for r in rows] == [
        (3, 101.0, 80.0), (12, 150.5, 60.25)]
    view = load_scene(run).views["front"]
    assert view.manual_points_text == "front_manual.csv"
    assert read_manual_points(view.manual_points, label="t", key="k").frames == (3, 12)
    for f in (20, 21, 40):
        assert edit(c, set="exclude", frame=f, excluded=True).status_code == 200
    assert load_scene(run).views["front"].exclude_frames == ((20, 22), (40, 41))
    assert edit(c, set="exclude", frame=20, excluded=False).status_code == 200
    assert load_scene(run).views["front"].exclude_frames == ((21, 22), (40, 41))
    info = c.get("/api/frame/front/21").json
    assert info["excluded"] is True and info["manual_px"] is None
    assert c.get("/api/frame/front/12").json["manual_px"] == [150.5, 60.25]
    for f in (3, 12):
        assert edit(c, set="point", frame=f, at_px=None).status_code == 200
    assert load_scene(run).views["front"].manual_points_text is None
    r = edit(c, set="target", frame=30, at_px=[150.0, 60.0])
    assert r.status_code == 200
    assert load_scene(run).views["front"].target == (30, (150.0, 60.0))


def test_frames_drawn_from_the_run_as_last_read(tmp_path):
    """The corrections are read once per change: a frame asked for shows the run as the
    page last read it (after an edit, a fit, or the state asked for), and the manual
    points file changed behind the page shows once the state is asked for again."""
    run = copy_run(tmp_path / "run")
    c = client(run)
    assert edit(c, set="point", frame=12, at_px=[150.5, 60.25]).status_code == 200
    assert edit(c, set="exclude", frame=13, excluded=True).status_code == 200
    (run / "front_manual.csv").write_text("frame,u_px,v_px\n12,99.5,40.0\n14,1.0,2.0\n")
    assert c.get("/api/frame/front/12").json["manual_px"] == [150.5, 60.25]
    assert c.get("/api/frame/front/14").json["manual_px"] is None
    assert c.get("/api/state").status_code == 200
    assert c.get("/api/frame/front/12").json["manual_px"] == [99.5, 40.0]
    assert c.get("/api/frame/front/14").json["manual_px"] == [1.0, 2.0]
    assert c.get("/api/frame/front/13").json["excluded"] is True


def test_target_removed_rest_of_the_file_byte_for_byte(tmp_path):
    """A target written by hand (with its comment) removed from the page: scene.toml is
    the file it was without that line, and the loader finds no target."""
    from vidtrack.scene import load_scene

    run = copy_run(tmp_path / "run")
    original = (RUN42 / "scene.toml").read_text()
    line = "target = { frame = 30, at_px = [150.0, 60.0] }   # the straw, not the chaff\n"
    anchor = "origin_px = [80.49, 69.76]\n"
    (run / "scene.toml").write_text(original.replace(anchor, anchor + line))
    c = client(run)
    assert c.get("/api/state").json["views"]["front"]["target"] == {
        "frame": 30, "at_px": [150.0, 60.0]}
    assert c.get("/api/frame/front/30").json["target_px"] == [150.0, 60.0]
    r = edit(c, set="target", at_px=None)
    assert r.status_code == 200 and r.json["written"] == ["scene.toml"]
    assert (run / "scene.toml").read_text() == original
    assert load_scene(run).views["front"].target is None
    assert c.get("/api/state").json["views"]["front"]["target"] is None
    assert c.get("/api/frame/front/30").json["target_px"] is None
    before = digests(run)
    r = edit(c, set="target", at_px=None)
    assert r.status_code == 400
    assert r.json["error"].endswith("views.front.target is not set; expected a target to "
                                    "remove")
    assert digests(run) == before


def _bad_cases():
    return [
        (dict(set="origin", at_px=[81, "x"]), "views.front.origin_px must be a pixel"),
        (dict(set="origin", at_px=[1e9, 0]), "views.front.origin_px must be within"),
        (dict(set="ruler", from_px=[10, 10], to_px=[10.5, 10], length_m=0.5),
         "views.front.ruler ends"),
        (dict(set="ruler", from_px=[10, 10], to_px=[100, 10], length_m=-1),
         "views.front.ruler.length_m must be > 0, got -1"),
        (dict(set="fps", fps=0), "views.front.fps must be > 0, got 0"),
        (dict(set="axes", first_px=[200, 70], second_px=[10, 71]),
         "were both clicked along the image columns"),
        (dict(set="target", frame=372, at_px=[1, 1]), "frame must be a frame of the footage"),
        (dict(set="point", frame=-1, at_px=[1, 1]), "frame must be a frame of the footage"),
        (dict(set="exclude", frame=5, excluded="yes"), "needs excluded true or false"),
        (dict(set="zoom"), "edit 'zoom' is not one the page makes"),
        (dict(set="origin", view="side", at_px=[1, 1]), "views.side is not in the file"),
    ]


@pytest.mark.parametrize("body, message", _bad_cases())
def test_bad_input_400_one_line_nothing_written(tmp_path, body, message):
    run = copy_run(tmp_path / "run")
    before = digests(run)
    r = edit(client(run), **body)
    assert r.status_code == 400
    error = r.json["error"]
    assert message in error and "\n" not in error
    assert error.startswith(str((run / "scene.toml").resolve()))
    assert digests(run) == before


def test_point_in_an_excluded_frame_refused(tmp_path):
    run = copy_run(tmp_path / "run")
    c = client(run)
    assert edit(c, set="exclude", frame=12, excluded=True).status_code == 200
    before = digests(run)
    r = edit(c, set="point", frame=12, at_px=[150.5, 60.25])
    assert r.status_code == 400
    assert "has frame 12, which exclude_frames [12, 13) takes out" in r.json["error"]
    assert "front_manual.csv" in r.json["error"]
    assert digests(run) == before


def bluish(img):
    """Pixels in the scene's pale blue (the footage is grey: B = G = R)."""
    b, g, r = (img[..., k].astype(int) for k in range(3))
    return (b - r > 60) & (b > 180)


def frame_image(c, index, view="front"):
    r = c.get(f"/frame/{view}/{index}.png")
    assert r.status_code == 200 and r.mimetype == "image/png"
    return cv2.imdecode(np.frombuffer(r.data, np.uint8), cv2.IMREAD_COLOR)


def test_frame_drawn_with_the_origin_where_it_was_clicked(tmp_path):
    run = copy_run(tmp_path / "run")
    c = client(run)
    cap = cv2.VideoCapture(str(run / "front.avi"))
    w, h = cap.get(cv2.CAP_PROP_FRAME_WIDTH), cap.get(cv2.CAP_PROP_FRAME_HEIGHT)
    cap.release()
    state = c.get("/api/state").json["views"]["front"]
    assert (state["width_px"], state["height_px"]) == (w, h)
    scale = state["scale"]
    for origin in ([120.0, 60.0], [300.0, 120.0]):
        assert edit(c, set="origin", at_px=origin).status_code == 200
        img = frame_image(c, 5)
        assert img.shape[:2] == (round(h * scale), round(w * scale))
        u, v = ((np.asarray(origin) + 0.5) * scale - 0.5).round().astype(int)
        assert bluish(img[v - 2:v + 3, u - 2:u + 3]).any()      # the circled cross at O
    old_u, old_v = ((np.array([120.0, 60.0]) + 0.5) * scale - 0.5).round().astype(int)
    assert not bluish(img[old_v - 2:old_v + 3, old_u - 2:old_u + 3]).any()
    assert c.get("/frame/front/372.png").status_code == 404
    assert "not a view" in c.get("/frame/side/0.png").json["error"]


def decoded_frame(path, index):
    """Frame ``index`` of the video as OpenCV decodes it, grey (the footage is grey)."""
    cap = cv2.VideoCapture(str(path))
    for _ in range(index + 1):
        ok, img = cap.read()
        assert ok
    cap.release()
    return img[..., 1].astype(int)


@pytest.mark.parametrize("at, centre", [((150.4, 60.6), (150, 61)), ((1.0, 2.49), (1, 2))])
def test_zoom_is_the_footage_pixels_magnified(tmp_path, at, centre):
    """Each frame pixel around the one asked for is a block of the zoom, its value as
    OpenCV decodes the frame; the centre pixel is outlined, outside the frame is black."""
    from vidtrack.view.zoom import ZOOM_FACTOR, ZOOM_HALF_PX

    run = copy_run(tmp_path / "run")
    c = client(run)
    r = c.get(f"/zoom/front/7.png?u={at[0]}&v={at[1]}")
    assert r.status_code == 200 and r.mimetype == "image/png"
    img = cv2.imdecode(np.frombuffer(r.data, np.uint8), cv2.IMREAD_COLOR).astype(int)
    side = 2 * ZOOM_HALF_PX + 1
    assert img.shape == (side * ZOOM_FACTOR, side * ZOOM_FACTOR, 3)
    truth = decoded_frame(run / "front.avi", 7)
    mid = ZOOM_FACTOR // 2
    for i in range(side):
        for j in range(side):
            v, u = centre[1] + i - ZOOM_HALF_PX, centre[0] + j - ZOOM_HALF_PX
            cell = img[i * ZOOM_FACTOR + mid, j * ZOOM_FACTOR + mid]
            inside = 0 <= v < truth.shape[0] and 0 <= u < truth.shape[1]
            expected = truth[v, u] if inside else 0
            assert np.abs(cell - expected).max() <= 1, (u, v)
    edge = img[ZOOM_HALF_PX * ZOOM_FACTOR, ZOOM_HALF_PX * ZOOM_FACTOR]
    assert edge[0] < 60 < min(edge[1], edge[2])     # the outline: yellow (B, G, R) on grey


@pytest.mark.parametrize("query, status, message", [
    ("u=5&v=x", 400, "zoom: u and v must be the frame pixel to magnify"),
    ("v=5", 400, "zoom: u and v must be the frame pixel to magnify"),
    ("u=nan&v=5", 400, "zoom: u and v must be the frame pixel to magnify"),
    ("u=5000&v=5", 400, "is outside the frame; expected u in 0.."),
    ("u=5&v=-3", 400, "is outside the frame"),
])
def test_zoom_bad_pixel_one_line(tmp_path, query, status, message):
    c = client(copy_run(tmp_path / "run"))
    r = c.get(f"/zoom/front/7.png?{query}")
    assert r.status_code == status and message in r.json["error"]
    assert "\n" not in r.json["error"]
    assert c.get("/zoom/front/372.png?u=5&v=5").status_code == 404
    assert c.get("/zoom/side/0.png?u=5&v=5").status_code == 404


def test_fit_from_the_page_uses_the_point_placed_by_hand(tmp_path):
    run = copy_run(tmp_path / "run")
    c = client(run)
    assert c.get("/api/frame/front/100").json["tracked"] is False
    assert edit(c, set="point", frame=100, at_px=[205.5, 50.25]).status_code == 200
    r = c.post("/api/fit")
    assert r.status_code == 202
    c.application.config["FIT_JOB"].wait()
    status = c.get("/api/fit").json
    assert status["state"] == "done", status
    table = pd.read_csv(run / "vidtrack" / "tracks.csv")
    row = table[(table["view"] == "front") & (table["frame"] == 100)].iloc[0]
    assert (row["u_px"], row["v_px"]) == pytest.approx((205.5, 50.25))
    info = c.get("/api/frame/front/100").json
    assert info["tracked"] is True
    assert (info["u_px"], info["v_px"]) == pytest.approx((205.5, 50.25))
    other = table[(table["view"] == "top") & (table["frame"] == 150)].iloc[0]
    top = c.get("/api/frame/top/150").json
    assert top["flags"] == other["flags"]
    assert top["flag_text"] == ("ok" if other["flags"] == 0 else other["flag_names"])


def test_fit_from_the_page_says_why_it_fails(tmp_path, vidtrack_cli):
    run = copy_run(tmp_path / "run", views=("front.avi",), scene=False)
    assert vidtrack_cli("init", run).returncode == 0
    c = client(run)
    assert c.post("/api/fit").status_code == 202
    c.application.config["FIT_JOB"].wait()
    status = c.get("/api/fit").json
    assert status["state"] == "failed"
    assert status["message"].startswith("vidtrack fit: error: ")
    assert "views.front.fps must be > 0, got 0" in status["message"]
    assert not (run / "vidtrack").exists()


#: The flag of an excluded frame (docs/scene.md, "Correcting the tracker").
EXCLUDED = 256


def copy_throws_run(dst):
    """run42's scene with its front view alone, and two throws of the same front footage
    (so what differs between their tracks is what the test corrected)."""
    dst.mkdir(parents=True)
    text = (RUN42 / "scene.toml").read_text()
    (dst / "scene.toml").write_text(text[:text.index("[views.top]")])
    for throw in ("01", "02"):
        (dst / "throws" / throw).mkdir(parents=True)
        shutil.copy2(RUN42 / "front.avi", dst / "throws" / throw / "front.avi")
    return dst


def test_a_run_of_throws_corrections_go_to_the_throw_shown(tmp_path):
    """A run with throws/: the page shows one throw at a time; a target, a point and an
    exclusion go to that throw's throw.toml and manual points file, the origin to the
    run's scene.toml; fitted from the page, the point is in that throw's tracks alone."""
    from vidtrack.scene import load_scene, throw_scene

    run = copy_throws_run(tmp_path / "run")
    shared = (run / "scene.toml").read_text()
    c = client(run)
    state = c.get("/api/state").json
    assert (state["throws"], state["throw"]) == (["01", "02"], "01")
    assert state["views"]["front"]["source"] == "throws/01/front.avi"
    r = c.post("/api/throw", json={"throw": "02"})
    assert r.status_code == 200 and r.json["throw"] == "02"
    assert r.json["views"]["front"]["source"] == "throws/02/front.avi"
    assert edit(c, set="exclude", frame=20, excluded=True).json["written"] == [
        "throws/02/throw.toml"]
    assert edit(c, set="point", frame=100, at_px=[205.5, 50.25]).json["written"] == [
        "throws/02/front_manual.csv", "throws/02/throw.toml"]
    assert edit(c, set="target", frame=30, at_px=[150.0, 60.0]).status_code == 200
    assert (run / "scene.toml").read_text() == shared
    scene = load_scene(run)
    two = throw_scene(scene, run / "throws" / "02").views["front"]
    assert two.exclude_frames == ((20, 21),) and two.target == (30, (150.0, 60.0))
    with open(run / "throws" / "02" / "front_manual.csv", newline="") as f:
        assert [(r["frame"], r["u_px"], r["v_px"]) for r in csv.DictReader(f)] == [
            ("100", "205.50", "50.25")]
    assert throw_scene(scene, run / "throws" / "01") is scene    # 01: nothing of its own
    r = edit(c, set="point", frame=20, at_px=[1.0, 2.0])          # refused: one line, no write
    assert r.status_code == 400 and "\n" not in r.json["error"]
    assert r.json["error"].startswith(f"{(run / 'throws' / '02' / 'throw.toml').resolve()}: ")
    assert "has frame 20, which exclude_frames [20, 21) takes out" in r.json["error"]
    assert edit(c, set="origin", at_px=[81.0, 70.0]).json["written"] == ["scene.toml"]
    assert load_scene(run).views["front"].origin_px == (81.0, 70.0)
    assert c.get("/api/frame/front/20").json["excluded"] is True
    assert c.post("/api/throw", json={"throw": "01"}).status_code == 200
    info = c.get("/api/frame/front/20").json
    assert info["excluded"] is False and c.get("/api/frame/front/100").json["manual_px"] is None
    assert c.post("/api/throw", json={"throw": "03"}).status_code == 400
    assert c.post("/api/fit").status_code == 202
    c.application.config["FIT_JOB"].wait()
    assert c.get("/api/fit").json["state"] == "done"
    rows = {t: pd.read_csv(run / "vidtrack" / t / "tracks.csv").set_index("frame")
            for t in ("01", "02")}
    assert (rows["02"].loc[100, "u_px"], rows["02"].loc[100, "v_px"]) == (205.5, 50.25)
    assert rows["02"].loc[20, "flags"] & EXCLUDED and "EXCLUDED" in rows["02"].loc[
        20, "flag_names"]
    assert rows["01"].loc[100, "u_px"] != 205.5 and not rows["01"].loc[20, "flags"] & EXCLUDED
    assert c.get("/api/frame/front/100").json["u_px"] == rows["01"].loc[100, "u_px"]


def test_other_host_names_refused(tmp_path):
    run = copy_run(tmp_path / "run")
    c = client(run)
    r = c.get("/api/state", headers={"Host": "evil.example:8000"})
    assert r.status_code == 403 and "evil.example" in r.json["error"]
    assert c.get("/api/state", headers={"Host": "127.0.0.1:8000"}).status_code == 200


def test_help_has_an_example(vidtrack_cli):
    r = vidtrack_cli("view", "--help")
    assert r.returncode == 0
    assert "vidtrack view runs/07" in r.stdout and "--no-browser" in r.stdout


@pytest.mark.parametrize("setup, args, message", [
    (lambda run: None, ["--no-browser"], "no such folder"),
    (lambda run: run.mkdir(), ["--no-browser"], "scene.toml: no such file"),
    (lambda run: copy_run(run), ["--port", "70000"], "--port 70000: expected a port"),
    (lambda run: (copy_run(run), (run / "throws").write_text("")), ["--no-browser"],
     "expected a folder of replicate throws"),
    (lambda run: (copy_run(run), (run / "front.avi").write_bytes(b"not a video")),
     ["--no-browser"], "front.avi"),
])
def test_bad_input_exit_2_one_line(tmp_path, vidtrack_cli, setup, args, message):
    run = tmp_path / "run"
    setup(run)
    before = digests(run) if run.exists() else None
    r = vidtrack_cli("view", run, *args)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vidtrack view: error: ")
    assert message in lines[0]
    assert (digests(run) if run.exists() else None) == before


def _ctrl_c_as_in_a_terminal():
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def serve(run):
    """The real command in a child process; returns it and the URL it printed."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    # (Ctrl-C reaches it as in a terminal: a test run started in the background of a
    # shell without job control inherits SIGINT ignored, and Python keeps it so)
    proc = subprocess.Popen([sys.executable, "-m", "vidtrack", "view", str(run), "--no-browser"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            preexec_fn=_ctrl_c_as_in_a_terminal)
    line = proc.stdout.readline()
    m = re.search(r"(http://127\.0\.0\.1:\d+/)", line)
    if m is None:
        proc.kill()
        _, err = proc.communicate()
        pytest.fail(f"vidtrack view printed no URL: {line!r} {err!r}")
    return proc, m.group(1)


def stop(proc):
    """Ctrl-C, as a user stops it; the exit code and stderr (the pipes closed)."""
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    return proc.returncode, err


def test_command_serves_on_loopback_and_stops_on_ctrl_c(tmp_path):
    run = copy_run(tmp_path / "run")
    proc, url = serve(run)
    try:
        with urllib.request.urlopen(url + "api/state") as r:
            state = json.load(r)
        with urllib.request.urlopen(url) as r:
            page = r.read().decode()
    finally:
        code, err = stop(proc)
    assert code == 0, err
    assert set(state["views"]) == {"front", "top"} and state["views"]["front"]["frames"] == 372
    assert 'id="frame"' in page


def test_a_fit_of_another_scene_names_the_throws_own_file_where_it_has_one(tmp_path):
    """The page's note on tracks that no longer match the scene names the file that can
    have changed: scene.toml, and a throw's throw.toml where the throw has one."""
    from vidtrack.run.overlay_run import stale_reason
    from vidtrack.scene import load_scene

    scene = load_scene(REPO / "datasets" / "run42")
    out = tmp_path / "out"
    out.mkdir()
    (out / "tracks.h5").write_bytes(b"")
    (out / "fit.json").write_text(json.dumps({"scene_hash": "another", "coefficients": {}}))
    throw = tmp_path / "02"
    throw.mkdir()
    assert stale_reason(scene, throw, out) == "scene.toml changed since the fit"
    (throw / "throw.toml").write_text("schema = 1\n")
    assert stale_reason(scene, throw, out) == "scene.toml or throw.toml changed since the fit"
