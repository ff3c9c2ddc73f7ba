"""A shaking camera (vidtrack.track.steady): every frame moved back onto the background
before it is tracked, against the camera motion ``vidtrack synth --shake`` drew (its
truth.json says how far each frame's content lies from a still camera's).

The steadied positions are the still camera's up to one constant: the reference is the
median of the frames the background is sampled from, which lie where the camera was on
average over them.
"""

import json

import numpy as np
import pytest

from conftest import assert_k_within, run_vidtrack
from vidtrack.footage import open_source
from vidtrack.track import steady
from vidtrack.track.background import sample_indices
from vidtrack.track.tracker import track

REPO = __import__("pathlib").Path(__file__).resolve().parents[1]

#: The scale of tests/test_synth_distractors.py, the cameras vibrating 1.5 px at 9 Hz
SHAKEN = ["--size", "320x150", "--top-size", "320x96", "--straw-length-m", "0.25",
          "--straw-diameter-m", "0.025", "--quality", "60", "--noise", "1.0",
          "--flight-s", "0.3", "--shake", "1.5,9"]


@pytest.fixture(scope="module")
def shaken(tmp_path_factory):
    out = tmp_path_factory.mktemp("shaken") / "run"
    res = run_vidtrack("synth", out, *SHAKEN, "-q")
    assert res.returncode == 0, res.stderr
    fit = run_vidtrack("fit", out, "--json", "--no-report", "-q")
    return out, json.loads((out / "truth.json").read_text()), fit


@pytest.fixture(scope="module")
def shaken_flight(shaken, tmp_path_factory):
    """The same footage fitted with the flight tracker (``[track] engine = "flight"``)."""
    import shutil

    out = tmp_path_factory.mktemp("shaken_flight") / "run"
    shutil.copytree(shaken[0], out, ignore=shutil.ignore_patterns("vidtrack"))
    with open(out / "scene.toml", "a", encoding="utf-8") as f:
        f.write('\n[track]\nengine = "flight"\n')
    fit = run_vidtrack("fit", out, "--json", "--no-report", "-q")
    return out, shaken[1], fit


@pytest.fixture(params=["rules", "flight"])
def shaken_run(request):
    """The shaken run fitted by each tracker."""
    return request.getfixturevalue("shaken" if request.param == "rules" else "shaken_flight")


def _truth(truth, view):
    tab = truth["views"][view]["per_frame"]
    return {k: np.asarray(tab[k], dtype=float) for k in
            ("u_coverage_px", "v_coverage_px", "camera_du_px", "camera_dv_px")}


def _tracks(run, view):
    import pandas as pd

    t = pd.read_csv(run / "vidtrack" / "tracks.csv")
    return t[t["view"] == view].set_index("frame").sort_index()


def test_synth_shake_moves_the_whole_image(tmp_path):
    from vidtrack.synth import SynthSpec, render_run

    small = dict(size_px=(160, 96), top_size_px=(160, 64), straw_length_m=0.25,
                 straw_diameter_m=0.025, flight_s=0.1, frames=40, output_format="png",
                 exposure_samples=2, views=("front",), read_noise_dn=0.0)
    render_run(tmp_path / "still", SynthSpec(**small))
    render_run(tmp_path / "shook", SynthSpec(**small, shake=(2.0, 9.0)))
    truth = json.loads((tmp_path / "shook" / "truth.json").read_text())
    tab = _truth(truth, "front")
    with open_source(tmp_path / "still" / "front") as a, \
            open_source(tmp_path / "shook" / "front") as b:
        for i in (5, 30):
            still = np.asarray(a[i], np.float32)
            shook = np.asarray(b[i], np.float32)
            # the still frame moved by the truth's shift is the shaken frame (inside)
            w = np.array([[1, 0, tab["camera_du_px"][i]], [0, 1, tab["camera_dv_px"][i]]])
            import cv2

            moved = cv2.warpAffine(still, w, still.shape[::-1], flags=cv2.INTER_CUBIC)
            inner = (slice(8, -8), slice(8, -8))
            assert np.abs(moved[inner] - shook[inner]).mean() < 1.0
            assert np.abs(still[inner] - shook[inner]).mean() > 2.0 * np.abs(
                moved[inner] - shook[inner]).mean()


def test_a_shaking_camera_fits_k_back(shaken_run):
    run, truth, fit = shaken_run
    assert fit.returncode == 0, fit.stderr
    record = json.loads(fit.stdout)
    assert_k_within(record, truth["truth"]["k"])
    notes = json.loads((run / "vidtrack" / "fit.json").read_text())["notes"]
    for view in ("front", "top"):
        assert any(n.startswith(f"{view}: camera: shakes") for n in notes), notes


