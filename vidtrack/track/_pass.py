"""One tracking pass over a view's frames (:class:`Pass`): the background, the search
for the object while it is not followed, following it (:mod:`vidtrack.track._step`),
following it backwards from where it was taken, and the refinement afterwards.

Internal to :mod:`vidtrack.track.tracker`, whose :func:`~vidtrack.track.tracker.track_parts`
runs it.
"""

import copy
import math
from collections import deque
from types import SimpleNamespace

import numpy as np

from vidtrack._progress import progress
from vidtrack.errors import TrackError
from vidtrack.track import _refine
from vidtrack.track._flags import (APPEARANCE, BLADE, BORDER, LOST, MERGED, OUTLIER,
                                   PRE_RELEASE, PREDICTED)
from vidtrack.track._follow import Follow, unlike
from vidtrack.track._rods import OFF_AXIS_MAX, rod_fill, rodlike_run, thin_line_run
from vidtrack.track._search import search_blobs
from vidtrack.track._segment import Segmenter
from vidtrack.track._select import Acquirer, Tracklet
from vidtrack.track._step import HIDDEN_PX, follow, part_hidden
from vidtrack.track._target import ambiguity_message, target_blob, target_index
from vidtrack.track.background import Background, estimate_background, sample_indices
from vidtrack.track.flight import Cancelled, blade_mask
from vidtrack.track.steady import CAMERA_COLUMNS, Steadier

#: Memory the start-of-footage buffer for the background may take (bytes).
_WARMUP_BYTES = 96 * 1024 * 1024
#: Memory the frames before a ``target`` frame may take for following backwards (bytes);
#: earlier frames are read again.
_BACK_BYTES = 128 * 1024 * 1024
#: Memory the frames round where the object is first taken may take, without a target
#: (bytes): following it backwards from there reads them from memory (re-reading 24
#: frames of a 1024 x 1024 MJPG video took 4 % of the tracker's time).
_RECENT_BYTES = 32 * 1024 * 1024
#: Specks (:meth:`~vidtrack.track._segment.Segmenter.specks`) a frame may hold per
#: megapixel (and at least :data:`_SPECKS_MIN`) before the threshold is raised by
#: :data:`_SPECK_STEP` at a time, up to :data:`_SPECK_MAX` times the noise's: Gaussian
#: noise at 5 sigma makes none; the real clips at the measured noise make 16-85 (a ball
#: toss), 170-430 (a classroom clip), 60-930 (phone clips of a bear) and about 1000 (a
#: hard compressed 2048 x 1536 badminton camera, where a shuttlecock of 8 px is lost
#: among them).
_SPECKS_PER_MPX = 300
_SPECKS_MIN = 20
_SPECK_STEP = 1.25
_SPECK_MAX = 8.0
#: Frames between two counts of the specks.
_SPECK_EVERY = 16
#: An object measured by its silhouette has a shadow attached (:meth:`Pass.attached_shadow`)
#: when a soft, weak, darker part offset from the rest is found in at least this share of
#: its clean frames, on the same side (the mean of the unit vectors towards it at least
#: :data:`_SHADOW_ALIGN` long): a lamp casts it the same way all through a throw, where
#: an object's own faint parts come and go as it turns.
_SHADOW_SHARE = 0.6
_SHADOW_ALIGN = 0.8

_TOP_RELEASE_NOTE = ("not looked for in the top view: it sees the rotor's plane edge-on, "
                     "where the ride on the blade barely differs from free flight; the "
                     "merge carries t = 0 over from the front view through the shared X")


def _name(view, source):
    if view:
        return f"view {view}"
    return f"{getattr(source, 'path', 'footage')}"


def _release_evidence(u, flags, *, clear_run=10):
    """Frames whose centroid may serve to find the release.

    Measured frames not at the border, not bridged and not outliers. Frames merged with
    another moving object count while the straw may still be on or near the rotor: up
    to the first run of ``clear_run`` consecutive clean frames (riding the tooth the
    straw is often merged with it, and it may be clear of it for a few frames before
    the release); later merged frames (another straw crossing) do not.
    """
    ok = np.isfinite(u) & ((flags & (BORDER | LOST | PREDICTED | OUTLIER | APPEARANCE)) == 0)
    clean = (flags == 0) & np.isfinite(u)
    run = 0
    for i, c in enumerate(clean):
        run = run + 1 if c else 0
        if run >= clear_run:
            later = np.arange(u.size) > i
            ok &= ~(later & ((flags & MERGED) > 0))
            break
    return ok


