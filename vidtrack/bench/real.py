"""``vidtrack bench track --real``: the tracker scoreboard, real clips and synthetic scenes.

Every clip of ``<shared>/data/real`` that has footage and every synthetic distractor
scene (:data:`vidtrack.bench.scenes.CASES`) is tracked by each tracker engine
(``vidtrack.track.tracker.ENGINES``; "rules" where the tracker has no engines), and
scored against a reference someone else made. ``<shared>`` is the folder given with
``--shared`` (without it the real clips are skipped, saying so); the footage is read
there, never copied. A clip whose files are
absent is skipped, saying so; a clip an engine refuses (exit 2 in ``vidtrack fit``)
gives a ``failed`` row with the message.

Columns of ``bench_track_real.csv``: ``clip``, ``engine``, ``status`` (ok; failed: the
engine refused the clip; error: it raised something else, logged; skipped),
``flight_frames`` (frames of the flight, as the reference has it), ``unflagged`` (of
those, frames with flags 0 and a position) and ``unflagged_frac``, ``scored``
(unflagged flight frames with a reference point), ``median_px``, ``p95_px``,
``max_px``, ``rms_px`` (distance from the reference over the scored frames, px),
``fit`` (what the next figures are), ``fit_track`` (from the track's unflagged flight
points), ``fit_ref`` (from the reference's own points), ``fit_ratio`` (track / ref),
``fit_ref_same`` (from the reference's points on the frames the track's figure used:
what a perfect track flagged alike gives), ``track_cpu_s`` (CPU seconds of the
``track()`` call, opening the footage included), ``track_wall_s``, ``decode_cpu_s``
(CPU seconds to decode the same frames, measured in the same run), ``x_decode``
(decode_cpu_s / track_cpu_s: the tracker's speed as a share of decoding's; 1 is the
limit), ``note``, then ``track_cpu_median_s``, ``track_wall_median_s``,
``decode_cpu_median_s``, ``decode_wall_s``, ``decode_wall_median_s``, ``x_decode_wall``
(decode_wall_s / track_wall_s) and ``calls``.

Timing (:mod:`vidtrack.bench._timing`): per clip, decoding and each engine are called in
turn, round by round, one warm-up round uncounted (``warmup``) and then ``repeats``
counted rounds; a figure without ``median`` in its name is the min of the counted calls
(CPU time: the process's threads and its child processes), and the track scored is the
last call's. An engine that fails is timed to its failure.

Per clip (reference; alignment; ``fit``):

- launcher (240 fps, frames 259-329): ``ball_reference.csv``, the ball's disc centroid;
  none; ``k2/k1`` of a drag-free fit of v(t) with a gravity of its own on each side of
  the apex (1 for a drag-free ball; the issue asks within 2 %).
- balltoss (30 fps): Tracker's points in metres; the frame offset and the u and v
  scales that fit best (as the test does); ``g m/s2`` of a parabola y(t) in metres.
- oso_sin_globo, oso_globo_grande (60 fps): the group's CSV (heights only); the frame
  offset (-2..1) and the scale that fit best; distances are vertical; ``k 1/s`` of a
  linear-drag fit with g = 9.81 m/s^2 (the issue asks the bear alone within 2.3 px RMS).
- diabolo (240 fps, flight frames 1-409): the authors' hand-placed points; their median
  offset from the track taken out (they mark a spot on the glider, not its centre);
  ``g m/s2`` of a parabola y(t) at their 459.448 px/m (a glider: not 9.8).
- badminton_cam1, badminton_cam2 (119.12 fps, frames 732-871, ``target`` at frame 802
  on the label): the labels (the cork, which leads the centroid); none; ``|a| px/s2``
  of a 2-D parabola (u, v)(t) (a shuttlecock: drag-dominated).
- synth:NAME/VIEW: truth.json's coverage centroid (:mod:`vidtrack.bench.scenes`).
"""

import dataclasses
import logging
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from vidtrack._atomic import atomic_path, write_text
from vidtrack.bench._score import (Score, accel_2d, decode, descent_over_ascent,
                                   linear_drag_k, quadratic_accel, track_once)
from vidtrack.bench._timing import timed_each

