"""vidtrack.scene: scene.toml schema 1 and experiment.toml, as docs/scene.md gives them.

The examples are read from the user's page (docs/scene.md) and, where ../shared is beside
the checkout, from the team's contract of the same files (SPEC.md): both must load.

Every bad value must be refused with a SceneError naming the file, the key path and
what was expected; the writer must write what the loader reads.
"""

import copy
import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest
import tomli_w
from hypothesis import given, settings
from hypothesis import strategies as st

from calibration.calibration_file import calibration_to_toml
from calibration.camera import CameraCalibration, distort_points
from calibration.scale import ruler_scale
from vidtrack.errors import SceneError
from vidtrack.scene import (
    find_throw_dirs,
    load_experiment,
    load_scene,
    parse_scene,
    scene_to_toml,
    throw_scene,
    write_scene,
)


DOCS_SCENE = Path(__file__).resolve().parents[1] / "docs" / "scene.md"


def toml_block(path, heading):
    """The first ```toml block after ``heading`` in the Markdown file ``path``."""
    text = path.read_text(encoding="utf-8")
    start = text.index(heading)
    m = re.search(r"```toml\n(.*?)```", text[start:], re.S)
    return m.group(1)


def example(request, docs_heading, spec_heading):
    """The example of docs/scene.md, or (param "contract") that of ../shared/SPEC.md."""
    if request.param == "docs":
        return toml_block(DOCS_SCENE, docs_heading)
    return toml_block(request.getfixturevalue("shared_dir") / "SPEC.md", spec_heading)


@pytest.fixture(params=["docs", "contract"])
def spec_scene(request):
    return example(request, "## A complete example", "## scene.toml (schema 1)")


def base():
    """A valid scene dict (the SPEC example's content)."""
    return {
        "schema": 1,
        "run": {"name": "run42"},
        "factors": {"n_rpm": 550, "blade_angle_deg": 0, "speed_kmh": 7.2},
        "physics": {"gravity_m_s2": 9.80665, "air_density_kg_m3": 1.205},
        "straw": {"mass_kg": 0.080, "area_m2": 0.0172, "drag_coefficient": 1.0},
        "machine": {"speed_kmh": 7.2},
        "views": {
            "front": {"source": "front.avi", "fps": 1200, "axes": ["+x", "-y"],
                      "origin_px": [40.0, 330.0],
                      "ruler": {"length_m": 0.5, "from_px": [80, 482], "to_px": [205, 482]}},
            "top": {"source": "top.avi", "fps": 1200, "axes": ["+x", "+z"],
                    "origin_px": [40.0, 300.0],
                    "ruler": {"length_m": 0.5, "from_px": [80, 482], "to_px": [205, 482]}},
        },
    }


