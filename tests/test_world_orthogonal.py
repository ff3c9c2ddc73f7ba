"""The two-view merge on synthetic runs whose clocks and world positions are known."""

import shlex
from pathlib import Path

import numpy as np
import pytest
from synth_runs import synth_run, truth, view_truth

from calibration.views import ViewMapping
from vidtrack.errors import TrackError
from vidtrack.footage import open_source
from vidtrack.scene import load_scene
from vidtrack.world.orthogonal import WORLD_COLUMNS, merge_tracks, view_world
from vidtrack.track.tracker import PRE_RELEASE, Track, track

RUN42 = Path(__file__).resolve().parents[1] / "datasets" / "run42"
#: A run of the ``vidtrack report`` end-to-end test (tests/test_cli_report.py): the
#: straw rides the rotor tooth for 12 frames, clear of it for some of them.
SMALL_RUN = ("vidtrack synth OUT --size 300x140 --top-size 300x90 --straw-length-m 0.25 "
             "--straw-diameter-m 0.025 --flight-s 0.25 --noise 1.0 --k 3.25,2.8,4.2,19.3 "
             "--n-rpm 650 --blade-angle-deg -5 --seed 2")


def _track_scene(folder):
    scene = load_scene(folder)
    tracks = {}
    for name, view in scene.views.items():
        with open_source(view.source, fps=view.fps, frames=view.frames) as src:
            tracks[name] = track(src, view=name)
    mappings = {n: v.mapping() for n, v in scene.views.items()}
    world = merge_tracks(tracks, mappings, sync={n: v.sync_frame for n, v in
                                                 scene.views.items()})
    return scene, tracks, world

FPS = 1200.0
DELAY_FRAMES = 0.37            # the top camera's frames are this much later


@pytest.fixture(scope="module")
def delayed():
    """Both views tracked, the top view's clock 0.37 frame behind the front's."""
    run = synth_run("delayed", top_delay_s=DELAY_FRAMES / FPS)
    scene = load_scene(run)
    tracks = {}
    for name, view in scene.views.items():
        with open_source(view.source, fps=view.fps) as src:
            tracks[name] = track(src, view=name)
    mappings = {n: v.mapping() for n, v in scene.views.items()}
    return run, tracks, mappings


def test_auto_sync_recovers_a_subframe_offset_from_the_shared_x(delayed):
    run, tracks, mappings = delayed
    w = merge_tracks(tracks, mappings)
    assert w.reference == "front" and w.sync == {"front": "release", "top": "shared x"}
    # frame i of a view is at t = (i - 12) / fps + delay: t = 0 is at source time
    # 12 / fps - delay, so the top's t0 is DELAY_FRAMES frames before the front's
    offset_frames = (w.t0_s["front"] - w.t0_s["top"]) * FPS
    assert offset_frames == pytest.approx(DELAY_FRAMES, abs=0.1)
    assert abs(w.t0_s["front"] * FPS - 12.0) <= 1.0          # the release, from the track
    assert w.x_rms_px is not None and w.x_rms_px < 0.3
    # no warning (without camera_distance_m the merge says nothing of perspective: the
    # fit stage notes it only where it could move k, vidtrack.run.perspective)
    assert w.x_points >= 50
    assert w.warnings == ()


def test_world_track_against_truth(delayed):
    run, tracks, mappings = delayed
    w = merge_tracks(tracks, mappings, sync={"front": 12, "top": "auto"})
    assert tuple(w.data.columns) == WORLD_COLUMNS
    assert w.data["t_s"].iloc[0] >= 0 and np.all(np.diff(w.data["t_s"]) > 0)
    # the rows are the front view's frames from its sync frame on: t = (frame - 12) / fps
    assert w.data["frame"].dtype == np.int64
    np.testing.assert_array_equal(w.data["frame"], 12 + np.round(w.data["t_s"] * FPS))
    per_frame, _ = view_truth(run, "front")
    t_true = per_frame["t_s"].to_numpy(float)
    for axis in "xyz":
        got = w.data[f"{axis}_m"].to_numpy()
        want = np.interp(w.data["t_s"], t_true, per_frame[f"{axis}_m"].to_numpy(float))
        ok = np.isfinite(got)
        assert ok.sum() >= 50
        scale = mappings["front"].m_per_px
        assert np.sqrt(np.mean((got[ok] - want[ok]) ** 2)) < 0.25 * scale, axis