__all__ = ["clip_names", "REAL_CLIPS", "Clip", "default_shared", "select_clips", "engines_to_run",
           "score_launcher", "score_balltoss", "score_bear", "score_diabolo",
           "score_badminton", "run_scoreboard", "format_scoreboard"]

log = logging.getLogger(__name__)

#: The launcher's rate (the container says 29.97) and the diabolo's scale (the authors'
#: Tracker project: 459.448 px/m, y up from row 500.00).
LAUNCHER_FPS = 240.0
DIABOLO_PX_PER_M, DIABOLO_ROW0_PX = 459.448, 500.00
#: The badminton flight between two hits (file frames, half-open) and the target's frame.
BADMINTON_FRAMES, BADMINTON_TARGET = (732, 872), 802
BADMINTON_FPS = 119.12
#: g (m/s^2) of the bear's linear-drag fit, and the frame offsets of the group's CSV tried.
BEAR_G_M_S2 = 9.81
BEAR_OFFSETS = (-2, -1, 0, 1)
#: Fewest aligned frames an offset search accepts.
MIN_ALIGNED = 8


@dataclasses.dataclass(frozen=True)
class Clip:
    """A real clip of the scoreboard: where it is, how it is opened, how it is scored.

    ``footage`` and ``reference`` are relative to ``<shared>/data/real``; ``frames`` the
    half-open file-frame range opened (None: all); ``slow`` clips are left out by
    ``--quick``; ``score(track, reference) -> Score``; ``load(path) -> reference``;
    ``target(reference)`` the ``target`` handed to ``track()`` (None: none).
    """

    name: str
    footage: str
    reference: str
    fps: float
    load: object
    score: object
    frames: tuple | None = None
    view: str = "front"
    slow: bool = False
    target: object = None


# ------------------------------------------------------------------- helpers


def _at(tr, frames):
    """``u, v, ok`` of the track at file frames ``frames`` (NaN, False where absent)."""
    d = tr.data
    frames = np.asarray(frames, dtype=int)
    pos = pd.Series(np.arange(len(d)), index=d["frame"].to_numpy(dtype=int))
    idx = pos.reindex(frames).to_numpy(dtype=float)
    have = np.isfinite(idx)
    rows = idx[have].astype(int)
    u = np.full(frames.size, np.nan)
    v = np.full(frames.size, np.nan)
    ok = np.zeros(frames.size, bool)
    u[have] = d["u_px"].to_numpy(dtype=float)[rows]
    v[have] = d["v_px"].to_numpy(dtype=float)[rows]
    ok[have] = tr.usable[rows]
    return u, v, ok


def _line(x, y):
    """Least-squares ``y = a x + b``: ``(a, b, residuals)``."""
    a = np.column_stack([x, np.ones_like(x)])
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    return float(coef[0]), float(coef[1]), y - a @ coef


# ------------------------------------------------------------------- scorers


def score_launcher(tr, ref, *, fps=LAUNCHER_FPS):
    """The launcher's ball against ``ball_reference.csv`` (columns frame, u_px, v_px).

    The flight is the reference's frames; distances are plain (the reference is the
    ball's disc centroid); the figure is k2/k1 (:func:`descent_over_ascent`).
    """
    frames = ref["frame"].to_numpy(dtype=int)
    ru, rv = ref["u_px"].to_numpy(dtype=float), ref["v_px"].to_numpy(dtype=float)
    u, v, ok = _at(tr, frames)
    t = frames / fps
    return Score(flight_frames=frames.size, unflagged=int(ok.sum()),
                 dist_px=np.hypot(u - ru, v - rv)[ok], fit="k2/k1",
                 fit_track=descent_over_ascent(t[ok], v[ok]),
                 fit_ref=descent_over_ascent(t, rv),
                 fit_ref_same=descent_over_ascent(t[ok], rv[ok]))


