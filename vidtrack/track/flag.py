"""Step 5 of the flight tracker: every frame judged by statistics, with its reason.

Against the chain's own clean frames, two tests with one threshold, ``k_flag``:

- **path**: each frame's distance from the local quadratic path through its neighbours
  (:func:`vidtrack.track.path.local_quadratic`, ``path_window`` frames either side, the
  frame itself left out), studentized (over ``sqrt(1 + h)``, ``h`` the prediction's own
  variance factor: the ends of a path are predicted from one side), beyond ``k_flag``
  times their scatter (per axis: their median over 1.1774, as for a 2-D normal law),
  and farther than ``flag_floor_px`` from the path (a distance, not studentized):
  OUTLIER; taken again from the frames each round keeps (:func:`_path_outliers`);
- **appearance** (first: the path test starts from the frames that pass it): the log of
  each frame's detected size (pixels: what joins the object grows it) against the
  median of its neighbours' within twice ``path_window`` frames; the log of its weight measured by
  its shape's fit (its coverage) short of its neighbours' within four times
  ``path_window`` (scatter at least ``weight_floor``: part of it hidden); and the share
  of its weight that the fit left out (:mod:`vidtrack.track.measure`) against the
  chain's, over its robust scatter (at least ``residual_floor``): beyond ``k_flag``
  (grown or shrunk at a stroke: something touching, part hidden), APPEARANCE; so is a
  shadow-like detection (:mod:`vidtrack.track.detect`) in a chain that is not one. A
  rod's frames measured by its bar (:mod:`vidtrack.track.rod`) are judged by the bar
  instead: its length for the size, its covered area for the weight, each against the
  local quadratic in time through its neighbours' (a rod turning end on shrinks
  smoothly: it is followed, where a median of the neighbours lags it), its misfit over
  its footprint and caps for the residual, and its misfit over its footprint alone
  (beyond ``footprint_floor``: the bar fitted to a rod part hidden misfits its own
  pixels); its width, its diameter in any attitude, against its neighbours' median
  over four times ``path_window`` (scatter at least ``width_floor``): a post hiding its
  side narrows it gradually, which a trend would follow; and its kernel's weight, as an
  object's (the bar reads a part hidden as a fainter whole). Something beside the rod, even
  joined to its detection, does not touch the bar; something over it does. A
  frame only short of weight or size (``hidden``, not narrower) is suspect, not wrong:
  where the clean frames round it (one within ``path_window`` on each side), every such
  frame left out, predict it within ``k_flag`` of their scatter (:func:`_on_clean_path`),
  it is kept (a white glider over a cream wall of its own tones loses a quarter of its
  weight, its point still on its path).

A detection touching the frame's border is BORDER; frames inside the chain's span
without a detection are LOST, and so are the frames at either end of the chain that the
path test rejects (in view): what the chain took where the object was not seen, a hand
before the throw, a racket after a hit, is not the object, and its position is left
out.

The **release** (front views): where the path's acceleration drops at a stroke, from the
ride on a blade or in a hand to free flight (:func:`vidtrack.track.release.find_release`:
a spline knot fitted robustly to the chain's first ``release_window`` frames on its
path, counted when it is significant (``release_significance``), the acceleration before
it at least ``release_ratio`` times that after, and the extra acceleration before it
pushed or turned the object rather than braked it (``release_push_deg``: a blade or a
hand pushes what it carries; drag falling off, touched or not, brakes)); the frames
before it are PRE_RELEASE.
"""

import numpy as np

from vidtrack.track._flags import (APPEARANCE, BORDER, LOST, MERGED, OUTLIER, PRE_RELEASE,
                                   PREDICTED)
from vidtrack.track.choose import MAJORITY
from vidtrack.track.joined import size_z
from vidtrack.track.measure import residual_outliers
from vidtrack.track.path import (RAYLEIGH_MEDIAN, clean_side, local_quadratic,
                                 neighbour_median, robust_scale, runs)
from vidtrack.track.release import find_release as release_knot

__all__ = ["judge", "REASONS", "REASON_COLUMN", "reason_codes"]

#: The per-frame column of a track (and dataset of tracks.h5, column of tracks.csv)
#: holding each frame's reason codes.
REASON_COLUMN = "reason"

