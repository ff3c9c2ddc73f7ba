"""The straw tracker: one view's footage to a per-frame track in pixels.

>>> from vidtrack.footage import open_source                          # doctest: +SKIP
>>> from vidtrack.track.tracker import track                          # doctest: +SKIP
>>> with open_source("run42/front.avi", fps=1200) as src:       # doctest: +SKIP
...     tr = track(src, view="front")
>>> tr.data.head()                                              # doctest: +SKIP
>>> tr.data[tr.usable]                                          # the frames a fit may use

How it works (details in ``docs/tracker.md``):

1. **Background and noise** (:mod:`vidtrack.track.background`): the per-pixel median of frames
   spread over the first part of the footage (frames the pass decodes anyway: no
   second decoding), the noise from the MAD of frame differences, a per-pixel noise
   map, a floor for compressed video that repeats blocks, and the extra noise of edges
   and texture (a shaking phone); the threshold is ``k_sigma`` times the noise. Every
   16 frames the specks of hard compression (weak sets of changed pixels) are counted;
   where a frame holds too many the threshold is raised, and the notes say so.
2. **Finding the object** while it is not followed: moving blobs of the whole frame
   (block-reduced, cheap), each polarity and, where an object shows both, the whole,
   start tentative tracklets. The one thing moving is taken once steady; among several
   (a person, a machine part, a shadow) the one that *flies*: travelled twice its size
   along a quadratic path in time, keeping its size. Shadows and reflections of it
   and its parts give way; two objects tied together are one; the fastest by half
   again wins (a straw leaving the rotor); else the choice is ambiguous and the
   TrackError names the candidates with the ``target`` line to add. With a
   ``target`` the object at that pixel is taken (looked for there first, however many
   larger things move elsewhere) and followed both ways in time.
3. **Following it**: only a region of interest around the position predicted from the
   last clean positions is segmented; among its blobs the object is the one nearest the
   prediction within a gate (a speck is not it), changes are counted only *towards*
   its own grey level (a shadow is not the straw) until it shows both polarities.
4. **Measuring it** (:mod:`vidtrack.track._segment`): a rod (a straw) by its coverage
   (unbiased over a textured background); an object of one grey level by its fully
   covered core and the ring round it read against its surroundings (what is attached
   beyond, a shadow, cut off); any other object by its silhouette (holes filled).
   A frame unlike the object's clean frames (grown, shrunk at a stroke, a rod's shape
   broken by something across it) is flagged, not measured as the object.
5. **Afterwards** (:mod:`vidtrack.track._refine`): sizes off the clean frames round them
   and points off the smooth path are flagged, the release (first frame of free
   flight) is found where the path's strong acceleration on the rotor ends, while it
   touched the rotor (not in the ``top`` view, which sees the rotor's plane edge-on:
   there :func:`vidtrack.world.orthogonal.merge_tracks` carries the release over from
   the ``front`` view), short gaps are bridged.

Flags (bit field, column ``flags``; a frame is usable for fitting only when it is 0):

======  ===============  ===========================================================
value   name             meaning
======  ===============  ===========================================================
1       BORDER           the straw touches the image border (partly out of view)
2       BLADE            the straw overlaps the blade region (``blade_region``)
4       MERGED           the straw's blob merged with or touches another moving blob
8       LOST             not found in this frame (u, v are NaN)
16      PREDICTED        gap bridged: u, v interpolated from the clean neighbours
32      PRE_RELEASE      before the detected release (still on the blade)
64      OUTLIER          off the smooth path of its clean neighbours
128     APPEARANCE       unlike the object's clean frames (part of it hidden, or two
                         grey levels where it has one): not measured as the object
256     EXCLUDED         in a range of the scene's ``exclude_frames``: never fitted (set
                         after tracking, :mod:`vidtrack.track.corrections`)
======  ===============  ===========================================================

A point placed by hand (the scene's ``manual_points``) replaces the tracker's in its
frame with flags 0 (usable, as any clean frame) and is marked in a boolean column
``manual`` that the track then has (:mod:`vidtrack.track.corrections`); a track without
manual points has no such column.
"""

import copy
import logging
import math
from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING
from types import SimpleNamespace

import numpy as np

from vidtrack.track import _refine
from vidtrack._progress import progress
from vidtrack.track._segment import (Segmenter, edge_stats, measure, measure_mixed,
                                     measure_silhouette,
                                     measure_solid, other_behind, other_touching, read_level,
                                     shade_background, trim_attached, work_margin)
from vidtrack.track._follow import Follow
from vidtrack.track._rods import (FILL_MIN, FILL_SEPARATE, OFF_AXIS_MAX, SEPARATE_FRAMES,
                                  attached_across, rod_alone, rod_fill, rodlike_run,
                                  thin_line_run)
from vidtrack.track._select import Acquirer, Tracklet, on_body
from vidtrack.track._target import ambiguity_message, target_blob, target_index
from vidtrack.track._thin import FAINTER
from vidtrack.track._touch import beside_thin, edge_width, opposite_touching, shadow_beside
from vidtrack.track.background import Background, estimate_background, sample_indices
from vidtrack.errors import TrackError

log = logging.getLogger(__name__)

if TYPE_CHECKING:
    import pandas

__all__ = ["Track", "track", "track_parts", "FLAGS", "BORDER", "BLADE", "MERGED", "LOST",
           "PREDICTED", "PRE_RELEASE", "OUTLIER", "APPEARANCE", "EXCLUDED", "TRACK_COLUMNS",
           "describe_flags"]

BORDER = 1
BLADE = 2
MERGED = 4
LOST = 8
PREDICTED = 16
PRE_RELEASE = 32
OUTLIER = 64
APPEARANCE = 128
EXCLUDED = 256

#: Flag names by bit value.
FLAGS = {BORDER: "border", BLADE: "blade", MERGED: "merged", LOST: "lost",
         PREDICTED: "predicted", PRE_RELEASE: "pre_release", OUTLIER: "outlier",
         APPEARANCE: "appearance", EXCLUDED: "excluded"}

#: Columns of :attr:`Track.data`, in order.
TRACK_COLUMNS = ("frame", "t_s", "u_px", "v_px", "area_px", "angle_rad", "length_px", "flags")

#: Memory the start-of-footage buffer for the background may take (bytes).
_WARMUP_BYTES = 96 * 1024 * 1024
#: Memory the frames before a ``target`` frame may take for following backwards (bytes);
#: earlier frames are read again.
_BACK_BYTES = 128 * 1024 * 1024
#: Boxes of moving pixels looked at per frame while searching (largest first).
_SEARCH_BOXES = 16
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
#: Components per polarity and box measured while searching (largest first).
_SEARCH_PARTS = 24