def score_balltoss(tr, ref):
    """Tracker's ball toss against its points (columns t, x, y in metres, y up).

    The reference's t = 0 is a video frame the source does not state: the frame offset,
    and the u and v scales, that map the reference onto the track's unflagged points
    best (least RMS) are taken, as ``tests/test_real_footage.py`` does; the flight is
    the reference's frames from there. The figure is g (m/s^2) of a parabola y(t), the
    track's rows read in metres by the fitted v scale.
    """
    ref = np.asarray(ref, dtype=float)
    d = tr.data
    ok_all = tr.usable
    n = len(d)
    u, v = d["u_px"].to_numpy(dtype=float), d["v_px"].to_numpy(dtype=float)
    t = d["t_s"].to_numpy(dtype=float)
    g_ref = -quadratic_accel(ref[:, 0], ref[:, 2])               # y up: y'' = -g
    best = None
    for off in range(0, max(n - MIN_ALIGNED, 0)):
        idx = np.arange(len(ref)) + off
        m = idx < n
        m[m] &= ok_all[idx[m]]
        if m.sum() < MIN_ALIGNED:
            continue
        av, bv, rv = _line(-ref[m, 2], v[idx[m]])
        au, bu, ru = _line(ref[m, 1], u[idx[m]])
        rms = float(np.sqrt(np.mean(np.r_[rv, ru] ** 2)))
        if best is None or rms < best[0]:
            best = (rms, off, av, bv, au, bu)
    if best is None:
        return Score(len(ref), 0, np.empty(0), "g m/s2", float("nan"), g_ref,
                     note=f"fewer than {MIN_ALIGNED} unflagged frames to align")
    _, off, av, bv, au, bu = best
    idx = np.arange(len(ref)) + off
    inside = idx < n
    flight = idx[inside]
    ok = ok_all[flight]
    du = u[flight] - (au * ref[inside, 1] + bu)
    dv = v[flight] - (av * -ref[inside, 2] + bv)
    # rows grow downwards, av px per metre up: g = v'' / av
    g = quadratic_accel(t[flight][ok], v[flight][ok]) / av if av else float("nan")
    same = -quadratic_accel(ref[inside][ok, 0], ref[inside][ok, 2])
    return Score(flight_frames=len(ref), unflagged=int(ok.sum()),
                 dist_px=np.hypot(du, dv)[ok], fit="g m/s2", fit_track=g,
                 fit_ref=g_ref, fit_ref_same=same,
                 note=f"reference t=0 at frame {off}, {av:.1f} px/m")


def score_bear(tr, ref, *, fps=60.0):
    """A bear's drop against the group's CSV (``Frame``, ``Y_metros``; heights only).

    Their frame k is the video's k + offset, the offset (-2..1) and their scale (m per
    px) the ones that fit the track's unflagged heights best, as the test does; the
    flight is their frames; distances are the vertical residuals in px. The figure is
    k (1/s) of a linear-drag fit with g fixed (:func:`linear_drag_k`), the track's
    heights read in metres by the fitted scale.
    """
    v_all = tr.data["v_px"].to_numpy(dtype=float)
    ok_all = tr.usable
    frames = ref["Frame"].to_numpy(dtype=int)
    y = ref["Y_metros"].to_numpy(dtype=float)
    k_ref = linear_drag_k(frames / fps, y, g=BEAR_G_M_S2)
    best = None
    for off in BEAR_OFFSETS:
        idx = frames + off
        m = (idx >= 0) & (idx < len(v_all))
        m[m] &= ok_all[idx[m]]
        if m.sum() < MIN_ALIGNED:
            continue
        a, b, r = _line(-v_all[idx[m]], y[m])
        rms = float(np.sqrt(np.mean(r ** 2)))
        if best is None or rms < best[0]:
            best = (rms, off, a, b)
    if best is None:
        return Score(frames.size, 0, np.empty(0), "k 1/s", float("nan"), k_ref,
                     note=f"fewer than {MIN_ALIGNED} unflagged frames to align")
    _, off, m_per_px, b = best
    idx = frames + off
    inside = (idx >= 0) & (idx < len(v_all))
    ok = np.zeros(frames.size, bool)
    ok[inside] = ok_all[idx[inside]]
    v = np.full(frames.size, np.nan)
    v[inside] = v_all[idx[inside]]
    dist = np.abs(y - (m_per_px * -v + b)) / abs(m_per_px) if m_per_px else v * np.nan
    y_track = -v * m_per_px
    return Score(flight_frames=frames.size, unflagged=int(ok.sum()), dist_px=dist[ok],
                 fit="k 1/s", fit_track=linear_drag_k(frames[ok] / fps, y_track[ok],
                                                      g=BEAR_G_M_S2),
                 fit_ref=k_ref, fit_ref_same=linear_drag_k(frames[ok] / fps, y[ok],
                                                           g=BEAR_G_M_S2),
                 note=f"offset {off:+d} frames, {1.0 / m_per_px:.1f} px/m")


