"""``tracks.h5``: the per-view tracks and the world track of a run (docs/fit-outputs.md).

Layout (HDF5, written with h5py, whole or not at all)::

    /                 attrs: vidtrack_version, scene_hash, calibration (JSON text),
                             schema (1), flags (JSON: bit value -> name),
                             views_sha256 (the views' values as written: views_digest)
    /front, /top      datasets (one value per frame): frame (int64), t_s, u_px, v_px,
                      area_px, angle_rad, length_px (float64), flags (int32),
                      manual (uint8 0/1; only in a view with points placed by hand),
                      camera_du_px, camera_dv_px (float64; only in a view whose
                      shaking camera was steadied), end1_u_px, end1_v_px,
                      end2_u_px, end2_v_px (float64; a rod's two ends, from the
                      flight tracker; NaN where no bar), reason (UTF-8 strings: which
                      test flagged the frame, vidtrack.track.flag.REASONS, "+"-joined;
                      only from the flight tracker)
                      attrs: release_frame (-1: none), release_t_s (NaN: none),
                             release_note, fps, frame_shape, noise_sigma, k_sigma,
                             straw_level, scatter_px, notes (JSON)
    /world            datasets: t_s, x_m, y_m, z_m (float64, NaN where not measured),
                      axis_x, axis_y, axis_z, spin_rad_s (float64: the straw's unit
                      axis in the world frame and the rate it turns at, rad/s; NaN where
                      not measured; each with attrs units, meaning;
                      vidtrack.world.attitude)
                      attrs: kind ("orthogonal"), reference, t0_s (JSON), sync (JSON),
                             x_rms_m, x_rms_px (NaN: not checked), x_points, warnings (JSON),
                             shared_x (JSON, two views: the views' relative scale on the
                             shared X and whether it was reconciled,
                             vidtrack.world.shared_x.SharedScale)

Calibrated cameras (a scene with ``[world]``): one group per view of any name (the root
attribute ``views`` lists them in order); ``/world`` has kind "calibrated", the datasets
``frame``, ``views``, ``flags``, ``reprojection_px_<view>`` and ``X_m, Y_m, Z_m`` (the
calibration's frame) besides t_s, x_m, y_m, z_m (the throw's frame), and attributes
``columns`` and ``summary`` (JSON: the offsets, sync, rotation, reprojection figures).

``t_s`` of a view is its source clock (s from the file's first frame); ``t_s`` of
``/world`` is the time since the release (t = 0), and ``/world`` attribute ``t0_s``
gives, per view, the source-clock time that is t = 0.

>>> write_tracks("run42/vidtrack/tracks.h5", {"front": tr}, world,    # doctest: +SKIP
...              scene_hash=scene.hash, calibration={"front": m.to_dict()})
>>> f = read_tracks("run42/vidtrack/tracks.h5")                         # doctest: +SKIP
>>> f.tracks["front"].data, f.world.data                              # doctest: +SKIP

The file does not keep the world track's ``frame`` column: :func:`read_tracks` gives it
back from the reference view's track (:func:`vidtrack.world.orthogonal.reference_frames`).

Beside it, the same numbers as tables (:func:`write_tables`): ``tracks.csv`` (one row
per view and frame: ``view``, the view's datasets, and ``flag_names``, e.g.
``MERGED|PRE_RELEASE``) and ``world.csv`` (``/world``'s datasets), full float precision, NaN
as an empty cell, read back by ``pandas.read_csv`` equal to what tracks.h5 holds.
"""

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from vidtrack._atomic import atomic_path
from vidtrack.errors import TrackError
from vidtrack.world.attitude import ATTITUDE_COLUMNS, ATTITUDE_MEANINGS

__all__ = ["TracksFile", "write_tracks", "read_tracks", "write_tables", "tracks_table",
           "world_table", "SCHEMA", "TRACKS_CSV", "WORLD_CSV"]

#: Layout version written to the root attribute ``schema``.
SCHEMA = 1
_VIEWS = ("front", "top")
_FLOAT_COLS = ("t_s", "u_px", "v_px", "area_px", "angle_rad", "length_px")
_WORLD_COLS = ("t_s", "x_m", "y_m", "z_m")
#: The tables written beside tracks.h5 by :func:`write_tables`.
TRACKS_CSV = "tracks.csv"
WORLD_CSV = "world.csv"
# tracks.csv's leading columns; the view's other datasets follow, then flag_names
_TRACKS_CSV_FIRST = ("view", "frame", "t_s", "u_px", "v_px", "flags")
#: A view's boolean column (dataset, in tracks.h5 as 0/1) of points placed by hand; only
#: in a view that has some (vidtrack.track.corrections).
_MANUAL = "manual"
#: A view's per-frame reason codes (the flight tracker's; in tracks.h5 as UTF-8
#: strings): which test flagged the frame, ``+``-joined, empty when clean.
_REASON = "reason"


