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


def _overlap(lo, hi, centres, size=1.0):
    """Length of [lo, hi] within each pixel of ``size`` centred at ``centres``."""
    return np.clip(np.minimum(hi, centres + 0.5 * size)
                   - np.maximum(lo, centres - 0.5 * size), 0.0, None)


def _rows_of_strip(v, width, rows, blur, fine=32):
    """Each pixel row's share of a strip across the rows (centre ``v``): exact without
    blur; with ``blur`` (px), the strip on a grid ``fine`` times finer, blurred there by a
    Gaussian (the optics, before the pixels), each row the mean of its fine rows."""
    if not blur:
        return _overlap(v - 0.5 * width, v + 0.5 * width, rows)
    centres = rows[0] - 0.5 + (np.arange(rows.size * fine) + 0.5) / fine
    f = _overlap(v - 0.5 * width, v + 0.5 * width, centres, 1.0 / fine) * fine
    f = cv2.GaussianBlur(f.reshape(-1, 1), (1, 0), sigmaX=0.1, sigmaY=blur * fine,
                         borderType=cv2.BORDER_CONSTANT).ravel()
    return f.reshape(rows.size, fine).mean(axis=1)


@pytest.mark.parametrize("blur", [0.0, 0.5])
def test_a_straw_along_a_row_is_placed_across_it_better_than_its_pixels_moments(blur):
    """A 1.4 px straw lying along a pixel row, its coverage the overlap of its strip with
    each pixel (the pixel's box, which is not a blur; with the optics' blur before it):
    the pixels' coverage centroid is up to 0.1 px off its centre across the row as it
    moves across it, the strip fitted through the box is not."""
    rng = np.random.default_rng(7)
    rows, cols = np.arange(SHAPE[0], dtype=float), np.arange(SHAPE[1], dtype=float)
    errs, moments = [], []
    for v in 20.0 + np.linspace(-0.5, 0.5, 21)[:-1]:
        u = 30.0 + rng.uniform(-0.5, 0.5)
        c = np.outer(_rows_of_strip(v, 1.4, rows, blur), _overlap(u - 10.0, u + 10.0, cols))
        c = (c + rng.normal(0, 0.01, SHAPE)).astype(np.float32)
        got = _fit(c)
        assert got is not None
        errs.append(got[1] - v)
        m = cv2.moments(np.where(c > 0.1, c, 0), False)
        moments.append(m["m01"] / m["m00"] - v)
    errs, moments = np.abs(errs), np.abs(moments)
    print(f"\nblur {blur}: fit across {errs.max():.3f} px at most, "
          f"{np.sqrt(np.mean(errs ** 2)):.3f} RMS; moments {moments.max():.3f}, "
          f"{np.sqrt(np.mean(moments ** 2)):.3f}")
    assert np.sqrt(np.mean(errs ** 2)) < 0.25 * np.sqrt(np.mean(moments ** 2))
    assert errs.max() < 0.02