def score_diabolo(tr, ref, *, fps=240.0):
    """The diabolo glider against the authors' points (frame, t_s, u_px, v_px).

    The flight is frames 1 on (frame 0: on the string); the median offset of the
    unflagged points from theirs is taken out (their point is a spot on the glider,
    drifting off it late in the flight). The figure is g (m/s^2) of a parabola y(t) at
    their scale.
    """
    ref = np.asarray(ref, dtype=float)
    flight = ref[:, 0] >= 1
    frames = ref[flight, 0].astype(int)
    ru, rv = ref[flight, 2], ref[flight, 3]
    u, v, ok = _at(tr, frames)
    t = frames / fps
    g_ref = -quadratic_accel(t, (DIABOLO_ROW0_PX - rv) / DIABOLO_PX_PER_M)
    if not ok.any():
        return Score(frames.size, 0, np.empty(0), "g m/s2", float("nan"), g_ref)
    off = np.median(np.column_stack([u - ru, v - rv])[ok], axis=0)
    dist = np.hypot(u - ru - off[0], v - rv - off[1])
    g = -quadratic_accel(t[ok], (DIABOLO_ROW0_PX - v[ok]) / DIABOLO_PX_PER_M)
    return Score(flight_frames=frames.size, unflagged=int(ok.sum()), dist_px=dist[ok],
                 fit="g m/s2", fit_track=g, fit_ref=g_ref,
                 fit_ref_same=-quadratic_accel(t[ok], (DIABOLO_ROW0_PX - rv[ok])
                                               / DIABOLO_PX_PER_M),
                 note=f"offset ({off[0]:+.1f}, {off[1]:+.1f}) px taken out")


def score_badminton(tr, lab, *, fps=BADMINTON_FPS):
    """A badminton camera against its labels (``Frame``, ``X``, ``Y``) over the flight.

    Distances are plain (the labels mark the cork, which leads the centroid along the
    flight); the figure is |a| (px/s^2) of a 2-D parabola (:func:`accel_2d`).
    """
    frames = lab["Frame"].to_numpy(dtype=int)
    x, y = lab["X"].to_numpy(dtype=float), lab["Y"].to_numpy(dtype=float)
    u, v, ok = _at(tr, frames)
    t = frames / fps
    return Score(flight_frames=frames.size, unflagged=int(ok.sum()),
                 dist_px=np.hypot(u - x, v - y)[ok], fit="|a| px/s2",
                 fit_track=accel_2d(t[ok], u[ok], v[ok]), fit_ref=accel_2d(t, x, y),
                 fit_ref_same=accel_2d(t[ok], x[ok], y[ok]))


# ------------------------------------------------------------------- the clips


def _load_badminton(path):
    lab = pd.read_csv(path)
    a, b = BADMINTON_FRAMES
    return lab[(lab["Frame"] >= a) & (lab["Frame"] < b)].reset_index(drop=True)


def _badminton_target(lab):
    row = lab[lab["Frame"] == BADMINTON_TARGET].iloc[0]
    return (BADMINTON_TARGET, (float(row["X"]), float(row["Y"])))