@pytest.mark.parametrize("view", ["front", "top"])
def test_steadied_points_are_where_a_still_camera_sees_the_straw(shaken_run, view):
    run, truth, _ = shaken_run
    tab = _truth(truth, view)
    t = _tracks(run, view)
    ok = (t["flags"] == 0).to_numpy() & np.isfinite(t["u_px"].to_numpy())
    assert ok.mean() >= 0.5
    fr = t.index.to_numpy()[ok]
    du = t["u_px"].to_numpy()[ok] - tab["u_coverage_px"][fr]
    dv = t["v_px"].to_numpy()[ok] - tab["v_coverage_px"][fr]
    off = np.median(du), np.median(dv)
    err = np.hypot(du - off[0], dv - off[1])
    # the constant: where the camera was on average over the background's frames
    assert np.hypot(*off) < 1.5
    assert np.sqrt(np.mean(err ** 2)) < 0.15, np.sqrt(np.mean(err ** 2))
    # (measured: 0.08-0.10 px RMS; the top view's first dozen frames of flight, beside
    # the turning rotor, up to 0.67 px, where a still camera's are within 0.1 px; the
    # flight tracker 0.08 / 0.07 px RMS, 0.27 / 0.17 px at most)
    assert err.max() < 0.8, err.max()
    # what the camera did is in the image: 1.5 px at 9 Hz, 1.1 px RMS
    cam = np.hypot(tab["camera_du_px"][fr] - tab["camera_du_px"][fr].mean(),
                   tab["camera_dv_px"][fr] - tab["camera_dv_px"][fr].mean())
    assert np.sqrt(np.mean(cam ** 2)) > 0.8


def test_the_shake_measured_is_the_cameras(shaken):
    run, truth, _ = shaken
    tab = _truth(truth, "front")
    with open_source(run / "front.avi", fps=1200) as src:
        frames = [np.asarray(f) for f in src]
    idx = sample_indices(300, 25)
    st, note = steady.Steadier.look([frames[i] for i in idx], idx)
    assert st is not None, note
    got = np.array([st.shift(i, f) for i, f in enumerate(frames)])
    err = got - np.column_stack([tab["camera_du_px"], tab["camera_dv_px"]])
    err -= np.median(err, axis=0)
    # (measured: 0.083 px RMS here, 0.065 in the top view; 0.03-0.07 on the sample run
    # shaken by 1-2 px)
    assert np.sqrt(np.mean(np.sum(err ** 2, axis=1))) < 0.1
    assert st.failed == 0


def _within(tr, tab, px=0.5):
    """Frames unflagged and within ``px`` of the still camera's point (one constant
    offset taken out)."""
    d, ok = tr.data, tr.usable
    du = d["u_px"].to_numpy()[ok] - tab["u_coverage_px"][ok]
    dv = d["v_px"].to_numpy()[ok] - tab["v_coverage_px"][ok]
    return int(np.count_nonzero(np.hypot(du - np.median(du), dv - np.median(dv)) <= px))


def _fitted_track(run, view):
    """The track ``vidtrack fit`` made of ``view`` (its tracks.h5): the tracker with the
    settings of :func:`vidtrack.track.tracker.track` (the scene sets none)."""
    from vidtrack.run.tracks_file import read_tracks

    return read_tracks(run / "vidtrack" / "tracks.h5").tracks[view]


def test_without_steadying_the_shake_would_be_in_the_track(shaken, monkeypatch):
    # the control: with the look switched off, the same footage is tracked as shot:
    # the straw is lost or flagged in most frames (23 of 372 unflagged), and what is
    # measured carries the camera's motion (steadied: the module's fit of the footage)
    run, truth, _ = shaken
    tab = _truth(truth, "front")
    steadied = _fitted_track(run, "front")
    assert any(n.startswith("camera: shakes") for n in steadied.notes), steadied.notes
    with open_source(run / "front.avi", fps=1200) as src:
        monkeypatch.setattr(steady, "SHAKE_PX", float("inf"))
        shot = track(src, view="front")
    assert not any(n.startswith("camera") for n in shot.notes)
    n = len(tab["u_coverage_px"])
    assert _within(steadied, tab) >= 0.5 * n
    assert _within(shot, tab) < 0.2 * n


def test_a_steady_camera_is_left_alone():
    # the sample run's cameras do not move: looked at, nothing is done
    with open_source(REPO / "datasets" / "run42" / "front.avi", fps=1200) as src:
        idx = sample_indices(300, 25)
        samples = [np.asarray(src[int(i)]) for i in idx]
        st, note = steady.Steadier.look(samples, idx)
        assert st is None and note.startswith("camera: steady"), note
        tr = track(src, view="front")
    assert not any(n.startswith("camera") for n in tr.notes)


