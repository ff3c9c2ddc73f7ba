"""report.html's views in their own pixels: the residuals in pixels and the whole track
over a full frame (vidtrack.report.trajectory), through the real ``vidtrack fit``.

Truth the code did not produce: truth.json (the renderer's projected straw centre) and
tracks.csv (the tracker's numbers): a view's residual in pixels is the measured point
minus the fitted path, and where the fit is as exact as on the sample run (its path
within 0.013 px of truth.json, docs/fit-outputs.md) that is the tracker's error against
truth.json. The drawn trajectory is decoded from report.html and its rings, found by
their colour, are compared with tracks.csv. A run of points digitized elsewhere, made
with OpenCV's projectPoints plus N(0, 0.1 px) noise, has no footage: its residuals in
pixels are that noise.
"""

import base64
import re

import numpy as np
import pandas as pd
import pytest

cv2 = pytest.importorskip("cv2")

from test_contact_sheet import fitted  # noqa: E402,F401 (the sample run, fitted)
from test_overlay import PALETTE, nearest  # noqa: E402

#: The report's residual table in report.md: view, points, RMS u, RMS v, RMS distance.
PX_ROW = re.compile(r"^\| (\w+) \| (\d+) \| ([0-9.e-]+) \| ([0-9.e-]+) \| ([0-9.e-]+) \|$",
                    re.M)


def _truth(run, view):
    import json

    truth = json.loads((run / "truth.json").read_text())
    return pd.DataFrame(truth["views"][view]["per_frame"]).set_index("frame")


def test_pixel_residuals_are_the_trackers_error_against_truth(fitted):
    from test_contact_sheet import _inputs

    from vidtrack.report.trajectory import pixel_residuals

    _, tracks, paths, sources = _inputs(fitted)
    for s in sources.values():
        s.close()
    px = pixel_residuals(tracks, paths)
    table = pd.read_csv(fitted / "vidtrack" / "tracks.csv")
    md = {m.group(1): m.groups()[1:] for m in
          PX_ROW.finditer((fitted / "vidtrack" / "report.md").read_text())}
    assert set(px) == set(md) == {"front", "top"}
    for name, r in px.items():
        d = table[(table["view"] == name) & (table["flags"] == 0)].set_index("frame")
        truth = _truth(fitted, name)
        assert set(r.frame) <= set(d.index) and r.points > 300
        measured = d.loc[r.frame, ["u_px", "v_px"]].to_numpy()
        error = measured - truth.loc[r.frame, ["u_px", "v_px"]].to_numpy(float)
        got = np.column_stack([r.du_px, r.dv_px])
        # measured - fitted is measured - truth, up to the path's own error (<= 0.013 px)
        assert np.abs(got - error).max() < 0.03, name
        assert r.rms_px < 0.1, name
        # report.md prints the same numbers, to 3 digits
        points, u, v, dist = md[name]
        assert int(points) == r.points
        rms = np.sqrt(np.mean(error ** 2, axis=0))
        assert float(u) == pytest.approx(rms[0], abs=0.005), name
        assert float(v) == pytest.approx(rms[1], abs=0.005), name
        assert float(dist) == pytest.approx(np.hypot(*rms), abs=0.005), name
    html = (fitted / "vidtrack" / "report.html").read_text()
    assert "<h2>Residuals in pixels</h2>" in html and 'alt="residuals in pixels"' in html


def _image(html, alt):
    m = re.search(rf'alt="{alt}" src="data:image/png;base64,([^"]+)"', html)
    assert m, alt
    return cv2.imdecode(np.frombuffer(base64.b64decode(m.group(1)), np.uint8),
                        cv2.IMREAD_COLOR)


@pytest.mark.parametrize("view", ["front", "top"])
def test_trajectory_drawn_where_tracks_csv_says(fitted, view):
    html = (fitted / "vidtrack" / "report.html").read_text()
    assert "<h2>Trajectory over a full frame</h2>" in html
    img = _image(html, f"trajectory {view}")
    cap = cv2.VideoCapture(str(fitted / f"{view}.avi"))
    width = cap.get(cv2.CAP_PROP_FRAME_WIDTH)
    cap.release()
    scale = img.shape[1] / width
    assert scale >= 1.5                                  # enlarged, a full frame
    # the banner: the black box in the top-left corner
    banner_h = int(np.argmax(img[:, 0].any(axis=1)))
    banner_w = int(np.argmax(img[0].any(axis=1)))
    d = pd.read_csv(fitted / "vidtrack" / "tracks.csv")
    d = d[(d["view"] == view) & d["u_px"].notna()]
    uv = (d[["u_px", "v_px"]].to_numpy() + 0.5) * scale - 0.5
    hidden = (uv[:, 0] < banner_w + 12) & (uv[:, 1] < banner_h + 12)
    uv, flags = uv[~hidden], d["flags"].to_numpy()[~hidden]
    assert len(uv) > 300
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    mask = (hsv[..., 1] > 110) & (hsv[..., 2] > 110)
    mask[:banner_h + 1, :banner_w + 1] = False
    rr, cc = np.nonzero(mask)
    pix = np.column_stack([cc, rr]).astype(float)
    dist = np.hypot(*(pix[:, None, :] - uv[None, :, :]).transpose(2, 0, 1))
    # every measured point has a ring round it ...
    assert (dist.min(axis=0) < 4.0).all()
    # ... and what is drawn saturated is those rings, and the shown frame's large ring
    far = pix[dist.min(axis=1) > 5.5]
    if len(far):                 # all round one point (the track crosses the ring)
        reach = np.hypot(*(far[:, None, :] - uv[None, :, :]).transpose(2, 0, 1)).max(axis=0)
        assert reach.min() < 13.0, reach.min()
    # in the colours of the flags that occur (pixels of a palette colour, not the blends
    # at the rings' anti-aliased edges)
    found = set()
    for c in img[rr, cc].astype(float):
        k = nearest(c)
        if np.linalg.norm(c - np.array(PALETTE[k], float)) < 30:
            found.add(k)
    want = {f & -f if f else 0 for f in flags}
    assert found == want, (found, want)


def test_points_digitized_elsewhere_get_residuals_in_pixels(tmp_path, vidtrack_cli):
    from test_cli_fit_calibrated import write_run

    run = write_run(tmp_path / "run", np.random.default_rng(11))
    r = vidtrack_cli("fit", run)
    assert r.returncode == 0, r.stderr
    md = {m.group(1): m.groups()[1:] for m in
          PX_ROW.finditer((run / "vidtrack" / "report.md").read_text())}
    assert set(md) == {"left", "right"}
    for name, (points, u, v, _) in md.items():
        # the points are projectPoints + N(0, 0.1 px): the residuals are that noise
        assert int(points) > 250, name
        assert 0.08 < float(u) < 0.12 and 0.08 < float(v) < 0.12, (name, u, v)
    html = (run / "vidtrack" / "report.html").read_text()
    assert 'alt="residuals in pixels"' in html
    assert "<h2>Trajectory over a full frame</h2>" in html
    assert 'alt="trajectory' not in html and "gives points, not footage" in html
