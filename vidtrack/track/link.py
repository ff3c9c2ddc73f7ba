"""Step 2 of the flight tracker: detections linked into tracklets, every moving thing its own.

A constant-velocity predictor per tracklet (its last two points), a gate round the
prediction of ``max(gate_px, gate_sizes * size)`` pixels (a size is the square root of
the detection's pixel count; a tracklet of one detection, whose speed is not known,
looks as far as ``max_step`` of the frame's diagonal per frame), and one global assignment per frame
(:func:`scipy.optimize.linear_sum_assignment`, the Hungarian method) of the open
tracklets to the frame's detections by distance. A detection no tracklet takes starts a
new one; a tracklet without a detection for more than ``max_gap`` frames is closed.
"""

import numpy as np
from scipy.optimize import linear_sum_assignment

__all__ = ["link", "Tracklet"]

_FAR = 1e12


class Tracklet:
    """One moving thing's detections: ``frames`` (frame positions) and ``index`` (the
    detection's index in its frame), in time order."""

    __slots__ = ("frames", "index", "u", "v", "size")

    def __init__(self, frame, index, u, v, size):
        self.frames, self.index = [frame], [index]
        self.u, self.v, self.size = [u], [v], [size]

    def add(self, frame, index, u, v, size):
        self.frames.append(frame)
        self.index.append(index)
        self.u.append(u)
        self.v.append(v)
        self.size.append(size)

    def predict(self, frame):
        """Where the tracklet should be in ``frame`` (constant velocity)."""
        if len(self.frames) < 2:
            return self.u[-1], self.v[-1]
        dt = self.frames[-1] - self.frames[-2]
        k = (frame - self.frames[-1]) / dt
        return (self.u[-1] + k * (self.u[-1] - self.u[-2]),
                self.v[-1] + k * (self.v[-1] - self.v[-2]))

    def travel(self):
        """Largest distance (px) between its first point and any other."""
        u, v = np.asarray(self.u), np.asarray(self.v)
        return float(np.max(np.hypot(u - u[0], v - v[0])))

    def __len__(self):
        return len(self.frames)


def link(detections, settings, *, frame_shape=None):
    """Link per-frame detections into tracklets.

    Parameters
    ----------
    detections : sequence of numpy.ndarray
        One :data:`vidtrack.track.detect.DETECTION_DTYPE` array per frame position.
    settings : vidtrack.track.settings.TrackerSettings
        ``gate_px``, ``gate_sizes``, ``max_gap``, ``max_step``.
    frame_shape : (int, int), optional
        ``(rows, cols)``: a tracklet of one detection, whose speed is not known yet, takes
        its next one within ``max_step`` of the frame's diagonal per frame.

    Returns
    -------
    list of Tracklet
        Every tracklet, closed or not, in order of their first frame.
    """
    done, open_ = [], []
    first_gate = (settings.max_step * float(np.hypot(*frame_shape))
                  if frame_shape is not None else settings.gate_px)
    for fi, dets in enumerate(detections):
        still = []
        for tr in open_:
            (still if fi - tr.frames[-1] <= settings.max_gap + 1 else done).append(tr)
        open_ = still
        if len(dets) == 0:
            continue
        size = np.sqrt(np.maximum(dets["area"], 1).astype(float))
        taken = np.zeros(len(dets), bool)
        if open_:
            pred = np.array([tr.predict(fi) for tr in open_])
            gate = np.maximum(settings.gate_px, settings.gate_sizes
                              * np.array([tr.size[-1] for tr in open_]))
            new = np.array([len(tr) == 1 for tr in open_])
            gate = np.where(new, np.maximum(gate, first_gate
                                            * np.array([fi - tr.frames[-1] for tr in open_])),
                            gate)
            dist = np.hypot(pred[:, :1] - dets["u"][None, :], pred[:, 1:] - dets["v"][None, :])
            cost = np.where(dist <= gate[:, None], dist, _FAR)
            rows, cols = linear_sum_assignment(cost)
            for r, c in zip(rows, cols):
                if cost[r, c] < _FAR:
                    open_[r].add(fi, int(c), float(dets["u"][c]), float(dets["v"][c]),
                                 float(size[c]))
                    taken[c] = True
        for c in np.flatnonzero(~taken):
            open_.append(Tracklet(fi, int(c), float(dets["u"][c]), float(dets["v"][c]),
                                  float(size[c])))
    done.extend(open_)
    done.sort(key=lambda tr: tr.frames[0])
    return done