@dataclass(frozen=True, eq=False)
class TracksFile:
    """What :func:`read_tracks` found.

    Attributes
    ----------
    tracks : dict of str to vidtrack.track.tracker.Track
        The views in the file.
    world : vidtrack.world.world_track.WorldTrack or None
        The world track, when the file has one.
    vidtrack_version, scene_hash : str
        Root attributes.
    calibration : object
        The ``calibration`` attribute decoded from JSON.
    path : pathlib.Path
    """

    tracks: dict
    world: object
    vidtrack_version: str
    scene_hash: str
    calibration: object
    path: Path
    views_sha256: str | None = None

    def to_dict(self):
        """A JSON-ready summary."""
        return {"path": str(self.path), "vidtrack_version": self.vidtrack_version,
                "scene_hash": self.scene_hash, "calibration": self.calibration,
                "views": {v: t.to_dict() for v, t in self.tracks.items()},
                "world": None if self.world is None else self.world.to_dict()}


def _json(obj):
    return json.dumps(obj, sort_keys=True, allow_nan=True, default=_plain)


def _plain(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, (np.ndarray, tuple)):
        return list(obj)
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "to_dict"):
        return obj.to_dict()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def _num(value):
    return float("nan") if value is None else float(value)


def _dataset(group, name, data):
    """A dataset with a Fletcher-32 checksum (chunked, as the filter needs)."""
    return group.create_dataset(name, data=data, fletcher32=True)


def _is_calibrated(world):
    return world is not None and world.calibrated


def _view_order(tracks):
    """front before top; calibrated views in their order."""
    return [v for v in _VIEWS if v in tracks] + [v for v in tracks if v not in _VIEWS]


def _check_tracks(tracks, label, *, calibrated=False):
    from vidtrack.track.tracker import TRACK_COLUMNS

    for v, tr in tracks.items():
        if calibrated:
            if not isinstance(v, str) or not v or "/" in v or v == "world":
                raise TrackError(f"{label}: a view name must be a plain name, got {v!r}")
        elif v not in _VIEWS:
            raise TrackError(f"{label}: unknown view {v!r}; expected front or top")
        missing = [c for c in TRACK_COLUMNS if c not in tr.data]
        if missing:
            raise TrackError(f"{label}: the {v} track lacks columns {missing}")


def views_digest(tracks):
    """sha256 of the views' per-frame values (frame, the floats, flags, manual), in view
    order: stored as the root attribute ``views_sha256``, so that a later reader can tell
    a view edited by hand from an edit elsewhere in the file."""
    import hashlib

    from vidtrack.track.tracker import OPTIONAL_COLUMNS, TRACK_COLUMNS

    h = hashlib.sha256()
    for v in _view_order(tracks):
        d = tracks[v].data
        h.update(v.encode())
        for c in (TRACK_COLUMNS + ((_MANUAL,) if _MANUAL in d else ())
                  + tuple(c for c in OPTIONAL_COLUMNS if c in d)):
            dtype = {"frame": np.int64, "flags": np.int32, _MANUAL: np.uint8}.get(c, np.float64)
            h.update(c.encode())
            h.update(np.ascontiguousarray(d[c].to_numpy(dtype=dtype)).tobytes())
    return h.hexdigest()


