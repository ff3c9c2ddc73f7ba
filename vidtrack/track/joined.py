"""Step 4b of the flight tracker: a rod followed, by its own model, into what it is joined to.

A straw riding a blade before its release is one detection with the blade, or its
piece clear of the blade is: the chain's growth (:mod:`vidtrack.track.choose`) takes a
detection of the object's own size near its predicted point, so the chain starts only
where the straw has left the blade, or takes the piece, and the release is looked for
where there is no ride left to see. Before the flight's first clean frame (the first
frame the flight explains whose bar's misfit and whose detection's size lie within
``k_flag`` robust scatters of the flight's: the rod whole and alone), frame by frame
back in time, the rod is followed by its model instead: its point predicted by a
quadratic in time through the ``predict_frames`` points followed after it
(:func:`vidtrack.track.path.extrapolate`), its angle carried from the frame after it;
there the bar of the flight's own length, width and blurs (the median of its first
``predict_frames`` clean frames) is fitted to the frame's pixels, its centre, angle and
coverage free
(:func:`vidtrack.track.measure.rod_at`). What the rod is joined to, of another tone or
beside it, is not explained by a bar of the rod's length, and weighs little in the
robust fit.

A frame is the rod's when the fit converges within :data:`~vidtrack.track.rod.MAX_SHIFT`
half lengths of the prediction and covers at least ``joined_cover`` of the flight's
coverage (a rod hidden behind what it is joined to is not seen, whatever fits); the
first frame where it is not ends the following, and at most ``release_window`` frames
are followed. A frame followed takes the detection its point lies in; it is judged like
the chain's other frames (:mod:`vidtrack.track.flag`: its bar's misfit says what
overlaps it) and its path is where the release is looked for.
"""

import numpy as np

from vidtrack.track.measure import OWN_SPREADS, rod_at, spreads_sq
from vidtrack.track.path import extrapolate, robust_scale, robust_trend

__all__ = ["follow_back", "hold_profile", "size_z"]


def _inside(dets, u, v):
    """The detection whose ellipse of second moments holds ``(u, v)`` (within
    :data:`vidtrack.track.measure.OWN_SPREADS`) nearest its centre, in its own spreads,
    or -1."""
    if len(dets) == 0:
        return -1
    m2 = spreads_sq(u - dets["u"], v - dets["v"], np.maximum(dets["muu"], 0.25),
                    np.maximum(dets["mvv"], 0.25), dets["muv"])
    j = int(np.argmin(m2))
    return j if m2[j] <= OWN_SPREADS ** 2 else -1


def _clean(chain, bars, flight, settings):
    """Which of the flight's frames show the rod whole and alone: measured by a bar,
    whose misfit, and whose detection's log size, lie within ``k_flag`` robust scatters
    of the flight's (at least ``residual_floor`` and ``size_floor``)."""
    barred = np.isfinite(bars[flight, :4]).all(axis=1) & np.isfinite(bars[flight, 5:7]).all(axis=1)
    if not barred.any():
        return barred
    misfit = bars[flight, 3]
    scale = robust_scale(misfit[barred], floor=settings.residual_floor)
    ok = barred & (np.abs(misfit - np.median(misfit[barred])) <= settings.k_flag * scale)
    return ok & (np.abs(size_z(chain, flight, flight[barred], settings)) <= settings.k_flag)


def size_z(chain, frames, ref, settings):
    """The log size of each of ``frames``' detections less the median of the ``ref``
    frames', in robust scatters of theirs (at least ``size_floor``)."""
    logs = np.log(np.maximum(chain.size[ref], 1.0))
    scale = robust_scale(logs, floor=settings.size_floor)
    return (np.log(np.maximum(chain.size[frames], 1.0)) - np.median(logs)) / scale


def follow_back(get, detections, chain, bars, detector, shape, settings):
    """Follow a rod's chain back in time from its flight's first clean frame, by its model.

    Parameters
    ----------
    get : callable
        Frame position to its grey frame (steadied), or None where it is not at hand.
    detections : list of numpy.ndarray
    chain : vidtrack.track.choose.Chain
        Its ``pick``, ``u``, ``v`` and per-frame fields are changed in place for the
        frames followed.
    bars : numpy.ndarray
        ``(n, 7)``: per frame the bar measured
        (:data:`~vidtrack.track.measure.BAR_COLUMNS`); set for the frames followed.
    detector : vidtrack.track.detect.Detector
    shape : vidtrack.track.measure.Shape
    settings : vidtrack.track.settings.TrackerSettings

    Returns
    -------
    numpy.ndarray of int
        The frame positions followed.
    """
    flight = np.flatnonzero(chain.explained)
    k = settings.predict_frames
    none = np.zeros(0, int)
    clean = flight[_clean(chain, bars, flight, settings)]
    if clean.size < 3:
        return none
    first = int(clean[0])
    lead = clean[:k]
    h, w, a, _misfit, _angle, s, s2 = np.median(bars[lead, :7], axis=0)
    template = np.array([np.nan, np.nan, np.nan, h, w, a, s, s2])
    ref = detections[first][chain.pick[first]]
    t = [int(i) for i in lead][::-1]                # (the nearest last)
    pu = [float(chain.u[i]) for i in t]
    pv = [float(chain.v[i]) for i in t]
    theta = float(bars[first, 4]) if np.isfinite(bars[first, 4]) else 0.0
    followed = []
    for fi in range(first - 1, max(first - settings.release_window, 0) - 1, -1):
        frame = get(fi)
        if frame is None or len(detections[fi]) == 0:
            break
        u0, v0 = extrapolate([-x for x in t[-k:]], pu[-k:], pv[-k:], -fi)
        fit = rod_at(frame, detector.bg, detector.sigma, ref, (u0, v0, theta), template,
                     shape, settings, shadow_test=detector.shadow_test)
        if fit is None or fit[2][5] < settings.joined_cover * a:
            break
        u, v, p, misfit, own = fit
        j = _inside(detections[fi], u, v)
        if j < 0:
            break
        theta = float(p[2])
        followed.append((fi, j, u, v, (p[3], p[4], p[5], misfit, p[2], p[6], p[7], own)))
        t.append(fi)
        pu.append(u)
        pv.append(v)
    for fi, j, u, v, bar in followed:
        chain.take(fi, j, detections, at=(u, v))
        bars[fi] = bar
    return np.array([f[0] for f in followed], int)


