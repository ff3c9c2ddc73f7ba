"""The contact sheet of report.html: crops round the straw with what was measured drawn.

Checked against tracks.csv (the tracker's numbers as ``vidtrack fit`` wrote them): each
crop's drawn ring, found by its colour, sits on the tracked pixel and has the frame's
flag colour; every flag of the run has an example.
"""

import base64
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

cv2 = pytest.importorskip("cv2")

from test_overlay import PALETTE, RUN42, expected_colour, nearest, ring  # noqa: E402


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    from conftest import run_vidtrack

    run = tmp_path_factory.mktemp("sheet") / "run"
    shutil.copytree(RUN42, run, ignore=shutil.ignore_patterns("vidtrack"))
    res = run_vidtrack("fit", run)
    assert res.returncode == 0, res.stderr
    return run


def _inputs(run):
    import json

    from vidtrack.footage import open_source
    from vidtrack.report.view_path import view_paths
    from vidtrack.run.tracks_file import read_tracks
    from vidtrack.scene import load_scene

    scene = load_scene(run)
    tf = read_tracks(run / "vidtrack" / "tracks.h5")
    record = json.loads((run / "vidtrack" / "fit.json").read_text())
    world = {c: tf.world.data[c].to_numpy() for c in tf.world.data.columns}
    paths = view_paths(scene, record, world,
                       frame_shapes={n: t.frame_shape for n, t in tf.tracks.items()})
    tracks = {n: t.data for n, t in tf.tracks.items()}
    sources = {n: open_source(scene.views[n].source, fps=scene.views[n].fps)
               for n in scene.view_names}
    return scene, tracks, paths, sources


def test_report_has_the_sheet(fitted):
    html = (fitted / "vidtrack" / "report.html").read_text()
    assert "<h2>Contact sheet</h2>" in html
    m = re.search(r'alt="contact sheet" src="data:image/png;base64,([^"]+)"', html)
    assert m
    img = cv2.imdecode(np.frombuffer(base64.b64decode(m.group(1)), np.uint8),
                       cv2.IMREAD_COLOR)
    assert img is not None and img.shape[0] > 300 and img.shape[1] > 500
    assert "vidtrack:contact-sheet" not in html          # the slot was filled
    assert "contact sheet" in (fitted / "vidtrack" / "report.md").read_text()


def test_crops_drawn_on_tracked_pixels(fitted):
    from vidtrack.report.contact_sheet import MIN_CROP_PX, contact_crops

    _, tracks, paths, sources = _inputs(fitted)
    try:
        crops, notes = contact_crops(sources, tracks, paths)
    finally:
        for s in sources.values():
            s.close()
    table = pd.read_csv(fitted / "vidtrack" / "tracks.csv").set_index(["view", "frame"])
    assert 9 <= len(crops) <= 16 and not notes
    flights = [c for c in crops if c.why == "flight"]
    assert {c.view for c in flights} == {"front", "top"} and len(flights) >= 8
    # one example of every flag that occurs in tracks.csv
    names = set()
    for text in table["flag_names"].fillna(""):
        names.update(n for n in text.split("|") if n)
    assert {c.why for c in crops if c.why != "flight"} == names
    for c in crops:
        row = table.loc[(c.view, c.frame)]
        assert int(row["flags"]) == c.flags
        assert c.image.shape[0] / c.zoom >= MIN_CROP_PX
        if not np.isfinite(row["u_px"]):
            continue
        # where the crop maps the tracked pixel, the ring must be drawn
        want = ((row["u_px"] - c.corner_px[0] + 0.5) * c.zoom - 0.5,
                (row["v_px"] - c.corner_px[1] + 0.5) * c.zoom - 0.5)
        centre, colour = ring(c.image, *want, half=20)
        assert centre is not None, (c.view, c.frame)
        u = c.corner_px[0] + (centre[0] + 0.5) / c.zoom - 0.5
        v = c.corner_px[1] + (centre[1] + 0.5) / c.zoom - 0.5
        assert np.hypot(u - row["u_px"], v - row["v_px"]) < 0.5, (c.view, c.frame)
        assert PALETTE[nearest(colour)] == expected_colour(row["flags"]), (c.view, c.frame)


def test_footage_gone_is_said(fitted, tmp_path):
    from vidtrack.report.contact_sheet import contact_sheet_html

    scene, tracks, paths, sources = _inputs(fitted)
    for s in sources.values():
        s.close()
    moved = tmp_path / "run"
    shutil.copytree(fitted, moved)
    for v in ("front.avi", "top.avi"):
        (moved / v).unlink()
    from vidtrack.scene import load_scene

    assert not load_scene(moved).views["front"].source.exists()
    html = contact_sheet_html(load_scene(moved), moved, tracks, paths)
    assert "<h2>Contact sheet</h2>" in html and "No footage to show" in html
    assert "<img" not in html
    assert Path(fitted / "front.avi").is_file()


def test_footage_frames_read_once_in_order(fitted, monkeypatch):
    """footage_html reads each frame it shows once per view, in increasing order (the
    first read of a video decodes from its start), and shows what reading them where
    they are drawn shows."""
    from vidtrack.footage.video import VideoSource
    from vidtrack.report.trajectory import footage_html, read_ahead

    scene, tracks, paths, sources = _inputs(fitted)
    for s in sources.values():
        s.close()
    reads = []
    own = VideoSource._read_file_frame

    def recorded(self, k):
        reads.append((self.path.name, k))
        return own(self, k)

    monkeypatch.setattr(VideoSource, "_read_file_frame", recorded)
    html = footage_html(scene, scene.folder, tracks, paths)
    assert reads
    for name in {n for n, _ in reads}:
        frames = [k for n, k in reads if n == name]
        assert frames == sorted(set(frames))
    # the same page when every frame is read where it is drawn
    import vidtrack.report.trajectory as trajectory

    monkeypatch.setattr(trajectory, "read_ahead", lambda sources, frames: sources)
    assert footage_html(scene, scene.folder, tracks, paths) == html
    assert read_ahead({}, {}) == {}
