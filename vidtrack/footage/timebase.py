"""Time base checks: capture vs container rate, time stamps, duplicated and dropped frames.

A tracker fed the wrong time base fits nonsense with perfect confidence, so every
source's clock is checked before it is trusted:

- the capture rate (``scene.toml`` fps) against the rate the container claims:
  exported high-speed videos carry a playback rate (30 fps) instead of the capture
  rate (1200 fps);
- per-image time stamps (.cine) against the nominal rate: a camera or a save that
  decimated shows stamps every k nominal intervals; gaps in the stamps are dropped
  frames;
- duplicated frames: an exported video that repeats a frame holds a bit-identical (or,
  after re-encoding, nearly identical) copy, whereas two genuine frames of even a
  static scene differ by sensor noise everywhere.

Dropped frames can only be found from time stamps; a video without them cannot show a
drop (its frames are evenly timed by construction).
"""

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "FrameDifferences",
    "StampCheck",
    "TimeBaseReport",
    "check_time_base",
    "check_time_stamps",
    "compare_rates",
    "stamp_rate",
    "estimate_noise_sigma",
    "find_duplicates",
    "frame_differences",
]

#: Relative difference at which two rates are said to disagree.
RATE_RTOL = 0.005
#: An interval longer than this many median intervals is a gap (dropped frames).
GAP_FACTOR = 1.5
#: Mean |difference| of two independent N(0, sigma^2) noise images, in units of sigma.
_NOISE_MAD = 2.0 / math.sqrt(math.pi)


def stamp_rate(times_s):
    """Frame rate that time stamps show: 1 / mean ordinary interval (frames/s).

    Parameters
    ----------
    times_s : array_like
        Time of every frame in s, in frame order.

    Returns
    -------
    float or None
        None with fewer than two increasing stamps.

    Notes
    -----
    Ordinary intervals are the increasing ones up to ``GAP_FACTOR`` (1.5) median
    intervals: gaps (dropped frames) are left out. The mean, not the median, averages
    out stamps quantised to a microsecond, whose single intervals jitter by one tick.
    """
    steps = np.diff(np.asarray(times_s, dtype=np.float64))
    steps = steps[steps > 0]
    if steps.size == 0:
        return None
    ordinary = steps[steps <= GAP_FACTOR * np.median(steps)]
    return float(1.0 / np.mean(ordinary))


def compare_rates(capture_fps, container_fps, *, rtol=RATE_RTOL):
    """Say whether the capture rate and the container's rate disagree.

    Parameters
    ----------
    capture_fps : float or None
        The capture rate given by the user (frames/s).
    container_fps : float or None
        The rate the file claims (frames/s).
    rtol : float, optional
        Relative tolerance.

    Returns
    -------
    str or None
        A one-sentence warning, or None when they agree or one is unknown.
    """
    if not capture_fps or not container_fps:
        return None
    ratio = capture_fps / container_fps
    if abs(ratio - 1.0) <= rtol:
        return None
    return (f"the container claims {container_fps:g} fps but the capture rate is {capture_fps:g} "
            f"fps (ratio {ratio:.4g}); times use the capture rate")


@dataclass(frozen=True)
class StampCheck:
    """Per-image time stamps checked against the nominal rate.

    Attributes
    ----------
    fps_nominal : float or None
        The rate the stamps were checked against (frames/s).
    fps_time_stamps : float or None
        The rate the stamps show: 1 / mean ordinary interval (frames/s).
    interval_s : float or None
        Median interval between consecutive stamps (s).
    decimation : int or None
        k >= 2 when the stamps are k nominal intervals apart (the camera or the save
        kept every k-th image); 1 when they match the nominal rate; None when they
        match no whole multiple or no nominal rate is known.
    dropped : tuple of (int, int)
        ``(i, missing)``: between frames ``i - 1`` and ``i``, ``missing`` frames are
        absent (an interval of ``missing + 1`` median intervals).
    not_increasing : tuple of int
        Frames ``i`` whose stamp is not after frame ``i - 1``'s.
    warnings : tuple of str
    """

    fps_nominal: float | None
    fps_time_stamps: float | None
    interval_s: float | None
    decimation: int | None
    dropped: tuple = ()
    not_increasing: tuple = ()
    warnings: tuple = ()

    def to_dict(self):
        return {
            "fps_nominal": self.fps_nominal,
            "fps_time_stamps": self.fps_time_stamps,
            "interval_s": self.interval_s,
            "decimation": self.decimation,
            "dropped": [{"frame": i, "missing": m} for i, m in self.dropped],
            "not_increasing": list(self.not_increasing),
            "warnings": list(self.warnings),
        }


