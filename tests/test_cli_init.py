"""``vidtrack init`` end to end, through the real command line: the footage found and
described (checked against what datasets/README.md states and what the test itself
wrote), a template that vidtrack refuses until it is filled in, and, filled with the
values of datasets/run42/scene.toml, the same scene and the same k1..k4."""

import hashlib
import json
import re
import shutil
import tomllib

import numpy as np
import pytest

from conftest import REPO

RUN42 = REPO / "datasets" / "run42"
VIEW_KEYS = ("fps", "axes", "origin_px", "ruler")


def _one_line(res):
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    return lines[0]


def _digest(folder):
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def run42_footage(tmp_path):
    """datasets/run42 without its scene.toml (nor outputs): footage and truth only."""
    run = tmp_path / "run42"
    shutil.copytree(RUN42, run, ignore=shutil.ignore_patterns("vidtrack", "scene.toml"))
    return run


# -- filling the template in, by text edits of its marked lines --------------------------

def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(v)


def fill(text, section, key, value):
    """``key = value`` in place of the one line of ``key`` in ``[section]`` (a marked
    line, or a commented template line)."""
    lines = text.splitlines(keepends=True)
    here, hits = False, 0
    for i, line in enumerate(lines):
        if line.startswith("["):
            here = line.split("#")[0].strip() == f"[{section}]"
        elif here and re.match(rf"#?\s*{re.escape(key)}\s*=", line):
            lines[i] = f"{key} = {_toml_value(value)}\n"
            hits += 1
    assert hits == 1, (section, key, hits)
    return "".join(lines)


def filled(text, original, *, leave_out=()):
    """The template with every value of ``original`` (a parsed scene.toml) put in, but
    those in ``leave_out`` ((view, key) pairs)."""
    for section in ("factors", "physics", "straw", "machine"):
        for key, value in original.get(section, {}).items():
            text = fill(text, section, key, value)
    for view, table in original["views"].items():
        for key in VIEW_KEYS:
            if (view, key) not in leave_out:
                text = fill(text, f"views.{view}", key, table[key])
    return text


def test_init_finds_and_describes_the_footage(vidtrack_cli, run42_footage):
    before = _digest(run42_footage)
    res = vidtrack_cli("init", run42_footage)
    assert res.returncode == 0, res.stderr
    toml = run42_footage / "scene.toml"
    assert str(toml) in res.stdout and "TODO(user)" in res.stdout
    # nothing else was written or changed
    after = _digest(run42_footage)
    assert set(after) - set(before) == {"scene.toml"}
    assert {k: after[k] for k in before} == before
    assert not list(run42_footage.glob(".*"))                   # no temporary left

    text = toml.read_text()
    data = tomllib.loads(text)                                  # valid TOML as written
    assert data["schema"] == 1
    assert set(data) == {"schema", "run", "factors", "physics", "straw", "machine", "views"}
    assert data["views"]["front"]["source"] == "front.avi"
    assert data["views"]["top"]["source"] == "top.avi"
    # datasets/README.md: 372 frames each, 400 x 184 and 400 x 112 px, 30 fps in the
    # container (the playback rate of an exported high-speed video)
    front, top = text.split("[views.front]")[1].split("[views.top]")
    assert "372 frames of 400 x 184 px" in front and "372 frames of 400 x 112 px" in top
    for part in (front, top):
        assert "30 fps" in part and "PLAYBACK" in part and "CAPTURE" in part
        for key in ("fps", "axes", "origin_px"):                # each marked
            line = next(ln for ln in part.splitlines() if ln.startswith(f"{key} ="))
            assert "TODO(user)" in line, line
        assert re.search(r"^# ruler = ", part, re.M) and re.search(r"^# m_per_px = ", part, re.M)
    assert re.search(r"^# cp_s_per_m = ", text, re.M)
    for section in ("[run]", "[factors]", "[straw]", "[machine]"):
        assert section in text

    # the same facts as JSON, on a second folder of the same footage
    other = run42_footage.parent / "again"
    shutil.copytree(run42_footage, other, ignore=shutil.ignore_patterns("scene.toml"))
    res = vidtrack_cli("init", other, "--json")
    assert res.returncode == 0, res.stderr
    views = json.loads(res.stdout)["views"]
    assert (views["front"]["frames"], views["front"]["width_px"],
            views["front"]["height_px"]) == (372, 400, 184)
    assert (views["top"]["frames"], views["top"]["width_px"],
            views["top"]["height_px"]) == (372, 400, 112)
    assert views["front"]["fps_container"] == pytest.approx(30.0)