#: The reason codes of a frame (tracks.h5 and tracks.csv's ``reason``, in this order,
#: joined by ``+``): more than the flag bits say, which test flagged it.
REASONS = {"lost": "no detection of the object in this frame (LOST)",
           "border": "the object touches the frame's border (BORDER)",
           "pre-release": "before the release found in the path (PRE_RELEASE)",
           "touched": "something touches the object: its detection grown at a stroke, "
                      "weight near it outside its kernel, or a rod's bar misfitting its own "
                      "pixels (APPEARANCE)",
           "merged": "its detection another moving thing's too, the two followed apart "
                     "before and after: they cross (MERGED)",
           "hidden": "part of the object hidden: its size or measured weight shrunk at a "
                     "stroke, or a rod narrower than its neighbours (APPEARANCE)",
           "unfit": "a rod whose bar could not be fitted to it (the fit failed or ran "
                    "off; measured by its kernel alone), not on the path of the clean "
                    "frames round it (APPEARANCE)",
           "shadow": "shadow-like in a chain that is not (APPEARANCE)",
           "held": "over pixels where the object stood in nearly every frame the background "
                   "was taken from, which none shows without it: measured against the "
                   "object itself (APPEARANCE)",
           "off-path": ("off the local path of its neighbours, or its detection off the chain's "
                        "robust path with none on it: another thing's (OUTLIER)"),
           "blade": "where the blade sweeps (BLADE)",
           "predicted": "no detection inside the object's chain (hidden, or too faint): "
                        "its position is the path's through the clean frames either side "
                        "(PREDICTED)"}


#: The object at rest: the straight line in time through its still frames moves less
#: than this share of their tolerance (``rest_px``, ``rest_scatters``) across them; a
#: slow object moving steadily within the tolerance is not at rest.
REST_DRIFT_SHARE = 0.5


def _at_rest(idx, uv, scatter, settings):
    """How many frames at the start of a chain (positions ``idx``, points ``uv``) the
    object lies still (``rest_frames``, ``rest_px``, ``rest_scatters``); 0 where it
    does not."""
    if idx.size <= settings.rest_frames:
        return 0
    tol = settings.rest_px
    if np.isfinite(scatter):
        tol = max(tol, settings.rest_scatters * scatter)
    home = np.median(uv[:settings.rest_frames], axis=0)
    far = np.flatnonzero(np.hypot(*(uv - home).T) > tol)
    run = int(far[0]) if far.size else idx.size
    if run < settings.rest_frames or run == idx.size:
        return 0
    t = idx[:run].astype(float)
    slope = np.polyfit(t - t.mean(), uv[:run], 1)[0]
    drift = float(np.hypot(*slope)) * (t[-1] - t[0])
    return run if drift <= REST_DRIFT_SHARE * tol else 0


#: A frame is tested against its neighbours' path only where its prediction's variance
#: is at most this many times a point's (one frame beyond the frames kept, with
#: ``path_window`` 6: 4.6; two frames: 33); else it may be left out, not taken in.
PREDICTION_H_MAX = 5.0

#: A run of fewer than this many frames of the object's own size between frames
#: flagged for their appearance is not trusted at first by the path test (it must pass
#: it): the cause that flagged its neighbours (part hidden, something touching) lasts,
#: and frames it moved alike predict each other.
CLEAN_RUN_MIN = 3


