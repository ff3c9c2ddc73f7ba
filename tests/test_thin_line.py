"""A thin straw's own line fitted to the pixels (vidtrack/track/_thin.py), against the
centre of rods drawn here by supersampling (tests/rod_render.py), not by the model the
fit assumes: a 1.1 px straw alone, with a rider of half its contrast and half its width
1.5 px beside it, and with its middle cancelled by a highlight (not fitted)."""

import cv2
import numpy as np
import pytest

from rod_render import rod_coverage
from vidtrack.track._thin import THIN_PX, fit_line, strong_line

SHAPE = (40, 60)


def _scene(u, v, angle, *, rider=False, rng):
    c = rod_coverage(SHAPE, u, v, 19.0, 1.1, angle)
    if rider:
        nu, nv = -np.sin(angle), np.cos(angle)
        # half the contrast, half the width, 0.6 of the length, 1.5 px beside it and
        # 3 px ahead along it (what vidtrack synth --rider riding draws)
        c = np.maximum(c, 0.5 * rod_coverage(SHAPE, u + 1.5 * nu + 3 * np.cos(angle),
                                             v + 1.5 * nv + 3 * np.sin(angle), 11.4, 0.55,
                                             angle))
    c = cv2.GaussianBlur(c, (0, 0), 0.5)
    return (c + rng.normal(0, 0.01, SHAPE)).astype(np.float32)


def _fit(c):
    line = strong_line(c)
    assert line is not None and line[0] < THIN_PX
    domain = np.ones(c.shape, bool)
    return fit_line(c, domain, line, float(c.sum()) / max(line[1], 1.0))


@pytest.mark.parametrize("rider", [False, True])
def test_the_fitted_centre_is_the_straws(rider):
    rng = np.random.default_rng(3)
    errs, pulls = [], []
    for k in range(40):
        u, v = 30.0 + rng.uniform(-0.5, 0.5), 20.0 + rng.uniform(-0.5, 0.5)
        angle = rng.uniform(-np.pi / 2, np.pi / 2)
        c = _scene(u, v, angle, rider=rider, rng=rng)
        got = _fit(c)
        assert got is not None, k
        errs.append(np.hypot(got[0] - u, got[1] - v))
        # what the coverage moments of the detected pixels give: the rider pulls them
        m = cv2.moments(np.where(c > 0.1, c, 0), False)
        pulls.append(np.hypot(m["m10"] / m["m00"] - u, m["m01"] / m["m00"] - v))
    errs, pulls = np.array(errs), np.array(pulls)
    assert errs.max() < 0.15, errs.max()
    if rider:
        # the rider moves the moments by 0.44 px (median, 0.59 at most); the fit stays
        # on the straw (0.04 px median, 0.10 at most)
        assert np.median(pulls) > 0.3 and np.median(errs) < 0.25 * np.median(pulls)


def test_a_middle_cancelled_by_a_highlight_is_not_fitted():
    rng = np.random.default_rng(5)
    c = rod_coverage(SHAPE, 30.0, 20.0, 19.0, 1.1, 0.3)
    c = c - 0.9 * rod_coverage(SHAPE, 30.0, 20.0, 13.0, 1.1, 0.3)   # its middle gone
    c = (cv2.GaussianBlur(c, (0, 0), 0.5) + rng.normal(0, 0.01, SHAPE)).astype(np.float32)
    assert _fit(c) is None
