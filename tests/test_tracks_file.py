"""tracks.h5: the SPEC layout read back with h5py itself, round trips, atomic writes."""

import h5py
import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vidtrack import __version__
from vidtrack.errors import TrackError
from vidtrack.world.world_track import WorldTrack
from vidtrack.track.tracker import TRACK_COLUMNS, Track
from vidtrack.run.tracks_file import read_tracks, write_tracks


def _track(view, n, rng, *, release=5):
    data = pd.DataFrame({
        "frame": np.arange(10, 10 + n, dtype=np.int64),
        "t_s": np.arange(10, 10 + n) / 1200.0,
        "u_px": rng.uniform(0, 300, n), "v_px": rng.uniform(0, 200, n),
        "area_px": rng.uniform(10, 40, n), "angle_rad": rng.uniform(-1.5, 1.5, n),
        "length_px": rng.uniform(10, 30, n),
        "flags": rng.choice([0, 0, 0, 4, 8, 32], n).astype(np.int32)})
    data.loc[data["flags"] & 8 > 0, ["u_px", "v_px", "area_px", "angle_rad", "length_px"]] = \
        np.nan
    return Track(data=data, view=view, release_frame=None if release is None else 10 + release,
                 release_note="test", release_t_s=None if release is None else 0.0125,
                 fps=1200.0, frame_shape=(240, 320), noise_sigma=1.2, k_sigma=5.0,
                 straw_level=210.0, scatter_px=0.05, notes=("a note",))


def _world(n, rng):
    # rows at the front view's frames from t = 0 (t0 0.01 s: frame 12 of _track's clock)
    data = pd.DataFrame({"frame": 12 + np.arange(n), "t_s": np.arange(n) / 1200.0,
                         "x_m": rng.normal(0.3, 0.1, n),
                         "y_m": rng.normal(0.1, 0.1, n), "z_m": np.full(n, np.nan)})
    return WorldTrack(data=data, t0_s={"front": 0.01, "top": 0.0097},
                      sync={"front": "release", "top": "shared x"}, reference="front",
                      x_rms_m=0.0002, x_rms_px=0.05, x_points=n, warnings=("w",))


def test_layout_is_the_spec_one(tmp_path):
    rng = np.random.default_rng(1)
    tracks = {"front": _track("front", 30, rng), "top": _track("top", 25, rng, release=None)}
    path = write_tracks(tmp_path / "run" / "vidtrack" / "tracks.h5", tracks, _world(20, rng),
                        scene_hash="abc123", calibration={"front": {"m_per_px": 0.004}})
    with h5py.File(path, "r") as h:
        assert set(h.keys()) == {"front", "top", "world"}
        for v in ("front", "top"):
            assert set(h[v].keys()) == set(TRACK_COLUMNS)
            for c in ("frame", "t_s", "u_px", "v_px", "area_px", "angle_rad", "flags"):
                assert h[v][c].shape == (len(tracks[v].data),)
        assert h["front"]["flags"].dtype == np.int32
        assert set(h["world"].keys()) == {"t_s", "x_m", "y_m", "z_m"}
        assert h.attrs["vidtrack_version"] == __version__
        assert h.attrs["scene_hash"] == "abc123"
        assert '"m_per_px": 0.004' in h.attrs["calibration"]
        assert np.isnan(h["world"]["z_m"][()]).all()
    assert [p.name for p in path.parent.iterdir()] == ["tracks.h5"]   # no temporary left


def test_round_trip(tmp_path):
    rng = np.random.default_rng(2)
    tracks = {"front": _track("front", 40, rng), "top": _track("top", 40, rng, release=None)}
    world = _world(30, rng)
    path = write_tracks(tmp_path / "tracks.h5", tracks, world, scene_hash="h",
                        calibration=None)
    f = read_tracks(path)
    assert f.scene_hash == "h" and f.calibration is None and f.vidtrack_version == __version__
    for v, tr in tracks.items():
        got = f.tracks[v]
        pd.testing.assert_frame_equal(got.data, tr.data)
        assert got.release_frame == tr.release_frame and got.release_t_s == tr.release_t_s
        assert got.frame_shape == tr.frame_shape and got.notes == tr.notes
        assert got.to_dict() == tr.to_dict()
    pd.testing.assert_frame_equal(f.world.data, world.data)
    assert f.world.to_dict() == world.to_dict()