def _path_outliers(idx, uv, settings, start):
    """Frames (positions in idx) off their neighbours' path, and the scatter (px);
    ``start``: the frames trusted at first (those of the object's own size).

    The test is taken again from the frames each round keeps, until they stay the same.
    A frame predicted from afar (its prediction's variance beyond
    :data:`PREDICTION_H_MAX` times a point's) may be left out by the test but not taken
    in: the frames kept grow a frame a round from where they are, not by a reach
    through which anything passes. Where the rounds still come back to frames kept
    before (frames that pass only while others are left out, in turn), the frames kept
    are those of the round in that cycle whose path explains the chain best, its
    truncated cost (the sum over the frames of ``min((residual / threshold)^2, 1)``, 1
    for a frame it cannot predict) the least, that its own test passes.
    """
    ok = start.copy()
    # (a short run of frames between frames flagged for their appearance is tested
    # before it is trusted)
    short = np.zeros(ok.size, bool)
    for a, b in runs(ok):
        if b - a < CLEAN_RUN_MIN and (a > 0 or b < ok.size):
            short[a:b] = True
    if np.count_nonzero(ok & ~short) >= 3:
        ok &= ~short
    # (a frame the others predict only from afar, at an end beyond a gap, cannot be
    # tested against them: it is not trusted at first either)
    _pred, _acc, h, _ha = local_quadratic(idx, uv, settings.path_window,
                                          weights=ok.astype(float), leverage=True)
    with np.errstate(invalid="ignore"):
        untested = ok & np.isfinite(h) & ~(h <= PREDICTION_H_MAX)
    if np.count_nonzero(ok & ~untested) >= 3:
        ok &= ~untested
    seen, rounds = {}, []
    scatter = float("nan")
    for r in range(idx.size + 1):
        pred, _acc, h, _ha = local_quadratic(idx, uv, settings.path_window,
                                             weights=ok.astype(float), leverage=True)
        # (the residual studentized: a point predicted from one side, at the ends,
        # is predicted less well)
        spread = np.sqrt(1.0 + np.where(np.isfinite(h), h, 0.0))
        res = np.hypot(*(pred - uv).T) / spread
        scatter = float(np.median(res[ok & np.isfinite(res)])) / RAYLEIGH_MEDIAN if ok.any() \
            else float("nan")
        # (the floor is a distance from the path, not studentized: a frame predicted from
        # one side is not let off beyond it)
        limit = np.maximum(settings.k_flag * scatter, settings.flag_floor_px / spread)
        new = ~(res > limit)
        new &= np.isfinite(res) | (idx.size < 4)
        with np.errstate(invalid="ignore"):
            far = np.isfinite(res) & ~(h <= PREDICTION_H_MAX)
        new = np.where(far, ok & new, new)
        if np.array_equal(new, ok):
            break
        # (a frame it cannot predict costs as much as one it rejects)
        with np.errstate(invalid="ignore"):
            cost = float(np.sum(np.where(np.isfinite(res),
                                         np.minimum((res / limit) ** 2, 1.0), 1.0)))
        seen[ok.tobytes()] = r
        rounds.append((cost, ok & new, scatter))
        if new.tobytes() in seen:
            cost, ok, scatter = min(rounds[seen[new.tobytes()]:], key=lambda x: x[0])
            break
        ok = new
    return ~ok, scatter


def _on_clean_path(idx, uv, suspect, clean, scatter, settings):
    """The ``suspect`` frames (positions in ``idx``) that the ``clean`` frames' local
    path predicts: each predicted from the clean frames alone (every suspect frame left
    out, so frames moved alike do not predict each other), from near enough (variance
    at most :data:`PREDICTION_H_MAX` times a point's), within ``k_flag`` times the
    clean frames' ``scatter`` (studentized, no floor: a suspect frame gets no
    tolerance beyond the path's own)."""
    out = np.zeros(idx.size, bool)
    if not suspect.any() or np.count_nonzero(clean) < 3 or not np.isfinite(scatter):
        return out
    pred, _acc, h, _ha = local_quadratic(idx, uv, settings.path_window,
                                         weights=clean.astype(float), leverage=True)
    # (round it: a clean frame within ``path_window`` on each side; at the edge of a
    # hidden stretch the path is extrapolated from one side, where being hidden moves
    # a point the most)
    at = idx[clean]
    lo = np.searchsorted(at, idx - settings.path_window, side="left")
    below = np.searchsorted(at, idx, side="left")
    above = np.searchsorted(at, idx, side="right")
    hi = np.searchsorted(at, idx + settings.path_window, side="right")
    flanked = (below > lo) & (hi > above)
    with np.errstate(invalid="ignore"):
        res = np.hypot(*(pred - uv).T) / np.sqrt(1.0 + h)
        out = (suspect & flanked & (h <= PREDICTION_H_MAX)
               & (res <= settings.k_flag * scatter))
    return out


def _end_runs(mask):
    """The leading and the trailing runs of True of ``mask`` (all of it where it is all
    True)."""
    out = np.zeros(mask.size, bool)
    if mask.size == 0:
        return out
    false = np.flatnonzero(~mask)
    if false.size == 0:
        out[:] = True
        return out
    out[:false[0]] = True
    out[false[-1] + 1:] = True
    return out