@pytest.mark.parametrize("bad", ["0,9", "25,9", "1,700", "1.5"])
def test_bad_shake_exits_2(tmp_path, vidtrack_cli, bad):
    out = tmp_path / "bad"
    res = vidtrack_cli("synth", out, "--shake", bad)
    assert res.returncode == 2, res.stderr
    assert "shake" in res.stderr
    assert not out.exists()


def test_tracks_keep_the_camera_shift_and_the_footage_as_shot_is_drawn_with_it(shaken_run):
    # tracks.h5 keeps where the camera put each frame: the steadied point plus the shift
    # is where the straw is in the footage as shot (no constant left), and that is where
    # the contact sheet marks it
    from vidtrack.report.contact_sheet import contact_crops
    from vidtrack.run.tracks_file import read_tracks

    run, truth, _ = shaken_run
    tf = read_tracks(run / "vidtrack" / "tracks.h5")
    for view in ("front", "top"):
        d = tf.tracks[view].data
        tab = _truth(truth, view)
        ok = tf.tracks[view].usable
        fr = d["frame"].to_numpy()[ok]
        u = d["u_px"].to_numpy()[ok] + d["camera_du_px"].to_numpy()[ok]
        v = d["v_px"].to_numpy()[ok] + d["camera_dv_px"].to_numpy()[ok]
        err = np.hypot(u - (tab["u_coverage_px"][fr] + tab["camera_du_px"][fr]),
                       v - (tab["v_coverage_px"][fr] + tab["camera_dv_px"][fr]))
        assert np.sqrt(np.mean(err ** 2)) < 0.15 and err.max() < 0.8, (view, err.max())
    csv = __import__("pandas").read_csv(run / "vidtrack" / "tracks.csv")
    assert {"camera_du_px", "camera_dv_px"} <= set(csv.columns)
    d = tf.tracks["front"].data
    with open_source(run / "front.avi", fps=1200) as src:
        crops, _ = contact_crops({"front": src}, {"front": d}, {}, flight=4)
    assert crops
    for c in crops:
        k = int(np.flatnonzero(d["frame"].to_numpy() == c.frame)[0])
        want = (d["u_px"][k] + d["camera_du_px"][k], d["v_px"][k] + d["camera_dv_px"][k])
        assert c.measured_px == pytest.approx(want, abs=1e-9)


def test_a_scene_moving_as_a_whole_is_not_a_shake():
    # a pan (or the ground under a travelling machine): the whole sample run drifting
    # 0.1 px a frame, 30 px over the warm-up's frames, is not steadied, and said
    import cv2

    with open_source(REPO / "datasets" / "run42" / "front.avi", fps=1200) as src:
        idx = sample_indices(300, 25)
        samples = []
        for i in idx:
            f = np.asarray(src[int(i)])
            w = np.array([[1.0, 0.0, 0.1 * i], [0.0, 1.0, 0.0]])
            samples.append(cv2.warpAffine(f, w, f.shape[::-1], flags=cv2.INTER_CUBIC,
                                          borderMode=cv2.BORDER_REFLECT_101))
    st, note = steady.Steadier.look(samples, idx)
    assert st is None
    assert note.startswith("camera: the scene moves as a whole"), note


def test_footage_too_long_to_hold_is_steadied_alike(shaken_flight, monkeypatch):
    # the flight tracker holds footage of up to 96 MB; longer footage is decoded twice
    # (the detection, then the object's frames), each frame moved back as it comes: the
    # same track either way (held: the module's fit of the footage with the flight
    # tracker, whose footage is held)
    from vidtrack.track import flight

    run, _, _ = shaken_flight
    held = _fitted_track(run, "front")
    assert any(n.startswith("camera: shakes") for n in held.notes), held.notes
    with open_source(run / "front.avi", fps=1200) as src:
        frame_bytes = int(np.prod(src.shape)) * np.dtype(src.dtype).itemsize
        assert len(src) * frame_bytes <= flight.HOLD_BYTES          # held, not streamed
        monkeypatch.setattr(flight, "HOLD_BYTES", 0)
        streamed = track(src, view="front", engine="flight")
    assert any(n.startswith("camera: shakes") for n in streamed.notes), streamed.notes
    a, b = held.data, streamed.data
    assert (a["flags"].to_numpy() == b["flags"].to_numpy()).all()
    # (the shifts are measured from another starting guess where the frames come in
    # another order: measured, 3e-4 px apart)
    for col in ("u_px", "v_px", "camera_du_px", "camera_dv_px"):
        assert np.allclose(a[col], b[col], equal_nan=True, rtol=0, atol=0.005), col
