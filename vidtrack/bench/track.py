"""``vidtrack bench track``: the tracker's error against its speed, beside the alternatives.

One synthetic run of ``vidtrack synth`` (front view: a straw riding the rotor, released,
flying over a textured background with machine parts and a ruler; read noise, motion
blur, MJPG compression) is read by four methods, each timed on the same file:

- ``decode only``: iterating the frames and doing nothing (the limit any tracker has);
- ``vidtrack``: :func:`vidtrack.track.tracker.track`, background included, every frame;
  ``vidtrack (flight)``: the same with ``engine="flight"``;
- ``trackpy.locate``: the feature finder of trackpy (bandpass + centroid of mass in a
  disc of the straw's length), the feature nearest the previous position each frame;
- ``opencv <name>``: an OpenCV single-object tracker (CSRT or KCF when this OpenCV has
  them, else MIL), centroid = the centre of its box.

The two alternatives are started from the true position (a user drawing a box);
vidtrack finds the straw itself. Errors are against ``truth.json`` on the frames where
the straw is in free flight, wholly in view and touches nothing else (``scored``), and
only where the method gives a position it would hand to a fit (vidtrack: unflagged
frames; the others: every position they return). trackpy and the OpenCV tracker, being
slow at full size, run on the first ``alt_frames`` frames after the start, read into
memory before they are timed.

Timing (:mod:`vidtrack.bench._timing`): decoding and the vidtrack engines are called in
turn, round by round, one warm-up round uncounted and then ``repeats`` counted rounds;
trackpy and the OpenCV tracker each ``min(3, repeats)`` counted calls after their own
warm-up. Each call's CPU time (the process's threads and its children) and wall time are
kept; the table gives their min and median and the ratios to decoding measured in the
same run.

Columns of ``bench_track.csv``: ``method``, ``fps`` (frames per second of wall time,
median of the counted calls), ``fps_vs_decode`` (``fps`` over decoding's),
``rms_px`` and ``max_px`` (centroid error), ``frames_scored`` (positions compared with
truth), ``frames_clean`` (clean frames among those the method ran on), ``frames_run``,
``note``, ``fps_cpu`` (frames per second of CPU time, min of the counted calls),
``cpu_vs_decode`` (``fps_cpu`` over decoding's: the method's speed as a share of
decoding's, 1 the limit), ``cpu_min_s``, ``cpu_median_s``, ``wall_min_s``,
``wall_median_s`` (seconds per call) and ``calls`` (counted calls).
"""

import math
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from vidtrack._atomic import atomic_path
from vidtrack.bench._timing import timed, timed_each

__all__ = ["run_track_bench", "format_track_bench", "opencv_tracker", "plot_track_bench",
           "QUICK", "FULL", "COLUMNS"]

#: Tracker engines timed beside the default one (``vidtrack``), each a row
#: ``vidtrack (ENGINE)``.
_OTHER_ENGINES = ("flight",)

#: Footage of the quick and the full benchmark.
QUICK = {"size_px": (320, 240), "frames": 150, "alt_frames": 150}
FULL = {"size_px": (1024, 1024), "frames": 400, "alt_frames": 80}
#: Most counted calls of the alternatives (slow: trackpy runs at a few frames/s).
ALT_REPEATS = 3


def opencv_tracker():
    """The best single-object tracker this OpenCV offers: (name, factory).

    CSRT and KCF live in opencv-contrib (``cv2.TrackerCSRT_create`` or
    ``cv2.legacy.TrackerCSRT_create``); the main package has MIL.
    """
    import cv2

    for name in ("CSRT", "KCF"):
        for owner in (cv2, getattr(cv2, "legacy", None)):
            factory = getattr(owner, f"Tracker{name}_create", None) if owner else None
            if factory is not None:
                return name, factory
    return "MIL", cv2.TrackerMIL_create


def _render(folder, cfg):
    from vidtrack.synth import SynthSpec, render_run

    spec = SynthSpec(size_px=cfg["size_px"], frames=cfg["frames"], views=("front",),
                     read_noise_dn=1.5, exposure_fraction=0.5, output_format="avi",
                     video_codec="mjpg", jpeg_quality=75)
    run = render_run(folder, spec)
    import json

    truth = json.loads(run.truth_path.read_text())["views"]["front"]
    return folder / truth["source"], truth