REAL_CLIPS = (
    Clip("launcher", "launcher/launcher_30deg_240fps.mp4", "launcher/ball_reference.csv",
         LAUNCHER_FPS, pd.read_csv, score_launcher),
    Clip("balltoss", "balltoss/BallTossOut.mp4", "balltoss/balltoss_tracker_points.txt",
         30.0, lambda p: np.loadtxt(p, skiprows=2), score_balltoss),
    Clip("oso_sin_globo", "bear/oso_sin_globo.mov", "bear/trayectoria_sin_globo.csv",
         60.0, pd.read_csv, score_bear),
    Clip("oso_globo_grande", "bear/oso_globo_grande.mov", "bear/trayectoria_globo_grande.csv",
         60.0, pd.read_csv, score_bear),
    Clip("diabolo", "diabolo/diabolo_240fps.mp4", "diabolo/tracker_points_240fps.csv",
         240.0, lambda p: np.loadtxt(p, delimiter=",", skiprows=1), score_diabolo,
         slow=True),
    *(Clip(f"badminton_cam{c}", f"badminton_2cam/CameraReader_{c}.mp4",
           f"badminton_2cam/CameraReader_{c}.csv", BADMINTON_FPS, _load_badminton,
           score_badminton, frames=BADMINTON_FRAMES, view=f"cam{c}", slow=True,
           target=_badminton_target) for c in (1, 2)),
)


def _synth_names():
    from vidtrack.bench.scenes import scene_view_names

    return scene_view_names()


def clip_names():
    """Every clip name of the scoreboard, real first, then the synthetic scenes' views."""
    return [c.name for c in REAL_CLIPS] + _synth_names()


#: Names standing for several clips in ``--clips``.
GROUPS = {"real": lambda: [c.name for c in REAL_CLIPS],
          "synth": _synth_names,
          "bear": lambda: ["oso_sin_globo", "oso_globo_grande"],
          "badminton": lambda: ["badminton_cam1", "badminton_cam2"]}


def select_clips(spec=None):
    """Clip names (the scoreboard's order) that ``--clips`` ``spec`` names.

    ``spec``: None (all), or comma-separated names: a clip (``balltoss``,
    ``synth:shadow/front``), a scene's two views (``synth:shadow``) or a group (``real``,
    ``synth``, ``bear``, ``badminton``).

    Raises
    ------
    VidtrackError
        A name that is none of these (the message lists them).
    """
    from vidtrack.errors import VidtrackError

    names = clip_names()
    if spec is None:
        return names
    wanted = set()
    for item in (s.strip() for s in str(spec).split(",")):
        if not item:
            continue
        if item in GROUPS:
            wanted.update(GROUPS[item]())
            continue
        hit = [n for n in names if n == item or n.startswith(item + "/")]
        if not hit:
            scenes = sorted({n.split("/")[0] for n in names if n.startswith("synth:")})
            raise VidtrackError(
                f"--clips: no clip {item!r}; expected names from "
                f"{', '.join(c.name for c in REAL_CLIPS)}, {', '.join(scenes)} (each with "
                f"/front or /top, or both without), or the groups {', '.join(GROUPS)}")
        wanted.update(hit)
    return [n for n in names if n in wanted]


def engines_to_run(requested=None):
    """The engines to compare: ``requested`` (checked), else every engine the tracker has.

    ``vidtrack.track.tracker.ENGINES`` names them; a tracker without it has one, "rules".

    Raises
    ------
    VidtrackError
        A requested engine the tracker does not have.
    """
    from vidtrack.errors import VidtrackError
    from vidtrack.track import tracker

    have = tuple(getattr(tracker, "ENGINES", ("rules",)))
    if not requested:
        return have
    out = []
    for name in requested:
        if name not in have:
            raise VidtrackError(f"--engine {name}: this tracker's engines are "
                                f"{', '.join(have)}")
        if name not in out:
            out.append(name)
    return tuple(out)


def default_shared():
    """The folder of real footage when none is given: none (the real clips are third
    party, kept beside a developer's checkout, never in it); give ``--shared DIR``."""
    return None


# ------------------------------------------------------------------- the run