def _size_z(size, settings, window, floor=None, frames=None):
    """Each frame's log size less its neighbours' median within ``window`` frames (or,
    given the ``frames``, less the local quadratic in time through them: a size that
    changes smoothly, a rod turning end on, is followed), in robust scatters of those
    differences (at least ``floor``, default ``size_floor``): beyond ``k_flag``, grown at
    a stroke (something touching); below ``-k_flag``, shrunk (part hidden)."""
    logs = np.log(np.maximum(size, 1e-9))
    if frames is None:
        dev = logs - neighbour_median(logs, window)
    else:
        pred, _ = local_quadratic(np.asarray(frames, float), logs, window)
        dev = np.where(np.isfinite(pred), logs - pred, 0.0)
    return dev / robust_scale(dev, floor=settings.size_floor if floor is None else floor)


def _appearance(size_measures, residual, weight, settings, frames=None):
    """(touched, hidden) of a run of frames from their size measures (each grown or
    shrunk at a stroke against its neighbours', or against their local quadratic in
    time given the ``frames``), their residual (beyond the run's own) and their measured
    weight (short of their neighbours')."""
    m = size_measures[0].size
    touched = np.zeros(m, bool)
    hidden = np.zeros(m, bool)
    if m == 0:
        return touched, hidden
    if residual is not None:
        touched |= residual_outliers(residual, settings)
    if weight is not None:
        hidden |= _short_of_weight(weight, settings, frames=frames)
    for measure in size_measures:
        z = _size_z(np.maximum(measure, 0.3), settings, 2 * settings.path_window,
                    frames=frames)
        touched |= z > settings.k_flag
        hidden |= z < -settings.k_flag
    return touched, hidden


def _short_of_weight(weight, settings, frames=None):
    """Frames whose measured weight is short of their neighbours' within ``4 *
    path_window`` (or of their local quadratic in time, given the ``frames``) by more
    than ``k_flag`` scatters of the log weight (at least ``weight_floor``): part
    hidden."""
    return _size_z(np.maximum(weight, 1e-3), settings, 4 * settings.path_window,
                   floor=settings.weight_floor, frames=frames) < -settings.k_flag


def _width_z(width, settings):
    """A rod's log width (its diameter, in every attitude) less its neighbours' median
    over ``4 * path_window`` frames either side, in robust scatters of those differences
    (at least ``width_floor``): judged against its neighbours' level, not their trend (a
    post hiding the rod's side over a few frames narrows it gradually)."""
    return _size_z(np.maximum(width, 0.3), settings, 4 * settings.path_window,
                   floor=settings.width_floor)