def _clean(per_frame):
    return (per_frame["fully_in_view"].to_numpy() & (per_frame["phase"] == "flight").to_numpy()
            & ~per_frame["blade_overlap"].to_numpy() & ~per_frame["overlap"].to_numpy())


def _score(pos, per_frame, clean, ran):
    """RMS and max error (px) over clean frames with a position; counts."""
    truth = per_frame[["u_px", "v_px"]].to_numpy(dtype=float)
    have = np.isfinite(pos).all(axis=1) & clean & ran
    err = np.hypot(*(pos[have] - truth[have]).T)
    rms = float(np.sqrt(np.mean(err ** 2))) if err.size else float("nan")
    mx = float(err.max()) if err.size else float("nan")
    return rms, mx, int(have.sum()), int((clean & ran).sum())


def _decode(path, fps):
    """Frames decoded iterating the source, doing nothing with them."""
    from vidtrack.footage import open_source

    with open_source(path, fps=fps) as src:
        n = 0
        for _ in src:
            n += 1
    return n


def _ours(path, fps, engine=None):
    """The track of one whole run of :func:`vidtrack.track.tracker.track` on the file."""
    from vidtrack.footage import open_source
    from vidtrack.track.tracker import track

    with open_source(path, fps=fps) as src:
        return track(src, view="front") if engine is None else track(src, view="front",
                                                                     engine=engine)


def _positions(tr):
    """The track's positions, NaN where flagged."""
    pos = tr.data[["u_px", "v_px"]].to_numpy(dtype=float).copy()
    pos[~tr.usable] = np.nan
    return pos


def _start_frame(per_frame, clean):
    idx = np.flatnonzero(clean)
    return int(idx[0])


def _frames(path, fps, start, count, n):
    """Frames ``start`` to ``start + count`` (at most ``n``) in memory."""
    from vidtrack.footage import open_source

    with open_source(path, fps=fps) as src:
        return [src[i] for i in range(start, min(n, start + count))]


def _trackpy_diameter(length_px):
    return 2 * int(math.ceil(0.5 * length_px)) + 3


def _trackpy(frames, per_frame, start, diameter):
    """trackpy.locate on each frame, the feature nearest the previous position:
    ``(positions, ran)``."""
    import warnings

    import trackpy

    trackpy.quiet()
    n = len(per_frame)
    pos = np.full((n, 2), np.nan)
    ran = np.zeros(n, bool)
    prev = per_frame.loc[start, ["u_px", "v_px"]].to_numpy(dtype=float)
    gate = 0.5 * diameter
    for k, frame in enumerate(frames):
        i = start + k
        ran[i] = True
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            f = trackpy.locate(frame, diameter, invert=False, characterize=False,
                               engine="python")
        if len(f):
            xy = f[["x", "y"]].to_numpy(dtype=float)
            d = np.hypot(*(xy - prev).T)
            j = int(np.argmin(d))
            if d[j] <= gate:
                pos[i] = xy[j]
                prev = xy[j]
    return pos, ran


def _opencv_box(per_frame, start, length_px):
    side = int(math.ceil(length_px)) + 4
    u, v = per_frame.loc[start, ["u_px", "v_px"]].to_numpy(dtype=float)
    return (int(round(u - 0.5 * (side - 1))), int(round(v - 0.5 * (side - 1))), side, side)


def _opencv(frames, factory, n, start, box):
    """An OpenCV tracker started on ``box`` in the first frame: ``(positions, ran)``."""
    pos = np.full((n, 2), np.nan)
    ran = np.zeros(n, bool)
    tracker = factory()
    tracker.init(frames[0], box)
    pos[start] = (box[0] + 0.5 * (box[2] - 1), box[1] + 0.5 * (box[3] - 1))
    ran[start] = True
    for k, frame in enumerate(frames[1:], start=1):
        i = start + k
        ran[i] = True
        ok, b = tracker.update(frame)
        if ok:
            pos[i] = (b[0] + 0.5 * (b[2] - 1), b[1] + 0.5 * (b[3] - 1))
    return pos, ran


