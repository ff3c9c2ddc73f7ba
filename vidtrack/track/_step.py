"""One frame of following the object: found near its prediction, measured by its kind
(a rod by its coverage, an object of both polarities by its body, any other by its
silhouette or its fully covered core), and judged: a frame unlike the object's clean
frames (grown, shrunk at a stroke, a rod's shape broken by something across it, another
object touching it) is flagged, not learnt from (:func:`follow`).

Internal to :mod:`vidtrack.track._pass`.
"""

import math

import numpy as np

from vidtrack.track._flags import APPEARANCE, BORDER, MERGED
from vidtrack.track._rods import (FILL_MIN, FILL_SEPARATE, FILL_WIDTH_MIN, NARROW, OFF_AXIS_MAX,
                                  SEPARATE_FRAMES, WIDTH_GROWN,
                                  area_shrunk, attached_across, end_hidden, hidden_side, rod_alone,
                                  rod_fill, rod_shortened)
from vidtrack.track._coverage import measure, shade_background
from vidtrack.track._mixed import measure_mixed
from vidtrack.track._segment import edge_stats, read_level, work_margin
from vidtrack.track._silhouette import (hidden_bound, measure_silhouette, measure_solid,
                                        trim_attached)
from vidtrack.track._thin import FAINTER
from vidtrack.track._touch import (beside_thin, opposite_touching, other_behind, other_touching,
                                   shadow_beside)


#: A frame whose object could be this far (px) from where its detected pixels put it,
#: were the blind pixels touching it of it, is flagged (APPEARANCE).
HIDDEN_PX = 0.3


def follow(ps, i, frame, f):
    """Follow the object (its follower ``f``) into frame ``i`` of the pass ``ps``
    (:class:`~vidtrack.track._pass.Pass`): its row is stored, flagged or not, and a clean
    frame is learnt from. False when it is not found near its prediction."""
    st = f.pred.state(ps.tau[i])
    if st is None:
        return False
    step = _Step(ps, i, frame, f, st)
    if not step.find():
        return False
    step.gather()
    if not step.measure_blob():
        return False
    step.judge()
    return True


def one_end_hidden(b, p, ref_len, err, jitter):
    """The rod ``b`` lost part of its length at one end (behind something in front of
    it: a post, a machine part, the frame's edge), going by its prediction ``p`` (px),
    its clean frames' length ``ref_len`` and its change from one to the next ``jitter``,
    and the prediction's RMS error ``err`` (px) (:func:`~vidtrack.track._rods.end_hidden`)."""
    along = (b.u - p[0]) * math.cos(b.angle) + (b.v - p[1]) * math.sin(b.angle)
    return bool(end_hidden(along, ref_len - b.length, err, jitter))


def side_hidden(b, p, ref_cov, err, jitter, reach=None):
    """An object ``b`` lost part of its area at one side (behind something in front of
    it), going by its prediction ``p`` (px), its clean frames' coverage ``ref_cov``
    (px^2) and its relative change from one to the next ``jitter``, and the prediction's
    RMS error ``err`` (px); ``reach``: the farthest (px) its part lies from its centre,
    half a rod's length (:func:`~vidtrack.track._rods.hidden_side`)."""
    return bool(hidden_side(math.hypot(b.u - p[0], b.v - p[1]), 1.0 - b.area / ref_cov,
                            ref_cov, err, jitter, reach))


def part_hidden(b, p, f, err, rod):
    """Part of the object ``b`` hidden behind something before it, going by its
    prediction ``p`` (px) with RMS error ``err`` (px) and the clean frames of the
    follower ``f`` (3 at least): a rod (``rod``) shortened at one end
    (:func:`one_end_hidden`), or any object that lost coverage at a side or a corner
    (:func:`side_hidden`; a rod's part up to half its length from its centre)."""
    ref_len = f.ref(f.lengths, None)
    ref_cov = f.ref(f.covs, None)
    if rod and ref_len is not None and len(f.lengths) >= 3 and \
            one_end_hidden(b, p, ref_len, err, f.length_jitter):
        return True
    if ref_cov is None or len(f.covs) < 3 or (rod and ref_len is None):
        return False
    return side_hidden(b, p, ref_cov, err, f.cov_jitter, 0.5 * ref_len if rod else None)


