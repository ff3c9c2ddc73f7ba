"""Which stage a change of scene.toml computes again (issue 42), through the CLI.

Each view's tracking is keyed by what the tracker reads (the footage, the view's frames,
fps, channel and target, the ``[track]`` table, the tracker): renaming the run or moving
a ruler reuses the views' tracks from ``vidtrack/views.h5`` and rebuilds the world track
and the fit from them, with the same numbers as tracking again (``--force``); a change
the tracker reads tracks that view again, and only it. A views.h5 changed since it was
written (even one that reads back whole) is never taken for the tracker's tracks.
"""

import hashlib
import json
import re
import shutil

import h5py
import pytest

from conftest import REPO, run_vidtrack


def _fit(run, *args):
    res = run_vidtrack("fit", run, "--json", "--no-report", *args)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout), res.stderr


def _stages(run):
    return json.loads((run / "vidtrack" / "stages.json").read_text(encoding="utf-8"))


def _digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _edit(run, pattern, replacement):
    path = run / "scene.toml"
    text, n = re.subn(pattern, replacement, path.read_text(), count=1, flags=re.M | re.S)
    assert n == 1, pattern
    path.write_text(text)


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """datasets/run42 (without its outputs) fitted once: (run folder, fit record)."""
    run = tmp_path_factory.mktemp("reuse") / "run42"
    shutil.copytree(REPO / "datasets" / "run42", run, ignore=shutil.ignore_patterns("vidtrack"))
    record, _ = _fit(run)
    assert record["stages_reused"] == []
    return run, record


@pytest.fixture
def run(fitted, tmp_path):
    """A copy of the fitted run (its times kept, as a user's copy keeps them)."""
    return shutil.copytree(fitted[0], tmp_path / "run42")


def test_a_renamed_run_reuses_the_views_tracks_and_gives_the_same_tables(run, fitted):
    from vidtrack.scene import load_scene

    out = run / "vidtrack"
    before = {n: (out / n).read_bytes() for n in ("tracks.csv", "world.csv")}
    views = _stages(run).get("views")
    _edit(run, r'^name = .*?$', 'name = "run42-renamed"')
    record, err = _fit(run)
    # nothing the tracker reads changed: the views are not tracked again
    assert record["stages_reused"] == ["views"], err
    assert "tracks of the front and top views reused" in err
    assert _stages(run)["views"] == views           # views.h5 as it was, not written again
    assert _digest(out / "views.h5") == views["files"]["views.h5"]
    for name, data in before.items():
        assert (out / name).read_bytes() == data, name
    # the fit is computed again for the new name (fit.json holds it), with the same k
    assert record["run"] == "run42-renamed"
    for k, c in fitted[1]["coefficients"].items():
        assert c["value"] == record["coefficients"][k]["value"], k
    # tracks.h5 records the scene it was written for: this one
    with h5py.File(out / "tracks.h5") as h:
        assert h.attrs["scene_hash"] == load_scene(run).hash
    again, err = _fit(run)
    assert again["stages_reused"] == ["tracks", "fit"], err


def test_a_moved_ruler_rebuilds_the_world_from_the_views_as_tracking_again_would(run, fitted):
    out = run / "vidtrack"
    world = (out / "world.csv").read_bytes()
    _edit(run, r'(\[views\.top\.ruler\].*?^to_px = \[)([-0-9.e]+)',
          lambda m: m.group(1) + repr(float(m.group(2)) + 0.6))
    record, err = _fit(run)
    assert record["stages_reused"] == ["views"], err
    # the top view's X is 0.6 px of 80 shorter: the world track and the fit change
    assert (out / "world.csv").read_bytes() != world
    assert record["world"]["shared_x"]["ratio"] < 0.995
    assert record["coefficients"]["k1"]["value"] != fitted[1]["coefficients"]["k1"]["value"]
    # and are what tracking again gives
    tables = {n: (out / n).read_bytes() for n in ("tracks.csv", "world.csv")}
    forced, err = _fit(run, "--force")
    assert forced["stages_reused"] == [], err
    for name, data in tables.items():
        assert (out / name).read_bytes() == data, name
    for k, c in forced["coefficients"].items():
        assert c == record["coefficients"][k], k


def test_what_the_tracker_reads_tracks_that_view_again(run):
    out = run / "vidtrack"
    parts = _stages(run).get("views", {}).get("parts")
    # the top view's frames: the top view is tracked again, the front view's reused
    _edit(run, r'(\[views\.top\]\n)', r'\1frames = [0, 300]\n')
    record, err = _fit(run)
    assert record["stages_reused"] == ["views"], err
    assert "tracks of the front view reused" in err
    now = _stages(run)["views"]["parts"]
    assert now["front"] == parts["front"] and now["top"] != parts["top"]
    top = [r for r in (out / "tracks.csv").read_text().splitlines()[1:]
           if r.startswith("top,")]
    assert len(top) == 300 and max(int(r.split(",")[1]) for r in top) == 299
    # the [track] table: both views are tracked again, nothing reused
    views_h5 = _digest(out / "views.h5")
    (run / "scene.toml").write_text((run / "scene.toml").read_text()
                                    + '\n[track]\nengine = "flight"\n')
    record, err = _fit(run)
    assert record["stages_reused"] == [], err
    assert "views.h5" not in err
    now, before = _stages(run)["views"]["parts"], now
    assert now["front"] != before["front"] and now["top"] != before["top"]
    assert _digest(out / "views.h5") != views_h5


def test_a_views_h5_changed_since_it_was_written_is_not_used(run, fitted):
    out = run / "vidtrack"
    with h5py.File(out / "views.h5", "r+") as h:     # reads back whole, not the file written
        flags = h["front/flags"][()]
        flags[100:120] |= 256
        h["front/flags"][...] = flags
    _edit(run, r'^name = .*?$', 'name = "run42-renamed"')
    record, err = _fit(run)
    assert record["stages_reused"] == [], err
    assert "views.h5 changed since it was written" in err and "tracking the views again" in err
    assert record["points"] == fitted[1]["points"]
    views = _stages(run)["views"]
    assert _digest(out / "views.h5") == views["files"]["views.h5"]