def test_given_sync_frames_and_the_x_check_warns_on_a_wrong_scale(delayed):
    run, tracks, mappings = delayed
    w = merge_tracks(tracks, mappings, sync={"front": 12, "top": 12})
    assert w.sync == {"front": "sync_frame 12", "top": "sync_frame 12"}
    assert w.t0_s["front"] == pytest.approx(12 / FPS)
    wrong = dict(mappings)
    m = mappings["top"]
    wrong["top"] = ViewMapping(axes=m.axes, origin_px=m.origin_px, m_per_px=m.m_per_px * 1.05)
    w2 = merge_tracks(tracks, wrong, sync={"front": 12, "top": 12})
    assert w2.x_rms_px > 1.0
    assert any("disagree on X" in s for s in w2.warnings)


def test_views_at_different_frame_rates(delayed):
    # the top camera at half the rate: keep every other frame of its track
    run, tracks, mappings = delayed
    top = tracks["top"]
    half = Track(data=top.data.iloc[::2].reset_index(drop=True), **{
        k: getattr(top, k) for k in ("view", "release_frame", "release_note", "release_t_s",
                                     "fps", "frame_shape", "noise_sigma", "k_sigma",
                                     "straw_level", "scatter_px", "notes")})
    w = merge_tracks({"front": tracks["front"], "top": half}, mappings)
    assert (w.t0_s["front"] - w.t0_s["top"]) * FPS == pytest.approx(DELAY_FRAMES, abs=0.15)
    assert w.x_rms_px < 0.3 and np.isfinite(w.data["z_m"]).sum() >= 50


def test_one_view_leaves_its_missing_axis_nan(delayed):
    run, tracks, mappings = delayed
    w = merge_tracks({"front": tracks["front"]}, mappings)
    assert w.x_rms_m is None and len(w.data) > 50
    assert np.isnan(w.data["z_m"]).all() and np.isfinite(w.data["y_m"]).all()
    w = merge_tracks({"top": tracks["top"]}, mappings, sync={"top": 12})
    assert np.isnan(w.data["y_m"]).all() and np.isfinite(w.data["z_m"]).any()
    world = view_world(tracks["top"], mappings["top"])
    assert list(world.columns) == ["frame", "t_s", "x_m", "z_m"]
    assert len(world) == int(tracks["top"].usable.sum())


def test_bad_input(delayed):
    run, tracks, mappings = delayed
    with pytest.raises(TrackError, match="no view"):
        merge_tracks({}, mappings)
    with pytest.raises(TrackError, match="unknown view"):
        merge_tracks({"side": tracks["front"]}, mappings)
    with pytest.raises(TrackError, match="mapping"):
        merge_tracks(tracks, {"front": mappings["front"]})
    with pytest.raises(TrackError, match="sync_frame 999"):
        merge_tracks(tracks, mappings, sync={"front": 999})
    with pytest.raises(TrackError, match="frame index"):
        merge_tracks(tracks, mappings, sync={"front": 1.5})
    assert truth(run)["views"]["top"]["delay_s"] == pytest.approx(DELAY_FRAMES / FPS)


def test_merged_tracks_flag_exactly_the_frames_before_each_views_time_zero(delayed):
    run, tracks, mappings = delayed
    w = merge_tracks(tracks, mappings)
    assert tracks["top"].release_frame is None             # not looked for in the top view
    for name in ("front", "top"):
        got = w.tracks[name]
        t = got.data["t_s"].to_numpy()
        measured = np.isfinite(got.data["u_px"].to_numpy())
        before = t < w.t0_s[name] - 0.2 / FPS
        flags = got.data["flags"].to_numpy()
        assert np.all(flags[before & measured] & PRE_RELEASE)
        assert not np.any(flags[~before] & PRE_RELEASE)
        assert got.release_t_s == pytest.approx(w.t0_s[name])
    top = w.tracks["top"]
    assert "carried over from the front view" in top.release_note
    assert abs(top.release_frame - view_truth(run, "top")[1]["release_frame"]) <= 1
    # a given sync_frame overrides the detected release
    w = merge_tracks(tracks, mappings, sync={"front": 20, "top": "auto"})
    flags = w.tracks["front"].data["flags"].to_numpy()
    frames = w.tracks["front"].data["frame"].to_numpy()
    measured = np.isfinite(w.tracks["front"].data["u_px"].to_numpy())
    assert np.all(flags[(frames < 20) & measured] & PRE_RELEASE)
    assert not np.any(flags[frames >= 20] & PRE_RELEASE)
    assert w.tracks["front"].release_frame == 20