def plot_track_bench(table, path):
    """Error against frames per second, one point per method, decode-only as a line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    dec = table[table["method"] == "decode only"]
    if len(dec):
        ax.axvline(float(dec["fps"].iloc[0]), color="0.5", ls="--", lw=1,
                   label="decode only (the limit)")
        ax.axvline(0.8 * float(dec["fps"].iloc[0]), color="0.75", ls=":", lw=1,
                   label="0.8 x decode only")
    for _, row in table[table["method"] != "decode only"].iterrows():
        if np.isfinite(row["rms_px"]):
            ax.scatter(row["fps"], row["rms_px"], s=40, zorder=3)
            ax.annotate(row["method"], (row["fps"], row["rms_px"]), textcoords="offset points",
                        xytext=(6, 4), fontsize=9)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("frames per second (this machine)")
    ax.set_ylabel("centroid RMS error against truth (px)")
    ax.set_title("Straw tracking: error against speed (vidtrack synth footage)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def _speed(timing, frames):
    """A method's timing columns for ``frames`` frames a call."""
    return {"fps": frames / timing.wall_median_s, "fps_cpu": frames / timing.cpu_min_s,
            **timing.columns()}


def run_track_bench(out_dir, *, quick=False, repeats=3, warmup=1):
    """Run the tracking benchmark; write ``bench_track.csv`` and ``bench_track.png``.

    Parameters
    ----------
    out_dir : str or os.PathLike
        Folder for the outputs (created).
    quick : bool, keyword-only
        320 x 240, 150 frames (seconds) instead of 1024 x 1024, 400 frames (a few
        minutes, mostly rendering and trackpy).
    repeats : int, keyword-only
        Counted calls of decoding and of each vidtrack engine (round by round); trackpy
        and the OpenCV tracker make ``min(3, repeats)``.
    warmup : int, keyword-only
        Uncounted calls of each before them (0: time cold calls).

    Returns
    -------
    pandas.DataFrame
        One row per method (columns in the module notes).
    """
    import importlib.util

    from vidtrack.errors import VidtrackError

    if importlib.util.find_spec("trackpy") is None:
        raise VidtrackError("vidtrack bench track compares against trackpy, which is not "
                            "installed: pip install 'vidtrack[bench]'")
    cfg = QUICK if quick else FULL
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    alt_repeats = min(ALT_REPEATS, repeats)
    with tempfile.TemporaryDirectory(prefix="vidtrack-bench-track-") as tmp:
        path, truth = _render(Path(tmp) / "run", cfg)
        fps = truth["fps"]
        per_frame = pd.DataFrame(truth["per_frame"])
        clean = _clean(per_frame)
        n = len(per_frame)
        everything = np.ones(n, bool)
        # decoding and the engines in turn, round by round: a machine shared with other
        # work slows each alike
        runs = {"decode only": lambda: _decode(path, fps), "vidtrack": lambda: _ours(path, fps)}
        runs.update({f"vidtrack ({e})": (lambda e=e: _ours(path, fps, e))
                     for e in _OTHER_ENGINES})
        times = timed_each(runs, repeats=repeats, warmup=warmup)
        start = _start_frame(per_frame, clean)
        length = float(per_frame.loc[start, "length_px"])
        frames = _frames(path, fps, start, cfg["alt_frames"], n)
        diameter = _trackpy_diameter(length)
        tp = timed(lambda: _trackpy(frames, per_frame, start, diameter),
                   repeats=alt_repeats, warmup=warmup)
        cv_name, factory = opencv_tracker()
        box = _opencv_box(per_frame, start, length)
        cv = timed(lambda: _opencv(frames, factory, n, start, box), repeats=alt_repeats,
                   warmup=warmup)
    dec = times["decode only"]
    rows = [{"method": "decode only", **_speed(dec, dec.result), "rms_px": float("nan"),
             "max_px": float("nan"), "frames_scored": 0, "frames_clean": int(clean.sum()),
             "frames_run": n, "note": f"{cfg['size_px'][0]}x{cfg['size_px'][1]} MJPG, "
                                      f"{n} frames"}]
    tr = times["vidtrack"].result
    rms, mx, k, c = _score(_positions(tr), per_frame, clean, everything)
    rows.append({"method": "vidtrack", **_speed(times["vidtrack"], len(tr.data)),
                 "rms_px": rms, "max_px": mx, "frames_scored": k, "frames_clean": c,
                 "frames_run": n,
                 "note": "unflagged frames; background included; finds the straw itself"})
    for engine in _OTHER_ENGINES:
        t = times[f"vidtrack ({engine})"]
        rms, mx, k, c = _score(_positions(t.result), per_frame, clean, everything)
        rows.append({"method": f"vidtrack ({engine})", **_speed(t, len(t.result.data)),
                     "rms_px": rms, "max_px": mx, "frames_scored": k, "frames_clean": c,
                     "frames_run": n,
                     "note": f"[track] engine = \"{engine}\"; unflagged frames"})
    tp_pos, tp_ran = tp.result
    rms, mx, k, c = _score(tp_pos, per_frame, clean, tp_ran)
    rows.append({"method": "trackpy.locate", **_speed(tp, len(frames)), "rms_px": rms,
                 "max_px": mx, "frames_scored": k, "frames_clean": c,
                 "frames_run": int(tp_ran.sum()),
                 "note": f"diameter {diameter}, nearest feature; started at the truth"})
    cv_pos, cv_ran = cv.result
    rms, mx, k, c = _score(cv_pos, per_frame, clean, cv_ran)
    rows.append({"method": f"opencv {cv_name}", **_speed(cv, len(frames)), "rms_px": rms,
                 "max_px": mx, "frames_scored": k, "frames_clean": c,
                 "frames_run": int(cv_ran.sum()),
                 "note": "box centre; started from the true box"})
    table = pd.DataFrame(rows)
    table["fps_vs_decode"] = table["fps"] / table["fps"].iloc[0]
    table["cpu_vs_decode"] = table["fps_cpu"] / table["fps_cpu"].iloc[0]
    table = table.reindex(columns=COLUMNS)
    with atomic_path(out_dir / "bench_track.csv") as tmp:
        table.to_csv(tmp, index=False)
    with atomic_path(out_dir / "bench_track.png") as tmp:
        plot_track_bench(table, tmp)
    return table


