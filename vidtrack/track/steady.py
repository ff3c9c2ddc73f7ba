"""A shaking camera: every frame moved back onto the background's place.

A camera that rides on the machine, or stands on a floor the machine shakes, moves by a
pixel or two as the machine vibrates. The tracker measures the object where it is in
the frame; with the camera moving, that is not where it is in the scene, and the fit
takes the camera's motion for the object's (a smooth 1 px shake at 9 Hz made k1 12 %
and k4 10 % off on the sample run, with every frame tracked within 0.07 px).

:meth:`Steadier.look` measures, on the frames the background is taken from, how far
each lies from their median: up to 400 corners of the median (OpenCV's
``goodFeaturesToTrack``, spread over 16 cells) are followed into each frame (pyramidal
Lucas-Kanade, ``calcOpticalFlowPyrLK``); each cell votes with its corners' median
shift, and the frame's shift is the mean of the corners' shifts that agree within half
a pixel with the shift the most cells agree with, where those are at least a share of
the cells voting (the flight tracker's ``camera_agree_share``; the rules tracker takes
the cells' median, half of them agreeing) and outnumber any other group agreeing among
itself (a person, a hand,
the object or a turning machine part hold a few cells: a textured person swaying at the
side of the frame, with most of the corners, is not a shake). Below
:data:`SHAKE_PX` (RMS) the camera is steady and nothing is done: no cost beyond that
look. Above it, the samples are moved back and their median taken again (sharp, where
the shaken one blurs the texture), and every frame is measured against it and moved
back (:meth:`Steadier.warp`, bicubic) before it is tracked: the positions are then
against the scene as the background shows it, up to one constant (where the camera
was on average over the sampled frames). Translation only: a camera that turns about
its axis, or zooms, is not followed.

Internal to the trackers (:mod:`vidtrack.track._pass`, :mod:`vidtrack.track.flight`).
"""

import math

import cv2
import numpy as np

#: The columns of a steadied view's track (:mod:`vidtrack.track.tracker`, tracks.h5): how
#: far each frame's content lay from the steadied place, px (``u_px + camera_du_px`` is
#: where the point is in the footage as shot).
CAMERA_COLUMNS = ("camera_du_px", "camera_dv_px")
#: Shake (RMS of the sampled frames' shifts from their mean, px) above which the footage
#: is steadied. The look's own noise on steady footage is 0.01-0.04 px (synth runs, a
#: badminton camera); the real clips of docs/tracker.md show smooth motions of 0.055 px
#: (diabolo), 0.12-0.13 px (the bear's phone) and 0.32 px (ball toss), all left alone:
#: steadied at 0.25 px, the ball toss's variants (inverted, half the size, dimmer) fell
#: on either side of the threshold and their tracks differed from the clip's by up to
#: 2.9 px; at 0.1 (an earlier alignment) a bear clip kept 37 of 70 frames against 56.
SHAKE_PX = 0.5
#: A camera whose sampled frames lie farther apart than this (px, from their median)
#: is not shaking but panning, or the scene moving as a whole (the ground under a
#: travelling machine): not steadied, and the notes say so.
SHAKE_MAX_PX = 6.0
#: Corners followed (at most), and the fewest that must agree for a frame's shift.
CORNERS, AGREE_MIN = 400, 12
#: Two shifts (a cell's vote, a corner's) agree when they lie within this many pixels
#: of each other along each axis.
AGREE_PX = 0.5
#: The cells (about square) the corners are spread over (each votes once), and how strong a
#: corner must be against the strongest in the frame (its smaller eigenvalue).
_CELLS, _QUALITY = 16, 3e-4
#: No corner nearer the frame's edge (px): what the camera brings in or takes out there
#: is not a shift of what was there.
_EDGE = 16
#: Sampled frames the shake is first measured on, and their size then (pixels).
_LOOK, _LOOK_PX = 9, 330_000
_LK = dict(winSize=(21, 21), maxLevel=3,
           criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))


def _eight(frame, lo, hi):
    """A frame as 8 bits (Lucas-Kanade's input), grey levels ``lo..hi`` to 0..255."""
    f = np.asarray(frame, dtype=np.float32)
    return np.clip((f - lo) * (255.0 / max(hi - lo, 1e-6)), 0, 255).astype(np.uint8)


def _back(img, sh):
    """``img`` moved back by the shift ``sh`` (bicubic; same dtype)."""
    w = np.array([[1.0, 0.0, sh[0]], [0.0, 1.0, sh[1]]], np.float32)
    rows, cols = img.shape
    return cv2.warpAffine(img, w, (cols, rows), flags=cv2.INTER_CUBIC | cv2.WARP_INVERSE_MAP,
                          borderMode=cv2.BORDER_REPLICATE)


