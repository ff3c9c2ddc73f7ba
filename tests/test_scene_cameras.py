"""vidtrack.scene: calibrated cameras ([world], views of any name, dlt/projection, points).

Every key is checked with one message naming the file, the key and what was expected.
"""

import numpy as np
import pytest
import tomli_w

from vidtrack.errors import SceneError
from vidtrack.scene import load_scene, scene_to_toml

DLT = [-21.149, -176.1, 59.471, 306.75, 24.107, 13.157, 175.82, 96.214, 0.23335, -0.15703,
       0.11534]
P = [[1000.0, 0.0, 640.0, 100.0], [0.0, 1000.0, 360.0, 50.0], [0.0, 0.0, 1.0, 3.0]]
K = [[1000.0, 0.0, 640.0], [0.0, 1000.0, 360.0], [0.0, 0.0, 1.0]]


def base():
    return {"schema": 1, "world": {"up": [0.0, 0.0, 2.0]},
            "views": {"cam1": {"points": "p.csv", "fps": 25, "dlt": DLT,
                               "pixel_origin": "bottom-left"},
                      "cam2": {"source": "cam2.mp4", "fps": 119.12, "projection": P,
                               "intrinsics": K, "distortion": [-0.2, 0.05, 0.0, 0.0, 0.0]}}}


def write(folder, data):
    folder.mkdir(exist_ok=True)
    (folder / "scene.toml").write_text(tomli_w.dumps(data))
    (folder / "p.csv").write_text("frame,u_px,v_px\n0,1,2\n")
    return folder


def test_a_calibrated_scene_loads(tmp_path):
    s = load_scene(write(tmp_path / "run", base()))
    assert s.calibrated and s.view_names == ("cam1", "cam2")
    assert s.world.up == (0.0, 0.0, 1.0) and s.world.forward is None      # normalised
    c1, c2 = s.views["cam1"], s.views["cam2"]
    assert c1.points.format is None and c1.source == tmp_path / "run" / "p.csv"
    assert c1.camera.pixel_origin == "bottom-left" and c1.sync_frame == "auto"
    assert c2.points is None and c2.camera.lens is not None
    M = np.array(P)
    np.testing.assert_allclose(c2.camera.centre, -np.linalg.solve(M[:, :3], M[:, 3]))
    # the writer writes what the loader reads
    again = tmp_path / "again"
    again.mkdir()
    (again / "scene.toml").write_text(scene_to_toml(s.to_dict()))
    (again / "p.csv").write_text("frame,u_px,v_px\n0,1,2\n")
    assert load_scene(again).to_dict() == s.to_dict()
    assert load_scene(again).hash == s.hash


def test_a_calibrated_view_has_a_channel(tmp_path):
    data = base()
    assert load_scene(write(tmp_path / "luma", data)).views["cam2"].channel == "luma"
    data["views"]["cam2"]["channel"] = "blue"
    s = load_scene(write(tmp_path / "run", data))
    assert s.views["cam2"].channel == "blue" and s.views["cam2"].to_dict()["channel"] == "blue"
    assert "channel" not in s.views["cam1"].to_dict()
    again = write(tmp_path / "again", {})
    (again / "scene.toml").write_text(scene_to_toml(s.to_dict()))
    assert load_scene(again).views["cam2"].channel == "blue"


