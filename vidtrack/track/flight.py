"""The flight tracker: detect, link, choose by the flight, measure, flag by statistics.

One view's footage to the fields of a :class:`vidtrack.track.tracker.Track`, in one
decode of the footage (frames decoded in a thread beside the detection: OpenCV releases
the GIL while it decodes):

1. **background** (:mod:`vidtrack.track.background`): the per-pixel median of
   ``background_samples`` frames spread over the whole footage, and the noise of every
   pixel (footage of up to 96 MB is decoded once and held for it; longer footage has its
   samples read first, so memory stays flat in length);
2. **detect** (:mod:`vidtrack.track.detect`): every frame's detections, measured where
   they are found (weighted centroid, moments, photometric shadow test);
3. **link** (:mod:`vidtrack.track.link`): detections into tracklets;
4. **choose** (:mod:`vidtrack.track.choose`): the chain a flight explains, or the one
   through the user's ``target``;
5. **measure** (:mod:`vidtrack.track.measure`): each of its frames by the object's own
   shape, what touches it left out (footage not held is decoded a second time, for the
   chain's frames only);
6. **flag** (:mod:`vidtrack.track.flag`): each frame judged by statistics; the release.

Every threshold is a field of :class:`vidtrack.track.settings.TrackerSettings`.
"""

import queue
import threading

import numpy as np

from vidtrack.errors import TrackError
from vidtrack.track._flags import BLADE, LOST
from vidtrack.track.background import estimate_background, gather_samples, without_object
from vidtrack.track.choose import choose, others_note
from vidtrack.track.detect import Detector
from vidtrack.track.flag import REASON_COLUMN, bridge_gaps, judge, reason_codes
from vidtrack.track.joined import follow_back, hold_profile
from vidtrack.track.link import link
from vidtrack.track.matte import MATTE_FRAMES, fit_sample
from vidtrack.track.measure import (BAR_COLUMNS, bar_moments, beside_its_shadow,
                                    chain_shape, explained_frames, fit_shape,
                                    has_highlight, is_rod, measure_frame, moment_axes,
                                    MINOR_FLOOR_PX, SHAPE_FRAMES)
from vidtrack.track.rod import END_COLUMNS, MIN_LENGTH_PX
from vidtrack.track.settings import ALGORITHM_VERSION, TrackerSettings
from vidtrack.track.steady import CAMERA_COLUMNS, Steadier

__all__ = ["track_flight", "blade_mask", "rod_ends", "Cancelled"]

#: Frames decoded ahead of the detection (a bounded queue: memory flat in length).
_AHEAD = 8

#: Footage that fits in this many bytes is decoded once, held, and its background taken
#: from the frames held; longer footage has its background samples read first.
HOLD_BYTES = 96 * 2 ** 20

#: At most this many times the view is tracked again against a background taken without
#: the object (the second places the object where it stood by the chain the first found).
AGAIN_MAX = 2

#: Fewest frames of a compact object's chain its matte is fitted over.
MATTE_MIN_FRAMES = 8

_TOP_NOTE = ("release: not looked for in the top view (it sees the rotor's plane edge-on); "
             "the front view's is carried over")


class Cancelled(Exception):
    """Tracking stopped by its ``cancel`` event (either tracker)."""


def _frames(source, cancel):
    """The source's frames, decoded in a thread a few frames ahead."""
    q = queue.Queue(maxsize=_AHEAD)
    stop = threading.Event()
    end = object()

    def work():
        try:
            for frame in source:
                while not stop.is_set():
                    try:
                        q.put(frame, timeout=0.1)
                        break
                    except queue.Full:
                        continue
                if stop.is_set():
                    return
            q.put(end)
        except BaseException as err:      # noqa: BLE001 (re-raised in the caller)
            q.put(err)

    th = threading.Thread(target=work, name="vidtrack-decode", daemon=True)
    th.start()
    try:
        while True:
            item = q.get()
            if item is end:
                return
            if isinstance(item, BaseException):
                raise item
            if cancel is not None and cancel.is_set():
                raise Cancelled()
            yield item
    finally:
        stop.set()
        th.join(timeout=5.0)