class _Corners:
    """Corners of a reference image, spread over a grid of cells, followed into other
    frames; each cell votes with its corners' median shift (a person or a machine part,
    however rich in corners, holds a few cells, not the frame)."""

    def __init__(self, ref, lo, hi, agree_share=None):
        self.lo, self.hi = lo, hi
        self.agree_share = agree_share
        self.ref8 = _eight(ref, lo, hi)
        rows, cols = ref.shape
        eig = cv2.cornerMinEigenVal(self.ref8, 3)
        least = _QUALITY * float(eig.max())
        pts, cells = [], []
        # cells about square, about _CELLS of them over the frame less its edge
        inner_r, inner_c = rows - 2 * _EDGE, cols - 2 * _EDGE
        if inner_r >= 8 and inner_c >= 8:
            side = math.sqrt(inner_r * inner_c / _CELLS)
            nr, nc = max(1, round(inner_r / side)), max(1, round(inner_c / side))
            for a in range(nr):
                for b in range(nc):
                    r0, r1 = _EDGE + a * inner_r // nr, _EDGE + (a + 1) * inner_r // nr
                    c0, c1 = _EDGE + b * inner_c // nc, _EDGE + (b + 1) * inner_c // nc
                    top = float(eig[r0:r1, c0:c1].max())
                    if not top > least:
                        continue
                    got = cv2.goodFeaturesToTrack(self.ref8[r0:r1, c0:c1],
                                                  CORNERS // _CELLS, least / top, 5)
                    if got is not None:
                        pts.append(got.reshape(-1, 2) + np.float32([c0, r0]))
                        cells.extend([a * nc + b] * len(got))
        self.pts = np.concatenate(pts).reshape(-1, 1, 2).astype(np.float32) if pts else None
        self.cells = np.asarray(cells)

    def shift(self, frame, init=(0.0, 0.0)):
        """Where ``frame``'s content lies against the reference (px), or None: the median
        the most cells agree with within half a pixel (see :meth:`Steadier.look`'s
        ``agree_share``); the mean of their corners that agree too."""
        if self.pts is None or len(self.pts) < AGREE_MIN:
            return None
        img = _eight(frame, self.lo, self.hi)
        guess = self.pts + np.float32(init)
        got, st, _ = cv2.calcOpticalFlowPyrLK(self.ref8, img, self.pts, guess.copy(),
                                              flags=cv2.OPTFLOW_USE_INITIAL_FLOW, **_LK)
        ok = st.ravel() == 1
        d = (got - self.pts).reshape(-1, 2)[ok]
        cells = self.cells[ok]
        votes = {c: np.median(d[cells == c], axis=0) for c in np.unique(cells)
                 if np.count_nonzero(cells == c) >= 2}
        if len(votes) < 2:
            return None
        v = np.array(list(votes.values()))
        if self.agree_share is None:
            # (the rules tracker's: the cells' median, half of them agreeing with it)
            med = np.median(v, axis=0)
            agree_cells = [c for c, m in votes.items() if np.all(np.abs(m - med) <= AGREE_PX)]
            if len(agree_cells) < max(2, 0.5 * len(votes)):
                return None
        else:
            # the shift the most cells agree with (within half a pixel), the cells'
            # median deciding between equals; it must hold agree_share of the votes and
            # more cells than any group of the others that agree among themselves
            near = np.all(np.abs(v[:, None] - v[None]) <= AGREE_PX, axis=2)
            support = near.sum(axis=1)
            off = np.abs(v - np.median(v, axis=0)).sum(axis=1)
            best = min(range(len(v)), key=lambda j: (-support[j], off[j]))
            med = np.median(v[near[best]], axis=0)
            inside = np.all(np.abs(v - med) <= AGREE_PX, axis=1)
            rival = near[~inside][:, ~inside].sum(axis=1).max(initial=0)
            agree_cells = [c for c, ok in zip(votes, inside) if ok]
            if (len(agree_cells) < max(2, self.agree_share * len(votes))
                    or rival >= len(agree_cells)):
                return None
        agree = np.isin(cells, agree_cells) & np.all(np.abs(d - med) <= AGREE_PX, axis=1)
        if np.count_nonzero(agree) < AGREE_MIN:
            return None
        m = d[agree].mean(axis=0)
        return float(m[0]), float(m[1])


def _range(frames):
    lo, hi = np.percentile(np.stack([f[::4, ::4] for f in frames[:5]]), [0.5, 99.5])
    return float(lo), float(hi)


class Steadier:
    """Frames of a shaking camera moved back onto a reference (see the module).

    Attributes
    ----------
    shifts : dict
        Source index -> ``(du, dv)`` px: where frame content lies against the reference.
    failed : int
        Frames whose shift could not be measured (taken from the frame before).
    """

    def __init__(self, corners, shifts):
        self.corners = corners
        self.shifts = dict(shifts)
        self.failed = 0
        self._last = (0.0, 0.0)

    @classmethod
    def look(cls, samples, frames, median=None, agree_share=None):
        """Measure the shake on the background's sampled frames.

        Parameters
        ----------
        samples : list of numpy.ndarray
            The sampled frames (at least 3).
        frames : sequence of int
            Their source indices.
        median : numpy.ndarray, optional
            Their per-pixel median, where it is known (the background's image).
        agree_share : float, optional
            A frame's shift is the one the most cells agree with, where they are at
            least this share of the cells voting and outnumber any other group that
            agrees among itself (the flight tracker's ``camera_agree_share``). None:
            the cells' median, where at least half of them agree with it.

        Returns
        -------
        (Steadier or None, str)
            None where the camera is steady; and a note saying what was measured.
        """
        lo, hi = _range(samples)
        ref = (np.median(np.stack(samples), axis=0) if median is None else median)
        ref = np.asarray(ref, np.float32)
        # first on a few of them (a shake worth steadying shows in any 9), at most a
        # third of a megapixel (a shake of 0.5 px is still 0.3 px there)
        rows, cols = ref.shape
        f = min(1.0, math.sqrt(_LOOK_PX / float(rows * cols)))

        def small(img):
            img = np.asarray(img, np.float32)
            return img if f >= 1.0 else cv2.resize(img, None, fx=f, fy=f,
                                                   interpolation=cv2.INTER_AREA)

        few = np.unique(np.linspace(0, len(samples) - 1, _LOOK).round().astype(int))
        first = _Corners(small(ref), lo, hi, agree_share)
        sh = [first.shift(small(samples[k])) for k in few]
        sh = np.array([g for g in sh if g is not None]) / f
        if len(sh) < 3:
            return None, ("camera: too few corners agree between the sampled frames to "
                          "measure a shake: taken as steady")
        rms = float(np.sqrt(np.mean(np.sum((sh - sh.mean(axis=0)) ** 2, axis=1))))
        if rms <= SHAKE_PX:
            return None, (f"camera: steady ({len(sh)} of the sampled frames lie within "
                          f"{rms:.2g} px RMS of each other)")
        far = float(np.abs(sh - np.median(sh, axis=0)).max())
        if far > SHAKE_MAX_PX:
            return None, (f"camera: the scene moves as a whole by up to {far:.3g} px over "
                          f"the sampled frames, more than a shake ({SHAKE_MAX_PX:g} px): a "
                          f"pan, a zoom or a moving ground is not steadied")
        corners = _Corners(ref, lo, hi, agree_share)
        got = [corners.shift(s) for s in samples]
        sh = np.array([g for g in got if g is not None])
        rms = float(np.sqrt(np.mean(np.sum((sh - sh.mean(axis=0)) ** 2, axis=1))))
        # moved back, their median is sharp where the shaken one blurs the texture
        ref = np.median(np.stack([_back(np.asarray(s, np.float32), g)
                                  for s, g in zip(samples, got) if g is not None]), axis=0)
        steady = cls(_Corners(ref.astype(np.float32), lo, hi, agree_share), {})
        for i, s, g in zip(frames, samples, got):
            steady.shift(int(i), s, init=(0.0, 0.0) if g is None else g)
        return steady, (f"camera: shakes by {rms:.2g} px RMS over the sampled frames: every "
                        f"frame is moved back onto their median before it is tracked "
                        f"(positions against the scene)")

    def shift(self, i, frame, *, init=None):
        """Where frame ``i``'s content lies against the reference (px), measured once."""
        if i in self.shifts:
            return self.shifts[i]
        # started from the frame beside it where that is measured (frames may be
        # measured out of order: a pair for the background's noise), else the last
        guess = init if init is not None else self.shifts.get(
            i - 1, self.shifts.get(i + 1, self._last))
        got = self.corners.shift(frame, guess)
        if got is None and init is None:
            got = self.corners.shift(frame)
        if got is None:
            self.failed += 1
            got = guess
        self.shifts[i] = self._last = got
        return got

    def warp(self, i, frame):
        """Frame ``i`` moved back onto the reference (same shape and dtype)."""
        return _back(frame, self.shift(i, frame))

    def summary(self):
        """A note on the shifts measured: their RMS, largest, failures."""
        vals = np.array(list(self.shifts.values()))
        dev = vals - vals.mean(axis=0)
        rms = float(np.sqrt(np.mean(np.sum(dev ** 2, axis=1))))
        note = (f"camera: {len(vals)} frames moved back, by {rms:.2g} px RMS, up to "
                f"{float(np.abs(vals).max()):.2g} px")
        if self.failed:
            note += (f"; in {self.failed} frames too few corners agreed (moved as the frame "
                     f"before)")
        return note
