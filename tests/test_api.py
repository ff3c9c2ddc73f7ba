"""The notebook API as the user guide calls it: ``from vidtrack import open_source, track,
fit_run, read_tracks``, on a small synthetic run whose truth the code never sees.

The numbers are checked against what the code under test did not produce: the
renderer's truth.json, the files the run wrote (read with json, pandas and h5py, not
with vidtrack), the scene's capture rate, and numpy's own indexing.
"""

import json
import shutil

import h5py
import numpy as np
import pandas as pd
import pytest
from synth_runs import synth_run, truth

from vidtrack import (RunFit, TrackFlag, fit_run, flag_names, open_source, read_tracks,
                      track)
from vidtrack.errors import FitError
from vidtrack.scene import load_scene


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """A copy of a small synthetic run, fitted once through the top-level API."""
    run = tmp_path_factory.mktemp("api") / "run"
    shutil.copytree(synth_run("api-delayed", top_delay_s=0.37 / 1200.0), run)
    return run, fit_run(run)


def test_fit_run_gives_a_results_object_whose_to_dict_is_fit_json(fitted):
    run, fit = fitted
    assert isinstance(fit, RunFit)
    on_disk = json.loads((run / "vidtrack" / "fit.json").read_text())
    assert fit.to_dict() == on_disk
    d = fit.to_dict()
    d["coefficients"]["k1"]["value"] = -1.0      # a copy: the result is not changed
    assert fit.to_dict() == on_disk
    # as a read-only mapping it is the record fit_run returned before
    assert fit["run"] == on_disk["run"] and dict(fit)["coefficients"] == on_disk["coefficients"]
    assert fit["stages_reused"] == [] and set(fit) == set(fit.record)
    with pytest.raises(TypeError):
        fit["run"] = "other"


def test_params_bse_and_intervals_are_fit_json_s_and_near_the_truth(fitted):
    run, fit = fitted
    coeffs = json.loads((run / "vidtrack" / "fit.json").read_text())["coefficients"]
    true_k = truth(run)["truth"]["k"]
    assert list(fit.params.index) == ["k1", "k2", "k3", "k4"]
    ci = fit.conf_int()
    assert list(ci.columns) == ["lower", "upper"]
    determined = [k for k in ("k1", "k2", "k3", "k4") if coeffs[k]["determined"]]
    assert {"k1", "k3", "k4"} <= set(determined)     # the clip ends near the apex: k2 may not
    for k in ("k1", "k2", "k3", "k4"):
        c = coeffs[k]
        if k not in determined:
            assert np.isnan(fit.params[k]) and np.isnan(fit.bse[k])
            assert ci.loc[k].isna().all()
            assert c["reason"] in fit.summary()
            continue
        assert fit.params[k] == c["value"] and fit.bse[k] == c["stderr"]
        assert (ci.loc[k, "lower"], ci.loc[k, "upper"]) == tuple(c["ci95"])
        assert fit.params[k] == pytest.approx(true_k[k], rel=0.05), k
    with pytest.raises(FitError, match="0.05"):
        fit.conf_int(0.1)
    text = fit.summary()
    assert fit.run in text and "k4" in text and "95 % interval" in text
    assert f"{coeffs['k1']['value']:.5g}" in text
    assert "<table" in fit._repr_html_() and repr(fit).startswith("RunFit(run=")


def test_the_tracks_are_tracks_h5_s_with_a_frame_column(fitted):
    run, fit = fitted
    out = run / "vidtrack"
    csv = pd.read_csv(out / "tracks.csv")
    scene = load_scene(run)
    for view, data in fit.tracks.items():
        assert data.columns[0] == "frame"
        rows = csv[csv["view"] == view]
        np.testing.assert_array_equal(data["frame"], rows["frame"])
        np.testing.assert_array_equal(data["flags"], rows["flags"])
        with h5py.File(out / "tracks.h5", "r") as h:
            assert h[view]["flags"].dtype == np.int32        # the file as before
            np.testing.assert_array_equal(h[view]["flags"][()], data["flags"])
        # the flags read as TrackFlag give the names tracks.csv spells out
        names = ["|".join(f.name for f in TrackFlag if f in TrackFlag(int(v)))
                 for v in data["flags"]]
        assert names == rows["flag_names"].fillna("").tolist()
        assert flag_names(data["flags"]) == names
        assert (data["flags"] & TrackFlag.PRE_RELEASE).any()   # masks a column
    world = fit.world
    assert list(world.columns[:5]) == ["frame", "t_s", "x_m", "y_m", "z_m"]
    # the straw's attitude (vidtrack.world.attitude) after the columns of the contract
    assert list(pd.read_csv(out / "world.csv").columns) == ["t_s", "x_m", "y_m", "z_m",
                                                            "axis_x", "axis_y", "axis_z",
                                                            "spin_rad_s"]
    # the rows are the front view's frames: t = frame / fps - t0
    t0 = fit["world"]["t0_s"]["front"]
    fps = scene.views["front"].fps
    np.testing.assert_allclose(world["t_s"], world["frame"] / fps - t0, rtol=0, atol=1e-9)
    assert (read_tracks(out / "tracks.h5").world.data["frame"] == world["frame"]).all()


def test_the_frame_columns_are_the_source_s_frames(fitted):
    run, fit = fitted
    scene = load_scene(run)
    for name, data in fit.tracks.items():
        view = scene.views[name]
        with open_source(view.source, fps=view.fps, frames=view.frames) as src:
            np.testing.assert_array_equal(data["frame"], src.frame_numbers)
            np.testing.assert_allclose(data["t_s"], src.times_s, rtol=0, atol=1e-12)
    # the world track's rows are frames of its reference view, in order, and each row's
    # time is that frame's on the reference clock less its t = 0
    world = fit.world
    ref = fit["world"]["reference"]
    ref_track = fit.tracks[ref].set_index("frame")
    assert world["frame"].isin(ref_track.index).all()
    assert (np.diff(world["frame"]) > 0).all()
    t0 = fit["world"]["t0_s"][ref]
    np.testing.assert_allclose(world["t_s"], ref_track.loc[world["frame"], "t_s"] - t0,
                               rtol=0, atol=1e-9)


def test_a_second_call_reuses_and_fit_json_is_unchanged(fitted):
    run, fit = fitted
    again = fit_run(run)
    assert again["stages_reused"] == ["tracks", "fit"]
    assert again.to_dict() == fit.to_dict()
    assert "Reused: tracks, fit" in again.summary()


def test_track_takes_a_slice_as_it_takes_a_range(fitted):
    run, _ = fitted
    view = load_scene(run).views["front"]
    with open_source(view.source, fps=view.fps) as src:
        part = src[20:120]
        assert len(part) == 100
        sliced = track(part, view="front")
    with open_source(view.source, fps=view.fps, frames=(20, 120)) as src:
        ranged = track(src, view="front")
    np.testing.assert_array_equal(sliced.data["frame"], np.arange(20, 120))
    pd.testing.assert_frame_equal(sliced.data, ranged.data)
    assert sliced.release_frame == ranged.release_frame
