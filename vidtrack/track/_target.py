"""The object a view's ``target`` names: its frame in the footage, the moving blob at
its pixel, and the one-line message that lists the candidates when the automatic choice
is ambiguous (with the ``target`` line that settles it).

Internal to the tracker (:mod:`vidtrack.track._pass`).
"""

import numpy as np

from vidtrack.errors import TrackError


def target_index(target, fnums, name):
    """Source index of the ``target``'s frame; TrackError when it is not in the footage."""
    try:
        frame, (tu, tv) = target
        frame = int(frame) if float(frame) == int(frame) else None
        tu, tv = float(tu), float(tv)
    except (TypeError, ValueError):
        raise TrackError(f"target must be (frame, (u_px, v_px)), got {target!r}") from None
    if frame is None or not (np.isfinite(tu) and np.isfinite(tv)):
        raise TrackError(f"target must be (frame, (u_px, v_px)) with an integer frame and a "
                         f"finite pixel, got {target!r}")
    i = frame - int(fnums[0])
    if not 0 <= i < len(fnums):
        raise TrackError(f"{name}: the target's frame {frame} is not in the footage (frames "
                         f"{int(fnums[0])}..{int(fnums[-1])})")
    return i


def target_blob(blobs, target, name, frame):
    """The moving blob at the target's pixel: the one whose box holds it (the whole of
    an object of both polarities before one of its parts, the largest part before a
    highlight inside it), else the nearest within its own size."""
    tu, tv = (float(x) for x in target[1])

    def contains(b):
        x0, y0, x1, y1 = b.bbox
        return x0 - 1 <= tu <= x1 and y0 - 1 <= tv <= y1

    inside = [b for b in blobs if contains(b)]
    if inside:
        # the whole object (both polarities) before a part, the largest part before a
        # highlight or an opening inside it; but a whole that is one part and a speck
        # of the other polarity (compression noise at its edge) is that part
        best = min(inside, key=lambda b: (b.polarity != 0, -b.mask_area))
        parts = [b for b in inside if b.polarity != 0]
        if best.polarity == 0 and parts:
            part = max(parts, key=lambda b: b.mask_area)
            if part.mask_area >= 0.8 * best.mask_area:
                return part
        return best
    near = [(float(np.hypot(b.u - tu, b.v - tv)), b) for b in blobs]
    near = [(d, b) for d, b in near if d <= max(10.0, 2.0 * np.sqrt(b.mask_area))]
    if near:
        return min(near, key=lambda db: db[0])[1]
    where = ""
    if blobs:
        b = min(blobs, key=lambda b: np.hypot(b.u - tu, b.v - tv))
        where = f"; the nearest is at ({b.u:.0f}, {b.v:.0f})"
    raise TrackError(f"{name}: nothing moves at the target ({tu:g}, {tv:g}) in frame "
                     f"{int(frame)}{where}")


def ambiguity_message(name, view, candidates, origin):
    """One line: the candidates and the ``target`` line that settles it."""
    where = []
    for tr in sorted(candidates, key=lambda tr: tr.points[-1][1]):
        f, (cu, cv) = tr.describe(int(origin))
        where.append(f"frame {f} at ({cu:.0f}, {cv:.0f})")
    f, (cu, cv) = sorted(candidates, key=lambda tr: -tr.speed())[0].describe(int(origin))
    table = f"[views.{view}]" if view else "the view's table"
    return (f"{name}: {len(candidates)} objects fly alike and none can be told to be the one "
            f"to track: {'; '.join(where)}; name it in scene.toml {table}, e.g. "
            f"target = {{ frame = {f}, at_px = [{cu:.0f}, {cv:.0f}] }}")