#: A bar measured again with the rod's own (shorter) half length is taken where its
#: centre moved along it by at least this share of the half lengths' difference: 1
#: where one end stayed and the other came in (something in line with that end), 0
#: where both came in alike (the rod itself longer); halfway decides.
ONE_END = 0.5


def _along(bars):
    """A bar's log spread along the rod: its length's and its blur's along it
    (``sqrt(h^2 / 3 + s2^2)``, px)."""
    return np.log(np.sqrt(bars[:, 0] ** 2 / 3.0 + bars[:, 6] ** 2))


def hold_profile(chain, bars, settings, measure, keep, *, after=0):
    """A rod measured by its own length and blurs where its bar reaches farther along.

    Something in line with an end of a rod (a blade it has just left, of its tone) is
    taken by the bar, free, for more of the rod: the bar grows and blurs along at that
    end, and its centre moves towards it. A rod's spread along (its bar's half length
    ``h`` and blur along ``s2``, :func:`_along`) changes smoothly over its flight (it
    turns, its speed along it changes), so each frame's is compared with
    :func:`~vidtrack.track.path.robust_trend` through its flight's neighbours within
    ``8 * path_window`` frames either side. A frame beyond ``k_flag`` robust scatters of
    those differences (at least ``profile_floor``) above it is measured again with the
    bar's half length, half width and blurs held at the trend's, its centre, angle and
    coverage free. The new point is kept where one end stayed (:data:`ONE_END`): what
    touches an end moved the free bar's centre towards it, while a rod that is itself
    longer than the trend (turning fast) shortens at both ends alike. Its bar's misfit
    then says what touches it (:mod:`vidtrack.track.flag`).

    Parameters
    ----------
    chain : vidtrack.track.choose.Chain
    bars : numpy.ndarray
        Per frame the bar measured (:data:`~vidtrack.track.measure.BAR_COLUMNS`).
    settings : vidtrack.track.settings.TrackerSettings
    measure, keep : callable
        ``measure(i, held)``: frame position ``i`` measured again with the bar ``held``
        (a :class:`~vidtrack.track.measure.Measured`); ``keep(i, measured)`` sets the
        chain's point and ``bars`` (and the rest measured) to it.
    after : int, keyword-only
        The flight's frames from this position on (its release: before it, the rod
        rides what throws it, and its bar is not its own).

    Returns
    -------
    numpy.ndarray of int
        The frame positions measured again.
    numpy.ndarray of int
        The frame positions whose bar is as many scatters shorter than the trend and
        whose centre lies off the flight's (each coordinate's robust trend through the
        same frames) along the bar by at least :data:`ONE_END` of the half length lost:
        one end stayed, the other is hidden (a straw coming out from behind a post, the
        piece seen growing from the post's edge). They are flagged, not measured again
        (the pixels behind the post say "no rod" to a bar held at its length).
    """
    flight = np.flatnonzero(chain.explained)
    flight = flight[flight >= after]
    barred = flight[np.isfinite(bars[flight, :7]).all(axis=1)]
    if barred.size <= 2 * settings.path_window:
        return np.zeros(0, int), np.zeros(0, int)
    b = bars[barred]
    along = _along(b)
    trend = robust_trend(barred, np.column_stack([along, np.log(b[:, 0]), b[:, 1], b[:, 5],
                                                  b[:, 6]]), 8 * settings.path_window)
    dev = along - trend[:, 0]
    z = dev / robust_scale(dev, floor=settings.profile_floor)
    done, cut = [], []
    short = np.flatnonzero(z < -settings.k_flag)
    if short.size:
        # (where the flight puts its centre: each coordinate's robust trend)
        window = 8 * settings.path_window
        pu = robust_trend(barred, chain.u[barred], window)
        pv = robust_trend(barred, chain.v[barred], window)
        for j in short:
            i = int(barred[j])
            lost = np.exp(trend[j, 1]) - b[j, 0]
            shift = ((chain.u[i] - pu[j]) * np.cos(b[j, 4])
                     + (chain.v[i] - pv[j]) * np.sin(b[j, 4]))
            if np.isfinite(shift) and abs(shift) >= ONE_END * lost:
                cut.append(i)
    for j in np.flatnonzero(z > settings.k_flag):
        i = int(barred[j])
        if not np.isfinite(trend[j]).all():
            continue
        got = measure(i, np.array([np.nan, np.nan, np.nan, np.exp(trend[j, 1]),
                                   trend[j, 2], b[j, 2], trend[j, 3], trend[j, 4]]))
        if got.bar is None:
            continue
        shift = ((got.u - chain.u[i]) * np.cos(b[j, 4])
                 + (got.v - chain.v[i]) * np.sin(b[j, 4]))
        if abs(shift) < ONE_END * (b[j, 0] - got.bar[0]):
            continue
        keep(i, got)
        done.append(i)
    return np.array(done, int), np.array(cut, int)