def check_time_stamps(times_s, *, nominal_fps=None, rtol=RATE_RTOL):
    """Check per-image time stamps for gaps, disorder and agreement with a nominal rate.

    Parameters
    ----------
    times_s : array_like
        Time of every frame in s (any origin), in frame order.
    nominal_fps : float, optional
        The rate the camera was set to (setup FrameRate) or the user gave (frames/s).
    rtol : float, optional
        Relative tolerance for rates and whole multiples of the nominal interval.

    Returns
    -------
    StampCheck

    Notes
    -----
    The reference interval is the median interval, so a decimated recording is not
    mistaken for one gap per frame. Intervals over ``GAP_FACTOR`` (1.5) reference
    intervals are gaps; ``round(gap / interval) - 1`` frames are counted missing.
    The rate is 1 / mean of the ordinary (non-gap, increasing) intervals, which
    averages out stamps quantised to microseconds.
    """
    t = np.asarray(times_s, dtype=np.float64)
    warnings = []
    if t.size < 2:
        return StampCheck(nominal_fps, None, None, None, warnings=("fewer than two stamps",))
    steps = np.diff(t)
    backwards = tuple(int(i) + 1 for i in np.flatnonzero(steps <= 0))
    if backwards:
        warnings.append(f"time stamps do not increase at {len(backwards)} frame(s), first at "
                        f"frame {backwards[0]}")
    positive = steps[steps > 0]
    if positive.size == 0:
        return StampCheck(nominal_fps, None, None, None, (), backwards, tuple(warnings))
    interval = float(np.median(positive))
    gap = steps > GAP_FACTOR * interval
    dropped = tuple((int(i) + 1, int(round(steps[i] / interval)) - 1)
                    for i in np.flatnonzero(gap))
    dropped = tuple((i, m) for i, m in dropped if m >= 1)
    if dropped:
        total = sum(m for _, m in dropped)
        warnings.append(f"time stamps show {total} dropped frame(s) in {len(dropped)} gap(s), "
                        f"first before frame {dropped[0][0]}")
    fps_stamps = stamp_rate(t)
    decimation = None
    if nominal_fps:
        ratio = nominal_fps / fps_stamps
        k = int(round(ratio))
        if abs(ratio - 1.0) <= rtol:
            decimation = 1
        elif k >= 2 and abs(ratio - k) <= rtol * k:
            decimation = k
            warnings.append(
                f"time stamps are {k} nominal intervals apart ({fps_stamps:.6g} fps against the "
                f"nominal {nominal_fps:g} fps): the recording was decimated by {k}; times come "
                "from the stamps")
        else:
            warnings.append(f"time stamps give {fps_stamps:.6g} fps but the nominal rate is "
                            f"{nominal_fps:g} fps (ratio {ratio:.4g}); times come from the stamps")
    return StampCheck(nominal_fps, fps_stamps, interval, decimation, dropped, backwards,
                      tuple(warnings))