def _background(source, held, settings):
    """The background, a :class:`~vidtrack.track.steady.Steadier` (None where the
    camera is steady) with its note, and the samples' frame positions. ``held``
    (footage held whole, or None) is moved back in place where the camera shakes."""
    n = len(held) if held is not None else len(source)
    if n < 3:
        raise TrackError(f"the background needs at least 3 frames, the footage has {n}")
    samples = settings.background_samples
    idx, frames, pairs = gather_samples(_getter(source, held, None), n, samples=samples)
    background = estimate_background(frames, pairs=pairs, frames=idx)
    steady, note = Steadier.look(frames, idx, background.image,
                                 agree_share=settings.camera_agree_share)
    if steady is None:
        return background, None, note, idx
    if held is not None:
        for i, frame in enumerate(held):
            held[i] = steady.warp(i, frame)
    idx, frames, pairs = gather_samples(_getter(source, held, steady), n, samples=samples)
    return estimate_background(frames, pairs=pairs, frames=idx), steady, note, idx


def _getter(source, held, steady):
    """Frame position -> its frame: from ``held`` (footage held whole, already steadied),
    else decoded from ``source`` and moved back by ``steady`` (where not None)."""
    if held is not None:
        return held.__getitem__
    if steady is not None:
        return lambda i: steady.warp(i, source[i])
    return source.__getitem__


def _disc_reach(shape, settings):
    """The radius (px) of the disc the object covers round its centre (``stood_reach``)."""
    return settings.stood_reach * 2.0 * float(shape.major) + 1.0


def _discs(chain, shape, at, settings):
    """``(len(at), 3)``: the object's disc ``(u, v, radius)`` in frame positions ``at``,
    at its chain's position there (interpolated between its frames). Before its chain's
    first frame the object is taken to be where it was first seen, after the last where
    it was last seen (held still before the throw, lying where it landed), in a disc
    twice as wide: an object first seen as it leaves a place it stood on, joined to its
    "ghost" there, is first seen a part of its size away from it."""
    idx = chain.frames
    at = np.asarray(at)
    outside = (at < idx[0]) | (at > idx[-1])
    return np.column_stack([np.interp(at, idx, chain.u[idx]), np.interp(at, idx, chain.v[idx]),
                            _disc_reach(shape, settings) * np.where(outside, 2.0, 1.0)])


def _over(chain, shape, mask, settings):
    """Frame positions of the chain whose object's disc overlaps ``mask``."""
    ys, xs = np.nonzero(mask)
    if ys.size == 0:
        return np.zeros(0, int)
    idx = chain.frames
    r = _disc_reach(shape, settings)
    d2 = ((chain.u[idx, None] - xs[None, :]) ** 2 + (chain.v[idx, None] - ys[None, :]) ** 2)
    return idx[(d2 <= r * r).any(axis=1)]


def _bar_axes(muu, mvv, muv):
    """The angle (rad from +u towards +v), length and width (px) of the uniform
    rectangle of second central moments ``muu, mvv, muv`` (px^2)."""
    angle, along, across = moment_axes(muu, mvv, muv)
    return angle, np.sqrt(12.0 * along), np.sqrt(12.0 * across)


def _covers(mask, u, v, angle, length, width):
    """Whether the object at (``u``, ``v``), a rectangle of that ``angle``, ``length``
    and ``width`` (:func:`_bar_axes`; its centre alone where they are not known),
    shares a pixel with ``mask``: its points one pixel apart are looked up."""
    if not np.all(np.isfinite((angle, length, width))):
        angle = length = width = 0.0
    s = np.linspace(-0.5, 0.5, int(np.ceil(length)) + 1)[:, None] * length
    t = np.linspace(-0.5, 0.5, int(np.ceil(width)) + 1)[None, :] * width
    c, n = np.cos(angle), np.sin(angle)
    cols = np.rint(u + s * c - t * n).astype(int).ravel()
    rows = np.rint(v + s * n + t * c).astype(int).ravel()
    inside = (rows >= 0) & (rows < mask.shape[0]) & (cols >= 0) & (cols < mask.shape[1])
    return bool(mask[rows[inside], cols[inside]].any())


def _steadied(frames, steady):
    """``frames`` moved back by ``steady`` (unchanged where it is None)."""
    if steady is None:
        yield from frames
        return
    for i, frame in enumerate(frames):
        yield steady.warp(i, frame)