def _rows_of(name, engines, open_fn, score_fn, *, view, target, progress, repeats, warmup):
    """One clip: decoding and each engine in turn, round by round; a row per engine."""
    runs = {"": lambda: decode(open_fn)}           # no engine is named ""
    runs.update({engine: (lambda engine=engine: track_once(open_fn, engine, view=view,
                                                            target=target))
                 for engine in engines})
    times = timed_each(runs, repeats=repeats, warmup=warmup)
    dec = times.pop("")
    rows = []
    for engine, t in times.items():
        tr, status, msg = t.result
        row = {"clip": name, "engine": engine}
        if tr is None:
            row.update(status=status, note=msg)
        else:
            row.update(status="ok", **score_fn(tr).to_row())
        cpu, wall = t.cpu_min_s, t.wall_min_s
        row.update(track_cpu_s=cpu, track_wall_s=wall, decode_cpu_s=dec.cpu_min_s,
                   x_decode=dec.cpu_min_s / cpu if cpu > 0 else float("nan"),
                   track_cpu_median_s=t.cpu_median_s, track_wall_median_s=t.wall_median_s,
                   decode_cpu_median_s=dec.cpu_median_s, decode_wall_s=dec.wall_min_s,
                   decode_wall_median_s=dec.wall_median_s,
                   x_decode_wall=dec.wall_min_s / wall if wall > 0 else float("nan"),
                   calls=t.calls)
        rows.append(row)
        if progress:
            progress(f"{name} ({engine})")
    return rows


def _skipped(name, why):
    return {"clip": name, "engine": "", "status": "skipped", "note": why}


COLUMNS = ["clip", "engine", "status", "flight_frames", "unflagged", "unflagged_frac",
           "scored", "median_px", "p95_px", "max_px", "rms_px", "fit", "fit_track",
           "fit_ref", "fit_ratio", "fit_ref_same", "track_cpu_s", "track_wall_s", "decode_cpu_s",
           "x_decode", "note", "track_cpu_median_s", "track_wall_median_s",
           "decode_cpu_median_s", "decode_wall_s", "decode_wall_median_s", "x_decode_wall",
           "calls"]


def run_scoreboard(out_dir, *, shared=None, engines=None, clips=None, quick=False,
                   progress=None, repeats=3, warmup=1):
    """Track every clip with every engine, score each, write ``bench_track_real.csv``.

    Parameters
    ----------
    out_dir : str or os.PathLike
        Folder for ``bench_track_real.csv`` and ``bench_track_real.txt`` (created).
    shared : str or os.PathLike, optional
        The folder holding ``data/real`` (default :func:`default_shared`: none, the real
        clips skipped, saying so). Its footage is read in place.
    engines : sequence of str, optional
        Engines to compare (default: all, :func:`engines_to_run`).
    clips : str, optional
        Which clips (:func:`select_clips`); default all.
    quick : bool, keyword-only
        Leave out the slow real clips (the diabolo, 410 frames at 1536 x 848, and the
        badminton cameras at 2048 x 1536), saying so.
    progress : callable, optional
        Called with a short text after each clip and engine.
    repeats : int, keyword-only
        Counted calls of decoding and of each engine per clip (1 allowed).
    warmup : int, keyword-only
        Uncounted calls of each before them (0: time cold calls).

    Returns
    -------
    pandas.DataFrame
        One row per clip and engine, and one per clip skipped (columns in the module
        notes).
    """
    from vidtrack.bench import scenes
    from vidtrack.footage import open_source

    engines = engines_to_run(engines)
    names = select_clips(clips)
    shared = Path(shared) if shared is not None else default_shared()
    rows = []
    for clip in REAL_CLIPS:
        if clip.name not in names:
            continue
        if shared is None:
            rows.append(_skipped(clip.name, "no folder of real footage given (--shared DIR, "
                                            "the folder holding data/real)"))
            continue
        real_dir = shared / "data" / "real"
        path, ref_path = real_dir / clip.footage, real_dir / clip.reference
        missing = [p for p in (path, ref_path) if not p.is_file()]
        if missing:
            rows.append(_skipped(clip.name, f"{missing[0]} is not there"))
            log.info("%s skipped: %s not there", clip.name, missing[0])
            continue
        if quick and clip.slow:
            rows.append(_skipped(clip.name, "slow clip, left out by --quick"))
            continue
        ref = clip.load(ref_path)
        target = clip.target(ref) if clip.target else None

        def open_fn(path=path, clip=clip):
            return open_source(path, fps=clip.fps, frames=clip.frames)

        rows += _rows_of(clip.name, engines, open_fn,
                         lambda tr, clip=clip, ref=ref: clip.score(tr, ref),
                         view=clip.view, target=target, progress=progress,
                         repeats=repeats, warmup=warmup)
    wanted = {}
    for n in names:
        if n.startswith("synth:"):
            scene, view = n[len("synth:"):].split("/")
            wanted.setdefault(scene, []).append(view)
    if wanted:
        with tempfile.TemporaryDirectory(prefix="vidtrack-scoreboard-") as tmp:
            for scene, views in wanted.items():
                run_dir = Path(tmp) / scene
                truth = scenes.render_scene(scene, run_dir)
                for view in views:
                    about = truth["views"][view]
                    vpath = run_dir / about["source"]

                    def open_fn(vpath=vpath, fps=about["fps"]):
                        return open_source(vpath, fps=fps)

                    rows += _rows_of(f"synth:{scene}/{view}", engines, open_fn,
                                     lambda tr, about=about: scenes.score_view(tr, about),
                                     view=view, target=None, progress=progress,
                                     repeats=repeats, warmup=warmup)
    table = pd.DataFrame(rows).reindex(columns=COLUMNS)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with atomic_path(out_dir / "bench_track_real.csv") as tmp:
        table.to_csv(tmp, index=False)
    write_text(out_dir / "bench_track_real.txt", format_scoreboard(table) + "\n")
    return table


