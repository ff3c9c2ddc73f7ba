"""The running state of the tracker's follower: the object's reference size, shape and
grey level from its clean frames, its prediction, and what moves near it.

Internal to the tracker (:mod:`vidtrack.track._pass`, :mod:`vidtrack.track._step`).
"""

import statistics
from collections import deque

import numpy as np

from vidtrack.track._rods import rod_fill
from vidtrack.track._select import Intruders, Predictor
from vidtrack.track._thin import THIN_PX

#: A rod found again where the rod that was lost could be is another object when the
#: median width of its first frames differs from that of the lost rod's clean frames by
#: more than this factor either way (widths under
#: :data:`~vidtrack.track._thin.THIN_PX` taken as that: a rod 1.5 px wide and one 4 px,
#: 1.6) ...
LOOK_WIDTH = 1.5
#: ... or its grey level from the lost rod's by more than this share of the lost rod's
#: contrast to the background (the grey level of a rod of one level is its own wherever
#: it is; the rider of a dark straw, 64 against 13 on a background near 120: 0.9).
LOOK_LEVEL = 0.5


class Follow:
    """The running state of the follower (reference size, grey level, errors)."""

    def __init__(self):
        self.levels = deque(maxlen=9)
        self.areas = deque(maxlen=9)
        self.covs = deque(maxlen=9)      # coverage sums (px^2) of the clean frames
        self.grown_run = []              # sizes of the grown frames since the last clean
        self.cores = deque(maxlen=9)     # fully covered pixels of an object of one level
        self.fills = deque(maxlen=9)     # a rod's area / (length x width)
        self.uniforms = deque(maxlen=9)  # its share of such pixels inside its silhouette
        self.last_cov = None
        self.lengths = deque(maxlen=9)
        self.widths = deque(maxlen=9)
        self.strong_widths = deque(maxlen=9)  # its strongest pixels' (a thin straw's)
        self.errors = deque(maxlen=16)
        self.pred = Predictor()
        self.intruders = Intruders()
        self.gap = 0
        # (mask area, length) of the last frame followed, and whether every step since
        # the last clean frame was small: a straw turning out of an end-on view grows
        # smoothly from frame to frame, a merge jumps
        self.last_size = None
        self.smooth = True
        self.cut_at = -10 ** 9           # the last frame with something beyond its band
        # the last frame that was clean, and the last of the run of frames found one
        # after the other since (each judged for a part hidden)
        self.clean_at = -10 ** 9
        self.judged_at = -10 ** 9
        # found again coming out from behind something, part of it still hidden: (frame,
        # length, coverage) of the last such frame; it is still coming out while it grows
        # at a stroke from frame to frame (:meth:`coming_out`)
        self.emerging = None
        # an object of both polarities (segmented so), and one measured by its
        # silhouette (anything but a rod: the coverage by one grey level is a rod's)
        self.mixed = False
        self.compact = False
        self.rod = False        # an object of both polarities whose clean frames are a rod
        # (levels, areas, lengths, widths) of its first clean frames
        self.snapshot = None

    @property
    def level(self):
        return float(statistics.median(self.levels)) if self.levels else None

    def ref(self, q, default):
        return float(statistics.median(q)) if q else default

    def _small_step(self, a1, l1, *, step=1.25, slack_px=12.0):
        a0, l0 = self.last_size
        if a1 > step * a0 + slack_px:
            return False
        max_dl = 1.0 + 0.15 * max(self.lengths) if self.lengths else np.inf
        return not (np.isfinite(l0) and np.isfinite(l1) and l1 - l0 > max_dl)

    def smooth_growth(self, blob):
        """The blob's size reached from the last clean frame in small steps only.

        From frame to frame since the last clean frame, this one included, the mask
        area grows by at most 1.25 times plus 12 px (the edge pixels of a straw seen
        end-on come and go with the noise), and the length by at most 1 px plus 0.15 of
        the longest reference length: the straw turning, not another blob joining.
        """
        return (self.last_size is not None and self.smooth
                and self._small_step(blob.mask_area, blob.length))

    def become_mixed(self):
        """Measure the object by its silhouette from now on (its sizes start again)."""
        self.mixed = True
        self.compact = True
        self.areas.clear()
        self.covs.clear()
        self.last_cov = None
        self.lengths.clear()
        self.widths.clear()
        self.last_size = None
        self.smooth = True

    def regrown(self, blob, *, frames=6, spread=1.3):
        """``blob`` ends a run of ``frames`` consecutive grown frames of one size."""
        self.grown_run.append((blob.mask_area, blob.area, blob.length, blob.width))
        run = self.grown_run[-frames:]
        if len(run) < frames:
            return False
        a = [r[0] for r in run]
        return max(a) <= spread * min(a)

    def relearn(self):
        """Take the last grown frames' sizes as the reference."""
        run = self.grown_run[-6:]
        self.areas.clear()
        self.covs.clear()
        self.lengths.clear()
        self.widths.clear()
        for m, c, ln, w in run:
            self.areas.append(m)
            if np.isfinite(c):
                self.covs.append(c)
            if np.isfinite(ln):
                self.lengths.append(ln)
                self.widths.append(w)
        self.grown_run = []
        self.smooth = True

    def seen(self, blob):
        """Record the size of a followed frame that was not clean."""
        if self.last_size is not None:
            self.smooth = self.smooth and self._small_step(blob.mask_area, blob.length)
            self.last_size = (blob.mask_area, blob.length)

    @property
    def pred_error(self):
        """RMS distance (px) of its clean frames from their prediction (1 px before any)."""
        return float(np.sqrt(np.mean(np.square(self.errors)))) if self.errors else 1.0

    @property
    def length_jitter(self):
        """Median change (px) of the length from one clean frame to the next (0 before
        two are known)."""
        ls = list(self.lengths)
        return float(statistics.median(abs(b - a) for a, b in zip(ls, ls[1:]))) \
            if len(ls) >= 2 else 0.0

    @property
    def cov_jitter(self):
        """Median relative change of the coverage from one clean frame to the next (0
        before two are known)."""
        cs = list(self.covs)
        return float(statistics.median(abs(b - a) / max(a, 1e-9) for a, b in zip(cs, cs[1:]))) \
            if len(cs) >= 2 else 0.0

    @property
    def thin(self):
        """A thin straw: its clean frames' strongest pixels under
        :data:`~vidtrack.track._thin.THIN_PX` wide (3 of them at least)."""
        return len(self.strong_widths) >= 3 and \
            statistics.median(self.strong_widths) < THIN_PX

    def coming_out(self, i, blob, rod):
        """Frame ``i``'s ``blob`` of an object found again partly hidden (:attr:`emerging`)
        is still coming out: the frame follows the last such one and the object grew
        since by more than 3 times its clean frames' change from one to the next (a rod's
        length, at least 0.1 px; any other's coverage, at least 1 %). A frame that does
        not ends it."""
        if self.emerging is None:
            return False
        at, length, cov = self.emerging
        if rod:
            grew = blob.length - length >= max(3.0 * self.length_jitter, 0.1)
        else:
            grew = blob.area / max(cov, 1e-9) - 1.0 >= max(3.0 * self.cov_jitter, 0.01)
        if i - at != 1 or not grew:
            self.emerging = None
            return False
        self.emerging = (i, blob.length, blob.area)
        return True

    def look(self, background):
        """``(grey level, width, contrast)`` of a rod from its clean frames (``background``:
        the background's level where it was last clean), or None: an object of any shape
        (its size and level change as it turns), or one whose level or widths are not
        known from 3 clean frames."""
        if self.compact or self.level is None or len(self.widths) < 3 or \
                not np.isfinite(background):
            return None
        return self.level, float(statistics.median(self.widths)), self.level - background

    def trims(self):
        """An object of one grey level (learnt from 3 clean frames): what is attached
        beyond its core is cut off."""
        return (not self.mixed and len(self.uniforms) >= 3
                and statistics.median(self.uniforms) >= 0.8)

    def add(self, blob):
        fill = rod_fill(blob)
        if fill is not None:
            self.fills.append(fill)
        if getattr(blob, "core", None):
            self.cores.append(blob.core)
            self.uniforms.append(blob.uniform)
        self.grown_run = []
        self.last_size = (blob.mask_area, blob.length)
        self.smooth = True
        self.areas.append(blob.mask_area)
        if np.isfinite(blob.area):
            self.covs.append(blob.area)
        if np.isfinite(blob.length):
            self.lengths.append(blob.length)
            self.widths.append(blob.width)
        if np.isfinite(blob.strong_shape[0]):
            self.strong_widths.append(blob.strong_shape[0])
        if self.snapshot is None and len(self.areas) >= 5:
            self.snapshot = (list(self.levels), list(self.areas), list(self.lengths),
                             list(self.widths))


def unlike(look, blobs):
    """How the rod ``blobs`` (a tracklet's detections) differ from the rod of ``look``
    (:meth:`Follow.look`): a phrase, or None when they may be that rod (see
    :data:`LOOK_WIDTH`, :data:`LOOK_LEVEL`)."""
    level, width, contrast = look
    widths = [b.width for b in blobs if np.isfinite(b.width) and b.width > 0]
    levels = [b.level for b in blobs if np.isfinite(b.level)]
    if widths:
        # (narrower than THIN_PX, a rod's width is set by where it falls on the pixel
        # grid: such widths are all alike here)
        ratio = max(statistics.median(widths), THIN_PX) / max(width, THIN_PX)
        if not 1.0 / LOOK_WIDTH <= ratio <= LOOK_WIDTH:
            return f"{ratio:.2g} times as wide"
    if levels and abs(contrast) > 0:
        off = (statistics.median(levels) - level) / abs(contrast)
        if abs(off) > LOOK_LEVEL:
            return (f"grey level {statistics.median(levels):.0f} against {level:.0f} "
                    f"(background {level - contrast:.0f})")
    return None