def _measure(source, held, detector, detections, chain, shape, settings, cancel,
             steady=None):
    """Each chain frame measured by the object's shape (:mod:`vidtrack.track.measure`):
    the chain's positions are replaced; returns per frame position (weight, muu, mvv,
    muv), the residual share and the model's (half length, half width, coverage,
    misfit, angle, blurs; :data:`~vidtrack.track.measure.BAR_COLUMNS`) (NaN where the
    chain has no detection or no model), and the pixels the shadow test took for the
    object's shadow (touching it; left out). Footage not held is decoded again for it,
    one frame at a time."""
    n = len(detections)
    shaded = np.zeros(n, int)
    moments = np.full((n, 4), np.nan)
    residual = np.full(n, np.nan)
    bars = np.full((n, len(BAR_COLUMNS)), np.nan)
    wanted = set(int(i) for i in chain.frames)
    dets = [detections[i][chain.pick[i]] for i in chain.frames]
    highlight = has_highlight(dets, settings)
    beside = highlight and beside_its_shadow(dets, settings)
    if not highlight:
        shape = _model_shape(_getter(source, held, steady), detections, chain, shape,
                             detector, settings)
    frames = held if held is not None else _steadied(_frames(source, cancel), steady)

    def measure(i, frame, held=None):
        det = detections[i][chain.pick[i]]
        if det["mixed"] and beside:
            det = det.copy()
            det["obj_level"], det["mixed"] = det["lit_level"], False
        elif det["mixed"] and highlight:
            det = det.copy()
            det["obj_level"] = det["body_level"]
        return measure_frame(frame, detector.bg, detector.sigma, det, shape, settings,
                             shadow_test=detector.shadow_test, held=held)

    def keep(i, got):
        chain.u[i], chain.v[i] = got.u, got.v
        moments[i] = (got.weight, got.muu, got.mvv, got.muv)
        residual[i] = got.residual
        shaded[i] = got.shaded
        if got.bar is not None:
            bars[i] = got.bar

    for i, frame in enumerate(frames):
        if i not in wanted:
            continue
        keep(i, measure(i, frame))
        if i >= chain.frames[-1]:
            break
    get = _getter(source, held, steady)
    return moments, residual, bars, shaded, (lambda i, bar: measure(i, get(i), bar), keep)


def _by_matte(source, held, steady, chain, shape, bg, noise, settings, cancel):
    """A compact object's points measured by its matte (:mod:`vidtrack.track.matte`)
    where it explains the object to ``matte_misfit_max`` noises and better than its
    outline by ``matte_gain_min``; the chain's positions are replaced. Returns the note,
    or None (the points kept)."""
    idx = explained_frames(chain)
    idx = idx[np.isfinite(chain.u[idx]) & np.isfinite(chain.v[idx])]
    if idx.size < MATTE_MIN_FRAMES:
        return None
    sample = _spread(idx, MATTE_FRAMES)
    placer = fit_sample(_getter(source, held, steady), sample, chain.u, chain.v, bg, noise,
                        shape.major, settings.shadow_ratio_min, settings.matte_misfit_max)
    if not (placer.misfit <= settings.matte_misfit_max
            and placer.gain >= settings.matte_gain_min):
        return None
    want = chain.frames[np.isfinite(chain.u[chain.frames]) & np.isfinite(chain.v[chain.frames])]
    wanted = set(int(i) for i in want)
    frames = held if held is not None else _steadied(_frames(source, cancel), steady)
    for i, frame in enumerate(frames):
        if i in wanted:
            chain.u[i], chain.v[i] = placer.place(frame, bg, chain.u[i], chain.v[i])
        if i >= want[-1]:
            break
    du, dv = placer.matte.centre + placer.offset
    return (f"matte: measured by its own appearance over the walls it crosses (fitted over "
            f"{sample.size} frames to {placer.misfit:.2f} noises, {placer.gain:.2f} times "
            f"better than the outline's points, which it moves by ({du:+.2f}, {dv:+.2f}) "
            f"px on average)")


def _spread(idx, most):
    """At most ``most`` of the frame positions ``idx``, spread evenly over them."""
    return idx[np.unique(np.linspace(0, idx.size - 1, min(most, idx.size))
                         .round().astype(int))]


def _model_shape(get, detections, chain, shape, detector, settings):
    """The object's shape measured by its model (:func:`vidtrack.track.measure.fit_shape`)
    over up to :data:`~vidtrack.track.measure.SHAPE_FRAMES` of the frames its flight
    explains (all its frames where none is marked) where it is seen of one level;
    ``shape`` is updated in place."""
    idx = np.array([i for i in explained_frames(chain)
                    if not detections[i][chain.pick[i]]["mixed"]], int)
    if idx.size == 0:
        return shape
    take = _spread(idx, SHAPE_FRAMES)
    found = fit_shape([get(int(i)) for i in take],
                      [detections[i][chain.pick[i]] for i in take], shape, detector.bg,
                      detector.sigma, settings, shadow_test=detector.shadow_test)
    shape.major, shape.minor = found.major, found.minor
    return shape


