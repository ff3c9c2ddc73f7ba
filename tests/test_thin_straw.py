"""A thin straw at the default scale (480 x 360 px at 5.28 mm/px: a 19 px straw 1-2 px
thick), with each of vidtrack synth's distractors, fitted end to end by the real
``vidtrack fit RUN --json --no-report`` against truth.json: every unflagged frame of each
view within 0.5 px of the straw's coverage centroid, k as tolerated. Here the straw alone,
dark, with a person at the side and with a rider along it; crossed by a rider, in a
shadow, both, and cut in two by a post narrower than it: tests/test_thin_straw_crossed.py.
(Apart from tests/test_synth_distractors.py, whose scenes are drawn at a larger scale,
and in two files of four scenes each, so that they share the two cores.)"""

import json
import math

import pytest
from conftest import assert_k_within
from synth_runs import unflagged


#: case -> (options, the least share of each view's frames from the release on that
#: stays unflagged); every unflagged frame within 0.5 px, k within the tolerances
THIN = {
    "plain": ([], 0.85),
    "dark": (["--straw-polarity", "dark"], 0.85),
    "person": (["--person-at-side"], 0.85),
    "riding": (["--rider", "riding"], 0.5),
    "crossing": (["--rider", "crossing"], 0.5),
    "shadow": (["--shadow", "4,0.4,1.5"], 0.5),
    "hard": (["--shadow", "4,0.4,1.5", "--rider", "crossing", "--person-at-side"], 0.4),
    # a post narrower than the straw: never hidden whole, it is cut in two pieces
    "post": (["--post", "0.6,6"], 0.5),
}


@pytest.fixture(scope="module")
def fitted_thin(tmp_path_factory):
    from conftest import run_vidtrack

    cache = {}

    def get(name):
        if name not in cache:
            out = tmp_path_factory.mktemp(f"thin_{name}") / "run"
            # (the motion blur averaged over 2 renders a frame, not the default 8: the
            # straw moves about 0.6 px in an exposure, and a render with a person costs
            # 19 s of CPU with 8, 9 with 2; but the post's, whose check of 0.25 px sees
            # how the blur is sampled: with 2, one frame 0.45 px off)
            blur = [] if name == "post" else ["--exposure-samples", "2"]
            res = run_vidtrack("synth", out, *THIN[name][0], *blur, "-q")
            assert res.returncode == 0, res.stderr
            cache[name] = (out, run_vidtrack("fit", out, "--json", "--no-report", "-q"))
        return cache[name]
    return get


def check_thin_straw(fitted_thin, name):
    """Both views tracked in most frames, every unflagged frame within 0.5 px of the
    straw's own coverage centroid, k as tolerated. Before the thin straw's rules
    (4f519ef): the plain run's top view had 221 of its 492 frames flagged (its fill, set
    by the pixel grid) and the fit was refused; the riding rider pulled unflagged frames
    up to 0.83 px off, the shadow up to 1.07 px; the crossing rider's fit was refused;
    the hard run exited 0 with frames 2.3 px off and k3 +6.5 %, k4 -7 %."""
    check_fitted(*fitted_thin(name), THIN[name][1])


def check_fitted(run, res, least):
    """``vidtrack fit``'s result ``res`` on ``run``: each view's frames from the release
    on at least ``least`` unflagged, every unflagged frame within 0.5 px of the straw's
    coverage centroid, k as tolerated."""
    assert res.returncode == 0, res.stderr.strip().splitlines()[-1:]
    truth = json.loads((run / "truth.json").read_text())
    record = json.loads(res.stdout)
    for view, pts in unflagged(run).items():
        tab = truth["views"][view]["per_frame"]
        flying = sum(1 for f in tab["frame"] if f >= truth["views"][view]["release_frame"])
        assert len(pts) >= least * flying, (view, len(pts), flying)
        bad = [(i, round(math.hypot(u - tab["u_coverage_px"][i],
                                    v - tab["v_coverage_px"][i]), 3)) for i, u, v in pts]
        bad = [b for b in bad if b[1] > 0.5]
        assert not bad, f"{view}: {len(bad)} unflagged frames > 0.5 px off: {bad[:10]}"
    assert_k_within(record, truth["truth"]["k"])


#: The scenes checked here (the others: tests/test_thin_straw_crossed.py)
HERE = ["plain", "dark", "person", "riding"]


@pytest.mark.parametrize("name", HERE)
def test_thin_straw_at_the_default_scale(fitted_thin, name):
    check_thin_straw(fitted_thin, name)