@settings(max_examples=15, deadline=None)
@given(n=st.integers(1, 40), seed=st.integers(0, 10 ** 6), views=st.sampled_from(
    [("front",), ("top",), ("front", "top")]), with_world=st.booleans())
def test_round_trip_property(tmp_path_factory, n, seed, views, with_world):
    rng = np.random.default_rng(seed)
    tracks = {v: _track(v, n, rng, release=None if seed % 2 else 0) for v in views}
    world = _world(n, rng) if with_world else None
    path = write_tracks(tmp_path_factory.mktemp("h5") / "tracks.h5", tracks, world)
    f = read_tracks(path)
    assert set(f.tracks) == set(views)
    for v in views:
        pd.testing.assert_frame_equal(f.tracks[v].data, tracks[v].data)
    assert (f.world is None) == (world is None)


def test_failed_write_leaves_nothing(tmp_path):
    rng = np.random.default_rng(3)
    good = _track("front", 10, rng)
    bad = Track(data=good.data.drop(columns=["length_px"]), **{
        k: getattr(good, k) for k in ("view", "release_frame", "release_note", "release_t_s",
                                      "fps", "frame_shape", "noise_sigma", "k_sigma",
                                      "straw_level", "scatter_px", "notes")})
    target = tmp_path / "tracks.h5"
    write_tracks(target, {"front": good})
    before = target.read_bytes()
    with pytest.raises(TrackError, match="length_px"):
        write_tracks(target, {"front": bad})
    with pytest.raises(TrackError, match="unknown view"):
        write_tracks(target, {"side": good})
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tracks.h5"]


def test_read_errors(tmp_path):
    with pytest.raises(TrackError, match="no such file"):
        read_tracks(tmp_path / "missing.h5")
    (tmp_path / "text.h5").write_text("not hdf5")
    with pytest.raises(TrackError, match="HDF5"):
        read_tracks(tmp_path / "text.h5")
    with h5py.File(tmp_path / "other.h5", "w") as h:
        h.create_dataset("x", data=[1, 2])
    with pytest.raises(TrackError, match="vidtrack_version"):
        read_tracks(tmp_path / "other.h5")
    rng = np.random.default_rng(4)
    path = write_tracks(tmp_path / "cut.h5", {"front": _track("front", 5, rng)})
    with h5py.File(path, "a") as h:
        del h["front"]["u_px"]
    with pytest.raises(TrackError, match="u_px"):
        read_tracks(path)


# -- tracks.csv and world.csv beside tracks.h5 -------------------------------------------

#: docs/tracker.md's flag table (bit -> name), typed from the documentation.
FLAG_NAMES = {1: "BORDER", 2: "BLADE", 4: "MERGED", 8: "LOST", 16: "PREDICTED",
              32: "PRE_RELEASE", 64: "OUTLIER", 128: "APPEARANCE", 256: "EXCLUDED"}
TRACKS_CSV_FIRST = ["view", "frame", "t_s", "u_px", "v_px", "flags"]


def _expected_flag_names(value):
    return "|".join(name for bit, name in sorted(FLAG_NAMES.items()) if int(value) & bit)


def _h5_contents(path):
    """Every dataset of tracks.h5, read with h5py itself: ({view: {name: array}}, world)."""
    with h5py.File(path, "r") as h:
        views = {v: {c: h[v][c][()] for c in h[v]} for v in ("front", "top") if v in h}
        world = {c: h["world"][c][()] for c in h["world"]} if "world" in h else None
    return views, world


