"""The contact sheet of report.html: crops of the footage round the straw.

Frames spread over the flight of each view with footage, and one example of every flag
that occurs in the run, each cropped round the straw (4 times its tracked length, at
least :data:`MIN_CROP_PX`), enlarged to a tile and drawn as the overlay draws a frame
(:mod:`vidtrack.report.overlay`: the measured point as a ring in the flag colour, the
fitted path, the frame's fitted point), labelled with the view, the frame number and the
flag names. Only the frames shown are read (``source[i]``).
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["Crop", "pick_frames", "contact_crops", "sheet_image", "contact_sheet_html",
           "MIN_CROP_PX", "TILE_PX"]

#: Smallest crop (frame pixels) and the tile it is enlarged to (sheet pixels).
MIN_CROP_PX = 48
MAX_CROP_PX = 400
TILE_PX = 176
#: Frames spread over the flight, over all views together.
FLIGHT_CROPS = 8
_LABEL_PX = 34


@dataclass(frozen=True, eq=False)
class Crop:
    """One tile of the sheet.

    Attributes
    ----------
    view : str
    frame : int
        The file's frame index.
    flags : int
    why : str
        ``"flight"`` or the flag it is the example of (``"PRE_RELEASE"``).
    image : numpy.ndarray
        The drawn tile (BGR, :data:`TILE_PX` square), without its label.
    corner_px : (float, float)
        The frame pixel (u, v) of the tile's top-left pixel centre.
    zoom : float
        Tile pixels per frame pixel: frame (u, v) is tile
        ``((u - corner_u + 0.5) * zoom - 0.5, (v - corner_v + 0.5) * zoom - 0.5)``.
    measured_px : (float, float) or None
        The measured centroid (frame pixels), None when not measured.
    """

    view: str
    frame: int
    flags: int
    why: str
    image: np.ndarray
    corner_px: tuple
    zoom: float
    measured_px: tuple | None


def _spread(idx, n):
    if len(idx) <= n:
        return list(idx)
    return [idx[int(round(k))] for k in np.linspace(0, len(idx) - 1, n)]


def pick_frames(tracks, paths, *, flight=FLIGHT_CROPS):
    """(view, row) pairs to show: ``flight`` frames spread over the flight (split over
    the views) and one frame of every flag bit that occurs.

    ``tracks``: {view: columns}; ``paths``: {view: ViewPath} (the flight is t >= 0 on
    the fit's clock; without a path, the unflagged frames).
    """
    from vidtrack.track.tracker import FLAGS

    picks = []
    per_view = max(1, int(np.ceil(flight / max(len(tracks), 1))))
    for name, d in tracks.items():
        frames = np.asarray(d["frame"])
        ok = np.isfinite(np.asarray(d["u_px"], float)) & (np.asarray(d["flags"]) == 0)
        if name in paths:
            t = paths[name].world_time(frames, np.asarray(d["t_s"], float))
            ok &= (t >= 0) & (t <= paths[name].t_end_s)
        picks += [(name, int(k), "flight") for k in _spread(np.flatnonzero(ok), per_view)]
    for bit, label in FLAGS.items():
        best = None
        for name, d in tracks.items():
            fl = np.asarray(d["flags"])
            rows = np.flatnonzero(fl & bit)
            if not rows.size:
                continue
            seen = rows[np.isfinite(np.asarray(d["u_px"], float)[rows])]
            choice = (name, int((seen if seen.size else rows)[len(seen if seen.size
                                                                  else rows) // 2]))
            if best is None or (seen.size and not best[1]):
                best = (choice, bool(seen.size))
        if best is not None:
            picks.append((*best[0], label.upper()))
    return picks


def _crop(frame, centre, size):
    """A ``size`` square of ``frame`` centred on ``centre`` (u, v), padded with black at
    the edges; and its top-left pixel's (u, v)."""
    import cv2

    c0 = int(np.floor(centre[0] - size / 2 + 0.5))
    r0 = int(np.floor(centre[1] - size / 2 + 0.5))
    h, w = frame.shape[:2]
    a, b = max(r0, 0), min(r0 + size, h)
    c, d = max(c0, 0), min(c0 + size, w)
    part = frame[a:b, c:d] if (b > a and d > c) else np.zeros((0, 0) + frame.shape[2:],
                                                               frame.dtype)
    if part.size == 0:
        return np.zeros((size, size) + frame.shape[2:], frame.dtype), (c0, r0)
    out = cv2.copyMakeBorder(part, a - r0, r0 + size - b, c - c0, c0 + size - d,
                             cv2.BORDER_CONSTANT, value=0)
    return out, (c0, r0)


def _size(d):
    flags = np.asarray(d["flags"])
    length = np.asarray(d["length_px"], float)[flags == 0] if "length_px" in d else []
    length = length[np.isfinite(length)] if len(length) else length
    est = 4.0 * float(np.median(length)) if len(length) else MIN_CROP_PX
    return int(np.clip(round(est), MIN_CROP_PX, MAX_CROP_PX))


def contact_crops(sources, tracks, paths, *, bit_depths=None, flight=FLIGHT_CROPS,
                  tile=TILE_PX):
    """The sheet's tiles, drawn.

    Parameters
    ----------
    sources : dict of str to FrameSource
        Each view's footage, opened on the whole file (index = file frame).
    tracks : dict of str to mapping
        Each view's track columns (``frame``, ``t_s``, ``u_px``, ``v_px``, ``flags``,
        ``length_px``).
    paths : dict of str to vidtrack.report.view_path.ViewPath
    flight : int
        Frames spread over the flight.
    tile : int
        Tile size (px).

    Returns
    -------
    (list of Crop, list of str)
        The tiles and notes (frames that could not be shown).
    """
    from vidtrack.report.overlay import camera_shifts, draw_marks, to_bgr8

    crops, notes = [], []
    shown = {n: d for n, d in tracks.items() if n in sources}
    polylines = {n: p.polyline() for n, p in paths.items()}
    # (a steadied view's points and path moved as the camera moved the footage)
    shifts = {n: camera_shifts(d, len(np.asarray(d["frame"]))) for n, d in shown.items()}
    for name, k, why in pick_frames(shown, paths, flight=flight):
        d = shown[name]
        src = sources[name]
        frame_no = int(np.asarray(d["frame"])[k])
        t_s = float(np.asarray(d["t_s"], float)[k])
        sh = shifts[name][k]
        uv = (float(np.asarray(d["u_px"], float)[k]) + sh[0],
              float(np.asarray(d["v_px"], float)[k]) + sh[1])
        flags = int(np.asarray(d["flags"])[k])
        fitted = (paths[name].at_frames([frame_no], [t_s])[0] + sh if name in paths
                  else np.array([np.nan, np.nan]))
        measured = uv if np.all(np.isfinite(uv)) else None
        centre = measured if measured is not None else (
            fitted if np.all(np.isfinite(fitted)) else None)
        if centre is None:
            notes.append(f"{name} frame {frame_no} ({why}): neither measured nor on the "
                         "fitted path; not shown")
            continue
        if not 0 <= frame_no < len(src):
            notes.append(f"{name} frame {frame_no}: not in the footage ({len(src)} frames)")
            continue
        size = _size(d)
        img, corner = _crop(src[frame_no], centre, size)
        zoom = tile / size
        img = to_bgr8(img, (bit_depths or {}).get(name, 8), zoom)
        line = polylines.get(name)
        draw_marks(img, measured=measured, flags=flags,
                   path=None if line is None else line + sh,
                   fitted=fitted, scale=zoom, offset=corner, radius=max(6.0, tile / 22))
        crops.append(Crop(view=name, frame=frame_no, flags=flags, why=why, image=img,
                          corner_px=(float(corner[0]), float(corner[1])), zoom=zoom,
                          measured_px=measured))
    return crops, notes


def sheet_image(crops, *, columns=4):
    """The tiles on one BGR image, each with its label (view, frame, flags) below."""
    import cv2

    from vidtrack.report.overlay import flag_colour, flag_text

    tile = crops[0].image.shape[0]
    cols = min(columns, len(crops))
    rows = int(np.ceil(len(crops) / cols))
    gap = 6
    cell_h = tile + _LABEL_PX
    sheet = np.full((rows * (cell_h + gap) + gap, cols * (tile + gap) + gap, 3), 255, np.uint8)
    for k, c in enumerate(crops):
        y = gap + (k // cols) * (cell_h + gap)
        x = gap + (k % cols) * (tile + gap)
        sheet[y:y + tile, x:x + tile] = c.image
        label = f"{c.view} frame {c.frame}" + ("" if c.why == "flight" else f"  e.g. {c.why}")
        cv2.putText(sheet, label, (x + 2, y + tile + 13), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                    (0, 0, 0), 1, cv2.LINE_AA)
        colour = tuple(int(0.7 * v) for v in flag_colour(c.flags))
        cv2.putText(sheet, flag_text(c.flags), (x + 2, y + tile + 28),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.4, colour, 1, cv2.LINE_AA)
    return sheet


def open_views(scene, folder, names):
    """Open the footage of the views ``names`` of ``scene`` (the caller closes them).

    Returns
    -------
    (dict of str to FrameSource, list of str)
        The views opened on the whole file, and why each other view was not (it gives
        points, not footage; its footage cannot be read).
    """
    from vidtrack.footage import open_source

    opened, missing = {}, []
    for name in names:
        view = scene.views[name]
        if getattr(view, "points", None) is not None:
            missing.append(f"view {name} gives points, not footage")
            continue
        src_path = view.source if folder == scene.folder else view.source_in(folder)
        try:
            opened[name] = open_source(src_path, fps=view.fps, channel=view.channel)
        except Exception as exc:       # noqa: BLE001 (footage moved or unreadable)
            missing.append(f"view {name}: the footage cannot be read ({exc})")
    return opened, missing


def contact_sheet_html(scene, folder, tracks, paths, *, sources=None, missing=()):
    """The report's contact-sheet section (HTML); it says why when there is no footage.

    ``tracks``: {view: columns} of the merged tracks; ``paths``: {view: ViewPath};
    ``sources``, ``missing``: the views already opened and why the others were not
    (:func:`open_views`; the caller closes them), else they are opened and closed here.
    """
    from vidtrack.report import _html

    head = "<h2>Contact sheet</h2>"
    own = sources is None
    opened, missing = open_views(scene, folder, tracks) if own else (sources, list(missing))
    try:
        if not opened:
            return head + (f'<p class="note">No footage to show: {_html.esc("; ".join(missing))}'
                           ".</p>")
        crops, notes = contact_crops(opened, tracks, paths,
                                     bit_depths={n: s.bit_depth for n, s in opened.items()})
    finally:
        if own:
            for s in opened.values():
                s.close()
    if not crops:
        return head + '<p class="note">No frame to show.</p>'
    parts = [head, "<p>Crops of the footage round the straw: frames spread over the flight, "
             "then one example of every flag in the run. Ring: the measured centroid, green "
             "when unflagged, else the colour of the first flag named; white line: the "
             "fitted path, white cross: the frame's fitted point.</p>",
             _html.img(_html.encode_png(sheet_image(crops)), alt="contact sheet")]
    parts += [f'<p class="note">{_html.esc(n)}</p>' for n in missing + notes]
    return "".join(parts)