def _frames_before(source, steady, window):
    """A frame position's frame (steadied) for following back in footage not held: the
    first call, for the nearest frame, decodes the ``window`` frames up to it, once
    (memory bounded by ``window``, not by the footage's length); None outside them."""
    cache = {}

    def get(i):
        if not cache:
            lo = max(i + 1 - window, 0)
            for k, frame in enumerate(source[lo:i + 1], start=lo):
                cache[k] = frame if steady is None else steady.warp(k, frame)
        return cache.get(i)
    return get


def rod_ends(u, v, half_length, angle):
    """A rod's two ends per frame (``(n, 4)``: end 1's u, v, end 2's u, v; px), from its
    centre and its bar's half length and angle, end 1 kept on the side it was on in the
    frame before (the bar's angle is known up to a half turn); NaN without a bar, and
    where the bar fitted is shorter than :data:`~vidtrack.track.rod.MIN_LENGTH_PX` (a
    rod nearly end on: its angle is not measured)."""
    half_length = np.where(2.0 * half_length >= MIN_LENGTH_PX, half_length, np.nan)
    d = np.column_stack([np.cos(angle), np.sin(angle)]) * half_length[:, None]
    last = None
    for i in range(d.shape[0]):
        if not np.isfinite(d[i]).all():
            continue
        if last is not None and d[i] @ last < 0:
            d[i] = -d[i]
        last = d[i]
    c = np.column_stack([u, v])
    return np.column_stack([c + d, c - d])


def blade_mask(blade_region, shape):
    """Where the blade sweeps, as a boolean mask of the frame's ``shape``: from a mask of
    that shape or a circle ``(u_px, v_px, radius_px)``; None for None."""
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