def write_tracks(path, tracks, world=None, *, scene_hash="", calibration=None,
                 calibrated=None):
    """Write ``tracks.h5`` atomically.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write (its folder is created); an existing file is replaced only
        when the new one is complete.
    tracks : dict of str to vidtrack.track.tracker.Track
        ``front`` and/or ``top``.
    world : vidtrack.world.world_track.WorldTrack, optional
        The merged world track.
    scene_hash : str, keyword-only
        ``Scene.hash`` of the scene the tracks came from.
    calibration : object, keyword-only
        What calibration was used (JSON-able: e.g. each view's mapping ``to_dict()``),
        stored as JSON text.
    calibrated : bool, keyword-only, optional
        Whether the views are calibrated cameras (any plain name, not only ``front``
        and ``top``); default: as ``world`` says (without a world track: not).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    TrackError
        An unknown view name, or a track without the columns of
        :data:`vidtrack.track.tracker.TRACK_COLUMNS`.
    """
    import h5py

    from vidtrack import __version__
    from vidtrack.track.tracker import FLAGS, OPTIONAL_COLUMNS

    path = Path(path)
    calibrated = _is_calibrated(world) if calibrated is None else calibrated
    _check_tracks(tracks, "tracks.h5", calibrated=calibrated)
    import io

    buffer = io.BytesIO()
    # the HDF5 1.8 layout (object headers with checksums) and a Fletcher-32 checksum
    # on the datasets (_dataset): a file damaged on disk fails to read instead of
    # reading back other numbers, while an edit made through HDF5 keeps them right.
    # Built in memory and written by Python: a full disk is then an OSError here,
    # not an error inside HDF5's own writes (which h5py cannot close cleanly).
    with h5py.File(buffer, "w", libver=("v108", "latest")) as h:
        h.attrs["schema"] = SCHEMA
        h.attrs["vidtrack_version"] = __version__
        h.attrs["scene_hash"] = str(scene_hash or "")
        h.attrs["calibration"] = _json(calibration)
        h.attrs["flags"] = _json({str(k): v for k, v in FLAGS.items()})
        h.attrs["views"] = _json(_view_order(tracks))
        h.attrs["views_sha256"] = views_digest(tracks)
        for v in _view_order(tracks):
            tr = tracks[v]
            g = h.create_group(v)
            d = tr.data
            _dataset(g, "frame", d["frame"].to_numpy(dtype=np.int64))
            for c in _FLOAT_COLS:
                _dataset(g, c, d[c].to_numpy(dtype=np.float64))
            _dataset(g, "flags", d["flags"].to_numpy(dtype=np.int32))
            if _MANUAL in d:
                # points placed by hand (flags 0): only a view that has them
                _dataset(g, _MANUAL, d[_MANUAL].to_numpy(dtype=np.uint8))
            for c in OPTIONAL_COLUMNS:
                if c in d:
                    # a shaking camera's shift (a steadied view only), a rod's ends
                    _dataset(g, c, d[c].to_numpy(dtype=np.float64))
            if _REASON in d:
                g.create_dataset(_REASON, data=d[_REASON].astype(str).to_numpy(dtype=object),
                                 dtype=h5py.string_dtype())
            g.attrs["release_frame"] = -1 if tr.release_frame is None else int(
                tr.release_frame)
            g.attrs["release_t_s"] = _num(tr.release_t_s)
            g.attrs["release_note"] = str(tr.release_note)
            g.attrs["fps"] = _num(tr.fps)
            g.attrs["frame_shape"] = np.asarray(tr.frame_shape, dtype=np.int64)
            g.attrs["noise_sigma"] = float(tr.noise_sigma)
            g.attrs["k_sigma"] = float(tr.k_sigma)
            g.attrs["straw_level"] = float(tr.straw_level)
            g.attrs["scatter_px"] = float(tr.scatter_px)
            g.attrs["notes"] = _json(list(tr.notes))
        if world is not None:
            # (datasets listed in the order written: the contract's columns first)
            g = h.create_group("world", track_order=True)
            for c in _WORLD_COLS:
                _dataset(g, c, world.data[c].to_numpy(dtype=np.float64))
            if not calibrated:
                for c in _attitude_columns(world):
                    _dataset(g, c, world.data[c].to_numpy(dtype=np.float64))
            if calibrated:
                # the triangulation's columns (frame, views, flags, reprojection_px_*,
                # X_m..Z_m in the calibration's frame, the attitude) and its summary
                for c in world.data.columns:
                    if c not in _WORLD_COLS:
                        g.create_dataset(c, data=world.data[c].to_numpy())
                g.attrs["kind"] = "calibrated"
                g.attrs["columns"] = _json(list(world.data.columns))
                g.attrs["summary"] = _json(world.to_dict())
            else:
                g.attrs["kind"] = "orthogonal"
                g.attrs["reference"] = str(world.reference)
                g.attrs["t0_s"] = _json(world.t0_s)
                g.attrs["sync"] = _json(world.sync)
                g.attrs["x_rms_m"] = _num(world.x_rms_m)
                g.attrs["x_rms_px"] = _num(world.x_rms_px)
                g.attrs["x_points"] = int(world.x_points)
                g.attrs["warnings"] = _json(list(world.warnings))
                if world.shared_x is not None:
                    g.attrs["shared_x"] = _json(world.shared_x.to_dict())
            for c in _attitude_columns(world):
                g[c].attrs["units"], g[c].attrs["meaning"] = ATTITUDE_MEANINGS[c]
    with atomic_path(path) as tmp:
        tmp.write_bytes(buffer.getvalue())
    return path


