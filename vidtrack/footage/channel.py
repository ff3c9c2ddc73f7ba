"""Which grey image a source gives of colour footage (``scene.toml`` ``views.<v>.channel``).

An object that differs from its background in colour but not in brightness (a red
straw on a green board of the same luma) is invisible in the luma. A source opened with
``channel="red"``, ``"green"`` or ``"blue"`` gives that channel of every frame instead;
with ``channel="auto"`` it chooses, when it is opened, the one of luma, red, green and
blue in which moving things stand out most from the static background, by
:func:`settle_channel`:

- frames spread evenly over the source's range (25, fewer when their decoded colour
  frames would take more than 256 MiB; at least 3), read with the source's own random
  access, and the frame after every other one of them (all read forwards);
- for each candidate: the background is the per-pixel median of the samples (the upper
  one of an even count); the noise is the robust standard deviation of a pixel over
  time, ``1.4826 * median(|f[i+1] - f[i]|) / sqrt(2)`` over each pair of consecutive
  frames (the median over the pairs, at least 0.5 grey level: an integer image cannot
  show less);
- the score is the mean over the samples of the 16th largest ``|frame - background| /
  noise``: how far above the noise the brightest 16 pixels of whatever moves stand
  out (a fixed count of pixels, not a percentile, so that a small object in a large
  frame counts);
- the highest score wins (ties: the earlier of luma, red, green, blue), but a colour
  channel only when it scores at least 1.5 times the luma (an object of many colours,
  such as a plush toy, stands out about as well in any channel and loses parts in a
  single one); the choice and every score go into the source's ``notes``. The choice
  is deterministic.

``"auto"`` never chooses ``"chroma"`` (``max(R, G, B) - min(R, G, B)``), which a user
names for a coloured object before grey surroundings; it is not among the candidates
because what stands out more is not always followed better: on the bear drop under a
yellow balloon the pair shows whole in the chroma, one long object that the tracker
takes for a rod and loses for 65 of 70 frames (the luma keeps 56 usable), while on the
bear alone, before a grey wall, the chroma follows it 0.96 px RMS from the group's own
track against 2.3 px in the luma.

Grey footage (one channel, or three equal channels as some containers store grey) has
no colour: ``"auto"`` reads it as luma, a colour channel is refused with a
:class:`~vidtrack.errors.SourceError` naming the file.

The statistics are written out here rather than taken from :mod:`vidtrack.track.background`
(the tracker's, more elaborate): footage is read before anything is tracked, and this
package imports nothing of the tracker. The conversion to grey is the source's
(:func:`vidtrack.footage.base.to_grey`, passed in: that module imports this one).
"""

import numpy as np

from vidtrack.errors import SourceError

__all__ = ["CANDIDATES", "is_grey", "settle_channel"]

#: What ``"auto"`` chooses among, in order of preference on a tie.
CANDIDATES = ("luma", "red", "green", "blue")
#: Frames ``"auto"`` samples, at most.
_SAMPLES = 25
#: Largest size (bytes) of the decoded frames ``"auto"`` keeps at once.
_SAMPLE_BYTES = 256 * 2 ** 20
#: Frames checked before a colour channel of footage whose first frame is grey is refused.
_GREY_CHECKS = 5
#: The score of a frame: the TOP_PX-th largest deviation from the background.
_TOP_PX = 16
_MAD_TO_SIGMA = 1.4826
#: A channel other than the luma is chosen only when it scores this many times the luma.
_CLEARLY = 1.5


def is_grey(image):
    """True when a decoded frame has no colour: one channel, or B, G and R within one
    level of each other at every pixel."""
    if image.ndim == 2 or image.shape[2] == 1:
        return True
    b, g, r = (image[:, :, i].astype(np.int32) for i in range(3))
    return bool(np.abs(b - g).max() <= 1 and np.abs(g - r).max() <= 1)


def _spread(start, stop, count):
    """Up to ``count`` file indices spread evenly over ``start .. stop - 1``."""
    return np.unique(np.round(np.linspace(start, stop - 1, min(count, stop - start))).astype(int))


def _candidate(convert, image, channel):
    """A decoded frame as candidate ``channel`` sees it (a one-channel frame is every one)."""
    single = image.ndim == 2 or image.shape[2] == 1
    return convert(image) if single else convert(image, channel)


def _order_stat(values, k):
    """The ``k``-th smallest (0-based) of non-negative integers: exact, by counting."""
    return int(np.searchsorted(np.cumsum(np.bincount(values.reshape(-1))), k + 1))


