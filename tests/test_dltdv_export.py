"""vidtrack.run.dltdv_export: the run's points in DLTdv's layout, read back by the reader
of DLTdv files (vidtrack.track.digitized) and compared with what went in."""

import numpy as np
import pandas as pd
import pytest

from calibration.projective import ProjectiveCamera
from vidtrack.run.dltdv_export import write_dltdv
from vidtrack.track.digitized import read_points
from vidtrack.world.calibrated import triangulate_views
from vidtrack.world.world_track import WorldTrack


def test_round_trip_through_dltdv_files(shared_dir, tmp_path):
    d = shared_dir / "data" / "real" / "multicam3_dlt"
    src = d / "DLTdv7_data_gravityxypts.csv"
    L = np.loadtxt(d / "2018-08-17_wand_dltCoefs.csv", delimiter=",")
    cams = {f"cam{j + 1}": ProjectiveCamera.from_dlt(L[:, j], pixel_origin="bottom-left",
                                                     name=f"cam{j + 1}") for j in range(3)}
    tracks = {n: read_points(src, fps=25, camera=j + 1, view=n) for j, n in enumerate(cams)}
    world = triangulate_views(tracks, cams, fps=dict.fromkeys(cams, 25.0),
                              sync=dict.fromkeys(cams, 0), up=[0, 0, 1])
    files = write_dltdv(tmp_path, tracks, world, cameras=cams)
    assert [f.name for f in files] == ["xypts.csv", "xyzpts.csv", "xypts_cameras.txt"]
    original = pd.read_csv(src)
    exported = pd.read_csv(tmp_path / "xypts.csv")
    # the same pixels in the same columns; rows up to the last frame any camera saw
    n = len(exported)
    np.testing.assert_array_equal(exported.to_numpy(), original.to_numpy()[:n])
    assert original.iloc[n:].isna().all().all()
    for j, name in enumerate(cams):
        back = read_points(tmp_path / "xypts.csv", fps=25, camera=j + 1)
        np.testing.assert_array_equal(back.usable, tracks[name].usable[: len(back.usable)])
    xyz = pd.read_csv(tmp_path / "xyzpts.csv")
    ok = world.data["flags"].to_numpy() == 0
    np.testing.assert_allclose(xyz.to_numpy()[ok], world.data[["X_m", "Y_m", "Z_m"]][ok])
    assert xyz.to_numpy()[~ok].size == 0 or np.isnan(xyz.to_numpy()[~ok]).all()
    assert (tmp_path / "xypts_cameras.txt").read_text() == "cam1 = cam1\ncam2 = cam2\ncam3 = cam3\n"


def test_tracked_pixels_are_flipped_for_a_bottom_left_camera(tmp_path):
    from vidtrack.track.tracker import Track

    data = pd.DataFrame({"frame": [0, 1], "t_s": [0, 0.01], "u_px": [10.0, 11.0],
                         "v_px": [100.0, 90.0], "area_px": [5.0, 5.0], "angle_rad": [0.0, 0.0],
                         "length_px": [3.0, 3.0], "flags": [0, 0]})
    tr = Track(data=data, view="a", release_frame=None, release_note="", release_t_s=None,
               fps=100.0, frame_shape=(480, 640), noise_sigma=1.0, k_sigma=5.0,
               straw_level=200.0, scatter_px=0.1)
    cam = ProjectiveCamera.from_dlt([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0.1],
                                    pixel_origin="bottom-left")
    world = WorldTrack(data=pd.DataFrame({"frame": [0], "t_s": [0.0], "x_m": [1.0],
                                          "y_m": [2.0], "z_m": [3.0]}),
                       t0_s={"a": 0.0}, sync={"a": "sync_frame 0"}, reference="a")
    write_dltdv(tmp_path, {"a": tr}, world, cameras={"a": cam})
    xy = pd.read_csv(tmp_path / "xypts.csv")
    assert xy["pt1_cam1_Y"].tolist() == pytest.approx([380.0, 390.0])
    assert pd.read_csv(tmp_path / "xyzpts.csv").iloc[0].tolist() == [1.0, 2.0, 3.0]


def test_fit_writes_the_dltdv_files_beside_the_tracks(tmp_path, vidtrack_cli):
    """`vidtrack fit` on the bundled run writes xypts.csv with tracks.csv's unflagged
    pixels (read back by the DLTdv reader), and writes a deleted one again on reuse."""
    import shutil
    from pathlib import Path

    run = tmp_path / "run42"
    shutil.copytree(Path(__file__).resolve().parents[1] / "datasets" / "run42", run,
                    ignore=shutil.ignore_patterns("vidtrack"))
    r = vidtrack_cli("fit", run, "--no-report")
    assert r.returncode == 0, r.stderr
    out = run / "vidtrack"
    assert (out / "xypts_cameras.txt").read_text() == "cam1 = front\ncam2 = top\n"
    tracks = pd.read_csv(out / "tracks.csv")
    for c, view in enumerate(("front", "top"), start=1):
        t = tracks[(tracks["view"] == view) & (tracks["flags"] == 0)]
        back = read_points(out / "xypts.csv", fps=1200, camera=c)
        d = back.data.set_index("frame").loc[t["frame"]]
        np.testing.assert_allclose(d["u_px"].to_numpy(), t["u_px"].to_numpy(), rtol=1e-12)
        np.testing.assert_allclose(d["v_px"].to_numpy(), t["v_px"].to_numpy(), rtol=1e-12)
        assert int(back.usable.sum()) == len(t)
    (out / "xypts.csv").unlink()
    r = vidtrack_cli("fit", run, "--no-report")
    assert r.returncode == 0 and "xypts.csv is missing; written again" in r.stderr
    assert (out / "xypts.csv").is_file()