def _attr(obj, key, path, where):
    if key not in obj.attrs:
        raise TrackError(f"{path}: {where} has no attribute {key!r}; not a vidtrack tracks.h5")
    value = obj.attrs[key]
    if isinstance(value, bytes):
        value = value.decode("utf-8")
    return value


def _none_if_nan(value):
    value = float(value)
    return None if not np.isfinite(value) else value


def read_tracks(path):
    """Read a ``tracks.h5`` written by :func:`write_tracks`.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    TracksFile

    Raises
    ------
    TrackError
        A missing file, a file that is not HDF5, or one without the datasets and
        attributes of this layout (the message names what is missing).
    """
    import h5py

    from vidtrack.world.orthogonal import reference_frames
    from vidtrack.world.world_track import WorldTrack
    from vidtrack.world.shared_x import SharedScale
    from vidtrack.track.tracker import OPTIONAL_COLUMNS, TRACK_COLUMNS, Track

    path = Path(path)
    if not path.is_file():
        raise TrackError(f"{path}: no such file")
    try:
        h = h5py.File(path, "r")
    except OSError as exc:
        raise TrackError(f"{path}: cannot be read as HDF5 ({exc})") from None
    with h:
        version = str(_attr(h, "vidtrack_version", path, "the root"))
        scene_hash = str(_attr(h, "scene_hash", path, "the root"))
        calibration = json.loads(_attr(h, "calibration", path, "the root"))
        tracks = {}
        order = (json.loads(h.attrs["views"]) if "views" in h.attrs
                 else [v for v in _VIEWS if v in h])
        for v in order:
            if v not in h:
                raise TrackError(f"{path}: the root lists view {v!r} but there is no /{v}")
            g = h[v]
            cols = {}
            for c in TRACK_COLUMNS:
                if c not in g:
                    raise TrackError(f"{path}: /{v} has no dataset {c!r}")
                cols[c] = g[c][()]
            if _MANUAL in g:
                cols[_MANUAL] = g[_MANUAL][()].astype(bool)
            for c in OPTIONAL_COLUMNS:
                if c in g:
                    cols[c] = g[c][()]
            if _REASON in g:
                cols[_REASON] = g[_REASON].asstr()[()].astype(object)
            n = {c: len(a) for c, a in cols.items()}
            if len(set(n.values())) != 1:
                raise TrackError(f"{path}: /{v} datasets differ in length: {n}")
            data = pd.DataFrame(cols)
            rel = int(_attr(g, "release_frame", path, f"/{v}"))
            tracks[v] = Track(
                data=data, view=v, release_frame=None if rel < 0 else rel,
                release_note=str(_attr(g, "release_note", path, f"/{v}")),
                release_t_s=_none_if_nan(_attr(g, "release_t_s", path, f"/{v}")),
                fps=_none_if_nan(_attr(g, "fps", path, f"/{v}")),
                frame_shape=tuple(int(x) for x in _attr(g, "frame_shape", path, f"/{v}")),
                noise_sigma=float(_attr(g, "noise_sigma", path, f"/{v}")),
                k_sigma=float(_attr(g, "k_sigma", path, f"/{v}")),
                straw_level=float(_attr(g, "straw_level", path, f"/{v}")),
                scatter_px=float(_attr(g, "scatter_px", path, f"/{v}")),
                notes=tuple(json.loads(_attr(g, "notes", path, f"/{v}"))))
        world = None
        if "world" in h and h["world"].attrs.get("kind") == "calibrated":
            world = _read_calibrated(h["world"], path)
        elif "world" in h:
            g = h["world"]
            cols = {}
            for c in _WORLD_COLS:
                if c not in g:
                    raise TrackError(f"{path}: /world has no dataset {c!r}")
                cols[c] = g[c][()]
            t0_s = json.loads(_attr(g, "t0_s", path, "/world"))
            reference = str(_attr(g, "reference", path, "/world"))
            # the rows are the reference view's frames: their numbers come from its track
            frames = (reference_frames(tracks[reference].data, t0_s[reference], cols["t_s"])
                      if reference in tracks and reference in t0_s
                      else np.full(len(cols["t_s"]), -1, dtype=np.int64))
            for c in ATTITUDE_COLUMNS:
                if c in g:
                    cols[c] = g[c][()]
            world = WorldTrack(
                data=pd.DataFrame({"frame": frames, **cols}),
                t0_s=t0_s,
                sync=json.loads(_attr(g, "sync", path, "/world")),
                reference=reference, kind="orthogonal",
                x_rms_m=_none_if_nan(_attr(g, "x_rms_m", path, "/world")),
                x_rms_px=_none_if_nan(_attr(g, "x_rms_px", path, "/world")),
                x_points=int(_attr(g, "x_points", path, "/world")),
                warnings=tuple(json.loads(_attr(g, "warnings", path, "/world"))),
                shared_x=(SharedScale.from_dict(json.loads(_attr(g, "shared_x", path,
                                                                 "/world")))
                          if "shared_x" in g.attrs else None))
        stored = h.attrs.get("views_sha256")
        if isinstance(stored, bytes):
            stored = stored.decode("utf-8")
    return TracksFile(tracks=tracks, world=world, vidtrack_version=version,
                      scene_hash=scene_hash, calibration=calibration, path=path,
                      views_sha256=None if stored is None else str(stored))