#: Columns of ``bench_track.csv`` (the module notes say what each is).
COLUMNS = ["method", "fps", "fps_vs_decode", "rms_px", "max_px", "frames_scored",
           "frames_clean", "frames_run", "note", "fps_cpu", "cpu_vs_decode", "cpu_min_s",
           "cpu_median_s", "wall_min_s", "wall_median_s", "calls"]


def format_track_bench(table):
    """The benchmark as text: what was timed, then one line per method."""
    calls = table.set_index("method")["calls"]
    head = [f"Tracking {int(table['frames_run'].iloc[0])} frames: speed against decoding "
            f"them, measured in the same run (warm calls: {int(calls.iloc[0])} counted "
            f"of decoding and vidtrack, {int(calls.iloc[-1])} of the alternatives);",
            "fps_cpu and cpu_vs_decode by CPU time (min of the calls; threads and child "
            "processes included), fps and fps_vs_decode by wall time (median);",
            "centroid error against truth (px) on the clean frames scored", ""]
    shown = table.drop(columns=["note", "calls"]).copy()
    for col in ("fps", "fps_cpu"):
        shown[col] = shown[col].map(lambda v: f"{v:.0f}" if v >= 100 else f"{v:.3g}")
    for col in ("fps_vs_decode", "cpu_vs_decode"):
        shown[col] = shown[col].map(lambda v: f"{v:.3g}x")
    for col in ("rms_px", "max_px"):
        shown[col] = shown[col].map(lambda v: "" if not np.isfinite(v) else f"{v:.3g}")
    for col in ("cpu_min_s", "cpu_median_s", "wall_min_s", "wall_median_s"):
        shown[col] = shown[col].map(lambda v: f"{v:.3g}")
    shown = shown[["method", "fps_cpu", "cpu_vs_decode", "fps", "fps_vs_decode",
                   "cpu_min_s", "cpu_median_s", "wall_min_s", "wall_median_s", "rms_px",
                   "max_px", "frames_scored", "frames_clean", "frames_run"]]
    notes = [f"  {m}: {note}" for m, note in zip(table["method"], table["note"])]
    return "\n".join(head + [shown.to_string(index=False), ""] + notes)
