"""Real footage changed the way other labs' footage differs from it, tracked again.

The clips of ``../shared/data/real`` are re-encoded here, losslessly (FFV1 through
OpenCV), after one change a lab's footage could have: the polarity inverted (a dark
object on a bright wall), mirrored (the camera on the other side), half the size in
pixels (a wider view, a smaller sensor), a quarter of the brightness (a dim set-up,
short exposures), 0.4 times the contrast round mid-grey (haze, a flat picture profile),
every second frame (half the frame rate). The same object must come out: against the
track of the unchanged clip mapped through the change (itself checked against the
references made by others in ``test_real_footage.py``) and against those references.
What is measured (this code, 2-core machine) is in each test's docstring.

Skipped, saying why, where ``../shared`` is not beside the checkout.
"""

import cv2
import numpy as np
import pandas as pd
import pytest
from test_real_footage import _need

from vidtrack.footage import open_source
from vidtrack.track.tracker import track

CHANGES = {
    "invert": lambda im: 255 - im,
    "mirror": lambda im: np.ascontiguousarray(im[:, ::-1]),
    "half": lambda im: cv2.resize(im, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA),
    "dim": lambda im: np.rint(0.25 * im.astype(np.float32)).astype(np.uint8),
    "flat": lambda im: np.rint(0.4 * (im.astype(np.float32) - 128.0) + 128.0).astype(np.uint8),
    "every2": lambda im: im,
}


def _where(change, u, v, width):
    """Pixel (u, v) of the unchanged clip in the changed one (pixel centres at integers)."""
    if change == "half":
        return (u + 0.5) * 0.5 - 0.5, (v + 0.5) * 0.5 - 0.5
    if change == "mirror":
        return width - 1 - u, v
    return u, v


def _write(src_path, change, out, frames=None):
    """The clip (its file frames ``frames``, half-open; None: all) after ``change``, as a
    lossless FFV1 AVI, streamed frame by frame."""
    cap = cv2.VideoCapture(str(src_path))
    step = 2 if change == "every2" else 1
    a, b = frames if frames else (0, None)
    writer, k = None, 0
    try:
        while True:
            ok, image = cap.read()
            if not ok or (b is not None and k >= b):
                break
            if k >= a and (k - a) % step == 0:
                image = CHANGES[change](image)
                if writer is None:
                    h, w = image.shape[:2]
                    writer = cv2.VideoWriter(str(out), cv2.VideoWriter_fourcc(*"FFV1"), 30.0,
                                             (w, h), True)
                    assert writer.isOpened()
                writer.write(image)
            k += 1
    finally:
        cap.release()
        if writer is not None:
            writer.release()
    return out


def _track(path, fps, target=None, frames=None):
    with open_source(path, fps=fps, frames=frames) as src:
        return track(src, view="front", target=target), src.shape[1]


def _compare(change, base, width, tr):
    """Against the unchanged clip's track ``base``: (frames unflagged in both, each
    frame's distance in the unchanged clip's pixels, frames unflagged here where the
    unchanged clip measured nothing)."""
    step = 2 if change == "every2" else 1
    scale = 0.5 if change == "half" else 1.0
    d0 = base.data.iloc[::step]
    u0, v0 = _where(change, d0["u_px"].to_numpy(), d0["v_px"].to_numpy(), width)
    ok0 = base.usable[::step]
    d = tr.data
    n = min(len(d), len(u0))
    ok = tr.usable[:n]
    dist = np.hypot(d["u_px"].to_numpy()[:n] - u0[:n], d["v_px"].to_numpy()[:n] - v0[:n]) / scale
    both = ok & ok0[:n]
    return both, dist, ok & ~np.isfinite(u0[:n])


#: How far (px) the balltoss ball's points may move when the clip is inverted: at most,
#: and the median (measured with the flight tracker: 0.25 and 0.06; module notes of the
#: test).
INVERTED_MOST_PX = 0.3
INVERTED_MEDIAN_PX = 0.1


# --------------------------------------------------------------------- balltoss
@pytest.fixture(scope="module")
def balltoss(real_footage):
    path = real_footage / "balltoss" / "BallTossOut.mp4"
    _need(path)
    return path, *_track(path, 30)


@pytest.mark.parametrize("change", ["invert", "mirror"])
def test_balltoss_inverted_or_mirrored_gives_the_same_track(balltoss, change, tmp_path):
    """The tracker treats both polarities and both directions alike: the same flags,
    the same points. Mirrored: to 0.007 px (the order in which sums run and the noise's
    sampling grid are not mirrored). Inverted: a shadow darkens the wall by a factor,
    which a negative does not (its shadows lighten it), so the tests of a shadow and of
    a highlight, ratios to the wall, see other pixels: the flight tracker's points move
    by 0.06 px (median) and 0.25 px at most; the rules tracker's do not move."""
    path, base, width = balltoss
    tr, _ = _track(_write(path, change, tmp_path / f"{change}.avi"), 30)
    both, dist, extra = _compare(change, base, width, tr)
    np.testing.assert_array_equal(tr.usable, base.usable)
    np.testing.assert_array_equal(tr.data["flags"], base.data["flags"])
    assert np.all(dist[both] < (INVERTED_MOST_PX if change == "invert" else 0.02)), \
        dist[both].max()
    assert np.median(dist[both]) < (INVERTED_MEDIAN_PX if change == "invert" else 0.02)


@pytest.mark.parametrize("change,share,most", [("half", 0.85, 1.5), ("dim", 0.6, 3.0),
                                               ("flat", 0.9, 2.0), ("every2", 0.9, 1.5)])