class Cancelled(Exception):
    """A tracking pass stopped by its ``cancel`` event."""


def _finite_or_none(value):
    """A float for JSON, None where nothing was measured (points digitized elsewhere)."""
    value = float(value)
    return value if np.isfinite(value) else None


def describe_flags(value):
    """Names of the bits set in a flags value, e.g. ``describe_flags(12) -> ('merged', 'lost')``."""
    return tuple(name for bit, name in FLAGS.items() if int(value) & bit)


@dataclass(frozen=True, eq=False)
class Track:
    """One view's track of the straw, one row per frame of the source.

    Attributes
    ----------
    data : pandas.DataFrame
        Columns ``frame`` (0-based frame index in the file), ``t_s`` (time of the frame
        in s, relative to the file's first frame, from the source's time base),
        ``u_px, v_px`` (coverage centroid: column, row; pixel (c, r) has its centre at
        (c, r)), ``area_px`` (coverage sum, px^2), ``angle_rad`` (major axis from +u
        towards +v, in (-pi/2, pi/2]), ``length_px`` (``sqrt(12 lambda_max)`` of the
        coverage's second moments: a rod's length), ``flags`` (see the module); and
        ``manual`` (bool: the point was placed by hand, flags 0) when the scene gives
        manual points for the view.
    view : str or None
        ``"front"``, ``"top"`` or None.
    release_frame : int or None
        File frame index of the first frame of free flight; None when the release is
        not identifiable in this view (always so in the ``top`` view as tracked; the
        merged track of :attr:`vidtrack.world.orthogonal.WorldTrack.tracks` has it).
    release_note : str
        How the release was decided.
    release_t_s : float or None
        The release instant in the source's clock (s): between frames, from where the
        path's acceleration drops; the release frame's time when the straw was first
        seen already flying; in a merged track, the view's t = 0; None when the release
        is not identifiable.
    fps : float or None
        The source's capture rate.
    frame_shape : tuple of int
        ``(rows, cols)``.
    noise_sigma : float
        Measured noise of a static pixel (grey levels).
    k_sigma : float
        Threshold in multiples of the noise.
    straw_level : float
        The straw's grey level.
    scatter_px : float
        Robust scatter of the clean centroids about a smooth path (px).
    notes : tuple of str
        Things worth knowing (e.g. the background's frames).
    """

    data: "pandas.DataFrame"
    view: str | None
    release_frame: int | None
    release_note: str
    release_t_s: float | None
    fps: float | None
    frame_shape: tuple
    noise_sigma: float
    k_sigma: float
    straw_level: float
    scatter_px: float
    notes: tuple = ()

    def __repr__(self):
        fps = "None" if self.fps is None else f"{self.fps:g}"
        return (f"Track(view={self.view!r}, frames={len(self.data)}, "
                f"usable={int(np.count_nonzero(self.usable))}, "
                f"release_frame={self.release_frame}, fps={fps}, "
                f"scatter_px={self.scatter_px:.3g})")

    @classmethod
    def from_parts(cls, parts):
        """The Track of :func:`track_parts`' result."""
        import pandas as pd   # here, not at the top: decoding starts 0.2 s sooner

        parts = dict(parts)
        return cls(data=pd.DataFrame(parts.pop("columns")), **parts)

    @property
    def usable(self):
        """Boolean array: rows a fit may use (flags 0 and a finite position)."""
        d = self.data
        return ((d["flags"].to_numpy() == 0) & np.isfinite(d["u_px"].to_numpy())
                & np.isfinite(d["v_px"].to_numpy()))

    def flag_counts(self):
        """Frames carrying each flag, by name."""
        f = self.data["flags"].to_numpy()
        return {name: int(np.count_nonzero(f & bit)) for bit, name in FLAGS.items()}

    def to_dict(self):
        """A JSON-ready summary (not the rows)."""
        return {"view": self.view, "frames": int(len(self.data)),
                "usable": int(np.count_nonzero(self.usable)),
                "release_frame": self.release_frame, "release_note": self.release_note,
                "release_t_s": self.release_t_s,
                "fps": self.fps, "frame_shape": list(self.frame_shape),
                "noise_sigma": _finite_or_none(self.noise_sigma),
                "k_sigma": _finite_or_none(self.k_sigma),
                "straw_level": _finite_or_none(self.straw_level),
                "scatter_px": _finite_or_none(self.scatter_px),
                "flags": self.flag_counts(), "notes": list(self.notes)}


def _blade_mask(blade_region, shape):
    if blade_region is None:
        return None
    if isinstance(blade_region, np.ndarray) and blade_region.ndim == 2:
        if blade_region.shape != tuple(shape):
            raise TrackError(f"blade_region mask is {blade_region.shape}, the frames are "
                             f"{tuple(shape)}")
        return blade_region.astype(bool)
    try:
        u, v, r = (float(x) for x in blade_region)
    except (TypeError, ValueError):
        raise TrackError("blade_region must be a boolean mask of the frame's shape or a "
                         f"circle (u_px, v_px, radius_px), got {blade_region!r}") from None
    if not (np.isfinite(u) and np.isfinite(v) and np.isfinite(r) and r > 0):
        raise TrackError(f"blade_region circle needs finite u, v and radius > 0, got "
                         f"{blade_region!r}")
    rows, cols = shape
    yy, xx = np.ogrid[:rows, :cols]
    return (xx - u) ** 2 + (yy - v) ** 2 <= r * r


def _only_fainter(reg, others, p, reach, own_peak):
    """Something moves within ``reach`` (px) of ``p``, and all of it is fainter than the
    straw (:data:`~vidtrack.track._thin.FAINTER` of its largest change ``own_peak``): a
    rider beside a thin straw, not a second straw."""
    near = [o for o in others if math.hypot(o.u - p[0], o.v - p[1]) <= reach + 0.5 * (
        math.hypot(o.bbox[2] - o.bbox[0], o.bbox[3] - o.bbox[1]))]
    return bool(near) and all(reg.peak([o.label]) <= FAINTER * own_peak for o in near)


def _name(view, source):
    if view:
        return f"view {view}"
    return f"{getattr(source, 'path', 'footage')}"


_TOP_RELEASE_NOTE = ("not looked for in the top view: it sees the rotor's plane edge-on, "
                     "where the ride on the blade barely differs from free flight; the "
                     "merge carries t = 0 over from the front view through the shared X")


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