def _assert_tables_match_h5(folder):
    """tracks.csv and world.csv, read by pandas.read_csv with its defaults, hold exactly
    what tracks.h5 holds (h5py's reading, not the code's Track objects)."""
    import csv

    views, world = _h5_contents(folder / "tracks.h5")
    table = pd.read_csv(folder / "tracks.csv")
    assert list(table.columns[:6]) == TRACKS_CSV_FIRST
    # flag_names last, but for the flight tracker's reason after it (docs/fit-outputs.md)
    last = ["flag_names", "reason"] if "reason" in table else ["flag_names"]
    assert list(table.columns[-len(last):]) == last
    for cols in views.values():
        # every per-frame dataset of the view, and nothing else (no index column)
        assert set(table.columns) == set(cols) | {"view", "flag_names"}
    assert list(dict.fromkeys(table["view"])) == list(views)       # front, then top
    for v, cols in views.items():
        rows = table[table["view"] == v]
        for c, values in cols.items():
            got = rows[c].to_numpy()
            assert got.shape == values.shape, (v, c)
            if values.dtype.kind == "i":
                assert got.dtype.kind == "i", (v, c)             # integers stay integers
                assert (got == values).all(), (v, c)
            elif values.dtype.kind in "SO":
                # text (the flight tracker's reason): UTF-8 in tracks.h5, an empty cell
                # for an empty text
                want = [x.decode() if isinstance(x, bytes) else str(x) for x in values]
                assert rows[c].fillna("").tolist() == want, (v, c)
            else:
                # the same float64 bits (NaN where tracks.h5 has NaN)
                np.testing.assert_array_equal(got, values, err_msg=f"{v} {c}", strict=True)
        names = rows["flag_names"].fillna("").tolist()
        assert names == [_expected_flag_names(f) for f in cols["flags"]]
    # NaN is an empty cell in the text, never "nan"
    with open(folder / "tracks.csv", newline="") as f:
        raw = list(csv.reader(f))
    assert raw[0] == list(table.columns)
    u = raw[0].index("u_px")
    all_u = np.concatenate([views[v]["u_px"] for v in views])
    assert [r[u] == "" for r in raw[1:]] == list(np.isnan(all_u))
    assert "nan" not in (folder / "tracks.csv").read_text().lower()

    wt = pd.read_csv(folder / "world.csv")
    assert list(wt.columns) == list(world) and list(wt.columns[:4]) == ["t_s", "x_m", "y_m",
                                                                         "z_m"]
    for c, values in world.items():
        np.testing.assert_array_equal(wt[c].to_numpy(dtype=np.float64), values,
                                      err_msg=f"world {c}", strict=True)
    with open(folder / "world.csv", newline="") as f:
        raw = list(csv.reader(f))
    for i, c in enumerate(raw[0]):
        assert [r[i] == "" for r in raw[1:]] == list(np.isnan(world[c])), c
    return table, wt


def test_tables_hold_what_tracks_h5_holds(tmp_path):
    from vidtrack.run.tracks_file import write_tables

    rng = np.random.default_rng(5)
    tracks = {"front": _track("front", 30, rng), "top": _track("top", 25, rng, release=None)}
    tracks["top"].data.loc[3, "flags"] = 4 | 1 | 32          # several bits at once
    world = _world(20, rng)
    world.data.loc[4, "y_m"] = np.nan
    out = tmp_path / "vidtrack"
    write_tracks(out / "tracks.h5", tracks, world)
    written = write_tables(out, tracks, world)
    assert sorted(p.name for p in written) == ["tracks.csv", "world.csv"]
    assert sorted(p.name for p in out.iterdir()) == ["tracks.csv", "tracks.h5", "world.csv"]
    table, wt = _assert_tables_match_h5(out)
    assert table.loc[(table["view"] == "top") & (table["frame"] == 13),
                     "flag_names"].item() == "BORDER|MERGED|PRE_RELEASE"
    assert len(table) == 55 and len(wt) == 20
    assert wt["z_m"].isna().all() and wt["y_m"].isna().sum() == 1