def judge(chain, detections, n, settings, *, find_release=True, residual=None,
          weight=None, bar=None, foot=None, joined=None, held=None, cut=None, rod=False):
    """Flags, reasons and the release of a chosen chain.

    Parameters
    ----------
    chain : vidtrack.track.choose.Chain
    detections : list of numpy.ndarray
    n : int
        Frames.
    settings : vidtrack.track.settings.TrackerSettings
    find_release : bool
    residual, weight : numpy.ndarray, optional
        Per frame, the measurement's residual share and weight
        (:func:`vidtrack.track.measure.measure_frame`).
    bar : numpy.ndarray, optional
        ``(n, 4)``: per frame, the rod's bar (half length, half width, coverage,
        misfit), NaN where it was not measured by one.
    foot : numpy.ndarray, optional
        Per frame, the rod's bar's misfit over its footprint alone, NaN where it was not
        measured by one: touched beyond ``k_flag`` scatters (at least
        ``footprint_floor``) above the centre of the chain's clean side
        (:func:`vidtrack.track.path.clean_side`).
    joined : numpy.ndarray of int, optional
        Frame positions where a rod was followed by its model into what it is joined to
        (:mod:`vidtrack.track.joined`): touched where their detection's size exceeds the
        flight's (``k_flag`` robust scatters of its log, at least ``size_floor``).
    held : numpy.ndarray of int, optional
        Frame positions where the object lies over pixels no background sample shows
        without it (APPEARANCE, ``held``).
    cut : numpy.ndarray of int, optional
        Frame positions of a rod part hidden at an end (its bar shorter than its
        flight's with one end where it was, :func:`vidtrack.track.joined.hold_profile`):
        APPEARANCE, ``hidden``.
    rod : bool
        The object is a rod: its frames without a bar (the fit failed or ran off) are
        suspect (``unfit``), kept where the clean frames round them predict them. (A
        compact object's ellipse is fitted only where it explains the object: its other
        frames are measured by its kernel by design.)

    Returns
    -------
    flags : numpy.ndarray of int
        Per frame position (LOST where the chain has no detection).
    release : int or None
        Frame position of the release, None when not looked for or not seen.
    scatter_px : float
        Robust scatter of the clean frames about their local path.
    notes : list of str
    reasons : dict of str to numpy.ndarray of bool
        Per code of :data:`REASONS` (but ``blade``), the frames it applies to.
    """
    flags = np.full(n, LOST, np.int64)
    idx = chain.frames
    notes = []
    reasons = {code: np.zeros(n, bool) for code in REASONS if code != "blade"}
    if idx.size == 0:
        reasons["lost"][:] = True
        return flags, None, float("nan"), notes, reasons
    flags[idx] = 0
    for i in idx:
        if detections[i][chain.pick[i]]["border"]:
            flags[i] |= BORDER
    uv = np.column_stack([chain.u[idx], chain.v[idx]])
    release = None
    # something touching the object (its detection grown, weight left outside its
    # kernel), part of it hidden (its measured weight short of its neighbours'), over
    # the whole chain; a rod's frames measured by its bar are judged by the bar instead
    # (its length, width, coverage and misfit over its footprint: what lies beside it,
    # even joined to its detection, does not count), the frames without one (end on,
    # the fit run off) keep the detection's verdict
    touched, hidden = _appearance((chain.size[idx],),
                                  None if residual is None else residual[idx],
                                  None if weight is None else weight[idx], settings)
    barred = (np.isfinite(bar[idx]).all(axis=1) if bar is not None
              else np.zeros(idx.size, bool))
    narrow = np.zeros(idx.size, bool)
    # (a rod's frame without its bar, the fit failed or run off, is measured by its
    # kernel alone, which what lies beside it moves: suspect, kept where the clean frames
    # round it predict it)
    unfit = ~barred if rod and barred.any() else np.zeros(idx.size, bool)
    if barred.any():
        h, w, a, misfit = bar[idx[barred]].T
        touched[barred], hidden[barred] = _appearance((2.0 * h,), misfit, 4.0 * a * h * w,
                                                      settings, frames=idx[barred])
        if weight is not None:
            # (the kernel's weight too: the bar fitted to a rod part hidden reads the
            # hidden part as a fainter whole, its covered area less short than its
            # pixels' weight)
            hidden[barred] |= _short_of_weight(weight[idx[barred]], settings,
                                               frames=idx[barred])
        # (a rod narrower than its neighbours is part hidden along its side: its width
        # is measured to a few thousandths, so the frame is not kept on its path's word,
        # as one only short of weight or size is)
        z = _width_z(2.0 * w, settings)
        touched[barred] |= z > settings.k_flag
        narrow[barred] = z < -settings.k_flag
        hidden |= narrow
    if foot is not None:
        # (the bar misfits its own pixels: part of the rod hidden, or something on it)
        # (judged against its clean side: what touches a rod only raises it, and a straw
        # over the rotor or crossing another raises half a chain's)
        centre, scale = clean_side(foot[idx], floor=settings.footprint_floor)
        with np.errstate(invalid="ignore"):
            touched |= foot[idx] > centre + settings.k_flag * scale
    if joined is not None and len(joined):
        # (a frame followed by the rod's model: its length and width are the flight's,
        # held; its detection, grown beyond the flight's, is what it is joined to)
        flight = np.flatnonzero(chain.explained)
        touched[np.searchsorted(idx, joined)] |= (size_z(chain, joined, flight, settings)
                                                  > settings.k_flag)
    # (a rod cut at an end is not kept on its path's word: its centre is its piece's)
    ends = np.zeros(idx.size, bool)
    if cut is not None and len(cut):
        ends[np.searchsorted(idx, cut)] = True
    hidden |= ends
    grown = touched | hidden | unfit
    flags[idx[grown]] |= APPEARANCE
    # (two moving things seen as one detection where they cross: the place of neither)
    crossed = chain.merged[idx]
    flags[idx[crossed]] |= MERGED
    reasons["merged"][idx[crossed]] = True
    # (a detection off the chain's robust path, nothing on it: another thing's)
    strayed = chain.off_path[idx]
    off, scatter = _path_outliers(idx, uv, settings, ~grown & ~crossed & ~strayed)
    off |= strayed
    flags[idx[off]] |= OUTLIER
    # (a frame only short of weight or size is suspect, not wrong: where the clean
    # frames round it predict it, it is kept)
    unhid = _on_clean_path(idx, uv, (hidden & ~narrow & ~ends | unfit) & ~touched & ~crossed
                           & ~off, ~grown & ~crossed & ~off, scatter, settings)
    flags[idx[unhid]] &= ~APPEARANCE
    hidden &= ~unhid
    unfit &= ~unhid
    # (the chain's ends off its path, in view: what the chain took where the object was
    # not seen, a hand before the throw, a racket after a hit, is not the object)
    astray = _end_runs(off & ((flags[idx] & BORDER) == 0))
    reasons["touched"][idx[touched]] = True
    reasons["hidden"][idx[hidden]] = True
    reasons["unfit"][idx[unfit]] = True
    reasons["off-path"][idx[off]] = True
    if held is not None and len(held):
        flags[held] |= APPEARANCE
        reasons["held"][held] = True
    if find_release:
        # (the knot is fitted to the frames on the path, those touched by something
        # included: the ride on a blade or in a hand is such a touch)
        touched |= (flags[idx] & BORDER).astype(bool)
        pos, _tau, note = release_knot(
            idx.astype(float), uv, ~off, first_in_open=not touched[0],
            window=settings.release_window, significance=settings.release_significance,
            min_ratio=settings.release_ratio,
            pushed_cos=float(np.cos(np.radians(settings.release_push_deg))))
        rest = _at_rest(idx, uv, scatter, settings)
        if rest and (pos is None or pos < rest):
            pos = rest
            note = (f"the object lay still over the first {rest} frames of its chain, "
                    f"before it moved (not in flight)")
        if pos is not None and pos > 0:
            release = int(idx[pos])
            flags[idx[idx < release]] |= PRE_RELEASE
            reasons["pre-release"][idx[idx < release]] = True
        notes.append(f"release: {note}")
    if chain.shadow[idx].mean() <= MAJORITY:
        # (a frame shows itself a shadow's where the wall's texture is seen kept under
        # it: over a plain wall, a dark object dims it alike)
        seen = idx[chain.shadow_seen[idx]]
        flags[seen] |= APPEARANCE
        reasons["shadow"][seen] = True
    if astray.any() and not astray.all():
        flags[idx[astray]] = LOST
        for hit in reasons.values():
            hit[idx[astray]] = False
        notes.append(f"{int(astray.sum())} frames at the ends of the object's chain, off its "
                     f"path, left out (not the object)")
    first, last = idx[0], idx[-1]
    flags[:first] = LOST
    flags[last + 1:] = LOST
    reasons["lost"] = (flags & LOST).astype(bool)
    reasons["border"] = (flags & BORDER).astype(bool)
    return flags, release, scatter, notes, reasons