def test_balltoss_smaller_dimmer_flatter_or_slower_follows_the_same_ball(balltoss, change,
                                                                        share, most,
                                                                        tmp_path):
    """The ball (about 12 px across) at half the size, a quarter of the brightness, 0.4
    times the contrast or every second frame: found after it leaves the hand as before,
    within a pixel or two of where the unchanged clip puts it. Measured, of the 18
    frames unflagged in the unchanged clip (9 of every second), unflagged here too and
    the distance's median and largest: half 16, 0.46 and 0.91 px; dim 12, 0.79 and
    2.57 px (a quarter of the brightness leaves the ball's blurred rim below the
    threshold: its area, 100 px, drops to 60 and wavers, and 6 frames are flagged for
    it); flat 18, 0.35 and 1.19 px; every second frame 9, 0.12 and 1.15 px."""
    path, base, width = balltoss
    fps = 15 if change == "every2" else 30
    tr, _ = _track(_write(path, change, tmp_path / f"{change}.avi"), fps)
    both, dist, extra = _compare(change, base, width, tr)
    step = 2 if change == "every2" else 1
    seen = tr.usable & np.isfinite(dist)
    print(f"\nballtoss {change}: {tr.usable.sum()} unflagged (unchanged "
          f"{base.usable[::step].sum()}), {both.sum()} in both; distance median "
          f"{np.median(dist[both]):.2f} px, largest {dist[seen].max():.2f}")
    assert both.sum() >= share * base.usable[::step].sum()
    assert not extra.any()                    # never the hand before it lets go
    assert np.median(dist[both]) <= 1.0
    assert np.all(dist[seen] <= most)


# --------------------------------------------------------------------- diabolo
@pytest.fixture(scope="module")
def diabolo(real_footage):
    folder = real_footage / "diabolo"
    path, csv = folder / "diabolo_240fps.mp4", folder / "tracker_points_240fps.csv"
    _need(path, csv)
    ref = np.loadtxt(csv, delimiter=",", skiprows=1)
    return path, ref, *_track(path, 240)


@pytest.mark.parametrize("change", ["half", "flat"])
def test_diabolo_smaller_or_flatter_never_the_student(diabolo, change, tmp_path):
    """The glider at half the size (about 22 px) or at 0.4 times the contrast: still
    followed all flight, never the student, within a few pixels of the unchanged clip's
    track (measured: median 0.3 and 0.5 px, 95 % within 1.2 and 1.9 px) and as near the
    authors' points as before (median 4.3 px: their mark is a dark spot on the glider,
    and it drifts off it)."""
    path, ref, base, width = diabolo
    tr, _ = _track(_write(path, change, tmp_path / f"{change}.avi"), 240)
    both, dist, extra = _compare(change, base, width, tr)
    scale = 0.5 if change == "half" else 1.0
    d = tr.data
    ru, rv = _where(change, ref[:, 2], ref[:, 3], width)
    to_ref = np.hypot(d["u_px"].to_numpy() - ru, d["v_px"].to_numpy() - rv) / scale
    ok = tr.usable
    print(f"\ndiabolo {change}: {ok.sum()} of {len(ok)} unflagged; from the unchanged track "
          f"median {np.median(dist[both]):.2f} px, 95 % within "
          f"{np.percentile(dist[both], 95):.2f} px; from the authors' points median "
          f"{np.median(to_ref[ok]):.2f} px")
    assert ok[1:].mean() >= 0.9
    measured = np.isfinite(to_ref)
    # never the student (300+ px away): unflagged within 20 px of the authors' points,
    # flagged ones (off the path) within 100
    assert np.all(to_ref[ok] < 20.0) and np.all(to_ref[measured] < 100.0)
    assert np.median(dist[both]) <= 1.0 and np.percentile(dist[both], 95) <= 3.0
    assert np.median(to_ref[ok]) <= 5.0


# --------------------------------------------------------------------- badminton
#: One flight between two hits, and the frame where the user names the shuttlecock.
BAD_FRAMES, BAD_AT = (732, 872), 802


@pytest.fixture(scope="module")
def badminton(real_footage):
    folder = real_footage / "badminton_2cam"
    path, csv = folder / "CameraReader_1.mp4", folder / "CameraReader_1.csv"
    _need(path, csv)
    lab = pd.read_csv(csv).set_index("Frame")
    at = (BAD_AT, (float(lab.loc[BAD_AT, "X"]), float(lab.loc[BAD_AT, "Y"])))
    return path, at, *_track(path, 119.12, target=at, frames=BAD_FRAMES)


def test_badminton_at_half_the_size_keeps_the_shuttlecock(badminton, tmp_path):
    """A 2048 x 1536 camera compressed hard, players and a crowd moving: at half the size
    (the shuttlecock about 4 px long) the named shuttlecock is still followed between
    the two hits, within a few pixels of the unchanged clip's track (measured: of the 92
    frames unflagged unchanged, 89 unflagged here too, 115 in all; median 0.36 px,
    largest 2.9 px; at 0.4 times the contrast, measured once: 89, 0.13 and 2.6 px)."""
    change = "half"
    path, at, base, width = badminton
    u, v = _where(change, *at[1], width)
    out = _write(path, change, tmp_path / f"{change}.avi", frames=BAD_FRAMES)
    tr, _ = _track(out, 119.12, target=(at[0] - BAD_FRAMES[0], (u, v)))
    both, dist, extra = _compare(change, base, width, tr)
    seen = tr.usable & np.isfinite(dist)
    print(f"\nbadminton cam1 {change}: {tr.usable.sum()} unflagged (unchanged "
          f"{base.usable.sum()}), {both.sum()} in both; median {np.median(dist[both]):.2f} px,"
          f" largest {dist[seen].max():.2f} px")
    assert both.sum() >= 0.9 * base.usable.sum()
    assert np.median(dist[both]) <= 1.0
    assert np.all(dist[seen] <= 5.0)              # never a player or the crowd