def track(source, *, background=None, view=None, k_sigma=5.0, min_area_px=4,
          max_gap=5, blade_region=None, centre_line_px=None, warmup_frames=None,
          quiet=True, cancel=None, target=None):
    """Track the straw through one view's footage.

    Parameters
    ----------
    source : vidtrack.footage.base.FrameSource
        An open frame source with a time base (``fps`` known). Read once, in order.
    background : vidtrack.track.background.Background, optional
        A precomputed background (e.g. :func:`vidtrack.track.background.sample_background`
        over the whole footage). Default: the median of up to 25 frames spread over the
        first ``warmup_frames`` frames, which the pass holds and then tracks.
    view : str, optional
        The view's name, used in messages and the result. In the ``"top"`` view the
        release is not looked for (``release_frame`` None, the note says why): it sees
        the rotor's plane edge-on, where the ride on the blade barely differs from free
        flight; :func:`vidtrack.world.orthogonal.merge_tracks` carries the release over from the
        ``front`` view through the shared X.
    k_sigma : float, optional
        Segmentation threshold in multiples of the measured noise (default 5); raised
        from the frame where hard compression's specks call for it (the notes say so,
        and ``noise_sigma`` is then the raised noise).
    min_area_px : int, optional
        Smallest blob (pixels above threshold) that may be the straw.
    max_gap : int, optional
        Longest run of frames without a measurement bridged by prediction; a longer
        one makes the straw lost (search the whole frame again).
    blade_region : numpy.ndarray or (float, float, float), optional
        Where the blade sweeps: a boolean mask of the frame's shape, or a circle
        ``(u_px, v_px, radius_px)``. Frames where the straw overlaps it are flagged
        BLADE, and a blob wholly inside it is never taken for the straw.
    centre_line_px : ((float, float), (float, float)), optional
        Two pixel points on the stream's centre line: among several straws the one
        nearest it is followed.
    warmup_frames : int, optional
        Frames held for the background (default: as many as fit in 96 MB, 16 to 300).
    quiet : bool, optional
        No progress bar.
    cancel : threading.Event, optional
        Checked before each frame: once set, the pass stops with :class:`Cancelled`
        (another view failed or the user pressed Ctrl-C).
    target : (int, (float, float)), optional
        ``(frame, (u_px, v_px))``: the object to track is the moving one at that pixel
        in that file frame (``scene.toml``: ``target = { frame = F, at_px = [u, v] }``).
        It is followed forwards and backwards in time from there, and nothing else is
        taken for it. Without it the object is found automatically: the one thing
        moving, or the one flying (travelling smoothly along a ballistic path, keeping
        its size; a person moving about does not); when several fly alike, the
        TrackError names them and shows the ``target`` line to add.

    Returns
    -------
    Track

    Raises
    ------
    TrackError
        Nothing moves in the footage, or nothing moving behaves like the straw (the
        message names the view); a background of the wrong size; bad options.
    vidtrack.errors.SourceError
        The source has no time base, or a frame cannot be decoded.

    Notes
    -----
    One pass over the frames; memory is the background, the warm-up buffer and a few
    numbers per frame, whatever the footage's length.
    """
    tr = Track.from_parts(track_parts(
        source, background=background, view=view, k_sigma=k_sigma, min_area_px=min_area_px,
        max_gap=max_gap, blade_region=blade_region, centre_line_px=centre_line_px,
        warmup_frames=warmup_frames, quiet=quiet, cancel=cancel, target=target))
    log_tracked(tr)
    return tr


def log_tracked(tr):
    """Log what a view's tracking found (INFO) and its notes (DEBUG)."""
    log.info("%s: %d frames tracked, %d usable; release frame %s (%s)", tr.view or "view",
             len(tr.data), int(np.count_nonzero(tr.usable)), tr.release_frame,
             tr.release_note)
    for note in tr.notes:
        log.debug("%s: %s", tr.view or "view", note)

