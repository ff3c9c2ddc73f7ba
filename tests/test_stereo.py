"""The two-view merge on synthetic runs whose clocks and world positions are known."""

import numpy as np
import pytest
from synth_runs import synth_run, truth, view_truth

from calibration.views import ViewMapping
from vidtrack.errors import TrackError
from vidtrack.frames import open_source
from vidtrack.scene import load_scene
from vidtrack.stereo import WORLD_COLUMNS, merge_tracks, view_world
from vidtrack.tracker import Track, track

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
    assert w.x_points >= 50 and w.warnings == ()


def test_world_track_against_truth(delayed):
    run, tracks, mappings = delayed
    w = merge_tracks(tracks, mappings, sync={"front": 12, "top": "auto"})
    assert tuple(w.data.columns) == WORLD_COLUMNS
    assert w.data["t_s"].iloc[0] >= 0 and np.all(np.diff(w.data["t_s"]) > 0)
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