def estimate_noise_sigma(frame):
    """Robust estimate of the sensor noise standard deviation of one frame.

    Parameters
    ----------
    frame : numpy.ndarray
        A 2-D grey frame.

    Returns
    -------
    float
        Noise sigma in grey levels.

    Notes
    -----
    Immerkaer's operator (J. Immerkaer, Fast noise variance estimation, CVIU 64, 1996):
    the 3x3 kernel ``[[1, -2, 1], [-2, 4, -2], [1, -2, 1]]`` cancels smooth image
    content and turns white noise of std sigma into noise of std ``6 sigma``. The
    median of its magnitude (``0.6745 * 6 sigma`` for Gaussian noise) rather than the
    mean keeps edges and texture, which cover a minority of pixels, from inflating
    the estimate. Frames smaller than 3x3 give 0.
    """
    f = np.asarray(frame, dtype=np.float32)
    if f.ndim != 2 or min(f.shape) < 3:
        return 0.0
    lap = (f[:-2, :-2] - 2 * f[:-2, 1:-1] + f[:-2, 2:]
           - 2 * f[1:-1, :-2] + 4 * f[1:-1, 1:-1] - 2 * f[1:-1, 2:]
           + f[2:, :-2] - 2 * f[2:, 1:-1] + f[2:, 2:])
    values = np.abs(lap).ravel()
    step = max(1, values.size // 65536)
    return float(np.median(values[::step])) / (0.6745 * 6.0)


@dataclass(frozen=True)
class FrameDifferences:
    """Differences between consecutive frames, from one streaming pass.

    Attributes
    ----------
    mean_abs_diff : numpy.ndarray
        ``(n - 1,)``: mean |frame i - frame i-1| in grey levels, at position ``i - 1``.
    identical : numpy.ndarray of bool
        ``(n - 1,)``: frame i is bit-identical to frame i-1.
    noise_sigma : numpy.ndarray
        ``(n,)``: :func:`estimate_noise_sigma` of every frame.
    flat : numpy.ndarray of bool
        ``(n,)``: the frame is one constant value (no information: black, saturated).
    """

    mean_abs_diff: np.ndarray = field(repr=False)
    identical: np.ndarray = field(repr=False)
    noise_sigma: np.ndarray = field(repr=False)
    flat: np.ndarray = field(repr=False)


def frame_differences(frames):
    """Compare every frame with the one before, holding two frames at a time.

    Parameters
    ----------
    frames : iterable of numpy.ndarray
        2-D grey frames (a :class:`~vidtrack.footage.base.FrameSource` streams them).

    Returns
    -------
    FrameDifferences
    """
    mad, same, sigma, flat = [], [], [], []
    prev = None
    for frame in frames:
        frame = np.asarray(frame)
        sigma.append(estimate_noise_sigma(frame))
        flat.append(bool(frame.size == 0 or frame.min() == frame.max()))
        if prev is not None:
            if prev.shape != frame.shape:
                raise ValueError(f"frame {len(sigma) - 1} has shape {frame.shape}, the one "
                                 f"before {prev.shape}")
            equal = bool(np.array_equal(prev, frame))
            same.append(equal)
            mad.append(0.0 if equal else float(
                np.mean(np.abs(frame.astype(np.int64) - prev.astype(np.int64)))))
        prev = frame
    return FrameDifferences(np.array(mad, dtype=np.float64), np.array(same, dtype=bool),
                            np.array(sigma, dtype=np.float64), np.array(flat, dtype=bool))


def find_duplicates(diffs, *, ratio=0.1):
    """Frames that repeat the frame before them.

    Parameters
    ----------
    diffs : FrameDifferences
        From :func:`frame_differences`.
    ratio : float, optional
        A frame is a near-duplicate when its mean |difference| to the frame before is
        below ``ratio`` times what sensor noise alone gives between two genuine frames
        (``2 / sqrt(pi) * sigma``, sigma from :func:`estimate_noise_sigma`).

    Returns
    -------
    tuple of int
        Indices ``i`` (>= 1) such that frame ``i`` duplicates frame ``i - 1``.

    Notes
    -----
    A bit-identical pair is a duplicate unless the frames are flat (one constant
    value, e.g. black before the light comes on). Two genuine frames of a static scene
    differ by about ``1.13 sigma`` per pixel on average; an exported copy differs by
    nothing, or after lossy re-encoding by much less than that. Illumination flicker
    only adds to the difference, so it cannot make a genuine frame look duplicated.
    """
    out = []
    for j, (mad, same) in enumerate(zip(diffs.mean_abs_diff, diffs.identical)):
        i = j + 1
        if diffs.flat[i] and diffs.flat[j]:
            continue
        sigma = 0.5 * (diffs.noise_sigma[i] + diffs.noise_sigma[j])
        if same or mad < ratio * _NOISE_MAD * sigma:
            out.append(i)
    return tuple(out)


@dataclass(frozen=True)
class TimeBaseReport:
    """What a source's clock is and what looks wrong with it.

    Attributes
    ----------
    source : str
        The path.
    frames : int
    time_source : str
        ``"time stamps"``, ``"fps"`` (given), ``"container"`` or ``"none"``.
    fps, fps_container, fps_time_stamps : float or None
        The capture rate used, the container's claim, the rate the stamps show.
    stamps : StampCheck or None
        The stamp check, for sources with per-image time stamps.
    drops_checked : bool
        Whether dropped frames could be looked for (only with time stamps).
    duplicates : tuple of int or None
        Frames that repeat the one before (None: not scanned).
    warnings : tuple of str
    """

    source: str
    frames: int
    time_source: str
    fps: float | None
    fps_container: float | None
    fps_time_stamps: float | None
    stamps: StampCheck | None
    drops_checked: bool
    duplicates: tuple | None
    warnings: tuple = ()

    @property
    def dropped(self):
        return () if self.stamps is None else self.stamps.dropped

    @property
    def decimation(self):
        return None if self.stamps is None else self.stamps.decimation

    def to_dict(self):
        return {
            "source": self.source,
            "frames": self.frames,
            "time_source": self.time_source,
            "fps": self.fps,
            "fps_container": self.fps_container,
            "fps_time_stamps": self.fps_time_stamps,
            "stamps": None if self.stamps is None else self.stamps.to_dict(),
            "drops_checked": self.drops_checked,
            "dropped": [{"frame": i, "missing": m} for i, m in self.dropped],
            "duplicates": None if self.duplicates is None else list(self.duplicates),
            "warnings": list(self.warnings),
        }


def check_time_base(source, *, duplicates=True, ratio=0.1):
    """Check the time base of a frame source.

    Parameters
    ----------
    source : vidtrack.footage.base.FrameSource
        An open source.
    duplicates : bool, optional
        Scan the frames for duplicates (one streaming pass over the footage).
    ratio : float, optional
        Near-duplicate threshold of :func:`find_duplicates`.

    Returns
    -------
    TimeBaseReport

    Notes
    -----
    The nominal rate for time stamps is the given capture fps if any, else the setup
    FrameRate. Frame indices in the report are source indices.
    """
    warnings = list(source.notes)
    given = source.fps_given
    container = source.fps_container
    if source.kind == "cine":
        if given and container and abs(given / container - 1.0) > RATE_RTOL:
            warnings.append(f"the given capture rate {given:g} fps differs from the .cine setup "
                            f"FrameRate {container:g} fps")
    else:
        note = compare_rates(given, container)
        if note:
            warnings.append(note)
        if given is None and source.kind == "video" and container:
            warnings.append(f"no capture rate given: times use the container's {container:g} fps, "
                            "which for an exported high-speed video is usually a playback rate")
    if source.time_source == "none":
        warnings.append("no frame rate is known: give the capture rate")
    stamps = None
    stamp_times = getattr(source, "trigger_times_s", None)
    if stamp_times is not None:
        stamps = check_time_stamps(stamp_times, nominal_fps=given or container)
        warnings.extend(stamps.warnings)
    dups = None
    if duplicates:
        dups = find_duplicates(frame_differences(source), ratio=ratio)
        if dups:
            warnings.append(f"{len(dups)} frame(s) repeat the frame before them, first frame "
                            f"{dups[0]}")
    return TimeBaseReport(
        source=str(source.path), frames=len(source), time_source=source.time_source,
        fps=source.fps, fps_container=container,
        fps_time_stamps=None if stamps is None else stamps.fps_time_stamps,
        stamps=stamps, drops_checked=stamps is not None, duplicates=dups,
        warnings=tuple(warnings))