# ------------------------------------------------------------ the release on real runs
@pytest.fixture(scope="module")
def run42():
    return _track_scene(RUN42)


def test_run42_release_and_time_zero_within_a_frame_of_truth(run42):
    scene, tracks, w = run42
    t = truth(RUN42)
    front = tracks["front"]
    assert abs(front.release_frame - t["views"]["front"]["release_frame"]) <= 1
    assert abs(front.release_t_s * 1200.0 - t["views"]["front"]["t0_frame"]) <= 1.0
    assert w.sync == {"front": "release", "top": "shared x"}
    for name in ("front", "top"):
        vt = t["views"][name]
        assert abs(w.t0_s[name] * vt["fps"] - vt["t0_frame"]) <= 1.0, name
        assert abs(w.tracks[name].release_frame - vt["release_frame"]) <= 1, name


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    from vidtrack.cli import build_parser
    from vidtrack.cli.synth import spec_from_args
    from vidtrack.synth import render_run

    out = tmp_path_factory.mktemp("report-run") / "run"
    args = build_parser().parse_args(shlex.split(SMALL_RUN.replace("OUT", str(out)))[1:])
    render_run(out, spec_from_args(args))
    return (out, *_track_scene(out))


def test_small_run_release_found_and_no_frame_of_the_ride_fitted(small_run):
    out, scene, tracks, w = small_run
    per_frame, vt = view_truth(out, "front")
    assert abs(tracks["front"].release_frame - vt["release_frame"]) <= 1
    assert abs(w.t0_s["front"] * vt["fps"] - vt["t0_frame"]) <= 1.0
    assert w.data["t_s"].min() >= 0.0
    for name in ("front", "top"):
        per_frame, vt = view_truth(out, name)
        merged = w.tracks[name]
        ride = per_frame["phase"].to_numpy() == "blade"
        assert ride.sum() == vt["release_frame"]
        # riding the tooth the straw is at times clear of it: only the release says
        # that these frames are not free flight
        own = tracks[name].data["flags"].to_numpy()[ride] & ~PRE_RELEASE
        assert np.any(own == 0), name
        assert not np.any(merged.usable & ride), name
        assert np.all(merged.data["flags"].to_numpy()[ride[:len(merged.data)] &
                      np.isfinite(merged.data["u_px"].to_numpy())] != 0)


def test_small_run_world_track_fits_the_truth(small_run):
    from fits.lsq import fit_throw

    out, scene, tracks, w = small_run
    t = truth(out)["truth"]
    fit = fit_throw(w.data, scene.cp_s_per_m, g=scene.physics.gravity_m_s2, v1=scene.v1_m_s)
    for k, rel in (("k1", 0.03), ("k2", 0.03), ("k3", 0.03), ("k4", 0.05)):
        assert fit.coefficients[k].value == pytest.approx(t["k"][k], rel=rel), k
    st = fit.initial_state
    assert st["x0_m"] == pytest.approx(t["state"]["x0_m"], abs=0.01)
    assert st["y0_m"] == pytest.approx(t["state"]["y0_m"], abs=0.01)
    assert st["vx0_m_s"] == pytest.approx(t["state"]["vx0_m_s"], rel=0.03)
    assert st["vy0_m_s"] == pytest.approx(t["state"]["vy0_m_s"], rel=0.03)


def test_reprs_are_short_and_the_merge_is_logged(run42, caplog):
    scene, tracks, w = run42
    # were 1,224 and 3,227 characters: the DataFrames printed in full
    for obj in (tracks["front"], tracks["top"], w):
        text = repr(obj)
        assert len(text) < 300 and "\n" not in text, text
    assert repr(tracks["front"]).startswith("Track(view='front', frames=")
    assert f"rows={len(w.data)}" in repr(w) and "reference='front'" in repr(w)
    with caplog.at_level("INFO", logger="vidtrack"):
        merge_tracks(tracks, {n: v.mapping() for n, v in scene.views.items()},
                     sync={n: v.sync_frame for n, v in scene.views.items()})
    record = next(r for r in caplog.records if r.name == "vidtrack.world.orthogonal")
    assert record.levelname == "INFO" and record.getMessage().startswith(
        f"world track: {len(w.data)} rows from front, top")