def track_parts(source, *, background=None, view=None, k_sigma=5.0, min_area_px=4,
                max_gap=5, blade_region=None, centre_line_px=None, warmup_frames=None,
                quiet=True, cancel=None, target=None):
    """:func:`track`'s work, returning the :class:`Track`'s fields as a dict, its rows as
    a dict of numpy arrays (``columns``): a worker process need not load pandas
    (:meth:`Track.from_parts` builds the Track)."""
    name = _name(view, source)
    n = len(source)
    shape = tuple(source.shape)
    if n < 3:
        raise TrackError(f"{name}: tracking needs at least 3 frames, the footage has {n}")
    if not (np.isfinite(k_sigma) and k_sigma > 0):
        raise TrackError(f"k_sigma must be > 0, got {k_sigma!r}")
    if int(max_gap) < 0:
        raise TrackError(f"max_gap must be >= 0, got {max_gap!r}")
    times = np.asarray(source.times_s, dtype=np.float64)
    fnums = np.asarray(source.frame_numbers, dtype=np.int64)
    steps = np.diff(times)
    dt = float(np.median(steps)) if steps.size else 1.0
    if not dt > 0:
        raise TrackError(f"{name}: the frame times do not increase")
    tau = (times - times[0]) / dt
    blade = _blade_mask(blade_region, shape)
    notes = []

    frames = iter(source)
    buffer = deque()
    if background is None:
        frame_bytes = int(np.prod(shape)) * np.dtype(source.dtype).itemsize
        warm = warmup_frames or int(np.clip(_WARMUP_BYTES // max(frame_bytes, 1), 16, 300))
        warm = int(min(max(warm, 3), n))
        for _ in range(warm):
            buffer.append(next(frames))
        sidx = sample_indices(warm, 25)
        pidx = sample_indices(warm - 1, 12)
        background = estimate_background([buffer[i] for i in sidx],
                                         pairs=[(buffer[i], buffer[i + 1]) for i in pidx],
                                         frames=sidx)
        notes.append(f"background: median of {len(sidx)} frames spread over frames "
                     f"0..{warm - 1}")
    elif not isinstance(background, Background):
        raise TrackError(f"background must be a vidtrack.track.background.Background, got "
                         f"{type(background).__name__}")
    if tuple(background.shape) != shape:
        raise TrackError(f"{name}: the background is {background.shape}, the frames are {shape}")

    seg = Segmenter(background, k_sigma=k_sigma)
    rows, cols = shape
    u = np.full(n, np.nan)
    v = np.full(n, np.nan)
    area = np.full(n, np.nan)
    angle = np.full(n, np.nan)
    length = np.full(n, np.nan)
    flags = np.full(n, LOST, dtype=np.int64)
    clean = np.zeros(n, bool)
    seeded = np.zeros(n, bool)    # stored from an acquisition's tracklet, not followed
    solid = np.zeros(n, bool)     # measured as an object of any shape (not a rod)

    min_area = max(1, int(min_area_px))
    acq = Acquirer(confirm=3, max_step=0.25 * max(rows, cols), min_motion=0.3,
                   centre_line=centre_line_px, tiny_px=3 * min_area)
    fol = None
    lost_state = None        # (Predictor, tau) of the straw when it was lost
    last_level = [float("nan")]
    moving_frames = 0

    def store(i, blob, extra=0):
        u[i], v[i], area[i] = blob.u, blob.v, blob.area
        angle[i], length[i] = blob.angle, blob.length
        fl = extra
        if blob.touches_border:
            fl |= BORDER
        if blade is not None:
            x0, y0, x1, y1 = blob.bbox
            if blade[y0:y1, x0:x1].any():
                fl |= BLADE
        flags[i] = fl
        clean[i] = fl == 0
        return fl

    def search_blobs(i, frame, gain, level, near=None):
        boxes = seg.coarse(frame, gain)
        if not boxes:
            return []
        if near is not None:
            # the object named or just taken is looked for first, however many larger
            # things move elsewhere (players, a crowd; boxes are taken largest first)
            (nu, nv), reach = near
            boxes.sort(key=lambda bx: max(bx[0] - nu, nu - bx[2], bx[1] - nv,
                                          nv - bx[3], 0.0) > reach)
        pad = 2 * seg.decimate + 2
        if lost_state is not None:
            # a straw that was followed and lost is looked for only where it can be
            got = lost_gate(tau[i])
            if got is not None:
                p, _, _, gate = got
                boxes = [bx for bx in boxes
                         if max(bx[0] - p[0], p[0] - bx[2], bx[1] - p[1], p[1] - bx[3]) <= gate]
        rois = []
        for x0, y0, x1, y1, _ in boxes[:_SEARCH_BOXES]:
            r = [max(0, x0 - pad), max(0, y0 - pad), min(cols, x1 + pad), min(rows, y1 + pad)]
            for q in rois:
                if r[0] < q[2] and q[0] < r[2] and r[1] < q[3] and q[1] < r[3]:
                    q[:] = [min(r[0], q[0]), min(r[1], q[1]), max(r[2], q[2]), max(r[3], q[3])]
                    break
            else:
                rois.append(r)
        out = []
        for r in rois:
            parts = {1: [], -1: []}
            for pol in (1, -1):
                reg = seg.segment(frame, tuple(r), gain=gain, polarity=pol)
                if any(c.touches_roi for c in reg.components(min_area, shape)):
                    # the coarse box cut an object: look at a wider box
                    w, h = r[2] - r[0], r[3] - r[1]
                    r = [max(0, r[0] - w // 2 - pad), max(0, r[1] - h // 2 - pad),
                         min(cols, r[2] + w // 2 + pad), min(rows, r[3] + h // 2 + pad)]
                    reg = seg.segment(frame, tuple(r), gain=gain, polarity=pol)
                comps = sorted(reg.components(min_area, shape), key=lambda c: -c.mask_area)
                if len(comps) > _SEARCH_PARTS:     # compression noise: the small ones go
                    comps = [c for c in comps[:_SEARCH_PARTS] if c.mask_area >= 3 * min_area]
                for b in comps:
                    if blade is not None:
                        x0, y0, x1, y1 = b.bbox
                        if blade[y0:y1, x0:x1].all():
                            continue
                    lv = read_level(reg, b)
                    work = reg.work([b.label], lv, margin=work_margin(None, None, b.bbox))
                    b.contrast, b.edge_w = edge_stats(work)
                    b.edge_w_alone = edge_stats(work, alone=True)[1]
                    b.merged = other_behind(work, lv, width=None, min_area=min_area)
                    b.core, _, b.uniform = trim_attached(work, reach_px=None)
                    sil = measure_silhouette(work, copy.copy(b))
                    measure(work, b, lv, separate=False)
                    if not b.area > 0:
                        continue
                    if sil.area > 0:
                        b.silhouette = (sil.u, sil.v, sil.area, sil.angle, sil.length,
                                        sil.width)
                    b.level = lv
                    b.polarity = pol
                    b.index = i
                    out.append(b)
                    parts[pol].append(b)
            if parts[1] and parts[-1]:
                out.extend(_wholes(i, frame, r, gain, parts))
        return out

    def _wholes(i, frame, r, gain, parts):
        """Objects made of parts of both polarities (a dark ball with its highlight)."""
        reg = seg.segment(frame, tuple(r), gain=gain, polarity=0)
        found = []
        for b in reg.components(min_area, shape):
            x0, y0, x1, y1 = b.bbox
            inside = {pol: [q for q in parts[pol] if x0 <= q.u <= x1 and y0 <= q.v <= y1]
                      for pol in (1, -1)}
            if not inside[1] or not inside[-1]:
                continue
            area_of = {pol: sum(q.mask_area for q in inside[pol]) for pol in (1, -1)}
            big = max((1, -1), key=lambda pol: area_of[pol])
            small = -big
            if area_of[small] < max(min_area, 0.03 * b.mask_area):
                continue
            # the smaller polarity inside the larger's box (a highlight, an opening),
            # or parts side by side (a cup half lit, a plush toy's light and dark
            # sides); a straw on a large blade is neither
            outer = max(inside[big], key=lambda q: q.mask_area)
            ox0, oy0, ox1, oy1 = outer.bbox
            enclosed = all((ox0 <= q.bbox[0] and oy0 <= q.bbox[1] and q.bbox[2] <= ox1
                            and q.bbox[3] <= oy1) or on_body(q, outer) for q in inside[small])
            # (a rod riding a blade of the other polarity is its own object; a
            # patch of another shape is a part, up to a tenth of the whole)
            rods = any(rodlike_run([q]) for q in inside[small])
            if not enclosed and area_of[big] > (3.0 if rods else 10.0) * area_of[small]:
                continue
            # a shadow beside a bright object is not part of it: blurred edges
            wb, wd = edge_width(inside[1]), edge_width(inside[-1])
            if (not enclosed and np.isfinite(wb) and np.isfinite(wd)
                    and (wd >= 1.6 * wb or wb >= 1.6 * wd)):
                continue
            work = reg.work([b.label], np.nan, margin=work_margin(None, None, b.bbox))
            b.contrast, b.edge_w = edge_stats(work)
            b.edge_w_alone = b.edge_w
            measure_mixed(work, b, separate=False)
            if not b.area > 0:
                continue
            b.polarity = 0
            b.index = i
            found.append(b)
        return found

    def lost_gate(t_new):
        """Where the lost straw may be now: (position, velocity, acceleration, gate)."""
        pred, t_lost = lost_state
        st = pred.state(t_new)
        if st is None:
            return None
        p, vel, acc = st
        gap = t_new - t_lost
        speed = float(np.hypot(*vel))
        gate = 10.0 + 0.15 * speed * gap + 0.5 * float(np.hypot(*acc)) * gap * gap
        return p, vel, acc, gate

    def consistent_with_lost(tr):
        if lost_state is None:
            return True
        t_new = tr.points[-1][0]
        got = lost_gate(t_new)
        if got is None:
            return True
        p, vel, acc, gate = got
        gap = t_new - lost_state[1]
        speed = float(np.hypot(*vel))
        pts = np.array(tr.points[-2:])
        tv = (pts[1, 1:] - pts[0, 1:]) / max(pts[1, 0] - pts[0, 0], 1e-9)
        vgate = 2.0 + 0.3 * speed + float(np.hypot(*acc)) * gap
        return (np.hypot(*(pts[1, 1:] - p)) <= gate
                and np.hypot(*(tv - (vel + acc * gap))) <= vgate)

    def start_following(tr):
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
        for k, b in enumerate(tr.blobs):
            if f.compact and b.silhouette is not None:
                b.u, b.v, b.area, b.angle, b.length, b.width = b.silhouette
            if (not f.compact or f.rod) and b.separated is not None:
                # a rod of both polarities: on its core's band, as followed from here
                b.u, b.v, b.area, b.angle, b.length, b.width, b.off_axis = b.separated
            t = tr.points[k][0]
            bu, bv = b.u, b.v
            fill = rod_fill(b)
            odd = b.mask_area > 1.4 * med_area or (
                not f.compact and med_fill is not None and fill is not None
                and fill < 0.8 * med_fill) or (
                    (not f.compact or f.rod) and b.off_axis > OFF_AXIS_MAX)
            fl = store(b.index, b, MERGED if (b.merged or odd) else 0)
            solid[b.index] = f.compact
            seeded[b.index] = True
            if np.isfinite(b.level):
                f.levels.append(b.level)
            if not fl & (BORDER | MERGED) or (not odd and not fl & BORDER):
                f.pred.add(t, bu, bv)
                f.add(b)
        return f

    def follow(i, frame, f):
        st = f.pred.state(tau[i])
        if st is None:
            return False
        p, vel, acc = st
        speed = float(np.hypot(*vel))
        ref_len = f.ref(f.lengths, 10.0)
        ref_w = f.ref(f.widths, 3.0)
        err = float(np.sqrt(np.mean(np.square(f.errors)))) if f.errors else 1.0
        extra = 0.5 * f.gap * (speed + 1.0)
        # wide enough to see another straw coming before it touches this one
        hs = int(math.ceil(1.0 * ref_len + 2.0 * ref_w + 6.0 + 0.5 * speed + 3.0 * err + extra))
        gate = max(5.0, 0.5 * ref_len, 4.0 * err + 3.0) + extra
        level = f.level
        gain = seg.gain(frame)
        chosen = None
        for attempt in range(2):
            cu, cv = int(round(p[0])), int(round(p[1]))
            roi = (max(0, cu - hs), max(0, cv - hs), min(cols, cu + hs + 1),
                   min(rows, cv + hs + 1))
            if roi[2] - roi[0] < 2 or roi[3] - roi[1] < 2:
                return False
            if f.mixed:
                reg = seg.segment(frame, roi, gain=gain, polarity=0)
            else:
                reg = seg.segment(frame, roi, gain=gain, level=level)
            blobs = reg.components(min_area, shape)
            best, best_d, best_score = None, np.inf, np.inf
            ref_a = f.ref(f.areas, None) if len(f.areas) >= 3 else None
            for b in blobs:
                dd = float(np.hypot(b.u - p[0], b.v - p[1]))
                score = dd
                if f.intruders.items and f.intruders.closer_to_intruder(tau[i], b, p):
                    score += gate  # the other straw's, as far as its motion says
                if ref_a and b.mask_area < 0.25 * ref_a:
                    score += gate  # a speck, not the object (unless nothing else)
                if score < best_score:
                    best, best_d, best_score = b, dd, score
            if best is None or best_d > gate + 0.5 * math.sqrt(best.mask_area):
                if f.mixed or not f.compact or attempt > 0 or not f.areas:
                    return False
                # nothing of the object's polarity where it should be: it may have
                # moved in front of a background of its own brightness, where only its
                # parts of the other polarity show. Looked for with both polarities,
                # and measured by its silhouette from here on when found at its size
                reg2 = seg.segment(frame, roi, gain=gain, polarity=0)
                cand = [o for o in reg2.components(min_area, shape)
                        if np.hypot(o.u - p[0], o.v - p[1]) <= gate + 0.5 * math.sqrt(o.mask_area)
                        and 0.33 <= o.mask_area / max(f.ref(f.areas, 1.0), 1.0) <= 3.0]
                if not cand:
                    return False
                f.become_mixed()
                reg, blobs = reg2, reg2.components(min_area, shape)
                best = min(cand, key=lambda o: np.hypot(o.u - p[0], o.v - p[1]))
                best = next(o for o in blobs if o.label == best.label)
            chosen = best
            if best.touches_roi and attempt == 0:
                hs *= 2
                continue
            break
        b = chosen
        group = [b.label]
        mask_area = b.mask_area
        if f.compact and len(f.lengths) >= 3:
            # an object of any shape may show as several pieces (parts of it match
            # the background): all pieces within its footprint round the prediction
            reach = 0.6 * ref_len + 2.0 + 2.0 * err
            x0r, y0r = reg.roi[0], reg.roi[1]
            for k in range(1, reg.n):
                if k == b.label:
                    continue
                cu_k, cv_k = reg.centroids[k]
                if np.hypot(x0r + cu_k - p[0], y0r + cv_k - p[1]) <= reach:
                    group.append(k)
                    mask_area += int(reg.stats[k][4])
        elif len(f.lengths) >= 3:
            # parts of the straw split where it cannot be seen against the background:
            # small pieces within its reach (a whole second straw is not a piece)
            reach = 0.5 * ref_len + ref_w + 2.0
            ref_a = f.ref(f.areas, 0.0)
            x0r, y0r = reg.roi[0], reg.roi[1]
            for k in range(1, reg.n):
                if k == b.label:
                    continue
                cu_k, cv_k = reg.centroids[k]
                a_k = int(reg.stats[k][4])
                if (np.hypot(x0r + cu_k - p[0], y0r + cv_k - p[1]) <= reach
                        and a_k < 0.5 * ref_a and mask_area + a_k <= 1.3 * ref_a):
                    group.append(k)
                    mask_area += a_k
        fl = 0
        known = len(f.lengths) >= 3
        if f.mixed:
            # an object of both polarities: its silhouette (the other polarity is its
            # own, not something behind it)
            work = reg.work(group, np.nan, margin=work_margin(None, None, b.bbox))
            measure_mixed(work, b, rod=f.rod)
        elif not f.compact:
            lv = level if level is not None else read_level(reg, b)
            work = reg.work(group, lv, margin=work_margin(ref_w, ref_len if known else None,
                                                          b.bbox))
            # (a rod of one grey level is seen by its coverage against any background,
            # and what touches it in the other polarity is behind it: a blade)
            if not other_touching(work, width=ref_w, min_area=min_area):
                pass
            elif known and shadow_beside(work, least=0.2):
                # a shadow beside it (blurred edges, of the other polarity): not an
                # object behind it; the background darkened by it, also under the
                # straw's edge, is taken into the coverage's background
                shade_background(work)
            elif known and f.thin and beside_thin(work, width=ref_w):
                # a thin straw's faint shadow beside it: its own line is fitted to the
                # pixels (measure), where the shadow weighs little
                pass
            elif other_behind(work, lv, width=ref_w, min_area=min_area):
                fl |= MERGED
            measure(work, b, lv, width=ref_w if known else None,
                    length=ref_len if known else None,
                    thin=f.thin if len(f.strong_widths) >= 3 else None)
            if known and not f.thin and not b.banded and len(f.fills) >= 3 and (
                    attached_across(b, f) or (
                    len(f.areas) >= 3 and mask_area > 1.3 * f.ref(f.areas, np.inf))):
                # another rod attached across it or along it (grown): the straw's own band
                # (its width and length round the axis of its fully covered core)
                # measured alone, and kept when it has the straw's clean shape (a thin
                # straw's own line is fitted to the pixels instead, a rod of both
                # polarities was measured on its core's band: measure)
                b2, cut = rod_alone(reg, group, lv, b, f, ref_w, ref_len, min_area)
                if cut >= max(3 * min_area, 0.1 * b.mask_area):
                    f.cut_at = i       # something beyond its band: coming apart later
                if b2 is not None:
                    b = b2
                    mask_area = b2.mask_area
                    if not b2.merged:
                        fl &= ~MERGED     # what was across it was the rider, cut away
        else:
            lv = level if level is not None else read_level(reg, b)
            work = reg.work(group, lv, margin=work_margin(None, None, b.bbox))
            trim = f.trims() and known
            if not trim and opposite_touching(work, min_area):
                whole = own_other_half(frame, roi, gain, b, f) if known else None
                if whole is not None:
                    # the object's other half shows against a background of its own
                    # brightness: it is measured whole, by its silhouette, from here on
                    f.become_mixed()
                    reg, b = whole
                    blobs = reg.components(min_area, shape)
                    group = [b.label]
                    mask_area = b.mask_area
                    work = reg.work(group, np.nan, margin=work_margin(None, None, b.bbox))
                elif not shadow_beside(work):
                    fl |= MERGED
            if not f.mixed:
                # an object of one grey level: what is attached beyond its fully
                # covered core and the edge round it is not of it (a shadow); what
                # touches it changes nothing unless it hides part of the core
                n_core, n_drop, uni = trim_attached(
                    work, reach_px=2.0 if trim else None, along=np.asarray(vel))
                b.core = n_core
                b.uniform = uni
                if trim and f.cores and abs(n_core - f.ref(f.cores, n_core)) > \
                        0.3 * f.ref(f.cores, n_core):
                    fl |= APPEARANCE
                if trim:
                    measure_solid(work, b)
                else:
                    measure_silhouette(work, b)
            else:
                measure_silhouette(work, b)
        if not b.area > 0:
            return False
        b.mask_area = mask_area
        if len(group) > 1:
            xs = [reg.stats[k][0] for k in group]
            ys = [reg.stats[k][1] for k in group]
            xe = [reg.stats[k][0] + reg.stats[k][2] for k in group]
            ye = [reg.stats[k][1] + reg.stats[k][3] for k in group]
            b.bbox = (reg.roi[0] + min(xs), reg.roi[1] + min(ys), reg.roi[0] + max(xe),
                      reg.roi[1] + max(ye))
            b.touches_border = (b.bbox[0] <= 0 or b.bbox[1] <= 0 or b.bbox[2] >= cols
                                or b.bbox[3] >= rows)
        # merged with a blob of the same polarity (another straw): the centroid is not
        # the straw's; one of the other polarity was taken as background above
        same = False
        ref_area = f.ref(f.areas, None)
        same_shape = True
        if f.compact:
            grown = ref_area is not None and len(f.areas) >= 3 and (
                b.mask_area > 1.5 * ref_area
                or b.length > 1.3 * f.ref(f.lengths, np.inf))
        else:
            grown = ref_area is not None and len(f.areas) >= 3 and (
                b.mask_area > 1.6 * ref_area or b.mask_area > 1.4 * f.areas[-1]
                or b.length - f.lengths[-1] > 0.3 * max(f.lengths))
            # a rod's coverage fills the rectangle its moments describe (area = length
            # x width); another rod attached across it (crossing, riding along) leaves
            # much of that rectangle empty: a shape the straw's clean frames never had
            # (coming apart from something attached, it must fill FILL_SEPARATE of it
            # again for a while)
            fill = rod_fill(b)
            least_fill = FILL_SEPARATE if i - f.cut_at <= SEPARATE_FRAMES else FILL_MIN
            if fill is not None and len(f.fills) >= 3 and \
                    fill < least_fill * f.ref(f.fills, fill):
                same_shape = False
            else:
                same_shape = True
        # and whatever the clean frames looked like, a rod has no coverage beyond its
        # band away from its ends: arms of another rod across it or beside it do (also
        # of a rod of both polarities, measured by its body)
        rod_shape = not f.compact or f.rod
        if rod_shape and b.off_axis > OFF_AXIS_MAX and not (f.thin and b.fitted):
            # (a thin straw's own line fitted to the pixels is not moved by what lies
            # beyond its band)
            same_shape = False
        if grown:
            # grown since the last clean frame: a merge, unless it grew smoothly (the
            # straw turning out of an end-on view; the reference would otherwise stay
            # at the small size and flag the rest of the flight)
            same = not f.smooth_growth(b)
        # only the shape broken by something small attached (a thin rod riding along):
        # flagged, but its centroid is within a few pixels, so the prediction follows it
        # through a long ride (through a crossing with an object of its own size it
        # is predicted from its own clean motion alone)
        slight = rod_shape and not same_shape and not same
        if rod_shape and not same_shape:
            same = True
        x0, y0, x1, y1 = b.bbox
        others = [o for o in blobs if o.label not in group]
        # (an object of any shape: specks of noise or of itself round it are not
        # another object)
        least = max(3 * min_area, 0.1 * ref_area) if f.compact and ref_area else 0
        # (a thin straw whose own line was fitted: a fainter thing beside it does not
        # move it)
        own_peak = reg.peak(group) if f.thin and b.fitted else None
        for o in others:
            ox0, oy0, ox1, oy1 = o.bbox
            if (o.mask_area >= least and ox0 <= x1 + 1 and x0 <= ox1 + 1
                    and oy0 <= y1 + 1 and y0 <= oy1 + 1) and not (
                        own_peak is not None and reg.peak([o.label]) <= FAINTER * own_peak):
                same = True
                slight = False
                break
        for o in others:
            if not np.isfinite(o.length):
                o.length = float(max(o.bbox[2] - o.bbox[0], o.bbox[3] - o.bbox[1]))
        f.intruders.update(tau[i], others, min_area=0.4 * (ref_area or 0.0))
        if f.intruders.near(tau[i], p[0], p[1], ref_len) and not (
                own_peak is not None and _only_fainter(reg, others, p, ref_len, own_peak)):
            same = True
            slight = False
        # shrunk at a stroke: part of it hidden (behind something, or against a
        # background it cannot be told from); shrinking smoothly, it is receding or
        # turning (the reference follows)
        ref_cov = f.ref(f.covs, None)
        odd = (not same and ref_cov is not None and len(f.covs) >= 3
               and b.area < 0.65 * ref_cov and f.last_cov is not None
               and b.area < 0.8 * f.last_cov)
        f.last_cov = b.area
        fl = store(i, b, fl | (MERGED if same else 0) | (APPEARANCE if odd else 0))
        solid[i] = f.compact
        if same or odd or (fl & BORDER):
            f.seen(b)
        if slight and not odd and not (fl & BORDER):
            f.pred.add(tau[i], b.u, b.v)
        if (f.compact or (f.thin and b.fitted)) and grown and not odd and \
                not (fl & BORDER) and f.regrown(b):
            # an object of any shape that kept a new size for several frames, nothing
            # else touching it: it is that size now (a plush toy turning its large
            # side, a glider turning broadside; a thin straw whose own line was
            # fitted, first seen partly hidden); its sizes are learnt again
            f.relearn()
            same = False
        if not same and not odd and not (fl & BORDER):
            f.errors.append(float(np.hypot(b.u - p[0], b.v - p[1])))
            f.pred.add(tau[i], b.u, b.v)
            f.add(b)
            if not f.mixed and (i % 4 == 0 or len(f.levels) < 3):
                lv = read_level(reg, b)   # the level drifts slowly: every 4th frame
                if np.isfinite(lv):
                    f.levels.append(lv)
        return True

    def own_other_half(frame, roi, gain, b, f):
        """(region, blob) of the whole when what touches the object (``b``) in the other
        polarity is its own other half, else None.

        Its own when the whole (both polarities) keeps the object's size (mask area 0.6
        to 1.6 times its clean frames'), the other polarity's part is no larger than the
        object's clean size, and its edges are as sharp (a shadow's are blurred). A
        straw riding a blade, or crossing one, is dwarfed by the union.
        """
        ref_a = f.ref(f.areas, None)
        if not ref_a:
            return None
        reg0 = seg.segment(frame, roi, gain=gain, polarity=0)
        whole = None
        for o in reg0.components(min_area, shape):
            x0, y0, x1, y1 = o.bbox
            if x0 <= b.u <= x1 and y0 <= b.v <= y1 and (whole is None
                                                         or o.mask_area > whole.mask_area):
                whole = o
        if (whole is None or whole.touches_roi
                or not 0.6 * ref_a <= whole.mask_area <= 1.6 * ref_a):
            return None
        work = reg0.work([whole.label], np.nan, margin=work_margin(None, None, whole.bbox))
        sel = work.sel.view(bool)
        side = np.sign(f.level - float(np.median(work.b[sel]))) if f.level is not None else 1.0
        opp = sel & (work.d * side < 0)
        own = sel & (work.d * side > 0)
        if np.count_nonzero(opp) > 1.0 * ref_a or np.count_nonzero(own) < min_area:
            return None
        _, w_opp = edge_stats(work, opp)
        _, w_own = edge_stats(work, own)
        if np.isfinite(w_opp) and np.isfinite(w_own) and w_opp >= 1.6 * w_own:
            return None
        return reg0, whole

    def follow_back(t_idx, back, ahead, *, until_touch=False):
        """Follow the object from the target frame backwards to the first frame (with
        ``until_touch``, only until it first touches something: the hand or the
        machine that released it)."""
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
        chunk = max(1, _BACK_BYTES // max(1, int(np.prod(shape))
                                          * np.dtype(source.dtype).itemsize))
        i = t_idx - 1
        while i >= 0:
            if i not in held:
                lo = max(0, min(i, oldest) - chunk + 1)
                held = {j: source[j] for j in range(lo, i + 1)}
                oldest = lo
            frame = held.pop(i)
            before = (u[i], v[i], area[i], angle[i], length[i], flags[i], clean[i], solid[i])
            if follow(i, frame, f):
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
                if f.gap > max_gap:
                    break
            i -= 1

    speck_limit = max(_SPECKS_MIN, _SPECKS_PER_MPX * rows * cols / 1e6)
    specks_seen = []         # (frame, specks at the measured noise) where it was raised

    def count_specks(i, frame):
        gain = seg.gain(frame)
        found = seg.specks(frame, gain, at_least=speck_limit)
        first = found
        while found > speck_limit and seg.scale * _SPECK_STEP <= _SPECK_MAX:
            seg.raise_threshold(_SPECK_STEP)
            found = seg.specks(frame, gain, at_least=speck_limit)
        if found != first and not specks_seen:
            specks_seen.append((fnums[i], first))

    def stream():
        while buffer:
            yield buffer.popleft()
        yield from frames

    def checked(items):
        for item in items:
            if cancel.is_set():
                raise Cancelled(f"tracking of {_name(view, source)} cancelled")
            yield item

    t_idx = None if target is None else target_index(target, fnums, name)
    back = deque()           # frames before the target frame, newest last
    back_bytes = 0
    pinned = None            # the target's tracklet until it has 3 points
    first_fol = None         # the follower's state when the object was first taken
    ambiguous_run = 0
    for i, frame in enumerate(progress(stream() if cancel is None else checked(stream()),
                                       total=n, desc=f"track {view or ''}".strip(),
                                       quiet=quiet, unit="frame")):
        if i % _SPECK_EVERY == 0:
            count_specks(i, frame)
        if t_idx is not None and i < t_idx:
            # the target is named in a later frame: these frames are followed
            # backwards from it afterwards (the newest of them kept)
            back.append((i, frame))
            back_bytes += frame.nbytes
            while back_bytes > _BACK_BYTES and len(back) > 1:
                back_bytes -= back.popleft()[1].nbytes
            continue
        if fol is not None:
            if follow(i, frame, fol):
                fol.gap = 0
                continue
            fol.gap += 1
            if fol.gap <= max_gap:
                continue
            if t_idx is None and not _flew_clear(u, v, area, clean, fol.start, i):
                # never once seen flying clear of other objects (a rotor tooth
                # followed while it swept past, a machine part that moved its own size
                # and back): not the straw. Its frames are dropped and the straw is
                # looked for anywhere again, at either polarity
                drop = np.arange(fol.start, i)
                u[drop] = v[drop] = area[drop] = angle[drop] = length[drop] = np.nan
                flags[drop] = LOST
                clean[drop] = solid[drop] = False
            else:
                lost_state = (fol.pred, tau[i])
                if fol.level is not None:
                    last_level[0] = fol.level
            acq.reset()
            fol = None
        level = None
        gain = seg.gain(frame)
        near = None
        if i == t_idx:
            near = (target[1], 0.0)
        elif pinned is not None:
            last = pinned.blobs[-1]
            near = (pinned.predict(tau[i]), max(64.0, 8.0 * math.sqrt(last.mask_area)))
        blobs = search_blobs(i, frame, gain, level, near)
        if blobs:
            moving_frames += 1
        if i == t_idx:
            pinned = Tracklet(tau[i], target_blob(blobs, target, name, fnums[i]))
            acq.tracklets = [pinned]
            continue
        if pinned is not None:
            # the named object: followed by association until its motion is known
            acq.tracklets = [pinned]
            acq._associate(tau[i], blobs)
            if len(pinned.points) >= 3:
                fol = first_fol = start_following(pinned)
                pinned = None
                acq.reset()
            elif tau[i] - pinned.last_t > max_gap:
                fu, fv = target[1]
                raise TrackError(
                    f"{name}: the object at ({fu:g}, {fv:g}) in frame {target[0]} (the "
                    "target) could not be followed to the next frames")
            continue
        tr = acq.update(tau[i], blobs, accept=consistent_with_lost)
        if tr is None and acq.ambiguous and lost_state is None and t_idx is None:
            ambiguous_run += 1
            if ambiguous_run >= 3:
                raise TrackError(ambiguity_message(name, view, acq.ambiguous, fnums[0]))
        else:
            ambiguous_run = 0
        if tr is not None:
            fol = start_following(tr)
            if first_fol is None:
                first_fol = fol
            acq.reset()

    if t_idx is not None and t_idx > 0 and first_fol is not None:
        follow_back(t_idx, back, first_fol)
        back.clear()
    elif t_idx is None and first_fol is not None and first_fol.compact and first_fol.start > 0:
        # an object of any shape is taken once it has flown a while: its first frames
        # (from the release) are followed backwards from there, read again
        follow_back(first_fol.start, back, first_fol, until_touch=True)
    elif t_idx is None and first_fol is not None and not first_fol.compact:
        # a straw taken while something rode along it: the frames before its first
        # clean run, measured then as one blob with the rider, are followed backwards
        # from there with what the clean frames taught (its own band measured alone)
        k0 = _first_clean_run(clean, first_fol.start, 10)
        if k0 is not None and (flags[first_fol.start:k0] & MERGED).any():
            follow_back(k0, back, first_fol, until_touch=True)

    if seg.scale > 1.0:
        at, found = specks_seen[0]
        notes.append(f"threshold raised to {seg.scale:.3g} x the measured noise from frame "
                     f"{at}: compression specks ({found} at the measured noise, more than "
                     f"{speck_limit:.0f} in a frame of {rows * cols / 1e6:.2g} megapixels)")
    if not clean.any() and not np.isfinite(u).any():
        if moving_frames == 0:
            raise TrackError(
                f"{name}: nothing moves in frames {fnums[0]}..{fnums[-1]}: no pixel differs "
                f"from the background by more than {k_sigma:g} x the noise "
                f"({background.noise_sigma * seg.scale:.2g} grey levels)")
        raise TrackError(
            f"{name}: the straw never appears in frames {fnums[0]}..{fnums[-1]}: moving "
            f"blobs were seen in {moving_frames} frames, but none moved steadily over 3 "
            "consecutive frames")

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
    scatter = _refine.flag_outliers(tau, pos, flags, clean_mask=flags == 0,
                                    outlier_flag=OUTLIER)
    if view == "top":
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
    _refine.bridge_gaps(tau, pos, flags, good, max_gap=int(max_gap), lost_flag=LOST,
                        predicted_flag=PREDICTED)
    u, v = pos[:, 0], pos[:, 1]
    if rel is not None:
        flags[(np.arange(n) < rel) & ((flags & PREDICTED) > 0)] |= PRE_RELEASE

    if fol is not None and fol.level is not None:
        last_level[0] = fol.level
    columns = {"frame": fnums, "t_s": times, "u_px": u, "v_px": v, "area_px": area,
               "angle_rad": angle, "length_px": length, "flags": flags.astype(np.int32)}
    if rel is None:
        rel_t = None
    elif rel_tau is None:
        rel_t = float(times[rel])
    else:
        rel_t = float(np.interp(rel_tau, tau, times, left=np.nan, right=np.nan))
        if not np.isfinite(rel_t):
            rel_t = float(times[0] + rel_tau * dt)
    return dict(columns=columns, view=view,
                release_frame=None if rel is None else int(fnums[rel]),
                release_note=rel_note, release_t_s=rel_t, fps=source.fps, frame_shape=shape,
                noise_sigma=float(background.noise_sigma * seg.scale), k_sigma=float(k_sigma),
                straw_level=float(last_level[0]),
                scatter_px=float(scatter) if np.isfinite(scatter) else float("nan"),
                notes=tuple(notes))