def _read_calibrated(g, path):
    from vidtrack.world.world_track import WorldTrack

    columns = json.loads(_attr(g, "columns", path, "/world"))
    missing = [c for c in columns if c not in g]
    if missing:
        raise TrackError(f"{path}: /world has no dataset {missing[0]!r}")
    info = json.loads(_attr(g, "summary", path, "/world"))
    return WorldTrack(
        data=pd.DataFrame({c: g[c][()] for c in columns}), t0_s={}, sync=info["sync"],
        reference=info["reference"], kind="calibrated", warnings=tuple(info["warnings"]),
        offsets_s=info["offsets_s"], rotation=np.array(info["rotation"]),
        forward_from=info["forward_from"], median_reprojection_px=info["median_reprojection_px"],
        flag_threshold_px=info["flag_threshold_px"])


def _flag_names(values):
    from vidtrack.track.tracker import describe_flags

    names = {}
    out = []
    for v in values:
        v = int(v)
        if v not in names:
            names[v] = "|".join(n.upper() for n in describe_flags(v))
        out.append(names[v])
    return out


def tracks_table(tracks, *, calibrated=False):
    """The views' tracks as one table, the rows of ``tracks.csv``.

    Parameters
    ----------
    tracks : dict of str to vidtrack.track.tracker.Track
        ``front`` and/or ``top`` (written in that order).
    calibrated : bool, keyword-only
        The views are calibrated cameras: any names, in their order.

    Returns
    -------
    pandas.DataFrame
        One row per view and frame: ``view``, ``frame``, ``t_s``, ``u_px``, ``v_px``,
        ``flags``, the other columns that tracks.h5 keeps for a view (``area_px``,
        ``angle_rad``, ``length_px``), ``manual`` (1: a point placed by hand; only
        when a view has such points), ``camera_du_px``, ``camera_dv_px`` (a steadied
        view's camera shift; only when a view has one, NaN in the others), and
        ``flag_names`` (the set bits' names in
        upper case, in bit order, joined by ``|``, e.g. ``MERGED|PRE_RELEASE``; empty
        when unflagged), then ``reason`` (the flight tracker's reason codes,
        :data:`vidtrack.track.flag.REASONS`, ``+``-joined; only when a view has them).

    Raises
    ------
    TrackError
        An unknown view name, or a track without the columns of
        :data:`vidtrack.track.tracker.TRACK_COLUMNS`.
    """
    from vidtrack.track.tracker import CAMERA_COLUMNS, END_COLUMNS, TRACK_COLUMNS

    _check_tracks(tracks, TRACKS_CSV, calibrated=calibrated)
    manual = any(_MANUAL in tracks[v].data for v in tracks)
    columns = list(_TRACKS_CSV_FIRST) + [c for c in TRACK_COLUMNS
                                         if c not in _TRACKS_CSV_FIRST]
    camera = any(CAMERA_COLUMNS[0] in tracks[v].data for v in tracks)
    ends = any(END_COLUMNS[0] in tracks[v].data for v in tracks)
    reason = any(_REASON in tracks[v].data for v in tracks)
    optional = list(CAMERA_COLUMNS) * camera + list(END_COLUMNS) * ends
    columns += [_MANUAL] * manual + optional + ["flag_names"] + [_REASON] * reason
    parts = []
    for v in _view_order(tracks):
        d = tracks[v].data
        part = {"view": np.full(len(d), v, dtype=object),
                "frame": d["frame"].to_numpy(dtype=np.int64),
                "flags": d["flags"].to_numpy(dtype=np.int32)}
        for c in _FLOAT_COLS:
            part[c] = d[c].to_numpy(dtype=np.float64)
        if manual:
            part[_MANUAL] = (d[_MANUAL].to_numpy(dtype=np.uint8) if _MANUAL in d
                             else np.zeros(len(d), dtype=np.uint8))
        for c in optional:
            part[c] = (d[c].to_numpy(dtype=np.float64) if c in d
                       else np.full(len(d), np.nan))
        part["flag_names"] = _flag_names(part["flags"])
        if reason:
            part[_REASON] = (d[_REASON].astype(str).to_numpy(dtype=object) if _REASON in d
                             else np.full(len(d), "", dtype=object))
        parts.append(pd.DataFrame(part, columns=columns))
    if not parts:
        return pd.DataFrame({c: [] for c in columns})
    return pd.concat(parts, ignore_index=True)