def bridge_gaps(u, v, flags, reasons, chain, settings):
    """Frames inside the chain without a detection (LOST): their position predicted by a
    quadratic in time through up to ``path_window`` clean frames either side (at least
    2 each side), flagged PREDICTED instead. ``u``, ``v``, ``flags`` and ``reasons``
    are changed in place; returns how many frames were bridged."""
    idx = chain.frames
    clean = idx[flags[idx] == 0]
    done = 0
    for g in range(int(idx[0]) + 1, int(idx[-1])):
        if chain.pick[g] >= 0 or not flags[g] & LOST:
            continue
        before = clean[clean < g][-settings.path_window:]
        after = clean[clean > g][:settings.path_window]
        if before.size < 2 or after.size < 2:
            continue
        t = np.concatenate([before, after]).astype(float) - g
        cu = np.polyfit(t, u[np.concatenate([before, after])], 2)
        cv = np.polyfit(t, v[np.concatenate([before, after])], 2)
        u[g], v[g] = cu[-1], cv[-1]
        flags[g] = PREDICTED
        reasons["lost"][g] = False
        reasons.setdefault("predicted", np.zeros(flags.size, bool))[g] = True
        done += 1
    return done


def reason_codes(reasons, n):
    """Each frame's reason: the codes of :data:`REASONS` that apply, in that order,
    joined by ``+`` (empty for a clean frame)."""
    out = np.full(n, "", dtype=object)
    for code in REASONS:
        hit = reasons.get(code)
        if hit is None:
            continue
        for i in np.flatnonzero(hit):
            out[i] = f"{out[i]}+{code}" if out[i] else code
    return out