def _flew_clear(u, v, area, clean, start, stop):
    """The object followed over frames ``start:stop`` was seen flying clear of other
    objects: its clean frames span (their bounding box's diagonal) at least twice its
    size (the square root of their median area, at least 4 px), as
    :meth:`Tracklet.flying` asks of a candidate."""
    ok = np.flatnonzero(clean[start:stop]) + start
    if ok.size < 2:
        return False
    size = max(float(np.sqrt(np.median(area[ok]))), 4.0)
    reach = float(np.hypot(np.ptp(u[ok]), np.ptp(v[ok])))
    return reach >= 2.0 * size


def _last_split(blobs, *, ratio=1.33, keep=3):
    """Index of the first blob after the last one-frame change of the mask area by more
    than ``ratio`` (a split or a merge), when at least ``keep`` blobs follow it; else 0."""
    a = np.array([max(b.mask_area, 1) for b in blobs], float)
    if a.size <= keep:
        return 0
    jump = np.flatnonzero(np.maximum(a[1:] / a[:-1], a[:-1] / a[1:]) > ratio) + 1
    jump = jump[jump <= a.size - keep]
    return int(jump[-1]) if jump.size else 0


def _first_clean_run(clean, start, length):
    """First index at or after ``start`` that begins ``length`` clean frames, or None."""
    run = 0
    for k in range(start, len(clean)):
        run = run + 1 if clean[k] else 0
        if run >= length:
            return k - length + 1
    return None