def test_init_never_overwrites(vidtrack_cli, run42_footage):
    assert vidtrack_cli("init", run42_footage).returncode == 0
    toml = run42_footage / "scene.toml"
    toml.write_text(toml.read_text() + "# my notes\n")
    before = _digest(run42_footage)
    res = vidtrack_cli("init", run42_footage)
    assert res.returncode == 2
    line = _one_line(res)
    assert "scene.toml" in line and "already exists" in line
    assert _digest(run42_footage) == before


def test_run_must_be_an_existing_folder(vidtrack_cli, tmp_path):
    res = vidtrack_cli("init", tmp_path / "missing")
    assert res.returncode == 2 and "no such folder" in _one_line(res)
    (tmp_path / "file").write_text("x")
    res = vidtrack_cli("init", tmp_path / "file")
    assert res.returncode == 2 and "not a folder" in _one_line(res)
    assert not (tmp_path / "missing").exists()
    res = vidtrack_cli("init", tmp_path)                      # a folder without footage
    assert res.returncode == 2
    line = _one_line(res)
    assert "no footage" in line and "--front FILE" in line and "--top FILE" in line
    assert not (tmp_path / "scene.toml").exists()


def test_untouched_template_is_refused_by_fit(vidtrack_cli, run42_footage):
    assert vidtrack_cli("init", run42_footage).returncode == 0
    res = vidtrack_cli("fit", run42_footage)
    assert res.returncode == 2
    line = _one_line(res)
    assert line.startswith("vidtrack fit: error: ")
    assert "scene.toml: views.front.fps must be > 0, got 0" in line
    assert not (run42_footage / "vidtrack").exists()          # nothing was written


@pytest.mark.parametrize("view", ["front", "top"])
@pytest.mark.parametrize("key", VIEW_KEYS)
def test_each_marked_key_keeps_the_scene_from_loading(tmp_path, view, key):
    """Every value only the user knows blocks the file until it is given, the loader
    naming it: with all others filled in, that one left as written."""
    from vidtrack.errors import SceneError
    from vidtrack.scene import load_scene
    from vidtrack.scene_template import write_scene_template

    run = tmp_path / "run42"
    shutil.copytree(RUN42, run, ignore=shutil.ignore_patterns("vidtrack", "scene.toml"))
    write_scene_template(run)
    original = tomllib.loads((RUN42 / "scene.toml").read_text())
    toml = run / "scene.toml"
    toml.write_text(filled(toml.read_text(), original, leave_out={(view, key)}))
    expected = (rf"views\.{view} needs a scale" if key == "ruler"
                else rf"views\.{view}\.{key} (must|is required)")
    with pytest.raises(SceneError, match=expected):
        load_scene(run)
    # uncommented as written, the scale's template lines are refused too
    if key == "ruler":
        text = toml.read_text()
        for line, words in (("ruler", rf"views\.{view}\.ruler\.length_m must be > 0"),
                            ("m_per_px", rf"views\.{view}\.m_per_px must be > 0")):
            toml.write_text(uncomment(text, f"views.{view}", line))
            with pytest.raises(SceneError, match=words):
                load_scene(run)


def uncomment(text, section, key):
    """The commented template line of ``key`` in ``[section]``, uncommented as it is."""
    lines = text.splitlines(keepends=True)
    here, hits = False, 0
    for i, line in enumerate(lines):
        if line.startswith("["):
            here = line.split("#")[0].strip() == f"[{section}]"
        elif here and line.startswith(f"# {key} = "):
            lines[i] = line[2:]
            hits += 1
    assert hits == 1, (section, key, hits)
    return "".join(lines)


def test_filled_template_fits_to_the_same_k(vidtrack_cli, run42_footage):
    from vidtrack.scene import load_scene

    assert vidtrack_cli("init", run42_footage).returncode == 0
    toml = run42_footage / "scene.toml"
    original = tomllib.loads((RUN42 / "scene.toml").read_text())
    toml.write_text(filled(toml.read_text(), original))
    assert "?" not in "".join(ln.split("#")[0] for ln in toml.read_text().splitlines())
    # the same scene as datasets/run42/scene.toml, key for key (and so the same hash)
    mine, theirs = load_scene(run42_footage), load_scene(RUN42)
    assert mine.to_dict() == theirs.to_dict()
    assert mine.hash == theirs.hash

    res = vidtrack_cli("fit", run42_footage, "--json", "-q")
    assert res.returncode == 0, res.stderr
    k = {name: c["value"] for name, c in json.loads(res.stdout)["coefficients"].items()}
    # the k of the original scene, as docs/user-guide.md prints them
    assert [f"{k[n]:.4g}" for n in ("k1", "k2", "k3", "k4")] == ["2.203", "2.498", "4.6",
                                                                  "21.3"]
    truth = json.loads((run42_footage / "truth.json").read_text())["truth"]["k"]
    for n in ("k1", "k2", "k3", "k4"):
        assert k[n] == pytest.approx(truth[n], rel=0.01)


