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
4. **Measuring it**: a rod (a straw) by its coverage (:mod:`vidtrack.track._coverage`,
   unbiased over a textured background); an object of both polarities by its body
   (:mod:`vidtrack.track._mixed`); an object of one grey level by its fully covered core
   and the ring round it read against its surroundings (what is attached beyond, a
   shadow, cut off); any other object by its silhouette, holes filled
   (:mod:`vidtrack.track._silhouette`), without its shadow where one is attached to it
   on the same side all through (:mod:`vidtrack.track._shadow`: found in the first
   pass, cut off in a second).
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
                         grey levels where it has one), or part of it possibly unseen
                         against background of its own brightness: not measured as
                         the object
256     EXCLUDED         in a range of the scene's ``exclude_frames``: never fitted (set
                         after tracking, :mod:`vidtrack.track.corrections`)
======  ===============  ===========================================================

A point placed by hand (the scene's ``manual_points``) replaces the tracker's in its
frame with flags 0 (usable, as any clean frame) and is marked in a boolean column
``manual`` that the track then has (:mod:`vidtrack.track.corrections`); a track without
manual points has no such column.
"""

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from vidtrack.errors import TrackError, VidtrackError
from vidtrack.track._flags import (APPEARANCE, BLADE, BORDER, EXCLUDED, FLAGS, LOST, MERGED,
                                   OUTLIER, PRE_RELEASE, PREDICTED)
from vidtrack.track._ghost import (HELD_SHARE, changed, disc_radius, disc_share, held,
                                   moved_over, overlaps, slow_start, still_run,
                                   tail_background, tail_wins)
from vidtrack.track._pass import Cancelled, Pass
from vidtrack.track.rod import END_COLUMNS  # a rod's two ends (the flight tracker's)
from vidtrack.track.steady import CAMERA_COLUMNS  # a steadied camera's shift

#: The optional numeric columns a track may have: a steadied camera's shift, a rod's ends.
OPTIONAL_COLUMNS = CAMERA_COLUMNS + END_COLUMNS

log = logging.getLogger(__name__)

if TYPE_CHECKING:
    import pandas

__all__ = ["Track", "track", "track_parts", "FLAGS", "BORDER", "BLADE", "MERGED", "LOST",
           "PREDICTED", "PRE_RELEASE", "OUTLIER", "APPEARANCE", "EXCLUDED", "TRACK_COLUMNS",
           "describe_flags", "Cancelled", "ENGINES"]

#: The trackers :func:`track` offers (its ``engine``).
ENGINES = ("rules", "flight")

#: Columns of :attr:`Track.data`, in order.
TRACK_COLUMNS = ("frame", "t_s", "u_px", "v_px", "area_px", "angle_rad", "length_px", "flags")



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
        manual points for the view; ``reason`` (str: which test flagged the frame,
        :data:`vidtrack.track.flag.REASONS`) from the flight tracker; a steadied
        camera's shift (:data:`CAMERA_COLUMNS`); a rod's two ends from the flight
        tracker (:data:`END_COLUMNS`, px; end 1 on the side it was on in the frame
        before; NaN where no bar was fitted).
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


def track(source, *, background=None, view=None, k_sigma=5.0, min_area_px=4,
          max_gap=5, blade_region=None, centre_line_px=None, warmup_frames=None,
          quiet=True, cancel=None, target=None, engine="rules", settings=None):
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
    engine : {"rules", "flight"}, optional
        Which tracker: ``"rules"`` (default, described above) or ``"flight"``, the one
        mechanism of :mod:`vidtrack.track.flight` (detect, link, choose by the flight,
        flag by statistics), which reads its thresholds from ``settings``.
    settings : vidtrack.track.settings.TrackerSettings, optional
        The flight tracker's settings (``k_sigma``, ``min_area_px`` and ``max_gap``
        given here override theirs when they differ from the defaults).

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
    One pass over the frames (a second, with the first's background, where an object
    measured by its silhouette has its shadow attached all through: it is then measured
    without it); memory is the background, the warm-up buffer and a few numbers per
    frame, whatever the footage's length.
    """
    tr = Track.from_parts(track_parts(
        source, background=background, view=view, k_sigma=k_sigma, min_area_px=min_area_px,
        max_gap=max_gap, blade_region=blade_region, centre_line_px=centre_line_px,
        warmup_frames=warmup_frames, quiet=quiet, cancel=cancel, target=target,
        engine=engine, settings=settings))
    log_tracked(tr)
    return tr


def log_tracked(tr):
    """Log what a view's tracking found (INFO) and its notes (DEBUG)."""
    log.info("%s: %d frames tracked, %d usable; release frame %s (%s)", tr.view or "view",
             len(tr.data), int(np.count_nonzero(tr.usable)), tr.release_frame,
             tr.release_note)
    for note in tr.notes:
        log.debug("%s: %s", tr.view or "view", note)


#: Below this share of the frames clean, the tracker looks for a slow object too ...
SLOW_LOOK = 0.05
#: ... and takes it where it went at least this many times its size (its disc's
#: diameter) over the frames the background was taken from: a pixel on its way is then
#: covered in at most 40 % of them, and the median does not hold it. (A ball 12 px
#: across going 0.05 px a frame, 1.25 times its size over 300 frames, is in the
#: background, and seen against itself its track was 2 to 5 px off.)
SLOW_TRAVEL = 2.5


#: The notes of a first pass that a pass run again with its background keeps.
_FIRST_NOTES = ("background", "camera: shakes")


def _travel(ps):
    """How far (in its own sizes) the object of pass ``ps`` went over the frames its
    background was taken from (the frames' span, between its first and last position
    there)."""
    idx = [i for i in ps.background.frames if 0 <= i < ps.n and np.isfinite(ps.u[i])]
    if len(idx) < 2 or not np.isfinite(ps.area).any():
        return 0.0
    size = 2.0 * float(np.sqrt(np.nanmedian(ps.area) / np.pi))
    return float(np.hypot(ps.u[idx[-1]] - ps.u[idx[0]], ps.v[idx[-1]] - ps.v[idx[0]])) / size


def _on_held(ps, slow):
    """Clean frames of the pass ``ps`` whose point lies within its size (the diameter of
    its larger frames) of the slow object the pass ``slow`` followed (where it was then,
    or at its nearest frame): the slow object held by the background, seen against
    itself (bool per frame)."""
    seen = np.flatnonzero(np.isfinite(slow.u))
    on = np.zeros(ps.n, bool)
    if seen.size == 0 or not np.isfinite(slow.area).any():
        return on
    # (each pass sees a part of it, on either side of its centre: two parts of one disc
    # lie within its diameter of each other; its largest frames show most of it)
    size = 2.0 * float(np.sqrt(np.nanpercentile(slow.area, 90) / np.pi))
    idx = np.flatnonzero(ps.clean & np.isfinite(ps.u))
    near = seen[np.clip(np.searchsorted(seen, idx), 0, seen.size - 1)]
    before = seen[np.clip(np.searchsorted(seen, idx) - 1, 0, seen.size - 1)]
    near = np.where(np.abs(before - idx) < np.abs(near - idx), before, near)
    on[idx] = np.hypot(ps.u[idx] - slow.u[near], ps.v[idx] - slow.v[near]) <= size
    return on


def _without_ghost(source, ps, kw):
    """The pass ``ps``, or the view tracked again against a background from the last part
    of the footage where ``ps`` followed the ghost of an object that rested where its
    background was taken, alone or with the object (:mod:`vidtrack.track._ghost`)."""
    run = still_run(ps)
    if run is None and not slow_start(ps):
        return ps       # (thrown: no ghost to follow)
    tail = tail_background(source)
    if tail is None:
        return ps
    mask = changed(ps.background, tail, k_sigma=ps.k_sigma)
    if not mask.any() or not overlaps(ps, mask):
        return ps
    try:
        again = Pass(source, background=tail, **kw).run()
    except TrackError:
        return ps
    if run is not None:
        first, last, u0, v0 = run
        radius = disc_radius(ps.area[first:last + 1])
        if disc_share(mask, u0, v0, radius) >= 0.5 and moved_over(again, first, last,
                                                                   radius):
            said = (f"what was followed stood still at ({u0:.0f}, {v0:.0f}) px in frames "
                    f"{first}..{last}")
        else:
            run = None
    if run is None:
        if not tail_wins(ps, again, mask):
            return ps
        said = ("what was followed lay, where the two passes part, over places that "
                "differ")
    again.notes[:0] = [note for note in ps.notes if note.startswith("camera:")]
    frames = tail.frames
    again.notes.append(
        f"background: {said}, where the background of the first frames differs from that "
        f"of the last: the ghost of an object at rest there while the background was "
        f"taken. Tracked against a background from frames {frames[0]}..{frames[-1]} "
        f"instead")
    return again


def track_parts(source, *, background=None, view=None, k_sigma=5.0, min_area_px=4,
                max_gap=5, blade_region=None, centre_line_px=None, warmup_frames=None,
                quiet=True, cancel=None, target=None, engine="rules", settings=None):
    """:func:`track`'s work, returning the :class:`Track`'s fields as a dict, its rows as
    a dict of numpy arrays (``columns``): a worker process need not load pandas
    (:meth:`Track.from_parts` builds the Track)."""
    if engine not in ENGINES:
        raise TrackError(f"tracker engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    if engine == "flight":
        import dataclasses

        from vidtrack.track.flight import track_flight
        from vidtrack.track.settings import TrackerSettings

        settings = settings or TrackerSettings()
        given = {"k_sigma": k_sigma, "min_area_px": min_area_px, "max_gap": max_gap}
        defaults = {"k_sigma": 5.0, "min_area_px": 4, "max_gap": 5}
        try:
            settings = dataclasses.replace(
                settings, **{k: val for k, val in given.items() if val != defaults[k]})
        except VidtrackError as err:
            raise TrackError(str(err)) from None
        return track_flight(source, settings=settings, background=background, view=view,
                            target=target, blade_region=blade_region, cancel=cancel)
    kw = dict(view=view, k_sigma=k_sigma, min_area_px=min_area_px, max_gap=max_gap,
              blade_region=blade_region, centre_line_px=centre_line_px,
              warmup_frames=warmup_frames, quiet=quiet, cancel=cancel, target=target)
    ps = Pass(source, background=background, **kw).run()
    if ps.moving_frames and np.count_nonzero(ps.clean) < max(3, SLOW_LOOK * ps.n):
        # (next to) nothing moved 0.3 px a frame steadily: a slow object (high frame
        # rates), seen to move over many frames (only then: a rotor's tooth turning
        # slowly would be); against the first pass's background
        slow = Pass(source, background=ps.background, steady=ps.steady,
                    **{**kw, "slow": True}).run()
        slow.notes[:0] = [note for note in ps.notes if note.startswith(_FIRST_NOTES)]
        if np.count_nonzero(slow.clean) > np.count_nonzero(ps.clean):
            travel = _travel(slow)
            said = (f"search: {np.count_nonzero(ps.clean)} clean frames of objects moving "
                    f"0.3 px a frame or more; a slower one, moving steadily over 40 frames, "
                    f"went {travel:.2g} times its size over the frames the background was "
                    f"taken from")
            if travel >= SLOW_TRAVEL:
                slow.notes.append(said)
                ps = slow
            else:
                on = _on_held(ps, slow)
                also = (f"; {np.count_nonzero(on)} clean frames of the first search "
                        f"are on it (flagged appearance)" if on.any() else "")
                ps.flag(on, APPEARANCE)
                ps.notes.append(f"{said}, which then holds it (seen against itself, it "
                                f"would be off by a part of its size): not taken{also}")
    if background is None and ps.steady is None:
        ps = _without_ghost(source, ps, kw)
    shadow = ps.attached_shadow()
    if shadow is not None:
        # a shadow attached to it all through: measured again, without it
        n_has, n_ok, (du, dv) = shadow
        said = (f"shadow: a soft darker part attached on the same side in {n_has} of {n_ok} "
                f"clean frames (pulling the centroid by ({du:+.1f}, {dv:+.1f}) px)")
        try:
            again = Pass(source, background=ps.background, shadow="cut", steady=ps.steady,
                         **kw).run()
        except TrackError as err:
            # (measured whole, as the first pass did, rather than not at all)
            ps.notes.append(f"{said}: measured with it, the second pass without it "
                            f"failing ({err})")
        else:
            again.notes[:0] = [note for note in ps.notes if note.startswith(_FIRST_NOTES)]
            again.notes.append(f"{said}: a second pass measured the object without it")
            ps = again
    in_bg = held(ps)
    if in_bg.any():
        ps.flag(in_bg, APPEARANCE)
        ps.notes.append(f"background: it lay where it is in more than {100 * HELD_SHARE:g} % of "
                        f"the frames the background was taken from in {np.count_nonzero(in_bg)}"
                        f" clean frames: there the background holds it, and it is seen "
                        f"against itself, off by a part of its size (flagged appearance)")
    return ps.parts()