def world_table(world):
    """The world track as a table, the rows of ``world.csv``: ``t_s`` (s since the
    release), ``x_m``, ``y_m``, ``z_m`` (NaN where not measured); a calibrated scene's
    world track adds ``frame``, ``views``, ``flags``, ``reprojection_px_<view>`` and
    ``X_m``, ``Y_m``, ``Z_m`` (the calibration's frame); then the straw's attitude
    ``axis_x``, ``axis_y``, ``axis_z`` (unit axis, throw frame) and ``spin_rad_s`` (the
    rate its axis turns at; :mod:`vidtrack.world.attitude`), NaN where not measured."""
    table = pd.DataFrame({c: world.data[c].to_numpy(dtype=np.float64) for c in _WORLD_COLS})
    if _is_calibrated(world):
        for c in world.data.columns:
            if c not in _WORLD_COLS:
                table[c] = world.data[c].to_numpy()
    else:
        for c in _attitude_columns(world):
            table[c] = world.data[c].to_numpy(dtype=np.float64)
    return table


def _attitude_columns(world):
    """The attitude columns the world track has (:data:`ATTITUDE_COLUMNS`; none in a
    world track from before they were kept)."""
    return [c for c in ATTITUDE_COLUMNS if c in world.data]


def _write_csv(path, table):
    # pandas writes each float as its shortest repr (it reads back to the same bits),
    # NaN as an empty cell; no index column
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False, na_rep="", lineterminator="\n")
    return Path(path)


def write_tables(folder, tracks, world=None, *, missing_only=False):
    """Write ``tracks.csv`` and (with a world track) ``world.csv`` into ``folder``.

    The same numbers as tracks.h5 (:func:`write_tracks`), as tables a spreadsheet or
    ``pandas.read_csv`` reads: full float precision, NaN as an empty cell, a header row,
    no index column; each file whole or not at all.

    Parameters
    ----------
    folder : str or os.PathLike
        The output folder (beside tracks.h5; created if missing).
    tracks : dict of str to vidtrack.track.tracker.Track
    world : vidtrack.world.world_track.WorldTrack, optional
    missing_only : bool, keyword-only
        Write only a table that is missing or older than ``folder/tracks.h5`` (for
        tracks reused from that file).

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    folder = Path(folder)
    h5 = folder / "tracks.h5"

    def wanted(path):
        if not missing_only:
            return True
        try:
            return (not path.is_file()
                    or (h5.is_file() and path.stat().st_mtime_ns < h5.stat().st_mtime_ns))
        except OSError:
            return True

    written = []
    if wanted(folder / TRACKS_CSV):
        written.append(_write_csv(folder / TRACKS_CSV,
                                  tracks_table(tracks, calibrated=_is_calibrated(world))))
    if world is not None and wanted(folder / WORLD_CSV):
        written.append(_write_csv(folder / WORLD_CSV, world_table(world)))
    return written