def test_names_that_do_not_tell_are_refused_then_given(vidtrack_cli, tmp_path):
    run = tmp_path / "cams"
    run.mkdir()
    shutil.copy(RUN42 / "front.avi", run / "cam1.avi")
    shutil.copy(RUN42 / "top.avi", run / "cam2.avi")
    res = vidtrack_cli("init", run)
    assert res.returncode == 2
    line = _one_line(res)
    assert "cam1.avi" in line and "cam2.avi" in line
    assert "--front FILE" in line and "--top FILE" in line
    assert not (run / "scene.toml").exists()
    # FILE inside RUN, given from another working folder
    res = vidtrack_cli("init", run, "--front", "cam1.avi", "--top", "cam2.avi", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    views = tomllib.loads((run / "scene.toml").read_text())["views"]
    assert (views["front"]["source"], views["top"]["source"]) == ("cam1.avi", "cam2.avi")
    assert "400 x 112 px" in (run / "scene.toml").read_text().split("[views.top]")[1]


def test_one_view_given_leaves_the_other_out(vidtrack_cli, tmp_path):
    run = tmp_path / "one"
    run.mkdir()
    shutil.copy(RUN42 / "front.avi", run / "cam1.avi")
    shutil.copy(RUN42 / "top.avi", run / "other.avi")
    res = vidtrack_cli("init", run, "--front", run / "cam1.avi")
    assert res.returncode == 0, res.stderr
    assert "not used: other.avi" in res.stdout
    assert set(tomllib.loads((run / "scene.toml").read_text())["views"]) == {"front"}


def test_cine_and_image_folder(vidtrack_cli, tmp_path):
    import cv2

    from vidtrack.footage import write_cine

    run = tmp_path / "mixed"
    run.mkdir()
    rng = np.random.default_rng(0)
    write_cine(run / "Front_cam.cine", rng.integers(0, 4096, (7, 48, 64)).astype(np.uint16),
               fps=2000, bit_depth=12)
    images = run / "top_frames"
    images.mkdir()
    for i in range(5):
        cv2.imwrite(str(images / f"img_{i:03d}.png"),
                    rng.integers(0, 256, (60, 80)).astype(np.uint8))
    (run / "notes.txt").write_text("not footage")
    res = vidtrack_cli("init", run, "--json")
    assert res.returncode == 0, res.stderr
    views = json.loads(res.stdout)["views"]
    assert views["front"]["source"] == "Front_cam.cine" and views["front"]["kind"] == "cine"
    assert (views["front"]["frames"], views["front"]["width_px"], views["front"]["height_px"],
            views["front"]["bit_depth"]) == (7, 64, 48, 12)
    assert views["front"]["fps_container"] == pytest.approx(2000)
    assert views["top"]["source"] == "top_frames" and views["top"]["kind"] == "image folder"
    assert (views["top"]["frames"], views["top"]["width_px"],
            views["top"]["height_px"]) == (5, 80, 60)
    assert views["top"]["fps_container"] is None
    text = (run / "scene.toml").read_text()
    front, top = text.split("[views.front]")[1].split("[views.top]")
    assert "2000 fps" in front and "states no frame rate" in top
    assert tomllib.loads(text)["views"]["front"]["fps"] == 0       # still to be given


def test_replicate_throws(vidtrack_cli, tmp_path):
    run = tmp_path / "throws_run"
    for d in ("01", "02"):
        (run / "throws" / d).mkdir(parents=True)
        shutil.copy(RUN42 / "front.avi", run / "throws" / d / "front.avi")
    shutil.copy(RUN42 / "top.avi", run / "throws" / "01" / "top.avi")
    res = vidtrack_cli("init", run)
    assert res.returncode == 0, res.stderr
    text = (run / "scene.toml").read_text()
    views = tomllib.loads(text)["views"]
    assert (views["front"]["source"], views["top"]["source"]) == ("front.avi", "top.avi")
    assert "02/top.avi" in text                               # missing from throw 02