BAD = [
    (lambda d: d["views"]["cam1"].update(dlt=DLT[:10]), "views.cam1.dlt",
     "must be 11 finite numbers"),
    (lambda d: d["views"]["cam1"].update(projection=P), "views.cam1",
     "dlt = .* or projection = 3x4 .* exactly one"),
    (lambda d: d["views"]["cam2"].pop("projection"), "views.cam2", "needs a camera model"),
    (lambda d: d["views"]["cam2"].update(projection=P[:2]), "views.cam2.projection",
     "must be 3 rows of 4 finite numbers"),
    (lambda d: d["views"]["cam2"].update(intrinsics=[[1, 0, 0], [0, 1, 0]]),
     "views.cam2.intrinsics", "must be 3 rows of 3"),
    (lambda d: d["views"]["cam2"].update(distortion=[0.1, 0.2, 0.3]), "views.cam2.distortion",
     "must be 4 or 5 or 8 or 12 or 14 finite numbers"),
    (lambda d: d["views"]["cam2"].pop("intrinsics"), "views.cam2", "distortion needs intrinsics"),
    (lambda d: d["views"]["cam1"].update(intrinsics=K), "views.cam1.intrinsics",
     "goes with projection, not dlt"),
    (lambda d: d["views"]["cam1"].update(pixel_origin="centre"), "views.cam1.pixel_origin",
     "must be \"top-left\" .* or \"bottom-left\""),
    (lambda d: d["views"]["cam2"].update(pixel_origin="bottom-left"), "views.cam2.pixel_origin",
     "must be \"top-left\" with a lens model"),
    (lambda d: d["views"]["cam1"].update(source="a.mp4"), "views.cam1",
     "either source .* or points .*, not both"),
    (lambda d: d["views"]["cam2"].pop("source"), "views.cam2", "not neither"),
    (lambda d: d["views"]["cam1"].update(points={"file": "p.csv", "camera": 0}),
     "views.cam1.points.camera", "must be an integer >= 1"),
    (lambda d: d["views"]["cam1"].update(points={"file": "p.csv", "format": "xls"}),
     "views.cam1.points.format", "must be one of dltdv, tracker, csv"),
    (lambda d: d["views"]["cam1"].update(points="missing.csv"), "views.cam1.points.file",
     "no such file"),
    (lambda d: d["views"]["cam1"].update(axes=["+x", "-y"]), "views.cam1.axes",
     "is not a known key"),
    (lambda d: d["views"]["cam1"].update(fps=0), "views.cam1.fps", "must be > 0"),
    (lambda d: d["world"].update(up=[0, 0, 0]), "world.up", "must not be the zero vector"),
    (lambda d: d["world"].update(up=[0, 1]), "world.up", "must be three finite numbers"),
    (lambda d: d["world"].update(forward=[0, 0, -1]), "world.forward", "is vertical"),
    (lambda d: d["world"].pop("up"), "world.up", "is required"),
    (lambda d: d.pop("world"), "world", "is required with calibrated cameras"),
    (lambda d: d["views"].pop("cam2"), "views", "two or more views"),
    (lambda d: d["world"].update(down=[0, 0, 1]), "world.down", "is not a known key"),
    (lambda d: d["views"]["cam1"].update(channel="red"), "views.cam1.channel",
     "goes with source .*, not points"),
    (lambda d: d["views"]["cam2"].update(channel="purple"), "views.cam2.channel",
     "must be one of \"luma\", \"red\", \"green\", \"blue\", \"chroma\", \"auto\", got "
     "a string 'purple'"),
]


@pytest.mark.parametrize("change, key, message", BAD, ids=[f"{b[1]}-{i}" for i, b in
                                                            enumerate(BAD)])
def test_every_key_is_checked(tmp_path, change, key, message):
    data = base()
    change(data)
    with pytest.raises(SceneError) as err:
        load_scene(write(tmp_path / "run", data))
    text = str(err.value)
    assert text.startswith(str(tmp_path / "run" / "scene.toml")), text
    assert key in text and __import__("re").search(message, text), text
    assert "\n" not in text


def test_points_formats_are_recognised_when_read(tmp_path):
    from vidtrack.track.digitized import read_points, sniff_format

    f = tmp_path / "x.csv"
    f.write_text("pt1_cam1_X,pt1_cam1_Y,pt1_cam2_X,pt1_cam2_Y\n1,2,3,4\n")
    assert sniff_format(f) == "dltdv"
    assert read_points(f, fps=25, camera=2).data["u_px"].tolist() == [3.0]
    f.write_text("mass_A\nt\tx\ty\n0\t1\t2\n")
    assert sniff_format(f) == "tracker"
    f.write_text("frame,u_px,v_px\n0,1,2\n")
    assert sniff_format(f) == "csv"
    f.write_text("a,b\n1,2\n")
    with pytest.raises(SceneError, match="say which with points.format"):
        read_points(f, fps=25, view="cam1")