class Pass:
    """One pass over a view's frames (the arguments are
    :func:`~vidtrack.track.tracker.track`'s): the per-frame
    rows (``u, v, area, angle, length, flags``), the state of the search and of the
    follower. :meth:`run` reads the frames, :meth:`parts` refines and returns the
    result."""

    def __init__(self, source, *, background=None, view=None, k_sigma=5.0, min_area_px=4,
                 max_gap=5, blade_region=None, centre_line_px=None, warmup_frames=None,
                 quiet=True, cancel=None, target=None, shadow="aside", slow=False,
                 steady=None):
        self.source, self.view, self.quiet, self.cancel = source, view, quiet, cancel
        # a shaking camera's frames moved back onto the background (another pass's
        # Steadier, or measured on the warm-up's samples below)
        self.steady = steady
        self.shadow = shadow     # a silhouette's attached shadow: "aside" or "cut"
        self.target, self.k_sigma = target, k_sigma
        self.t_idx = None        # the target's source index (:meth:`run`)
        self.name = name = _name(view, source)
        self.n = n = len(source)
        self.shape = shape = tuple(source.shape)
        if n < 3:
            raise TrackError(f"{name}: tracking needs at least 3 frames, the footage has {n}")
        if not (np.isfinite(k_sigma) and k_sigma > 0):
            raise TrackError(f"k_sigma must be > 0, got {k_sigma!r}")
        if int(max_gap) < 0:
            raise TrackError(f"max_gap must be >= 0, got {max_gap!r}")
        self.max_gap = max_gap
        self.times = times = np.asarray(source.times_s, dtype=np.float64)
        self.fnums = np.asarray(source.frame_numbers, dtype=np.int64)
        steps = np.diff(times)
        self.dt = dt = float(np.median(steps)) if steps.size else 1.0
        if not dt > 0:
            raise TrackError(f"{name}: the frame times do not increase")
        self.tau = (times - times[0]) / dt
        self.blade = blade_mask(blade_region, shape)
        self.notes = []

        self.frames = iter(source)
        self.buffer = deque()
        if background is None:
            frame_bytes = int(np.prod(shape)) * np.dtype(source.dtype).itemsize
            warm = warmup_frames or int(np.clip(_WARMUP_BYTES // max(frame_bytes, 1), 16,
                                                300))
            warm = int(min(max(warm, 3), n))
            for _ in range(warm):
                self.buffer.append(next(self.frames))
            buffer = self.buffer
            sidx = sample_indices(warm, 25)
            pidx = sample_indices(warm - 1, 12)
            background = estimate_background([buffer[i] for i in sidx],
                                             pairs=[(buffer[i], buffer[i + 1]) for i in pidx],
                                             frames=sidx)
            self.notes.append(f"background: median of {len(sidx)} frames spread over frames "
                              f"0..{warm - 1}")
            if steady is None:
                steady, note = Steadier.look([buffer[i] for i in sidx], sidx,
                                             background.image)
                if steady is not None or note.startswith("camera: the scene moves"):
                    self.notes.append(note)
            if steady is not None:
                # the frames moved back onto one place, and their background again
                self.steady = steady
                self.buffer = buffer = deque(steady.warp(i, f) for i, f in enumerate(buffer))
                background = estimate_background(
                    [buffer[i] for i in sidx], pairs=[(buffer[i], buffer[i + 1]) for i in pidx],
                    frames=sidx)
        elif not isinstance(background, Background):
            raise TrackError(f"background must be a vidtrack.track.background.Background, "
                             f"got {type(background).__name__}")
        if tuple(background.shape) != shape:
            raise TrackError(f"{name}: the background is {background.shape}, the frames are "
                             f"{shape}")
        self.background = background

        self.seg = Segmenter(background, k_sigma=k_sigma)
        rows, cols = shape
        self.u = np.full(n, np.nan)
        self.v = np.full(n, np.nan)
        self.area = np.full(n, np.nan)
        self.angle = np.full(n, np.nan)
        self.length = np.full(n, np.nan)
        self.flags = np.full(n, LOST, dtype=np.int64)
        self.clean = np.zeros(n, bool)
        self.seeded = np.zeros(n, bool)  # stored from an acquisition's tracklet, not followed
        self.solid = np.zeros(n, bool)   # measured as an object of any shape (not a rod)
        self.shade = np.full((n, 2), np.nan)  # where its attached shadow pulls it (px)

        self.min_area = max(1, int(min_area_px))
        self.acq = Acquirer(confirm=3, max_step=0.25 * max(rows, cols), min_motion=0.3,
                            centre_line=centre_line_px, tiny_px=3 * self.min_area,
                            slow=slow)
        self.fol = None
        self.lost_state = None      # (Predictor, tau) of the straw when it was lost
        self.lost_index = None      # the frame where it was lost
        self.lost_look = None       # a lost rod's Follow.look, None for any other
        self.lost_fol = None        # the Follow of the object lost
        self.unlike_noted = set()   # first frames of the tracklets refused so
        self.last_level = float("nan")
        self.moving_frames = 0
        self.speck_limit = max(_SPECKS_MIN, _SPECKS_PER_MPX * rows * cols / 1e6)
        self.specks_seen = []       # (frame, specks at the measured noise) where raised

    # ------------------------------------------------------------------ rows

    def store(self, i, blob, extra=0):
        """Frame ``i``'s row from ``blob``, flagged ``extra`` and by where it is; the
        flags."""
        self.u[i], self.v[i], self.area[i] = blob.u, blob.v, blob.area
        self.angle[i], self.length[i] = blob.angle, blob.length
        if blob.shadowless is not None:
            self.shade[i] = (blob.u - blob.shadowless[0], blob.v - blob.shadowless[1])
        fl = extra
        if blob.touches_border:
            fl |= BORDER
        if self.blade is not None:
            x0, y0, x1, y1 = blob.bbox
            if self.blade[y0:y1, x0:x1].any():
                fl |= BLADE
        self.flags[i] = fl
        self.clean[i] = fl == 0
        return fl

    def flag(self, mask, bit):
        """Set the flag ``bit`` on the frames ``mask`` (bool per frame): they are no
        longer clean."""
        self.flags[mask] |= bit
        self.clean[mask] = False

    # ------------------------------------------------------------------ searching

    def lost_gate(self, t_new):
        """Where the lost straw may be now: (position, velocity, acceleration, gate)."""
        pred, t_lost = self.lost_state
        st = pred.state(t_new)
        if st is None:
            return None
        p, vel, acc = st
        gap = t_new - t_lost
        speed = float(np.hypot(*vel))
        gate = 10.0 + 0.15 * speed * gap + 0.5 * float(np.hypot(*acc)) * gap * gap
        return p, vel, acc, gate

    def consistent_with_lost(self, tr):
        """A tracklet may be the straw that was lost: where and as fast as it can be."""
        if self.lost_state is None:
            return True
        t_new = tr.points[-1][0]
        got = self.lost_gate(t_new)
        if got is None:
            return True
        p, vel, acc, gate = got
        gap = t_new - self.lost_state[1]
        speed = float(np.hypot(*vel))
        pts = np.array(tr.points[-2:])
        tv = (pts[1, 1:] - pts[0, 1:]) / max(pts[1, 0] - pts[0, 0], 1e-9)
        vgate = 2.0 + 0.3 * speed + float(np.hypot(*acc)) * gap
        if not (np.hypot(*(pts[1, 1:] - p)) <= gate
                and np.hypot(*(tv - (vel + acc * gap))) <= vgate):
            return False
        # where and as fast as it can be, a rod that does not look like the lost one is
        # another object (a straw that came out of a long merge with the rider followed)
        why = None if self.lost_look is None else unlike(self.lost_look, tr.blobs)
        if why is None:
            return True
        first = int(self.fnums[tr.blobs[0].index])
        if first not in self.unlike_noted and len(self.unlike_noted) < 3:
            self.unlike_noted.add(first)
            self.notes.append(
                f"lost at frame {int(self.fnums[self.lost_index])}: the rod found from frame "
                f"{first} where it could be is {why}: another object, not taken")
        return False

    def search(self, i, frame, gain, near=None):
        """:func:`~vidtrack.track._search.search_blobs` of frame ``i`` (only where a lost
        straw can be)."""
        within = None
        if self.lost_state is not None:
            # a straw that was followed and lost is looked for only where it can be
            got = self.lost_gate(self.tau[i])
            if got is not None:
                within = (got[0], got[3])
        return search_blobs(self.seg, i, frame, gain, shape=self.shape,
                            min_area=self.min_area, blade=self.blade, near=near,
                            within=within, shadow=self.shadow)

    def count_specks(self, i, frame):
        """Raise the threshold while frame ``i`` holds more specks than allowed."""
        seg = self.seg
        gain = seg.gain(frame)
        found = seg.specks(frame, gain, at_least=self.speck_limit)
        first = found
        while found > self.speck_limit and seg.scale * _SPECK_STEP <= _SPECK_MAX:
            seg.raise_threshold(_SPECK_STEP)
            found = seg.specks(frame, gain, at_least=self.speck_limit)
        if found != first and not self.specks_seen:
            self.specks_seen.append((self.fnums[i], first))

    # ------------------------------------------------------------------ following

    def start_following(self, tr):
        """A follower for the tracklet ``tr`` taken for the object; its frames stored."""
        f = Follow()
        f.mixed = tr.polarity == 0
        # (a rod of both polarities with something across it: its shape on its core's band)
        shapes = [b if b.separated is None else
                  SimpleNamespace(length=b.separated[4], width=b.separated[5])
                  for b in tr.blobs]
        f.compact = f.mixed or not (rodlike_run(shapes) or thin_line_run(tr.blobs))
        f.rod = f.mixed and rodlike_run(shapes)
        if f.compact:
            # frames before the tracklet's blob last split or grew at once (the object
            # leaving what it rode on) were of something else too: they are read again
            # backwards from the first after it
            k0 = _last_split(tr.blobs)
            if k0:
                tr = copy.copy(tr)
                tr.points, tr.blobs = tr.points[k0:], tr.blobs[k0:]
        f.start = tr.blobs[0].index
        # a detection unlike the tracklet's others (twice the area, or a rod's shape
        # broken by something across it) is not the object's alone
        med_area = float(np.median([b.mask_area for b in tr.blobs]))
        fills = [x for x in (rod_fill(b) for b in tr.blobs) if x is not None]
        med_fill = float(np.median(fills)) if fills else None
        for b in tr.blobs:
            if f.compact and b.silhouette is not None:
                b.u, b.v, b.area, b.angle, b.length, b.width = b.silhouette
            if f.compact and b.shadowless is not None and self.shadow == "cut":
                # (without the shadow attached to it, as followed from here)
                b.u, b.v, b.area, b.angle, b.length, b.width = b.shadowless
            if (not f.compact or f.rod) and b.separated is not None:
                # a rod of both polarities: on its core's band, as followed from here
                b.u, b.v, b.area, b.angle, b.length, b.width, b.off_axis = b.separated
        # found again after it was lost: coming out from behind what hid it, part of it
        # still hidden (judged against the lost object's clean frames and where they put
        # it), and followed on with what they taught
        out_of = self._hidden_when_found(tr, f) if self.lost_state is not None else None
        for k, b in enumerate(tr.blobs):
            t = tr.points[k][0]
            bu, bv = b.u, b.v
            fill = rod_fill(b)
            odd = b.mask_area > 1.4 * med_area or (
                not f.compact and med_fill is not None and fill is not None
                and fill < 0.8 * med_fill) or (
                    (not f.compact or f.rod) and b.off_axis > OFF_AXIS_MAX)
            # (part of it may lie, unseen, over background of its own brightness)
            hidden = (f.compact and not f.rod and b.hidden > HIDDEN_PX) or (
                out_of is not None and out_of[k])
            fl = self.store(b.index, b, (MERGED if (b.merged or odd) else 0)
                            | (APPEARANCE if hidden else 0))
            self.solid[b.index] = f.compact
            self.seeded[b.index] = True
            if np.isfinite(b.level):
                f.levels.append(b.level)
            if out_of is not None and out_of[k]:
                continue
            if not fl & (BORDER | MERGED) or (not odd and not fl & BORDER):
                f.pred.add(t, bu, bv)
                f.add(b)
                f.clean_at = b.index
        if out_of is not None:
            f.judged_at = tr.blobs[-1].index
            last = tr.blobs[-1]
            if out_of[-1]:
                f.emerging = (last.index, last.length, last.area)
        return f

    def _hidden_when_found(self, tr, f):
        """Per blob of the tracklet ``tr`` that found the lost object again: part of it
        hidden (a rod shorter at one end, any object smaller at a side or a corner,
        its centre off where the lost object's clean frames put it by as much as that
        moves it: :func:`~vidtrack.track._step.part_hidden`, the rule the follower
        judges by, the prediction's error grown with the frames since it was lost). The
        new follower ``f`` starts from the lost one's sizes and motion. None when the
        lost object's clean frames are too few to say, or its kind differs."""
        lost = self.lost_fol
        if lost is None or lost.compact != f.compact:
            return None
        rod = not f.compact
        if len(lost.lengths if rod else lost.covs) < 3:
            return None
        err = lost.pred_error
        out = []
        for t, b in zip((pt[0] for pt in tr.points), tr.blobs):
            got = self.lost_gate(t)
            gap = max(1, b.index - self.lost_index + 1)
            if got is None or not (np.isfinite(b.u) and np.isfinite(b.v)):
                out.append(False)
                continue
            p = got[0]
            out.append(part_hidden(b, p, lost, err * gap, rod))
        if any(out):
            for name in ("levels", "areas", "covs", "lengths", "widths", "fills",
                         "strong_widths"):
                getattr(f, name).extend(getattr(lost, name))
            f.errors.extend(lost.errors)
            f.clean_at = lost.clean_at
            f.pred = copy.deepcopy(self.lost_state[0])
        return out

    def follow_back(self, t_idx, back, ahead, *, until_touch=False):
        """Follow the object from the target frame backwards to the first frame (with
        ``until_touch``, only until it first touches something: the hand or the
        machine that released it)."""
        u, v, area, angle, length = self.u, self.v, self.area, self.angle, self.length
        flags, clean, solid, tau = self.flags, self.clean, self.solid, self.tau
        good = np.flatnonzero(clean[t_idx:]) + t_idx
        if good.size < 3:
            return
        f = Follow()
        f.mixed = ahead.mixed
        f.compact = ahead.compact
        f.rod = ahead.rod
        f.start = 0
        for k in good[:16]:
            f.pred.add(tau[k], u[k], v[k])
        near_area = float(np.median(area[good[:16]]))
        levels, areas, lengths, widths = ahead.snapshot or (
            list(ahead.levels), list(ahead.areas), list(ahead.lengths), list(ahead.widths))
        f.levels.extend(levels)
        f.areas.extend(areas)
        f.lengths.extend(lengths)
        f.widths.extend(widths)
        # (a rod's shape: something riding along it leaves its rectangle part empty; a
        # thin straw's: its strongest pixels' width)
        f.fills.extend(ahead.fills)
        f.strong_widths.extend(ahead.strong_widths)
        if areas and lengths:
            f.last_size = (areas[0], lengths[0])
        held = {i: fr for i, fr in back}
        oldest = min(held) if held else t_idx
        chunk = max(1, _BACK_BYTES // max(1, int(np.prod(self.shape))
                                          * np.dtype(self.source.dtype).itemsize))
        i = t_idx - 1
        while i >= 0:
            if i not in held:
                lo = max(0, min(i, oldest) - chunk + 1)
                held = {j: self.frame(j) for j in range(lo, i + 1)}
                oldest = lo
            frame = held.pop(i)
            before = (u[i], v[i], area[i], angle[i], length[i], flags[i], clean[i], solid[i])
            if follow(self, i, frame, f):
                f.gap = 0
                # (or merged into one blob with it: grown at once, from the frame after
                # it, beyond the size it had when first clean)
                if until_touch and (flags[i] != 0 or (
                        area[i] > 1.25 * near_area and area[i] > 1.25 * area[i + 1])):
                    # touching what released it: that frame is not the object's alone;
                    # as it was measured before (a rod's tracklet), or not at all
                    if np.isfinite(before[0]):
                        (u[i], v[i], area[i], angle[i], length[i], flags[i], clean[i],
                         solid[i]) = before
                    else:
                        u[i] = v[i] = area[i] = angle[i] = length[i] = np.nan
                        flags[i] = LOST
                        clean[i] = solid[i] = False
                    break
            else:
                f.gap += 1
                if f.gap > self.max_gap:
                    break
            i -= 1

    # ------------------------------------------------------------------ the pass

    def frame(self, i):
        """Source frame ``i`` read again (random access), steadied as the stream is."""
        frame = self.source[i]
        return frame if self.steady is None else self.steady.warp(i, frame)

    def _stream(self):
        held = len(self.buffer)
        while self.buffer:
            yield self.buffer.popleft()
        if self.steady is None:
            yield from self.frames
        else:
            for i, frame in enumerate(self.frames, start=held):
                yield self.steady.warp(i, frame)

    def _checked(self, items):
        for item in items:
            if self.cancel.is_set():
                raise Cancelled(f"tracking of {_name(self.view, self.source)} cancelled")
            yield item

    def _background_at(self, k):
        """The background's median level in the 9 x 9 pixels round frame ``k``'s point
        (round it, not under its one pixel)."""
        rows, cols = self.shape
        cu = int(np.clip(round(self.u[k]), 0, cols - 1))
        cv = int(np.clip(round(self.v[k]), 0, rows - 1))
        return float(np.median(self.seg.bg[max(cv - 4, 0):cv + 5, max(cu - 4, 0):cu + 5]))

    def _lost(self, i):
        """The follower lost the object at frame ``i``: dropped (never seen flying clear
        of other objects: not the straw) or remembered as lost."""
        fol = self.fol
        if self.t_idx is None and not _flew_clear(self.u, self.v, self.area, self.clean,
                                                   fol.start, i):
            # never once seen flying clear of other objects (a rotor tooth
            # followed while it swept past, a machine part that moved its own size
            # and back): not the straw. Its frames are dropped and the straw is
            # looked for anywhere again, at either polarity
            drop = np.arange(fol.start, i)
            self.u[drop] = self.v[drop] = self.area[drop] = np.nan
            self.angle[drop] = self.length[drop] = np.nan
            self.flags[drop] = LOST
            self.clean[drop] = self.solid[drop] = False
        else:
            self.lost_state = (fol.pred, self.tau[i])
            self.lost_index = i
            last = np.flatnonzero(self.clean[:i])
            self.lost_look = fol.look(self._background_at(last[-1]) if last.size else np.nan)
            self.lost_fol = fol
            if fol.level is not None:
                self.last_level = fol.level
        self.acq.reset()
        self.fol = None

    def run(self):
        """Read every frame: search for the object, follow it, then follow it backwards
        from where it was taken."""
        target, name, tau, fnums, acq = self.target, self.name, self.tau, self.fnums, self.acq
        max_gap, view = self.max_gap, self.view
        self.t_idx = t_idx = None if target is None else target_index(target, fnums, name)
        back = deque()           # frames before the target frame (or round where the
                                 # object is first taken: :data:`_RECENT_BYTES`), oldest first
        back_bytes = 0
        pinned = None            # the target's tracklet until it has 3 points
        first_fol = None         # the follower's state when the object was first taken
        ambiguous_run = 0
        stream = self._stream() if self.cancel is None else self._checked(self._stream())
        for i, frame in enumerate(progress(stream, total=self.n,
                                           desc=f"track {view or ''}".strip(),
                                           quiet=self.quiet, unit="frame")):
            if i % _SPECK_EVERY == 0:
                self.count_specks(i, frame)
            if t_idx is not None and i < t_idx:
                # the target is named in a later frame: these frames are followed
                # backwards from it afterwards (the newest of them kept)
                back.append((i, frame))
                back_bytes += frame.nbytes
                while back_bytes > _BACK_BYTES and len(back) > 1:
                    back_bytes -= back.popleft()[1].nbytes
                continue
            if t_idx is None and (first_fol is None or back_bytes < _RECENT_BYTES):
                # the frames round where the object is first taken, which it is followed
                # backwards over afterwards (not read again): the newest before it is
                # taken, and those after it until the budget is spent
                back.append((i, frame))
                back_bytes += frame.nbytes
                while first_fol is None and back_bytes > _RECENT_BYTES and len(back) > 1:
                    back_bytes -= back.popleft()[1].nbytes
            if self.fol is not None:
                if follow(self, i, frame, self.fol):
                    self.fol.gap = 0
                    continue
                self.fol.gap += 1
                if self.fol.gap <= max_gap:
                    continue
                self._lost(i)
            gain = self.seg.gain(frame)
            near = None
            if i == t_idx:
                near = (target[1], 0.0)
            elif pinned is not None:
                last = pinned.blobs[-1]
                near = (pinned.predict(tau[i]), max(64.0, 8.0 * math.sqrt(last.mask_area)))
            blobs = self.search(i, frame, gain, near)
            if blobs:
                self.moving_frames += 1
            if i == t_idx:
                pinned = Tracklet(tau[i], target_blob(blobs, target, name, fnums[i]))
                acq.tracklets = [pinned]
                continue
            if pinned is not None:
                # the named object: followed by association until its motion is known
                acq.tracklets = [pinned]
                acq._associate(tau[i], blobs)
                if len(pinned.points) >= 3:
                    self.fol = first_fol = self.start_following(pinned)
                    pinned = None
                    acq.reset()
                elif tau[i] - pinned.last_t > max_gap:
                    fu, fv = target[1]
                    raise TrackError(
                        f"{name}: the object at ({fu:g}, {fv:g}) in frame {target[0]} (the "
                        "target) could not be followed to the next frames: name it in a frame "
                        "where it flies clear of anything else that moves")
                continue
            tr = acq.update(tau[i], blobs, accept=self.consistent_with_lost)
            if tr is None and acq.ambiguous and self.lost_state is None and t_idx is None:
                ambiguous_run += 1
                if ambiguous_run >= 3:
                    raise TrackError(ambiguity_message(name, view, acq.ambiguous, fnums[0]))
            else:
                ambiguous_run = 0
            if tr is not None:
                self.fol = self.start_following(tr)
                if first_fol is None:
                    first_fol = self.fol
                acq.reset()

        if t_idx is not None and t_idx > 0 and first_fol is not None:
            self.follow_back(t_idx, back, first_fol)
            back.clear()
        elif t_idx is None and first_fol is not None and first_fol.compact and \
                first_fol.start > 0:
            # an object of any shape is taken once it has flown a while: its first frames
            # (from the release) are followed backwards from there, read again
            self.follow_back(first_fol.start, back, first_fol, until_touch=True)
        elif t_idx is None and first_fol is not None and not first_fol.compact:
            # a straw taken while something rode along it: the frames before its first
            # clean run, measured then as one blob with the rider, are followed backwards
            # from there with what the clean frames taught (its own band measured alone)
            k0 = _first_clean_run(self.clean, first_fol.start, 10)
            if k0 is not None and (self.flags[first_fol.start:k0] & MERGED).any():
                self.follow_back(k0, back, first_fol, until_touch=True)
        return self

    def attached_shadow(self):
        """``(frames, clean frames, (du, dv))`` when a shadow is attached to the object
        all through (see :data:`_SHADOW_SHARE`; ``(du, dv)``: the mean pull of it on the
        whole's centroid, px), else None."""
        ok = self.clean & np.isfinite(self.u)
        n_ok = int(np.count_nonzero(ok))
        has = ok & np.isfinite(self.shade[:, 0])
        n_has = int(np.count_nonzero(has))
        if n_ok < 5 or n_has < _SHADOW_SHARE * n_ok:
            return None
        vec = self.shade[has]
        norm = np.hypot(vec[:, 0], vec[:, 1])
        unit = vec[norm > 0] / norm[norm > 0, None]
        if unit.shape[0] < n_has or np.hypot(*unit.mean(axis=0)) < _SHADOW_ALIGN:
            return None
        return n_has, n_ok, tuple(vec.mean(axis=0))

    def parts(self):
        """The refined rows and the track's fields
        (:func:`~vidtrack.track.tracker.track_parts`' result)."""
        seg, fnums, n, tau, flags = self.seg, self.fnums, self.n, self.tau, self.flags
        u, v, area, length = self.u, self.v, self.area, self.length
        rows, cols = self.shape
        if seg.scale > 1.0:
            at, found = self.specks_seen[0]
            self.notes.append(
                f"threshold raised to {seg.scale:.3g} x the measured noise from frame {at}: "
                f"compression specks ({found} at the measured noise, more than "
                f"{self.speck_limit:.0f} in a frame of {rows * cols / 1e6:.2g} megapixels)")
        if not self.clean.any() and not np.isfinite(u).any():
            if self.moving_frames == 0:
                raise TrackError(
                    f"{self.name}: nothing moves in frames {fnums[0]}..{fnums[-1]}: no pixel "
                    f"differs from the background by more than {self.k_sigma:g} x the noise "
                    f"({self.background.noise_sigma * seg.scale:.2g} grey levels)")
            raise TrackError(
                f"{self.name}: the straw never appears in frames {fnums[0]}..{fnums[-1]}: "
                f"moving blobs were seen in {self.moving_frames} frames, but none moved "
                "steadily over 3 consecutive frames")

        solid, seeded = self.solid, self.seeded
        # an object of any shape: a clean frame whose size is far from that of the clean
        # frames round it was measured with something attached, or partly hidden, before
        # the object's appearance was known (its first frames, a shadow touching it)
        _refine.flag_odd_sizes(area, flags, solid & (flags == 0), odd_flag=APPEARANCE)
        # a rod's frames taken with the tracklet that found it were judged against that
        # tracklet alone: one measured all along with something of its polarity attached
        # (a dark straw on a dark blade) is larger than the straw followed after it
        _refine.flag_grown_seeds(area, length, flags, seeded & ~solid & (flags == 0),
                                 (flags == 0) & ~seeded & ~solid, merged_flag=MERGED)
        pos = np.column_stack([u, v])
        # an object taken as it came out from behind something before it: its first
        # frames partly hidden (a rod short at one end)
        _refine.flag_hidden_parts(tau, pos, length, flags, ~solid & (flags == 0),
                                  cut_flag=APPEARANCE, angle=self.angle)
        # (or at a corner or a side, its length kept)
        _refine.flag_hidden_parts(tau, pos, area, flags, ~solid & (flags == 0),
                                  cut_flag=APPEARANCE, reach=0.5 * length)
        _refine.flag_hidden_parts(tau, pos, area, flags, solid & (flags == 0),
                                  cut_flag=APPEARANCE)
        scatter = _refine.flag_outliers(tau, pos, flags, clean_mask=flags == 0,
                                        outlier_flag=OUTLIER)
        if self.view == "top":
            rel, rel_tau, rel_note = None, None, _TOP_RELEASE_NOTE
        else:
            # the straw's first sighting touched neither the border nor another object
            seen = np.flatnonzero(np.isfinite(u))
            first_in_open = seen.size > 0 and not flags[seen[0]] & (BORDER | MERGED | BLADE)
            rel, rel_tau, rel_note = _refine.find_release(
                tau, pos, _release_evidence(u, flags), first_in_open=bool(first_in_open),
                attached=(flags & (MERGED | BLADE)) > 0)
        if rel is not None:
            before = (np.arange(n) < rel) & np.isfinite(u)
            flags[before] |= PRE_RELEASE
        good = (flags == 0) & np.isfinite(u)
        _refine.bridge_gaps(tau, pos, flags, good, max_gap=int(self.max_gap), lost_flag=LOST,
                            predicted_flag=PREDICTED)
        u, v = pos[:, 0], pos[:, 1]
        if rel is not None:
            flags[(np.arange(n) < rel) & ((flags & PREDICTED) > 0)] |= PRE_RELEASE

        if self.fol is not None and self.fol.level is not None:
            self.last_level = self.fol.level
        if self.steady is not None:
            self.notes.append(self.steady.summary())
            shifts = np.full((n, 2), np.nan)
            for i, sh in self.steady.shifts.items():
                if 0 <= i < n:
                    shifts[i] = sh
        times = self.times
        columns = {"frame": fnums, "t_s": times, "u_px": u, "v_px": v, "area_px": area,
                   "angle_rad": self.angle, "length_px": length,
                   "flags": flags.astype(np.int32)}
        if self.steady is not None:
            columns.update(zip(CAMERA_COLUMNS, shifts.T))
        if rel is None:
            rel_t = None
        elif rel_tau is None:
            rel_t = float(times[rel])
        else:
            rel_t = float(np.interp(rel_tau, tau, times, left=np.nan, right=np.nan))
            if not np.isfinite(rel_t):
                rel_t = float(times[0] + rel_tau * self.dt)
        return dict(columns=columns, view=self.view,
                    release_frame=None if rel is None else int(fnums[rel]),
                    release_note=rel_note, release_t_s=rel_t, fps=self.source.fps,
                    frame_shape=self.shape,
                    noise_sigma=float(self.background.noise_sigma * seg.scale),
                    k_sigma=float(self.k_sigma), straw_level=float(self.last_level),
                    scatter_px=float(scatter) if np.isfinite(scatter) else float("nan"),
                    notes=tuple(self.notes))
