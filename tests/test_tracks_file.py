"""tracks.h5: the SPEC layout read back with h5py itself, round trips, atomic writes."""

import h5py
import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vidtrack import __version__
from vidtrack.errors import TrackError
from vidtrack.world.orthogonal import WorldTrack
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
    data = pd.DataFrame({"t_s": np.arange(n) / 1200.0, "x_m": rng.normal(0.3, 0.1, n),
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