def write_raw(folder, data):
    """Write a dict as scene.toml WITHOUT validation (to feed the loader bad files)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "scene.toml"
    path.write_text(tomli_w.dumps(data), encoding="utf-8")
    return path


# ----------------------------------------------------------------- the SPEC example


def test_spec_example_loads(tmp_path, spec_scene):
    run = tmp_path / "run42"
    run.mkdir()
    (run / "scene.toml").write_text(spec_scene, encoding="utf-8")
    s = load_scene(run)
    assert s.run_name == "run42"
    assert s.factors == {"n_rpm": 550, "blade_angle_deg": 0, "speed_kmh": 7.2}
    assert s.physics.gravity_m_s2 == 9.80665 and s.physics.air_density_kg_m3 == 1.205
    # Cp = sqrt(C a_s rho / (2 m g)) by hand: sqrt(1.0 * 0.0172 * 1.205 / (2 * 0.08 * 9.80665))
    assert s.cp_s_per_m == pytest.approx(0.114931, rel=1e-5)
    assert s.cp_s_per_m == pytest.approx(0.115, rel=1e-2)   # the example's commented value
    assert s.v1_m_s == pytest.approx(2.0)                   # 7.2 km/h
    assert s.view_names == ("front", "top")
    front, top = s.views["front"], s.views["top"]
    assert front.source == run / "front.avi" and front.source_text == "front.avi"
    assert front.fps == 1200.0 and front.axes == ("+x", "-y")
    assert front.origin_px == (40.0, 330.0)
    assert front.m_per_px == pytest.approx(0.004)            # 0.5 m / 125 px
    assert front.scale.method == "ruler" and front.scale.span_px == 125.0
    assert front.frames is None and front.sync_frame == "auto"
    assert front.world_axes == ("x", "y") and top.world_axes == ("x", "z")
    assert top.axes == ("+x", "+z")
    assert len(s.hash) == 64
    # The mapping of the view: 125 px right of O is 0.5 m along X.
    assert np.allclose(front.mapping().pixel_to_world([165.0, 330.0]), [0.5, 0.0])


def test_load_by_file_path_and_default_name(tmp_path):
    data = base()
    del data["run"]
    path = write_raw(tmp_path / "run07", data)
    s = load_scene(path)
    assert s.run_name == "run07"
    assert s.path == path and s.folder == tmp_path / "run07"


def test_defaults(tmp_path):
    data = base()
    for key in ("physics", "straw", "machine", "factors", "run"):
        del data[key]
    del data["views"]["top"]
    s = load_scene(write_raw(tmp_path / "r", data))
    assert s.physics.gravity_m_s2 == 9.80665 and s.physics.air_density_kg_m3 == 1.205
    assert s.cp_s_per_m is None
    assert "straw.mass_kg" in s.straw.cp_missing
    assert s.machine_speed_kmh == 0.0 and s.machine_speed_from == "default"
    assert s.factors == {} and s.view_names == ("front",)


def test_machine_speed_from_factors(tmp_path):
    data = base()
    del data["machine"]
    data["factors"]["speed_kmh"] = 9.0
    s = load_scene(write_raw(tmp_path / "r", data))
    assert s.machine_speed_kmh == 9.0 and s.machine_speed_from == "factors"
    assert s.v1_m_s == pytest.approx(2.5)


def test_cp_given_directly(tmp_path):
    data = base()
    data["straw"] = {"cp_s_per_m": 0.115}
    assert load_scene(write_raw(tmp_path / "a", data)).cp_s_per_m == 0.115
    data["straw"] = {"cp_s_per_m": 0.0}          # no drag is a valid scene
    assert load_scene(write_raw(tmp_path / "b", data)).cp_s_per_m == 0.0
    # Both, agreeing within 1 %: the given one is used.
    data["straw"] = {"mass_kg": 0.080, "area_m2": 0.0172, "drag_coefficient": 1.0,
                     "cp_s_per_m": 0.115}
    assert load_scene(write_raw(tmp_path / "c", data)).cp_s_per_m == 0.115


def test_m_per_px_and_frames_and_sync(tmp_path):
    data = base()
    v = data["views"]["front"]
    del v["ruler"]
    v.update(m_per_px=0.004, frames=[10, 490], sync_frame=12)
    s = load_scene(write_raw(tmp_path / "r", data))
    f = s.views["front"]
    assert f.m_per_px == 0.004 and f.scale.method == "given" and f.m_per_px_given == 0.004
    assert f.frames == (10, 490) and f.sync_frame == 12


# ----------------------------------------------------------------- bad values

def _set(path, value):
    def mutate(d):
        *head, last = path.split(".")
        for k in head:
            d = d[k]
        if value is DELETE:
            del d[last]
        else:
            d[last] = value
    return mutate


DELETE = object()


def _ruler_to_given(value, *, rel=None):
    """The front view's scale given as m_per_px = value instead of its ruler (and its
    m_per_px_rel_uncertainty = rel when given)."""
    def mutate(d):
        del d["views"]["front"]["ruler"]
        d["views"]["front"]["m_per_px"] = value
        if rel is not None:
            d["views"]["front"]["m_per_px_rel_uncertainty"] = rel
    return mutate

BAD = [
    # (mutation, key path in the message, the rest of the message)
    (_set("views.front.fps", 0), "views.front.fps", "must be > 0, got 0"),
    (_set("views.front.fps", -30.0), "views.front.fps", "must be > 0, got -30.0"),
    (_set("views.front.fps", "1200"), "views.front.fps", "must be a number, got a string '1200'"),
    (_set("views.front.fps", True), "views.front.fps", "must be a number, got a boolean"),
    (_set("views.front.fps", math.nan), "views.front.fps", "must be a finite number, got nan"),
    (_set("views.front.fps", 1e-300), "views.front.fps",
     "must be between 0.1 and 1e+07 frames/s, got 1e-300"),
    (_set("views.front.fps", 1e300), "views.front.fps",
     "must be between 0.1 and 1e+07 frames/s, got 1e+300"),
    (_set("views.front.fps", DELETE), "views.front.fps", "is required"),
    (_set("views.front.source", DELETE), "views.front.source", "is required"),
    (_set("views.front.source", 3), "views.front.source", "must be a string, got an integer 3"),
    (_set("views.front.source", " "), "views.front.source", "must not be empty"),
    (_set("views.front.ruler.to_px", [80, 482]), "views.front.ruler",
     "spans 0 pixels: from_px [80.0, 482.0] equals to_px [80.0, 482.0]"),
    (_set("views.front.ruler.length_m", 0), "views.front.ruler.length_m", "must be > 0, got 0"),
    (_set("views.front.ruler.from_px", DELETE), "views.front.ruler.from_px", "is required"),
    (_set("views.front.ruler.from_px", [1, 2, 3]), "views.front.ruler.from_px",
     "must be two numbers [u, v] in pixels, got [1, 2, 3]"),
    (_set("views.front.ruler.width", 1), "views.front.ruler.width", "is not a known key"),
    (_set("views.front.ruler", 0.004), "views.front.ruler", "must be a table"),
    (_set("views.front.axes", ["+x", "+x"]), "views.front.axes",
     "must be two different world axes, got [\"+x\", \"+x\"]"),
    (_set("views.front.axes", ["+y", "-y"]), "views.front.axes",
     "must be two different world axes"),
    (_set("views.front.axes", ["+x", "down"]), "views.front.axes", "must be two of"),
    (_set("views.front.axes", ["+x"]), "views.front.axes", "must be two of"),
    (_set("views.front.axes", "+x-y"), "views.front.axes", "must be two of"),
    (_set("views.front.axes", ["+x", "+z"]), "views.front.axes",
     "must be the world axes x and y (the front view sees X and Y)"),
    (_set("views.top.axes", ["+x", "-y"]), "views.top.axes",
     "must be the world axes x and z (the top view sees X and Z)"),
    (_set("views.front.axes", DELETE), "views.front.axes", "is required"),
    (_set("views.front.origin_px", DELETE), "views.front.origin_px", "is required"),
    (_set("views.front.origin_px", ["a", 1]), "views.front.origin_px", "must be two numbers"),
    (_set("views.front.m_per_px", 0.004), "views.front", "gives two scales (ruler and m_per_px)"),
    (_set("views.front.ruler", DELETE), "views.front", "needs a scale"),
    (_set("views.front.m_per_px", 0), "views.front.m_per_px", "must be > 0, got 0"),
    (_ruler_to_given(1e-300), "views.front.m_per_px",
     "must be between 1e-09 and 1000 m per pixel, got 1e-300"),
    (_ruler_to_given(math.inf), "views.front.m_per_px", "must be a finite number, got inf"),
    (_set("views.front.ruler.length_m", 1e300), "views.front.ruler",
     "expected a scale between 1e-09 and 1000 m per pixel"),
    (_set("views.front.frames", [10, 5]), "views.front.frames",
     "must be a non-empty range [first, end) with 0 <= first < end, got [10, 5]"),
    (_set("views.front.frames", [5, 5]), "views.front.frames", "must be a non-empty range"),
    (_set("views.front.frames", [-1, 5]), "views.front.frames", "must be a non-empty range"),
    (_set("views.front.frames", [0.5, 5]), "views.front.frames", "must be two integers"),
    (_set("views.front.frames", [0, 5, 9]), "views.front.frames", "must be two integers"),
    (_set("views.front.sync_frame", -1), "views.front.sync_frame", "must be >= 0"),
    (_set("views.front.sync_frame", "soon"), "views.front.sync_frame",
     "must be a frame index (an integer >= 0) or \"auto\", got a string 'soon'"),
    (_set("views.front.sync_frame", 1.5), "views.front.sync_frame", "must be a frame index"),
    (_set("views.front.fsp", 30), "views.front.fsp", "is not a known key (did you mean 'fps'?)"),
    (_set("views.front.calibration", 5), "views.front.calibration", "must be a string"),
    (_set("views.side", {"source": "s.avi"}), "views.side",
     "is not a view name; expected front or top"),
    (_set("views.fornt", {"source": "s.avi"}), "views.fornt", "did you mean 'front'?"),
    (_set("views", {}), "views", "must have a front or a top view (or both), got none"),
    (_set("views", DELETE), "views", "is required"),
    (_set("views", 3), "views", "must be a table"),
    (_set("views.front", "front.avi"), "views.front", "must be a table"),
    (_set("colour", "red"), "colour", "is not a known key"),
    (_set("schema", 2), "schema", "must be 1"),
    (_set("schema", DELETE), "schema", "is required"),
    (_set("run.name", 5), "run.name", "must be a string"),
    (_set("run.title", "x"), "run.title", "is not a known key"),
    (_set("straw.mass_kg", -0.08), "straw.mass_kg", "must be > 0, got -0.08"),
    (_set("straw.mass_kg", 0), "straw.mass_kg", "must be > 0, got 0"),
    (_set("straw.area_m2", 0), "straw.area_m2", "must be > 0, got 0"),
    (_set("straw.drag_coefficient", -1), "straw.drag_coefficient", "must be >= 0, got -1"),
    (_set("straw.cp_s_per_m", -0.1), "straw.cp_s_per_m", "must be >= 0, got -0.1"),
    (_set("straw.cp_s_per_m", 0.2), "straw.cp_s_per_m",
     "= 0.2 disagrees with sqrt(C a_s rho / (2 m g)) = 0.114931"),
    (_set("straw.length_m", 0.2), "straw.length_m", "is not a known key"),
    (_set("physics.gravity_m_s2", 0), "physics.gravity_m_s2", "must be > 0, got 0"),
    (_set("physics.air_density_kg_m3", -1.2), "physics.air_density_kg_m3", "must be >= 0"),
    (_set("machine.speed_kmh", -7.2), "machine.speed_kmh", "must be >= 0, got -7.2"),
    (_set("machine.speed_kmh", "fast"), "machine.speed_kmh", "must be a number"),
    (_set("factors.n_rpm", [550]), "factors.n_rpm", "must be a number or a string"),
    (_set("factors.n_rpm", {"value": 550}), "factors.n_rpm", "must be a number or a string"),
    (_set("views.front.ruler.px_uncertainty", -0.5), "views.front.ruler.px_uncertainty",
     "must be >= 0, got -0.5"),
    (_set("views.front.ruler.px_uncertainty", "half"), "views.front.ruler.px_uncertainty",
     "must be a number, got a string 'half'"),
    (_set("views.front.ruler.px_uncertainty", 1e3), "views.front.ruler.px_uncertainty",
     "must be between 0 and 100 px"),
    (_set("views.front.ruler.px_uncertainty", 50), "views.front.ruler.px_uncertainty",
     "= 50 px on a ruler of 125 px gives a scale uncertain by 56.6 %"),
    (_set("views.front.m_per_px_rel_uncertainty", 0.01), "views.front.m_per_px_rel_uncertainty",
     "is for a scale given directly"),
    (_ruler_to_given(0.004, rel=0.7), "views.front.m_per_px_rel_uncertainty",
     "must be between 0 and 0.5 (a relative standard uncertainty, e.g. 0.005 for 0.5 %), "
     "got 0.7"),
    (_ruler_to_given(0.004, rel=-0.01), "views.front.m_per_px_rel_uncertainty",
     "must be >= 0, got -0.01"),
    (_ruler_to_given(0.004, rel="1 %"), "views.front.m_per_px_rel_uncertainty",
     "must be a number, got a string '1 %'"),
]


@pytest.mark.parametrize("mutate,key,message", BAD,
                         ids=[f"{k}:{m[:30]}" for _, k, m in BAD])
def test_bad_values_are_named(tmp_path, mutate, key, message):
    data = base()
    mutate(data)
    path = write_raw(tmp_path / "run07", data)
    with pytest.raises(SceneError) as info:
        load_scene(tmp_path / "run07")
    msg = str(info.value)
    assert msg.startswith(f"{path}: {key} "), msg     # the file, then the key path
    assert message in msg, msg                        # what was expected, what came
    assert "\n" not in msg


def test_scale_uncertainty_keys(tmp_path):
    # a ruler's ends: half a pixel unless stated; rel = sqrt(2) sigma / N (N = 125 px here)
    s = load_scene(write_raw(tmp_path / "a", base()))
    rel, how = s.views["front"].scale_rel_uncertainty
    assert s.views["front"].ruler.px_uncertainty == 0.5
    assert rel == pytest.approx(math.sqrt(2) * 0.5 / 125, rel=1e-12) and "125 px" in how
    data = base()
    data["views"]["front"]["ruler"]["px_uncertainty"] = 0.2
    _ruler_to_given(0.004, rel=0.008)(data)           # the front view by m_per_px now
    data["views"]["top"]["ruler"]["px_uncertainty"] = 0.2
    s2 = load_scene(write_raw(tmp_path / "b", data))
    assert s2.views["front"].scale_rel_uncertainty[0] == 0.008
    assert s2.views["top"].scale_rel_uncertainty[0] == pytest.approx(
        math.sqrt(2) * 0.2 / 125, rel=1e-12)
    # written back and read again: the same scene
    again = load_scene(write_scene(tmp_path / "c" / "scene.toml", s2.to_dict()))
    assert again.to_dict()["views"] == s2.to_dict()["views"]
    # a scale given directly without a stated uncertainty: None (taken as exact, said so)
    data = base()
    _ruler_to_given(0.004)(data)
    s3 = load_scene(write_raw(tmp_path / "d", data))
    assert s3.views["front"].scale_rel_uncertainty[0] is None


def test_scale_uncertainty_is_not_in_the_scene_hash(tmp_path):
    # it changes the intervals, not the tracks: the tracks stage keys on the hash
    data = base()
    h0 = load_scene(write_raw(tmp_path / "a", data)).hash
    data["views"]["front"]["ruler"]["px_uncertainty"] = 0.3
    assert load_scene(write_raw(tmp_path / "b", data)).hash == h0
    data["views"]["front"]["ruler"]["to_px"] = [206, 482]
    assert load_scene(write_raw(tmp_path / "c", data)).hash != h0


def test_factor_speed_must_be_a_number_when_it_is_the_default(tmp_path):
    data = base()
    del data["machine"]
    data["factors"]["speed_kmh"] = "fast"
    write_raw(tmp_path / "r", data)
    with pytest.raises(SceneError, match=r"factors\.speed_kmh must be a number"):
        load_scene(tmp_path / "r")


def test_spec_message_form(tmp_path):
    # STYLE.md's own example, word for word after the file name.
    data = base()
    data["views"]["front"]["fps"] = 0
    path = write_raw(tmp_path / "run", data)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value) == f"{path}: views.front.fps must be > 0, got 0"


def test_missing_and_broken_files(tmp_path):
    with pytest.raises(SceneError, match="no such run folder or scene file"):
        load_scene(tmp_path / "nowhere")
    (tmp_path / "empty").mkdir()
    with pytest.raises(SceneError, match=r"empty: no scene.toml in this run folder"):
        load_scene(tmp_path / "empty")
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "scene.toml").write_text("schema = 1\n[views.front\n")
    with pytest.raises(SceneError, match=r"bad/scene.toml: not valid TOML: .*line 2"):
        load_scene(bad)
    (bad / "scene.toml").write_bytes(b"schema = 1\n\xff\xfe")
    with pytest.raises(SceneError, match="not UTF-8"):
        load_scene(bad)


def test_loading_never_writes(tmp_path, spec_scene):
    run = tmp_path / "run"
    run.mkdir()
    (run / "scene.toml").write_text(spec_scene)
    before = sorted(p.name for p in run.iterdir())
    load_scene(run)
    data = base()
    data["views"]["front"]["fps"] = 0
    with pytest.raises(SceneError):
        write_scene(run, data)
    assert sorted(p.name for p in run.iterdir()) == before
    assert (run / "scene.toml").read_text() == spec_scene


# ----------------------------------------------------------------- calibration files


CAM = CameraCalibration(fx=900.0, fy=900.0, cx=320.0, cy=240.0,
                        dist_coeffs=(-0.2, 0.05, 0.0, 0.0, 0.0), image_size=(640, 480))


def test_calibration_file_with_scale(tmp_path):
    run = tmp_path / "run"
    (run / "calibration").mkdir(parents=True)
    (run / "calibration" / "front.toml").write_text(
        calibration_to_toml(camera=CAM, scale=ruler_scale(0.3, (0, 0), (100, 0))))
    data = base()
    v = data["views"]["front"]
    del v["ruler"]
    v["calibration"] = "calibration/front.toml"
    s = load_scene(write_raw(run, data))
    f = s.views["front"]
    assert f.calibration == run / "calibration" / "front.toml"
    assert f.camera == CAM and f.m_per_px == pytest.approx(0.003)
    assert f.mapping().camera == CAM
    # The calibration is part of the hash: another camera, another hash.
    h1 = s.hash
    (run / "calibration" / "front.toml").write_text(
        calibration_to_toml(camera=dataclasses.replace(CAM, fx=901.0),
                            scale=ruler_scale(0.3, (0, 0), (100, 0))))
    assert load_scene(run).hash != h1


def test_ruler_is_measured_in_undistorted_pixels(tmp_path):
    # Truth: two ideal (pinhole) points 200 px apart, distorted by OpenCV's lens model;
    # the ruler is read on the raw image at the distorted positions.
    ideal = np.array([[100.0, 400.0], [300.0, 400.0]])
    raw = distort_points(ideal, CAM)
    run = tmp_path / "run"
    (run / "cal").mkdir(parents=True)
    (run / "cal" / "cam.toml").write_text(calibration_to_toml(camera=CAM))
    data = base()
    v = data["views"]["front"]
    v["calibration"] = "cal/cam.toml"
    v["ruler"] = {"length_m": 0.5, "from_px": raw[0].tolist(), "to_px": raw[1].tolist()}
    s = load_scene(write_raw(run, data))
    assert s.views["front"].m_per_px == pytest.approx(0.5 / 200.0, rel=1e-9)
    assert abs(np.linalg.norm(raw[1] - raw[0]) - 200.0) > 1.0   # the lens matters here


def test_calibration_file_problems(tmp_path):
    run = tmp_path / "run"
    (run / "cal").mkdir(parents=True)
    data = base()
    data["views"]["front"]["calibration"] = "cal/front.toml"
    write_raw(run, data)
    with pytest.raises(SceneError, match=r"views\.front\.calibration names 'cal/front.toml', "
                                         "but there is no such file"):
        load_scene(run)
    (run / "cal" / "front.toml").write_text("schema = 1\n[camera]\nfx = 0\n")
    with pytest.raises(SceneError, match=r"scene.toml: views\.front\.calibration "
                                         r"\(cal/front.toml\): front.toml: camera\.fx"):
        load_scene(run)
    (run / "cal" / "front.toml").write_text(
        calibration_to_toml(scale=ruler_scale(0.3, (0, 0), (100, 0))))
    with pytest.raises(SceneError, match=r"views\.front gives two scales"):
        load_scene(run)
    (run / "cal" / "front.toml").write_text(calibration_to_toml(camera=CAM))
    del data["views"]["front"]["ruler"]
    write_raw(run, data)
    with pytest.raises(SceneError, match=r"views\.front needs a scale: cal/front.toml has no "
                                         r"\[scale\] table"):
        load_scene(run)


# ----------------------------------------------------------------- writer round trip


def test_round_trip_of_the_spec_example(tmp_path, spec_scene):
    a = tmp_path / "a"
    a.mkdir()
    (a / "scene.toml").write_text(spec_scene)
    s = load_scene(a)
    path = write_scene(tmp_path / "b", s.to_dict())
    assert path == tmp_path / "b" / "scene.toml"
    t = load_scene(path)
    assert dataclasses.replace(t, path=s.path, folder=s.folder,
                               views={k: dataclasses.replace(v, source=s.views[k].source)
                                      for k, v in t.views.items()}) == s
    assert t.hash == s.hash                     # comments and layout do not count
    assert t.to_dict() == s.to_dict()


def test_writer_accepts_numpy_and_tuples(tmp_path):
    data = base()
    data["views"]["front"]["fps"] = np.float64(1200.0)
    data["views"]["front"]["origin_px"] = np.array([40.0, 330.0])
    data["views"]["front"]["frames"] = (np.int64(0), np.int64(480))
    data["views"]["front"]["sync_frame"] = None          # None: key left out
    data["factors"]["n_rpm"] = np.int64(550)
    s = load_scene(write_scene(tmp_path / "run" / "scene.toml", data))
    assert s.views["front"].frames == (0, 480) and s.views["front"].sync_frame == "auto"
    assert s.factors["n_rpm"] == 550 and isinstance(s.factors["n_rpm"], int)


def test_writer_refuses_what_the_loader_would(tmp_path):
    data = base()
    data["views"]["top"]["axes"] = ["+x", "+x"]
    with pytest.raises(SceneError, match=r"views\.top\.axes must be two different"):
        scene_to_toml(data)
    with pytest.raises(SceneError, match=r"views\.top\.axes"):
        write_scene(tmp_path / "r", data)
    assert not (tmp_path / "r" / "scene.toml").exists()


def test_scene_to_toml_is_what_load_reads(tmp_path):
    text = scene_to_toml(base())
    (tmp_path / "scene.toml").write_text(text)
    s = load_scene(tmp_path)
    expected = base()
    assert s.to_dict()["views"]["front"]["ruler"] == {
        "length_m": 0.5, "from_px": [80.0, 482.0], "to_px": [205.0, 482.0]}
    assert s.factors == expected["factors"]
    assert "axes = [\"+x\", \"-y\"]" in text          # compact arrays


finite = st.floats(-1e4, 1e4, allow_nan=False)
positive = st.floats(1e-6, 1e6, allow_nan=False)
capture_rate = st.floats(0.1, 1e7)              # FPS_RANGE
scale = st.floats(1e-9, 1e3)                    # M_PER_PX_RANGE
ruler_length = st.floats(1e-5, 1e3)             # over 1..1415 px: a scale in range
pair = st.tuples(finite, finite).map(list)


@st.composite
def scenes(draw):
    views = {}
    for name, world in (("front", ("x", "y")), ("top", ("x", "z"))):
        if not draw(st.booleans()) and views:
            continue
        order = draw(st.permutations(world))
        axes = [draw(st.sampled_from("+-")) + order[0], draw(st.sampled_from("+-")) + order[1]]
        view = {"source": draw(st.sampled_from(["v.avi", "frames/", "x.cine"])),
                "fps": draw(capture_rate), "axes": axes, "origin_px": draw(pair)}
        if draw(st.booleans()):
            a = draw(pair)
            b = [a[0] + draw(st.floats(1, 1e3)), a[1] + draw(st.floats(-1e3, 1e3))]
            view["ruler"] = {"length_m": draw(ruler_length), "from_px": a, "to_px": b}
        else:
            view["m_per_px"] = draw(scale)
        if draw(st.booleans()):
            first = draw(st.integers(0, 10**6))
            view["frames"] = [first, first + draw(st.integers(1, 10**6))]
        view["sync_frame"] = draw(st.one_of(st.just("auto"), st.integers(0, 10**6)))
        views[name] = view
    data = {"schema": 1, "run": {"name": draw(st.text("abc-_0123", min_size=1, max_size=8))},
            "views": views}
    data["factors"] = draw(st.dictionaries(st.sampled_from(["n_rpm", "angle", "note"]),
                                           st.one_of(finite, st.integers(-100, 100),
                                                     st.text("xyz", min_size=1, max_size=3))))
    if draw(st.booleans()):
        data["straw"] = {"cp_s_per_m": draw(st.floats(0, 10))}
    if draw(st.booleans()):
        data["machine"] = {"speed_kmh": draw(st.floats(0, 50))}
    return data


@settings(max_examples=60, deadline=None)
@given(data=scenes())
def test_write_then_load_round_trip(tmp_path_factory, data):
    folder = tmp_path_factory.mktemp("run")
    s = load_scene(write_scene(folder, copy.deepcopy(data)))
    again = load_scene(write_scene(tmp_path_factory.mktemp("run"), s.to_dict()))
    assert again.to_dict() == s.to_dict() and again.hash == s.hash
    for name, view in data["views"].items():
        v = s.views[name]
        assert v.fps == view["fps"] and list(v.axes) == view["axes"]
        assert v.source == folder / view["source"]
        if "m_per_px" in view:
            assert v.m_per_px == view["m_per_px"]
    assert s.factors == data["factors"]


def test_parse_without_folder_skips_files():
    data = base()
    data["views"]["front"]["calibration"] = "cal/none.toml"
    del data["views"]["front"]["ruler"]
    s = parse_scene(data, folder=None)
    assert s.views["front"].calibration.as_posix() == "cal/none.toml"


# ----------------------------------------------------------------- throws


def test_throw_dirs_in_natural_order(tmp_path):
    run = tmp_path / "run"
    write_raw(run, base())
    assert load_scene(run).throw_dirs() == []
    for name in ("10", "2", "01", ".hidden"):
        (run / "throws" / name).mkdir(parents=True)
    (run / "throws" / "notes.txt").write_text("x")
    s = load_scene(run)
    assert [p.name for p in s.throw_dirs()] == ["01", "2", "10"]
    front = s.views["front"]
    assert front.source_in(s.throw_dirs()[0]) == run / "throws" / "01" / "front.avi"


def test_throw_dirs_problems(tmp_path):
    (tmp_path / "a" / "throws").mkdir(parents=True)
    with pytest.raises(SceneError, match="no throw folders"):
        find_throw_dirs(tmp_path / "a")
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "throws").write_text("")
    with pytest.raises(SceneError, match="got a file"):
        find_throw_dirs(tmp_path / "b")


def test_a_throws_own_corrections_replace_the_runs_for_it_alone(tmp_path):
    run = tmp_path / "run"
    data = base()
    data["views"]["front"]["exclude_frames"] = [[5, 8]]
    data["views"]["front"]["target"] = {"frame": 3, "at_px": [10.0, 20.0]}
    write_raw(run, data)
    one, two = run / "throws" / "01", run / "throws" / "02"
    for d in (one, two):
        d.mkdir(parents=True)
    (two / "throw.toml").write_text('[views.front]  # this throw only\n'
                                    'exclude_frames = [[40, 52], [60, 61]]\n'
                                    'manual_points = "m.csv"\n')
    (two / "m.csv").write_text("frame,u_px,v_px\n70,1.5,2.5\n")
    s = load_scene(run)
    assert throw_scene(s, one) is s                        # no throw.toml: the run's scene
    t = throw_scene(s, two)
    front = t.views["front"]
    assert front.exclude_frames == ((40, 52), (60, 61))
    assert front.target == (3, (10.0, 20.0))             # not given: the run's
    assert front.manual_points == two / "m.csv" and front.manual_points_text == "m.csv"
    assert t.views["top"] == s.views["top"] and front.fps == s.views["front"].fps
    assert s.views["front"].exclude_frames == ((5, 8),)  # the run's scene unchanged
    assert t.hash != s.hash
    # the same content written into scene.toml gives the same scene and hash
    data["views"]["front"].update(exclude_frames=[[40, 52], [60, 61]], manual_points="m.csv")
    write_raw(tmp_path / "same", data)
    (tmp_path / "same" / "m.csv").write_text("frame,u_px,v_px\n70,1.5,2.5\n")
    assert load_scene(tmp_path / "same").hash == t.hash


@pytest.mark.parametrize("text, message", [
    ("[views.front]\nfps = 100\n", "views.front.fps is not a key a throw may set"),
    ("[views.side]\nexclude_frames = []\n", "views.side is not a view of"),
    ("[views.front]\nexclude_frames = [[9, 3]]\n",
     "views.front.exclude_frames[0] must be a non-empty range"),
    ("[views.front]\ntarget = 5\n", "views.front.target must be a table"),
    ("[views.front]\nmanual_points = \"none.csv\"\n",
     "views.front.manual_points names 'none.csv', but there is no such file"),
    ("schema = 2\n", "schema must be 1"),
    ("[views.front\n", "not valid TOML"),
])
def test_a_throws_bad_file_one_line(tmp_path, text, message):
    run = tmp_path / "run"
    write_raw(run, base())
    (run / "throws" / "01").mkdir(parents=True)
    (run / "throws" / "01" / "throw.toml").write_text(text)
    with pytest.raises(SceneError) as err:
        throw_scene(load_scene(run), run / "throws" / "01")
    assert str(err.value).startswith(f"{run / 'throws' / '01' / 'throw.toml'}: ")
    assert message in str(err.value) and "\n" not in str(err.value)


# ----------------------------------------------------------------- experiment.toml


@pytest.fixture(params=["docs", "contract"])
def spec_experiment(request):
    return example(request, "## experiment.toml", "## Experiment folder")


def test_spec_experiment_loads(tmp_path, spec_experiment):
    exp = tmp_path / "exp2016"
    exp.mkdir()
    (exp / "experiment.toml").write_text(spec_experiment)
    e = load_experiment(exp)
    assert e.design == "ccd" and e.responses == ("k1", "k2", "k3", "k4")
    assert e.runs == "runs/*"
    assert list(e.factors) == ["A", "B", "C"]
    a, b, c = e.factors.values()
    assert (a.name, a.centre, a.step) == ("n_rpm", 550, 100)
    assert (b.name, b.centre, b.step) == ("blade_angle_deg", 0, 5)
    assert (c.name, c.centre, c.step) == ("speed_kmh", 7.2, 1.8)
    # Chen 2018 Table 1: 750 r/min is coded +2, 3.6 km/h is -2.
    assert a.code(750) == 2.0 and c.code(3.6) == pytest.approx(-2.0)
    for n in ("10", "2", "1"):
        write_raw(exp / "runs" / n, base())
    (exp / "runs" / "README.md").write_text("not a run")
    assert [p.name for p in e.run_dirs()] == ["1", "2", "10"]
    (exp / "runs" / "3").mkdir()
    with pytest.raises(SceneError, match=r"run folder .*3 .*has no scene.toml"):
        e.run_dirs()


EXP_BAD = [
    ("design = 'box'", "design", "must be \"ccd\" or \"orthogonal\", got 'box'"),
    ("responses = []", "responses", "must be a non-empty list"),
    ("responses = ['k1', 'k1']", "responses", "names 'k1' twice"),
    ("runs = '/abs/*'", "runs", "must be a glob inside the experiment folder"),
    ("colour = 1", "colour", "is not a known key"),
    ("factors.A.step = 0", "factors.A.step", "must be > 0, got 0"),
    ("factors.A.centre = 'x'", "factors.A.centre", "must be a number"),
    ("factors.A.level = 2", "factors.A.level", "is not a known key"),
    ("factors.B.name = 'n_rpm'", "factors", "name 'n_rpm' is used by two factors"),
]


@pytest.mark.parametrize("change,key,message", EXP_BAD)
def test_bad_experiment(tmp_path, change, key, message):
    import tomllib

    data = {"schema": 1, "design": "ccd", "responses": ["k1"], "runs": "runs/*",
            "factors": {"A": {"name": "n_rpm", "centre": 550, "step": 100},
                        "B": {"name": "blade_angle_deg", "centre": 0, "step": 5}}}
    lhs, rhs = change.split(" = ")
    *head, last = lhs.split(".")
    d = data
    for k in head:
        d = d[k]
    d[last] = tomllib.loads(f"v = {rhs}")["v"]
    (tmp_path / "experiment.toml").write_text(tomli_w.dumps(data))
    with pytest.raises(SceneError) as info:
        load_experiment(tmp_path)
    msg = str(info.value)
    assert msg.startswith(f"{tmp_path / 'experiment.toml'}: {key} "), msg
    assert message in msg


def test_experiment_missing_pieces(tmp_path):
    with pytest.raises(SceneError, match="no experiment.toml"):
        load_experiment(tmp_path)
    (tmp_path / "experiment.toml").write_text("schema = 1\ndesign = 'ccd'\nresponses = ['k1']\n")
    with pytest.raises(SceneError, match="factors is required"):
        load_experiment(tmp_path)
    (tmp_path / "experiment.toml").write_text(
        "schema = 1\ndesign = 'orthogonal'\nresponses = ['power']\n")
    e = load_experiment(tmp_path)
    assert e.factors == {} and e.runs == "runs/*"
    with pytest.raises(SceneError, match="matches no run folder"):
        e.run_dirs()
