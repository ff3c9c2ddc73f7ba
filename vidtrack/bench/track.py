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
slow at full size, run on the first ``alt_frames`` frames after the start.

Columns of ``bench_track.csv``: ``method``, ``fps`` (frames per second, median of
repeats), ``fps_vs_decode``, ``rms_px`` and ``max_px`` (centroid error), ``frames_scored``
(positions compared with truth), ``frames_clean`` (clean frames among those the method
ran on), ``frames_run``, ``note``.
"""

import math
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from vidtrack._atomic import atomic_path

__all__ = ["run_track_bench", "opencv_tracker", "plot_track_bench", "QUICK", "FULL"]

#: Tracker engines timed beside the default one (``vidtrack``), each a row
#: ``vidtrack (ENGINE)``.
_OTHER_ENGINES = ("flight",)

#: Footage of the quick and the full benchmark.
QUICK = {"size_px": (320, 240), "frames": 150, "alt_frames": 150, "repeats": 1}
FULL = {"size_px": (1024, 1024), "frames": 400, "alt_frames": 80, "repeats": 3}


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
    from vidtrack.footage import open_source

    t0 = time.perf_counter()
    with open_source(path, fps=fps) as src:
        n = 0
        for _ in src:
            n += 1
    return n / (time.perf_counter() - t0)


def _ours(path, fps, engine=None):
    from vidtrack.footage import open_source
    from vidtrack.track.tracker import track

    t0 = time.perf_counter()
    with open_source(path, fps=fps) as src:
        tr = track(src, view="front") if engine is None else track(src, view="front",
                                                                   engine=engine)
    rate = len(tr.data) / (time.perf_counter() - t0)
    pos = tr.data[["u_px", "v_px"]].to_numpy(dtype=float).copy()
    pos[~tr.usable] = np.nan
    return rate, pos


def _start_frame(per_frame, clean):
    idx = np.flatnonzero(clean)
    return int(idx[0])


def _trackpy(path, fps, per_frame, start, count, length_px):
    import warnings

    import trackpy

    from vidtrack.footage import open_source

    trackpy.quiet()
    diameter = 2 * int(math.ceil(0.5 * length_px)) + 3
    n = len(per_frame)
    pos = np.full((n, 2), np.nan)
    ran = np.zeros(n, bool)
    prev = per_frame.loc[start, ["u_px", "v_px"]].to_numpy(dtype=float)
    gate = 0.5 * diameter
    with open_source(path, fps=fps) as src:
        frames = [src[i] for i in range(start, min(n, start + count))]
    t0 = time.perf_counter()
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
    rate = len(frames) / (time.perf_counter() - t0)
    return rate, pos, ran, diameter


def _opencv(path, fps, per_frame, start, count, length_px):
    from vidtrack.footage import open_source

    name, factory = opencv_tracker()
    n = len(per_frame)
    pos = np.full((n, 2), np.nan)
    ran = np.zeros(n, bool)
    side = int(math.ceil(length_px)) + 4
    u, v = per_frame.loc[start, ["u_px", "v_px"]].to_numpy(dtype=float)
    box = (int(round(u - 0.5 * (side - 1))), int(round(v - 0.5 * (side - 1))), side, side)
    with open_source(path, fps=fps) as src:
        frames = [src[i] for i in range(start, min(n, start + count))]
    t0 = time.perf_counter()
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
    rate = len(frames) / (time.perf_counter() - t0)
    return name, rate, pos, ran


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


def run_track_bench(out_dir, *, quick=False):
    """Run the tracking benchmark; write ``bench_track.csv`` and ``bench_track.png``.

    Parameters
    ----------
    out_dir : str or os.PathLike
        Folder for the outputs (created).
    quick : bool, keyword-only
        320 x 240, 150 frames, one repeat (seconds) instead of 1024 x 1024, 400 frames,
        three repeats (a few minutes, mostly rendering and trackpy).

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
    with tempfile.TemporaryDirectory(prefix="vidtrack-bench-track-") as tmp:
        path, truth = _render(Path(tmp) / "run", cfg)
        fps = truth["fps"]
        per_frame = pd.DataFrame(truth["per_frame"])
        clean = _clean(per_frame)
        n = len(per_frame)
        everything = np.ones(n, bool)
        dec_rates, our_rates, other_rates = [], [], {e: [] for e in _OTHER_ENGINES}
        pos, other_pos = None, {}
        for _ in range(cfg["repeats"]):
            # (interleaved: a machine shared with other work slows each alike)
            dec_rates.append(_decode(path, fps))
            rate, pos = _ours(path, fps)
            our_rates.append(rate)
            for engine in _OTHER_ENGINES:
                rate, other_pos[engine] = _ours(path, fps, engine)
                other_rates[engine].append(rate)
        dec = statistics.median(dec_rates)
        ours = statistics.median(our_rates)
        start = _start_frame(per_frame, clean)
        length = float(per_frame.loc[start, "length_px"])
        tp_rate, tp_pos, tp_ran, diameter = _trackpy(path, fps, per_frame, start,
                                                     cfg["alt_frames"], length)
        cv_name, cv_rate, cv_pos, cv_ran = _opencv(path, fps, per_frame, start,
                                                   cfg["alt_frames"], length)
    rows = [{"method": "decode only", "fps": dec, "rms_px": float("nan"),
             "max_px": float("nan"), "frames_scored": 0, "frames_clean": int(clean.sum()),
             "frames_run": n, "note": f"{cfg['size_px'][0]}x{cfg['size_px'][1]} MJPG, "
                                      f"{n} frames"}]
    rms, mx, k, c = _score(pos, per_frame, clean, everything)
    rows.append({"method": "vidtrack", "fps": ours, "rms_px": rms, "max_px": mx,
                 "frames_scored": k, "frames_clean": c, "frames_run": n,
                 "note": "unflagged frames; background included; finds the straw itself"})
    for engine in _OTHER_ENGINES:
        rms, mx, k, c = _score(other_pos[engine], per_frame, clean, everything)
        rows.append({"method": f"vidtrack ({engine})",
                     "fps": statistics.median(other_rates[engine]), "rms_px": rms,
                     "max_px": mx, "frames_scored": k, "frames_clean": c, "frames_run": n,
                     "note": f"[track] engine = \"{engine}\"; unflagged frames"})
    rms, mx, k, c = _score(tp_pos, per_frame, clean, tp_ran)
    rows.append({"method": "trackpy.locate", "fps": tp_rate, "rms_px": rms, "max_px": mx,
                 "frames_scored": k, "frames_clean": c, "frames_run": int(tp_ran.sum()),
                 "note": f"diameter {diameter}, nearest feature; started at the truth"})
    rms, mx, k, c = _score(cv_pos, per_frame, clean, cv_ran)
    rows.append({"method": f"opencv {cv_name}", "fps": cv_rate, "rms_px": rms, "max_px": mx,
                 "frames_scored": k, "frames_clean": c, "frames_run": int(cv_ran.sum()),
                 "note": "box centre; started from the true box"})
    table = pd.DataFrame(rows)
    table.insert(2, "fps_vs_decode", table["fps"] / dec)
    with atomic_path(out_dir / "bench_track.csv") as tmp:
        table.to_csv(tmp, index=False)
    with atomic_path(out_dir / "bench_track.png") as tmp:
        plot_track_bench(table, tmp)
    return table
