"""Small synthetic runs from ``vidtrack synth`` for the tracker and merge tests.

Rendered once per test session into a temporary folder (removed at exit) and shared by
the test modules that ask for the same parameters. Their ground truth is the renderer's
``truth.json`` (exact silhouette centroids), which the tracker never sees.
"""

import atexit
import csv
import json
import math
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

_ROOT = None
_CACHE = {}

#: What every test run shares: small frames, noise, motion blur, MJPG compression on.
BASE = {"size_px": (320, 240), "frames": 150, "read_noise_dn": 1.5,
        "exposure_fraction": 0.5, "output_format": "avi", "video_codec": "mjpg",
        "jpeg_quality": 75}


def _root():
    global _ROOT
    if _ROOT is None:
        _ROOT = Path(tempfile.mkdtemp(prefix="vidtrack-tests-synth-"))
        atexit.register(shutil.rmtree, _ROOT, True)
    return _ROOT


def synth_run(name, **overrides):
    """Render (once) and return the folder of a synthetic run."""
    from vidtrack.synth import SynthSpec, render_run

    params = {**BASE, **overrides}
    key = json.dumps(params, sort_keys=True, default=list)
    if key not in _CACHE:
        folder = _root() / f"{name}-{len(_CACHE)}"
        render_run(folder, SynthSpec(**params))
        _CACHE[key] = folder
    return _CACHE[key]


def truth(folder):
    """The run's truth.json as a dict."""
    return json.loads((Path(folder) / "truth.json").read_text())


def view_truth(folder, view):
    """(per-frame truth DataFrame, view dict) of one view."""
    t = truth(folder)["views"][view]
    return pd.DataFrame(t["per_frame"]), t


def centroid_errors(track, per_frame):
    """Per-frame distance (px) between the track and the true silhouette centroid."""
    d = track.data
    return np.hypot(d["u_px"].to_numpy() - per_frame["u_px"].to_numpy(dtype=float),
                    d["v_px"].to_numpy() - per_frame["v_px"].to_numpy(dtype=float))

def unflagged(run):
    """A fitted run's unflagged points from its tracks.csv: {view: [(frame, u, v)]}."""
    with open(run / "vidtrack" / "tracks.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    out = {}
    for r in rows:
        if int(r["flags"]) == 0 and r["u_px"] not in ("", "nan", "NaN"):
            out.setdefault(r["view"], []).append((int(r["frame"]), float(r["u_px"]),
                                                  float(r["v_px"])))
    return out


def check_behind_the_post(run, res, touched):
    """The fit went through; the straw went behind the post in ``touched`` frames or
    more; no front frame with 5 % of it behind the post is unflagged, and the unflagged
    ones lie within 0.25 px of the straw's coverage centroid."""
    assert res.returncode == 0, res.stderr.strip().splitlines()[-1:]
    truth = json.loads((run / "truth.json").read_text())
    tab = truth["views"]["front"]["per_frame"]
    share = np.asarray(tab["post_hidden"], float)
    errs = {i: math.hypot(u - tab["u_coverage_px"][i], v - tab["v_coverage_px"][i])
            for i, u, v in unflagged(run)["front"]}
    assert (share > 0.02).sum() >= touched
    behind = set(np.flatnonzero(share >= 0.05))
    assert not behind & set(errs), sorted(behind & set(errs))
    assert max(errs.values()) < 0.25, max(errs.values())