def test_tables_are_written_whole_or_not_at_all(tmp_path):
    from vidtrack.run.tracks_file import write_tables

    rng = np.random.default_rng(6)
    good = _track("front", 10, rng)
    write_tables(tmp_path, {"front": good})
    before = (tmp_path / "tracks.csv").read_bytes()
    bad = Track(data=good.data.drop(columns=["angle_rad"]), **{
        k: getattr(good, k) for k in ("view", "release_frame", "release_note", "release_t_s",
                                      "fps", "frame_shape", "noise_sigma", "k_sigma",
                                      "straw_level", "scatter_px", "notes")})
    with pytest.raises(TrackError, match="angle_rad"):
        write_tables(tmp_path, {"front": bad})
    with pytest.raises(TrackError, match="unknown view"):
        write_tables(tmp_path, {"side": good})
    assert (tmp_path / "tracks.csv").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tracks.csv"]   # no world, no .part


@pytest.fixture(scope="module")
def run42_fitted(tmp_path_factory):
    """datasets/run42 (without its outputs) fitted by the real command line."""
    import shutil

    from conftest import REPO, run_vidtrack

    run = tmp_path_factory.mktemp("csv") / "run42"
    shutil.copytree(REPO / "datasets" / "run42", run, ignore=shutil.ignore_patterns("vidtrack"))
    res = run_vidtrack("fit", run, "-q")
    assert res.returncode == 0, res.stderr
    return run


def test_fit_writes_tables_that_read_back_as_tracks_h5(run42_fitted):
    out = run42_fitted / "vidtrack"
    table, wt = _assert_tables_match_h5(out)
    # run42: 372 frames in each view (datasets/README.md), the ride on the rotor flagged
    assert (table["view"] == "front").sum() == 372 and (table["view"] == "top").sum() == 372
    assert table["flag_names"].fillna("").str.contains("PRE_RELEASE").any()
    assert wt["x_m"].notna().all() and wt["y_m"].notna().sum() > 300
    assert not list(out.glob(".*.part"))


def test_reused_tracks_write_missing_or_outdated_tables(run42_fitted):
    import json
    import os

    from conftest import run_vidtrack

    out = run42_fitted / "vidtrack"
    if not (out / "tracks.csv").exists():                       # the test above may not run
        assert run_vidtrack("fit", run42_fitted, "-q").returncode == 0
    first = {n: (out / n).read_bytes() for n in ("tracks.csv", "world.csv")}
    h5_before = (out / "tracks.h5").stat().st_mtime_ns
    for n in first:
        (out / n).unlink()
    res = run_vidtrack("fit", run42_fitted, "-q")
    assert res.returncode == 0, res.stderr
    assert (out / "tracks.h5").stat().st_mtime_ns == h5_before          # the tracks reused
    assert {n: (out / n).read_bytes() for n in first} == first           # written again
    _assert_tables_match_h5(out)

    # tracks.h5 edited by hand (a frame flagged OUTLIER): the tables follow the file
    with h5py.File(out / "tracks.h5", "a") as h:
        flags = h["front"]["flags"][()]
        i = int(np.flatnonzero(flags == 0)[0])
        flags[i] = 64
        h["front"]["flags"][...] = flags
    later = (out / "tracks.csv").stat().st_mtime_ns + 1_000_000_000      # a second later
    os.utime(out / "tracks.h5", ns=(later, later))
    res = run_vidtrack("fit", run42_fitted, "--json", "-q")
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["stages_reused"] == ["tracks"]
    table, _ = _assert_tables_match_h5(out)
    row = table[(table["view"] == "front")].iloc[i]
    assert row["flags"] == 64 and row["flag_names"] == "OUTLIER"