def _only_fainter(reg, others, p, reach, own_peak):
    """Something moves within ``reach`` (px) of ``p``, and all of it is fainter than the
    straw (:data:`~vidtrack.track._thin.FAINTER` of its largest change ``own_peak``): a
    rider beside a thin straw, not a second straw."""
    near = [o for o in others if math.hypot(o.u - p[0], o.v - p[1]) <= reach + 0.5 * (
        math.hypot(o.bbox[2] - o.bbox[0], o.bbox[3] - o.bbox[1]))]
    return bool(near) and all(reg.peak([o.label]) <= FAINTER * own_peak for o in near)


class _Step:
    """The follower's work on one frame; its fields are the frame's findings."""

    def __init__(self, ps, i, frame, f, st):
        self.ps, self.i, self.frame, self.f = ps, i, frame, f
        p, vel, acc = st
        self.p, self.vel = p, vel
        speed = float(np.hypot(*vel))
        self.ref_len = ref_len = f.ref(f.lengths, 10.0)
        self.ref_w = ref_w = f.ref(f.widths, 3.0)
        self.err = err = f.pred_error
        extra = 0.5 * f.gap * (speed + 1.0)
        # wide enough to see another straw coming before it touches this one
        self.hs = int(math.ceil(1.0 * ref_len + 2.0 * ref_w + 6.0 + 0.5 * speed + 3.0 * err
                                + extra))
        self.gate = max(5.0, 0.5 * ref_len, 4.0 * err + 3.0) + extra
        self.level = f.level
        self.gain = ps.seg.gain(frame)

    def find(self):
        """The blob nearest the prediction within the gate (``reg``, ``blobs``, ``b``,
        and the ``roi`` segmented); False when there is none."""
        ps, i, frame, f, p = self.ps, self.i, self.frame, self.f, self.p
        seg, min_area, shape, gain, gate = ps.seg, ps.min_area, ps.shape, self.gain, self.gate
        rows, cols = shape
        hs = self.hs
        level = self.level
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
                if f.intruders.items and f.intruders.closer_to_intruder(ps.tau[i], b, p):
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
        self.roi, self.reg, self.blobs, self.b = roi, reg, blobs, chosen
        return True

    def gather(self):
        """The blob's ``group`` of components (the object's pieces) and their
        ``mask_area``."""
        f, reg, b, p = self.f, self.reg, self.b, self.p
        ref_len, ref_w, err = self.ref_len, self.ref_w, self.err
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
        self.group, self.mask_area = group, mask_area

    def measure_blob(self):
        """The blob measured by the object's kind (``fl``: the flags it earned); False
        when nothing of it is left."""
        ps, i, f = self.ps, self.i, self.f
        min_area, shape = ps.min_area, ps.shape
        rows, cols = shape
        reg, blobs, b, group, mask_area = self.reg, self.blobs, self.b, self.group, self.mask_area
        level, ref_len, ref_w, vel = self.level, self.ref_len, self.ref_w, self.vel
        fl = 0
        known = len(f.lengths) >= 3
        if f.mixed:
            # an object of both polarities: its silhouette (the other polarity is its
            # own, not something behind it)
            work = reg.work(group, np.nan, margin=work_margin(None, None, b.bbox))
            measure_mixed(work, b, rod=f.rod, shadow=ps.shadow)
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
                whole = self.own_other_half(b) if known else None
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
                    measure_solid(work, b, smear=float(np.hypot(*vel)))
                else:
                    measure_silhouette(work, b, shadow=ps.shadow)
            else:
                measure_silhouette(work, b, shadow=ps.shadow)
        if not b.area > 0:
            return False
        if f.compact and not f.rod and hidden_bound(
                work, b, known=f.level if f.trims() else None,
                area=f.ref(f.covs, None)) > HIDDEN_PX:
            # an object of one grey level, part of it over background of its own
            # brightness, may be cut off there unseen (one known to be of one grey level
            # keeps it where too little of its interior shows to say)
            fl |= APPEARANCE
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
        self.reg, self.blobs, self.b, self.group, self.mask_area = reg, blobs, b, group, mask_area
        self.fl = fl
        return True

    def judge(self):
        """Whether the frame is the object's alone: stored with its flags, and learnt
        from when clean."""
        ps, i, f, p = self.ps, self.i, self.f, self.p
        tau, min_area, store = ps.tau, ps.min_area, ps.store
        reg, blobs, b, group = self.reg, self.blobs, self.b, self.group
        ref_len, ref_w, fl = self.ref_len, self.ref_w, self.fl
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
        if rod_shape and len(f.widths) >= 3 and ref_w >= FILL_WIDTH_MIN and \
                b.width > WIDTH_GROWN * ref_w:
            # a rod wider than its clean frames: something beside it is measured with it
            # (seen end on, its core is too short for a band to leave it out, and its
            # fill cannot tell)
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
        # smaller than its clean frames: part of it hidden, by something before it
        ref_cov = f.ref(f.covs, None)
        shrunk = ((rod_shape and len(f.lengths) >= 3
                   and bool(rod_shortened(ref_len - b.length, f.length_jitter)))
                  or (ref_cov is not None and len(f.covs) >= 3
                      and bool(area_shrunk(1.0 - b.area / ref_cov, f.cov_jitter))))
        # (what rides along adds to it: one smaller, something of the other polarity
        # touching it, is partly hidden by that, and is not followed so)
        slight = rod_shape and not same_shape and not same and not (shrunk and fl & MERGED)
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
        odd = (not same and ref_cov is not None and len(f.covs) >= 3
               and b.area < 0.65 * ref_cov and f.last_cov is not None
               and b.area < 0.8 * f.last_cov)
        # a rod narrower than it is: its coverage per unit length is kept as it turns
        # (pieces of it either side of a post measure long and thin)
        odd = odd or (not same and rod_shape and ref_cov is not None and len(f.covs) >= 3
                      and len(f.lengths) >= 3 and b.area < NARROW * b.length * ref_cov / ref_len)
        # a rod shortened at one end: part of it hidden behind something before it (its
        # centroid lags or leads its centre), not turning; a rod or any object that lost
        # part of its coverage at a side or a corner (a rod's length kept). Judged only
        # in a run of frames found one after the other since a clean one (not over a
        # gap), the prediction's error grown with the frames since that one
        err = self.err * max(1, abs(i - f.clean_at))
        cut = not same and abs(i - f.judged_at) == 1 and part_hidden(b, p, f, err, rod_shape)
        # found again partly hidden and still growing at a stroke: still coming out
        # (the prediction over the frames it was lost cannot say by how much)
        coming = not same and f.coming_out(i, b, rod_shape)
        odd = odd or cut or coming
        f.last_cov = b.area
        fl = store(i, b, fl | (MERGED if same else 0) | (APPEARANCE if odd else 0))
        if fl == 0 or abs(i - f.judged_at) == 1:
            f.judged_at = i
        ps.solid[i] = f.compact
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
            f.clean_at = i
            f.errors.append(float(np.hypot(b.u - p[0], b.v - p[1])))
            f.pred.add(tau[i], b.u, b.v)
            f.add(b)
            if not f.mixed and (i % 4 == 0 or len(f.levels) < 3):
                lv = read_level(reg, b)   # the level drifts slowly: every 4th frame
                if np.isfinite(lv):
                    f.levels.append(lv)

    def own_other_half(self, b):
        """(region, blob) of the whole when what touches the object (``b``) in the other
        polarity is its own other half, else None.

        Its own when the whole (both polarities) is about the object's size (mask area
        0.6 to 2.5 times its clean frames': a texture's dark half may be a third of the
        whole), the other polarity's part is no larger than the object's clean size,
        and its edges are as sharp (a shadow's are blurred). A straw riding a blade, or
        crossing one, is dwarfed by the union.
        """
        ps, frame, roi, gain, f = self.ps, self.frame, self.roi, self.gain, self.f
        seg, min_area, shape = ps.seg, ps.min_area, ps.shape
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
                or not 0.6 * ref_a <= whole.mask_area <= 2.5 * ref_a):
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