def track_flight(source, *, settings=None, background=None, view=None, target=None,
                 blade_region=None, cancel=None, what="the object"):
    """Track one view with the flight tracker; the :class:`Track`'s fields as a dict.

    Parameters
    ----------
    source : vidtrack.footage.base.FrameSource
        An open source with a time base.
    settings : TrackerSettings, optional
    background : vidtrack.track.background.Background, optional
        Default: :func:`~vidtrack.track.background.sample_background` over the whole
        footage with ``settings.background_samples`` frames.
    view : str, optional
        The view's name (the ``top`` view's release is not looked for).
    target : (int, (float, float)), optional
        ``(file frame, (u_px, v_px))`` of the object.
    blade_region : numpy.ndarray or (float, float, float), optional
        Where the blade sweeps: frames where the object shares a pixel with it are
        flagged BLADE.
    cancel : threading.Event, optional
    what : str
        What the scene calls the object, for messages.

    Returns
    -------
    dict
        As :func:`vidtrack.track.tracker.track_parts` returns.
    """
    settings = settings or TrackerSettings()
    mask = blade_mask(blade_region, tuple(source.shape))
    held = steady = samples = None
    camera_note = None
    if background is None:
        frame_bytes = int(np.prod(source.shape)) * np.dtype(source.dtype).itemsize
        if len(source) * frame_bytes <= HOLD_BYTES:
            held = list(_frames(source, cancel))
        background, steady, camera_note, samples = _background(source, held, settings)
    name = f"view {view}" if view else "the view"
    if tuple(background.shape) != tuple(source.shape):
        raise TrackError(f"{name}: the background is {background.shape[1]}x"
                         f"{background.shape[0]} px, the footage {source.shape[1]}x"
                         f"{source.shape[0]}")
    fnums = np.asarray(source.frame_numbers)

    def run(background):
        detector = Detector(background, settings)
        frames = held if held is not None else _steadied(_frames(source, cancel), steady)
        detections = [detector(frame) for frame in frames]
        del frames
        n = len(detections)
        if n == 0 or not any(len(d) for d in detections):
            raise TrackError(f"{name}: nothing moves in frames {fnums[0]}..{fnums[n - 1]}: no "
                             f"pixel differs from the background by more than "
                             f"{settings.k_sigma:g} x its noise "
                             f"({background.noise_sigma:.2g} grey levels)")
        tracklets = link(detections, settings, frame_shape=source.shape)
        try:
            chain, others = choose(detections, tracklets, settings, target=target,
                                   frame_numbers=fnums[:n], what=what)
        except TrackError as err:
            raise TrackError(f"{name}: {err}") from None
        shape = chain_shape(chain)
        return detector, detections, tracklets, chain, others, shape

    detector, detections, tracklets, chain, others, shape = run(background)
    over_held = np.zeros(0, int)
    again_note = None
    if samples is not None:
        # (the object stood still in many of the background's samples: the median is
        # the object's there; taken again from the samples that show the wall, and the
        # view tracked again where that moves enough of the object's area; the chain
        # then holds the object where it stood, which places it better the next time)
        get = _getter(source, held, steady)
        first = background
        for again in range(1, AGAIN_MAX + 1):
            redone, taken, no_wall = without_object(
                first, lambda k: get(int(samples[k])), _discs(chain, shape, samples, settings),
                stood_share=settings.stood_share)
            moved = taken & (np.abs(redone.image - background.image) > detector.grow_level)
            # (the object's area, for ``stood_moved_share``: the ellipse of twice its
            # spreads)
            area = np.pi * 4.0 * float(shape.major) * max(float(shape.minor), MINOR_FLOOR_PX)
            if moved.sum() < settings.stood_moved_share * area:
                break
            said = (f"background: the median held the object where it stood still (its "
                    f"ghost once it left); taken again without it there "
                    f"({int(taken.sum())} px)")
            try:
                result = run(redone)
            except TrackError as err:
                # (the pass before stands: a second look that finds nothing or two
                # objects does not undo the object the first one found)
                again_note = (f"{said}, the view tracked again found no object "
                              f"({str(err).removeprefix(name + ': ')}): the pass before "
                              f"is kept")
                break
            again_note = (f"{said} and the view tracked again "
                          f"({again} time{'s' if again > 1 else ''})")
            background = redone
            detector, detections, tracklets, chain, others, shape = result
        over_held = _over(chain, shape, no_wall, settings)
    del samples
    n = len(detections)
    fnums = fnums[:n]
    rod = is_rod(shape)     # (before the measurement refines the shape's profile)
    # (a rod is followed back into what it rides where its release is looked for)
    follow = rod and view != "top"
    moments, residual, bars, shaded, remeasure = _measure(source, held, detector, detections,
                                                      chain, shape, settings, cancel, steady)
    matte_note = None if rod else _by_matte(source, held, steady, chain, shape, detector.bg,
                                            float(background.noise_sigma), settings, cancel)
    get = (held.__getitem__ if held is not None
           else _frames_before(source, steady, settings.release_window))
    followed = (follow_back(get, detections, chain, bars, detector, shape, settings)
                if follow else np.zeros(0, int))
    del held, get
    for i in followed:
        moments[i] = bar_moments(bars[i])

    cut = np.zeros(0, int)

    def judged():
        return judge(chain, detections, n, settings, find_release=view != "top",
                     residual=residual, weight=moments[:, 0], bar=bars[:, :4],
                     foot=bars[:, BAR_COLUMNS.index("foot")], joined=followed,
                     held=over_held, cut=cut, rod=rod)

    flags, release, scatter, notes, reasons = judged()
    # (a rod's bar reaching along into what touches an end, in its flight: measured again
    # by its own length and blurs; one shorter with an end that stayed, part hidden: and
    # judged again)
    refit, cut = (hold_profile(chain, bars, settings, *remeasure, after=release or 0)
                  if rod else (np.zeros(0, int), np.zeros(0, int)))
    del remeasure
    if refit.size or cut.size:
        flags, release, scatter, notes, reasons = judged()
    if refit.size:
        notes.append(f"{refit.size} frames measured by the rod's own length and blurs: its "
                     f"bar reached farther along, into what touches an end")
    if cut.size:
        notes.append(f"{cut.size} frames of the rod cut at an end (shorter than its flight's, "
                     f"its centre moved along with the end it shows): flagged hidden")
    if again_note:
        notes.insert(0, again_note)
    if matte_note:
        notes.append(matte_note)
    if over_held.size:
        notes.append(f"background: it lay where it is in {over_held.size} frames, over "
                     f"pixels that no frame the background was taken from shows without "
                     f"it: there the background holds it, and it is seen against itself, "
                     f"off by a part of its size (flagged appearance)")
    u, v = chain.u.copy(), chain.v.copy()
    u[flags == LOST] = np.nan
    v[flags == LOST] = np.nan
    bridged = bridge_gaps(u, v, flags, reasons, chain, settings)
    if followed.size:
        notes.append(f"{followed.size} frames before the flight followed by the rod's model into "
                     f"what it is joined to")
    crossed = np.count_nonzero(chain.merged)
    if crossed:
        notes.append(f"{crossed} frames where the object's detection is another moving "
                     f"thing's too, followed apart from it before and after (they cross): "
                     f"left out of its flight, flagged merged")
    has = shaded[chain.frames] > 0
    if has.any():
        notes.append(f"shadow: pixels touching the object taken for its shadow (darker "
                     f"by a smooth factor, the wall's texture kept) and left out in "
                     f"{np.count_nonzero(has)} of its {has.size} frames (median "
                     f"{np.median(shaded[chain.frames][has]):.0f} px)")
    if chain.shadow_like:
        notes.append("shadow-like: the object darkens the wall as a shadow would (a "
                     "factor no darker than shadow_ratio_min, no texture under it to "
                     "tell); taken for the object since nothing else is in flight")
    apart = others_note(chain, others, fnums[:n], what)
    if apart:
        notes.append(apart)
    if bridged:
        notes.append(f"{bridged} frames without a detection inside the object's chain: "
                     f"placed on the path through the clean frames either side "
                     f"(flagged predicted)")
    area = np.full(n, np.nan)
    angle = np.full(n, np.nan)
    length = np.full(n, np.nan)
    width = np.full(n, np.nan)
    levels = []
    for i in chain.frames:
        d = detections[i][chain.pick[i]]
        area[i] = moments[i, 0]
        angle[i], length[i], width[i] = _bar_axes(*moments[i, 1:])
        # (its own grey level, as the straw_level of a Track is: its body's where it has
        # a highlight; none for an object of several tones)
        own = d["body_level"] if d["mixed"] else d["obj_level"]
        if np.isfinite(own):
            levels.append(float(own))
    reasons["blade"] = np.zeros(n, bool)
    if mask is not None:
        for i in chain.frames:
            if np.isfinite(u[i]) and _covers(mask, u[i], v[i], angle[i], length[i], width[i]):
                flags[i] |= BLADE
                reasons["blade"][i] = True
    times = np.asarray(source.times_s)[:n]
    notes = [f"tracker: {ALGORITHM_VERSION}; {len(tracklets)} tracklets, "
             f"{len(others) + 1} chains considered; {chain.frames.size} frames in the "
             f"object's chain, {int(np.count_nonzero(flags == 0))} unflagged",
             f"background: median of {background.n_samples} frames spread over the "
             f"footage"] + notes
    if steady is not None:
        notes[2:2] = [camera_note, steady.summary()]
        shifts = np.full((n, 2), np.nan)
        for i, sh in steady.shifts.items():
            if 0 <= i < n:
                shifts[i] = sh
    elif camera_note and camera_note.startswith("camera: the scene moves"):
        notes.insert(2, camera_note)
    if view == "top":
        rel_note = _TOP_NOTE
    elif release is None:
        rel_note = "first seen in free flight"
    else:
        rel_note = "where the path's sharp bend ends"
    first = int(chain.frames[0])
    rel_pos = release if release is not None else (None if view == "top" else first)
    columns = {"frame": fnums, "t_s": times, "u_px": u, "v_px": v, "area_px": area,
               "angle_rad": angle, "length_px": length, "flags": flags.astype(np.int32),
               REASON_COLUMN: reason_codes(reasons, n)}
    if steady is not None:
        columns.update(zip(CAMERA_COLUMNS, shifts.T))
    if rod:
        columns.update(zip(END_COLUMNS, rod_ends(u, v, bars[:, 0], bars[:, 4]).T))
    return dict(columns=columns, view=view,
                release_frame=None if rel_pos is None else int(fnums[rel_pos]),
                release_note=rel_note,
                release_t_s=None if rel_pos is None else float(times[rel_pos]),
                fps=source.fps, frame_shape=tuple(source.shape),
                noise_sigma=float(background.noise_sigma), k_sigma=float(settings.k_sigma),
                straw_level=float(np.median(levels)) if levels else float("nan"),
                scatter_px=float(scatter), notes=tuple(notes))
