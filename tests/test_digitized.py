"""vidtrack.track.digitized: points placed in DLTdv, Tracker or a spreadsheet, as a track.

The files are written here by hand in each tool's layout; the real DLTdv7 export of the
three-camera rig is read when ../shared is present.
"""

import numpy as np
import pytest

from vidtrack.errors import SceneError
from vidtrack.track.digitized import read_points

XYPTS = """pt1_cam1_X,pt1_cam1_Y,pt1_cam2_X,pt1_cam2_Y,pt2_cam1_X,pt2_cam1_Y,pt2_cam2_X,pt2_cam2_Y
NaN,NaN,10.5,20.25,1,2,3,4
100.5,200.25,NaN,NaN,5,6,7,8
101.5,199.0,12.0,21.0,9,10,11,12
"""

TRACKER = "mass_A\nt\tx\ty\n0.000000000E0\t10.5\t20.0\n3.333333333E-2\t11.5\t19.0\n" \
          "6.666666667E-2\t12.5\t18.5\n"


def test_dltdv_camera_and_point(tmp_path):
    f = tmp_path / "xypts.csv"
    f.write_text(XYPTS)
    tr = read_points(f, fps=25, fmt="dltdv", camera=1, point=1, view="cam1")
    assert tr.data["frame"].tolist() == [0, 1, 2]
    np.testing.assert_array_equal(tr.data["t_s"], [0, 0.04, 0.08])
    assert np.isnan(tr.data.loc[0, "u_px"]) and tr.usable.tolist() == [False, True, True]
    assert tr.data.loc[2, ["u_px", "v_px"]].tolist() == [101.5, 199.0]
    tr2 = read_points(f, fps=25, fmt="dltdv", camera=2, point=2)
    assert tr2.data["u_px"].tolist() == [3, 7, 11]
    with pytest.raises(SceneError, match=r"points \[1, 2\] and cameras \[1, 2\]; asked for "
                                         r"point 1 of camera 3"):
        read_points(f, fps=25, fmt="dltdv", camera=3)


def test_tracker_table(tmp_path):
    f = tmp_path / "tracker.txt"
    f.write_text(TRACKER)
    tr = read_points(f, fps=30, fmt="tracker")
    assert tr.data["frame"].tolist() == [0, 1, 2]
    assert tr.data["u_px"].tolist() == [10.5, 11.5, 12.5]
    with pytest.raises(SceneError, match="not on the frames of fps = 25"):
        read_points(f, fps=25, fmt="tracker")


def test_plain_csv_with_gaps(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("frame,u_px,v_px\n3,1.5,2.5\n5,2.5,3.5\n")
    tr = read_points(f, fps=100)
    assert tr.data["frame"].tolist() == [0, 1, 2, 3, 4, 5]     # time from the file's frame 0
    assert tr.usable.tolist() == [False, False, False, True, False, True]
    assert tr.data["t_s"].iloc[5] == pytest.approx(0.05)


@pytest.mark.parametrize("text, fmt, match", [
    ("", "csv", "empty"),
    ("frame,u,v\n0,1,2\n", "csv", "u_px, v_px missing"),
    ("frame,u_px,v_px\n0,1,2\n0,3,4\n", "csv", "frame 0 appears twice"),
    ("frame,u_px,v_px\n0,x,2\n", "csv", r"row 2, column 'u_px': expected a number, got 'x'"),
    ("frame,u_px,v_px\n1.5,1,2\n", "csv", "whole number"),
    ("frame,u_px,v_px\n0,inf,2\n", "csv", "not finite"),
    ("frame,u_px,v_px\n0,,\n", "csv", "no frame has a point"),
    ("a,b\n1,2\n", "dltdv", "not a DLTdv xypts file"),
    ("name\nt\tu\n0\t1\n", "tracker", "needs columns t, x, y"),
    ("frame,u_px,v_px\n0,1,2\n", "xls", "format must be one of"),
])
def test_bad_files_are_refused_with_where(tmp_path, text, fmt, match):
    f = tmp_path / "p.csv"
    f.write_text(text)
    with pytest.raises(SceneError, match=match) as err:
        read_points(f, fps=30, fmt=fmt, view="cam2")
    assert "view cam2: points p.csv" in str(err.value)


def test_unreadable_files(tmp_path):
    with pytest.raises(SceneError, match="cannot read"):
        read_points(tmp_path / "missing.csv", fps=30)
    f = tmp_path / "latin1.csv"
    f.write_bytes("frame,u_px,v_px\n0,1,2 \xe9\n".encode("latin-1"))
    with pytest.raises(SceneError, match="not UTF-8"):
        read_points(f, fps=30)
    with pytest.raises(SceneError, match="fps must be > 0"):
        read_points(f, fps=0)


def test_real_dltdv7_export(shared_dir):
    f = shared_dir / "data" / "real" / "multicam3_dlt" / "DLTdv7_data_gravityxypts.csv"
    counts = [int(read_points(f, fps=25, fmt="dltdv", camera=c).usable.sum()) for c in (1, 2, 3)]
    assert counts == [16, 25, 27]