def _num(x, fmt):
    return "" if x is None or not np.isfinite(x) else format(x, fmt)


def _calls(table):
    calls = table["calls"].dropna() if "calls" in table else ()
    return int(calls.max()) if len(calls) else 0


def format_scoreboard(table):
    """The scoreboard as text: one line per clip and engine, then the clips skipped."""
    shown, skipped, failed = [], [], []
    for _, r in table.iterrows():
        if r["status"] == "skipped":
            skipped.append(f"  skipped {r['clip']}: {r['note']}")
            continue
        line = {"clip": r["clip"], "engine": r["engine"]}
        if r["status"] == "ok":
            line.update({
                "unflagged": f"{int(r['unflagged'])}/{int(r['flight_frames'])} "
                             f"({_num(100 * r['unflagged_frac'], '.0f')}%)",
                "median px": _num(r["median_px"], ".2f"), "p95 px": _num(r["p95_px"], ".2f"),
                "max px": _num(r["max_px"], ".2f"), "rms px": _num(r["rms_px"], ".2f"),
                "fit": r["fit"], "track": _num(r["fit_track"], ".4g"),
                "ref": _num(r["fit_ref"], ".4g"), "ratio": _num(r["fit_ratio"], ".3f"),
                "ref same": _num(r["fit_ref_same"], ".4g")})
        else:
            line.update({"unflagged": r["status"]})
            failed.append(f"  {r['status']} {r['clip']} ({r['engine']}): {r['note']}")
        line.update({"cpu s": _num(r["track_cpu_s"], ".2f"),
                     "wall s": _num(r["track_wall_s"], ".2f"),
                     "x decode": _num(r["x_decode"], ".2f")})
        shown.append(line)
    cols = ["clip", "engine", "unflagged", "median px", "p95 px", "max px", "rms px", "fit",
            "track", "ref", "ratio", "ref same", "cpu s", "wall s", "x decode"]
    text = ["Tracker scoreboard: frames unflagged of the flight; distance from the "
            "reference (px);",
            "a fit's figure from the track (track), from the reference's own points (ref) "
            "and from them",
            "on the frames the track's figure used (ref same);",
            "CPU s and wall s of track() and decode-only CPU time / track CPU time (x decode),",
            f"the min of {_calls(table)} warm call(s) each, decoding and the engines in turn "
            "(CPU: threads and child processes included)", ""]
    if shown:
        width = max(len(x["clip"]) for x in shown)
        shown = pd.DataFrame(shown).reindex(columns=cols).fillna("")
        shown["clip"] = shown["clip"].str.ljust(width)
        shown["engine"] = shown["engine"].str.ljust(6)
        text.append(shown.rename(columns={"clip": "clip".ljust(width),
                                          "engine": "engine"}).to_string(index=False))
    else:
        text.append("  (no clip was run)")
    if failed or skipped:
        text += [""] + failed + skipped
    return "\n".join(text)