def _pair_noise(a, b):
    """Noise sigma (grey levels) of one pixel from two consecutive frames."""
    d = np.abs(b.astype(np.int32) - a)
    mad = _order_stat(d, (d.size - 1) // 2)
    if mad == 0:       # quantised, nearly noiseless: the mean sees the pixels that flip
        return max(0.5, float(np.mean(d)) / np.sqrt(2.0 / np.pi) / np.sqrt(2.0))
    return max(0.5, _MAD_TO_SIGMA * mad / np.sqrt(2.0))


def _score(frames, noise):
    """Mean over ``frames`` of the _TOP_PX-th largest |frame - median| / noise."""
    middle = len(frames) // 2
    background = np.partition(np.stack(frames, axis=-1), middle, axis=-1)[..., middle]
    background = background.astype(np.int32)
    top = [_order_stat(d, d.size - min(_TOP_PX, d.size))
           for d in (np.abs(f.astype(np.int32) - background) for f in frames)]
    return float(np.mean(top)) / noise


def _grey_refused(source, channel, first):
    why = ("one channel" if first.ndim == 2 or first.shape[2] == 1 else
           "three equal channels in every frame checked")
    return SourceError(
        f"{source.path}: channel \"{channel}\" takes the "
        f"{'chroma' if channel == 'chroma' else channel + ' channel'} of colour "
        f"footage, but this {source.kind} is grey ({why}); expected channel = \"luma\" "
        "or \"auto\" for grey footage")


def settle_channel(source, channel, convert):
    """The channel a source opened with ``channel`` gives.

    Parameters
    ----------
    source : vidtrack.footage.base.FrameSource
        A source set up to read its range, whose frames are still luma.
    channel : str
        ``"red"``, ``"green"``, ``"blue"``, ``"chroma"`` or ``"auto"``.
    convert : callable
        ``convert(image, channel="luma")``: a decoded frame to grey
        (:func:`vidtrack.footage.base.to_grey`).

    Returns
    -------
    (str, dict or None, tuple of str)
        The channel in effect, each candidate's score (``"auto"`` on colour footage;
        else None) and notes for the source.

    Raises
    ------
    SourceError
        A colour channel of grey footage (the message names the file).
    """
    start, stop = int(source.frame_numbers[0]), int(source.frame_numbers[-1]) + 1
    first = source._raw_frame(start)
    grey = is_grey(first) and (first.ndim == 2 or first.shape[2] == 1 or all(
        is_grey(source._raw_frame(int(k))) for k in _spread(start, stop, _GREY_CHECKS)[1:]))
    if channel != "auto":
        if grey:
            raise _grey_refused(source, channel, first)
        return channel, None, ()
    if grey:
        return "luma", None, ("channel auto: the footage is grey; read as luma",)
    count = int(np.clip(_SAMPLE_BYTES // max(first.nbytes, 1), 3, _SAMPLES))
    samples, noise, after = [], {c: [] for c in CANDIDATES}, None
    for j, k in enumerate(int(k) for k in _spread(start, stop, count)):
        # in order, never back: a video that cannot seek is not decoded from its start again
        image = (first if k == start else after[1] if after and after[0] == k else
                 source._raw_frame(k))
        samples.append(image)
        after = None
        if j % 2 == 0 and k + 1 < stop:
            after = (k + 1, source._raw_frame(k + 1))
            for c in CANDIDATES:
                noise[c].append(_pair_noise(_candidate(convert, image, c),
                                            _candidate(convert, after[1], c)))
    scores = {c: _score([_candidate(convert, s, c) for s in samples],
                        float(np.median(noise[c] or [0.5]))) for c in CANDIDATES}
    best = max(CANDIDATES, key=scores.get)         # the first of equal scores
    if best != "luma" and not scores[best] >= _CLEARLY * scores["luma"]:
        # a channel only somewhat better than the luma shows less of an object of many
        # colours (on the bear clips 1.03 and 1.16 times the luma's score lost 25 and
        # 9 of their 38 and 49 usable frames)
        best = "luma"
    said = ", ".join(f"{c} {scores[c]:.3g}" for c in CANDIDATES)
    return best, scores, (f"channel auto: {best} (a colour channel is taken when moving "
                          f"things stand out at least {_CLEARLY:g} times as much as in the "
                          f"luma; scores, the mean over {len(samples)} frames of the {_TOP_PX}th "
                          f"largest |frame - background| / noise: {said})",)
