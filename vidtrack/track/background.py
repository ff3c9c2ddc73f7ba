"""The static background of a view and the noise level the tracker's threshold comes from.

The cameras ride on the machine, so everything but the straw (machine parts, the
ruler, the textured backdrop) is static: the per-pixel median of frames sampled far
enough apart absorbs it, as long as the straw covers any one pixel in fewer than half of
the samples. The noise is measured, not assumed:

- ``noise_sigma``: the robust standard deviation of one pixel's value over time,
  ``1.4826 * median(|f[i+1] - f[i]|) / sqrt(2)`` over consecutive frames (MAD of frame
  differences; moving objects touch too few pixels to move the median);
- ``noise_map``: per pixel, ``1.4826 * median_k |f_k[i+1] - f_k[i]| / sqrt(2)`` over
  pairs of consecutive frames, which is larger where compression rings around sharp
  static edges (the ruler's ticks, machine parts) than in flat areas, but, unlike the
  spread of the samples about the median, not where the blade passes often.

- ``edge_noise``: compressed and phone footage (and a camera that shakes by a fraction of
  a pixel) changes pixels more where the scene has edges and texture: the extra noise is
  measured against the local gradient on a sparse grid of the sampled frames, the spread
  of each pixel about the median beyond the flat areas' noise; none for a static camera
  with only sensor noise. The same spread in flat areas is a floor under
  ``noise_sigma``: compressed video repeats blocks exactly from frame to frame (no
  difference, no noise by the first measure) and moves them by a few grey levels against
  the background at each refresh (:func:`sample_spread`).

The segmentation threshold of a pixel is
``k * sqrt(max(noise_sigma, noise_map)^2 + edge(g)^2)`` (``edge(g)`` the edge noise at
the background's gradient magnitude g, the largest in the pixel's 3 x 3 neighbourhood) times
``sqrt(1 + 1.57/n)`` for the background's own noise (:meth:`Background.threshold`).

Example
-------
>>> from vidtrack.footage import open_source                         # doctest: +SKIP
>>> from vidtrack.track.background import sample_background          # doctest: +SKIP
>>> with open_source("run42/front.avi", fps=1200) as src:      # doctest: +SKIP
...     bg = sample_background(src, samples=25)
...     print(bg.noise_sigma, bg.threshold(k=5.0).mean())
"""

from dataclasses import dataclass, replace

import numpy as np

from vidtrack.errors import TrackError

__all__ = ["Background", "estimate_background", "sample_background", "measure_noise",
           "median_images", "sample_indices", "sample_spread", "gradient_max3", "MAD_TO_SIGMA",
           "without_object", "STOOD_SHARE", "MIN_LEFT"]

#: Factor from a median absolute deviation to the standard deviation of a normal law.
MAD_TO_SIGMA = 1.482602218505602


#: A pixel the object covers in at least this share of the background's samples is
#: taken again from the samples that show it without the object (:func:`without_object`):
#: the median is the object's where it stood in half the samples or more, and leans
#: towards it from about a quarter.
STOOD_SHARE = 0.25

#: The fewest samples without the object a pixel is taken again from; where fewer show
#: it, no sample shows the background there (the pixel is ``held``).
MIN_LEFT = 2


@dataclass(frozen=True, eq=False)
class Background:
    """A view's static background and its noise.

    Attributes
    ----------
    image : numpy.ndarray
        ``(rows, cols)`` float32: the per-pixel median of the sampled frames, in the
        footage's grey levels.
    noise_sigma : float
        Robust standard deviation of a static pixel over time (grey levels), from frame
        differences (:func:`measure_noise`). At least half a grey level (quantisation).
    noise_map : numpy.ndarray
        ``(rows, cols)`` float32: per-pixel robust noise from consecutive-frame
        differences (grey levels), at most 5 x ``noise_sigma``.
    n_samples : int
        How many frames the median was taken over.
    frames : tuple of int
        Source indices of the sampled frames (empty when not known).
    dtype : numpy.dtype
        The footage's pixel type (``uint8`` or ``uint16``).
    edge_noise : tuple of (float, float)
        Noise that grows with the scene's gradient: pairs ``(g, extra)``, the gradient
        magnitude (grey levels/px) and the extra noise there (grey levels), interpolated
        between them (:func:`sample_spread`). Empty for a static camera with sensor
        noise only; compressed phone footage has some.
    """

    image: np.ndarray
    noise_sigma: float
    noise_map: np.ndarray
    n_samples: int
    frames: tuple = ()
    dtype: np.dtype = np.dtype(np.uint8)
    edge_noise: tuple = ()

    def __repr__(self):
        jit = (f", edge_noise={max(e for _, e in self.edge_noise):.3g}"
               if self.edge_noise else "")
        return (f"Background(shape={tuple(self.image.shape)}, noise_sigma={self.noise_sigma:.3g}"
                f"{jit}, n_samples={self.n_samples}, dtype={np.dtype(self.dtype).name})")

    @property
    def shape(self):
        """``(rows, cols)`` of the background."""
        return self.image.shape

    def threshold(self, *, k=5.0):
        """Per-pixel segmentation threshold in grey levels (float32 array).

        Parameters
        ----------
        k : float, optional
            Multiple of the noise; 5 keeps false pixels to about one in 10^6 for
            Gaussian noise.

        Returns
        -------
        numpy.ndarray
            ``k * sqrt(max(noise_sigma, noise_map)^2 + edge(g)^2) * sqrt(1 +
            1.57 / n_samples)``, ``edge(g)`` the :attr:`edge_noise` at the background's
            gradient magnitude g (largest in the 3 x 3 neighbourhood): the difference of
            a frame and a median of n samples has that extra variance (the median's
            variance is pi/2 times the mean's).
        """
        inflate = np.sqrt(1.0 + 1.5708 / max(self.n_samples, 1))
        base = np.maximum(self.noise_map, np.float32(self.noise_sigma))
        if self.edge_noise:
            gs, es = zip(*self.edge_noise)
            g = gradient_max3(self.image)
            edge = np.interp(g, gs, es, left=0.0).astype(np.float32)
            base = np.sqrt(base * base + edge * edge)
        return (base * np.float32(k * inflate)).astype(np.float32)

    def to_dict(self):
        """A JSON-ready summary (not the images)."""
        return {"shape": list(self.shape), "noise_sigma": float(self.noise_sigma),
                "noise_map_median": float(np.median(self.noise_map)),
                "edge_noise": [list(p) for p in self.edge_noise],
                "n_samples": int(self.n_samples), "frames": [int(f) for f in self.frames],
                "dtype": str(np.dtype(self.dtype))}


def gradient_max3(image):
    """Gradient magnitude of ``image`` (grey levels/px), the largest in each 3 x 3."""
    import cv2

    img = np.asarray(image, np.float32)
    gx = cv2.Sobel(img, cv2.CV_32F, 1, 0, ksize=3, scale=0.125)
    gy = cv2.Sobel(img, cv2.CV_32F, 0, 1, ksize=3, scale=0.125)
    return cv2.dilate(cv2.magnitude(gx, gy), np.ones((3, 3), np.uint8))


def sample_spread(samples, image, sigma, *, repeats=False, max_pixels=120_000):
    """Noise of flat areas and the noise that grows with the gradient, from the samples.

    Each pixel's spread about the median over the samples (the mean of the smaller 60 %
    of ``|f - b|``, as a Gaussian sigma: robust to a moving object covering it in a
    third of the samples; the per-bin medians below are robust to more) is measured
    on a sparse grid and compared with the background's gradient g there
    (:func:`gradient_max3`):

    - flat pixels (g < 2 ``sigma``): their median spread s0 is the noise floor of the
      footage; when consecutive frames mostly repeat exactly (``repeats``: compressed
      video that skips unchanged blocks, whose differences say there is no noise while
      a block jumps by a few grey levels at a refresh), the 95th percentile of all
      their deviations over 1.96 (the tail counts). Sensor noise alone gives ``sigma``
      again;
    - textured pixels, in bins of g (a factor of 2 wide, from 4 s0 up): the bin's median
      spread, less 1.5 s0 in quadrature, is the noise that follows the gradient there
      (sub-pixel shake, compression, a phone's sharpening and tone mapping) when it is
      at least 2 s0; none at all unless some bin adds s0 or more. Sensor noise alone
      gives none.

    Parameters
    ----------
    samples : sequence of numpy.ndarray
        The frames the background is the median of (at least 5 for a result).
    image : numpy.ndarray
        The background (their median).
    sigma : float
        The noise measured from consecutive frames.
    repeats : bool
        Consecutive frames mostly repeat exactly (the median of their differences is 0).

    Returns
    -------
    (float, tuple)
        The flat areas' noise (at least ``sigma``), and the edge noise as pairs
        ``(g, extra)`` (grey levels/px, grey levels), g increasing, ``extra``
        non-decreasing; empty when the texture adds nothing.
    """
    k = len(samples)
    if k < 5:
        return float(sigma), ()
    rows, cols = image.shape
    step = max(1, int(np.ceil(np.sqrt(rows * cols / max_pixels))))
    med = np.asarray(image, np.float32)[::step, ::step]
    stack = np.stack([np.asarray(s)[::step, ::step] for s in samples]).astype(np.float32)
    dev = np.abs(stack - med)
    # the mean of the smaller 60 % of the deviations, as a Gaussian sigma (for |N(0, 1)|
    # below its 60th percentile the mean is 0.3963): robust to a moving object in a
    # third of the samples (a blade sweeping past), and not coarsened by integer grey
    # levels as a median is
    q = max(1, int(round(0.6 * k)))
    low = np.partition(dev, q - 1, axis=0)[:q]
    spread = low.mean(axis=0) * np.float32(1.0 / 0.3963)
    g = gradient_max3(image)[::step, ::step]
    flat = g < 2.0 * sigma
    s0 = float(sigma)
    if np.count_nonzero(flat) >= 100:
        # from the tail of the flat pixels' deviations, pooled over the samples (the
        # 95th percentile is 1.96 sigma of a normal law): compression's noise is mostly
        # exact repeats and now and then a jump of several grey levels, which a
        # threshold of k sigma must clear
        s0 = max(s0, float(np.median(spread[flat])))
        if repeats:
            s0 = max(s0, float(np.percentile(dev[:, flat], 95)) / 1.96)
    curve = []
    lo = 4.0 * s0
    top = float(g.max()) if g.size else 0.0
    while lo < top:
        sel = (g >= lo) & (g < 2.0 * lo)
        if np.count_nonzero(sel) >= 100:
            s50 = float(np.median(spread[sel]))
            extra = float(np.sqrt(max(0.0, s50 * s50 - (1.5 * s0) ** 2))) \
                if s50 >= 2.0 * s0 else 0.0
            curve.append((float(np.median(g[sel])), extra))
        lo *= 2.0
    if not curve or max(e for _, e in curve) < s0:
        return s0, ()
    out, run = [(2.0 * s0, 0.0)], 0.0
    for gc, e in curve:
        run = max(run, e)
        out.append((gc, run))
    return s0, tuple(out)


def _batcher_pairs(n):
    """Comparators (i, j) of Batcher's odd-even merge sort of n = 2^k inputs."""
    pairs = []
    p = 1
    while p < n:
        k = p
        while k >= 1:
            for j in range(k % p, n - k, 2 * k):
                for i in range(min(k, n - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        pairs.append((i + j, i + j + k))
            k //= 2
        p *= 2
    return pairs


def median_images(images, *, rows_per_chunk=64):
    """Exact per-pixel median of integer images (element ``K // 2`` of the sorted K).

    Sorts each pixel's values with Batcher's odd-even merge network built of
    ``cv2.min`` and ``cv2.max`` (padded to a power of two with the type's lowest and
    highest values, which leaves the middle element in place), a block of rows at a
    time: about 20 times faster than ``numpy.median`` along the stack axis, and exact.

    Parameters
    ----------
    images : sequence of numpy.ndarray
        Same shape, ``uint8`` or ``uint16``.

    Returns
    -------
    numpy.ndarray
        The median image, same dtype (the upper median for an even count).
    """
    import cv2

    k = len(images)
    n = 1
    while n < k:
        n *= 2
    lo = (n - k) // 2
    hi = n - k - lo
    # the middle of the k real values sits at sorted index lo + k // 2 of the padded n
    pairs = _batcher_pairs(n)
    dtype = images[0].dtype
    top = np.iinfo(dtype).max
    rows = images[0].shape[0]
    out = np.empty_like(images[0])
    for r in range(0, rows, rows_per_chunk):
        block = [np.ascontiguousarray(im[r:r + rows_per_chunk]) for im in images]
        zero = np.zeros_like(block[0])
        full = np.full_like(block[0], top)
        a = [zero] * lo + block + [full] * hi
        for i, j in pairs:
            x, y = a[i], a[j]
            a[i] = cv2.min(x, y)
            a[j] = cv2.max(x, y)
        out[r:r + rows_per_chunk] = a[lo + k // 2]
    return out


def _noise_from_diffs(diffs, max_pixels=1_000_000):
    size = diffs[0].size
    step = max(1, int(np.ceil(size * len(diffs) / max_pixels)))
    allv = np.concatenate([d.reshape(-1)[::step] for d in diffs])
    mad = float(np.median(allv))
    if mad == 0.0:
        # Quantised, nearly noiseless footage: the mean absolute difference still sees
        # the pixels that flip by one level (E|X| = sqrt(2/pi) sigma for a normal X).
        return max(0.5, float(np.mean(allv)) / np.sqrt(2.0 / np.pi) / np.sqrt(2.0))
    return max(0.5, MAD_TO_SIGMA * mad / np.sqrt(2.0))


def _repeats(diffs, max_pixels=200_000):
    """Consecutive frames mostly repeat exactly: the median absolute difference is 0."""
    size = diffs[0].size
    step = max(1, int(np.ceil(size * len(diffs) / max_pixels)))
    allv = np.concatenate([d.reshape(-1)[::step] for d in diffs])
    return float(np.median(allv)) == 0.0


def measure_noise(frames):
    """Robust noise level of a static pixel from differences of consecutive frames.

    Parameters
    ----------
    frames : sequence of numpy.ndarray
        At least two consecutive frames of one size.

    Returns
    -------
    float
        ``1.4826 * median(|f[i+1] - f[i]|) / sqrt(2)`` in grey levels, at least 0.5
        (an integer image cannot show less than its quantisation).

    Raises
    ------
    TrackError
        Fewer than two frames.
    """
    frames = list(frames)
    if len(frames) < 2:
        raise TrackError(f"the noise needs at least two consecutive frames, got {len(frames)}")
    diffs = [np.abs(b.astype(np.float32) - a) for a, b in zip(frames[:-1], frames[1:])]
    return _noise_from_diffs(diffs)


def _pair_noise_map(pairs, sigma):
    """Per-pixel noise from consecutive-frame pairs, capped at 5 x the global noise."""
    import cv2

    diffs = [cv2.absdiff(a, b) for a, b in pairs]
    med = median_images(diffs).astype(np.float32)
    med *= np.float32(MAD_TO_SIGMA / np.sqrt(2.0))
    np.clip(med, 0.0, 5.0 * sigma, out=med)
    return med


def estimate_background(samples, *, pairs, frames=()):
    """Background, noise level and noise map from sampled frames.

    Parameters
    ----------
    samples : sequence of numpy.ndarray
        Frames of one view spread over the footage (at least 3; an odd number makes
        the median one of the values).
    pairs : sequence of (numpy.ndarray, numpy.ndarray)
        Pairs of consecutive frames (at least one; a dozen spread over the footage is
        plenty) for the noise: the global level by :func:`measure_noise`, the per-pixel
        map from the median of their absolute differences (capped at 5 x the global
        level). Differences of consecutive frames see compression noise at static
        edges, but not a blade that covers a pixel in many samples.
    frames : sequence of int, optional
        Source indices of the samples, recorded in the result.

    Returns
    -------
    Background

    Raises
    ------
    TrackError
        Fewer than 3 samples, no pair, or frames of different sizes.
    """
    samples = list(samples)
    pairs = [tuple(p) for p in pairs]
    if len(samples) < 3:
        raise TrackError(f"the background needs at least 3 frames, got {len(samples)}")
    if not pairs:
        raise TrackError("the noise needs at least one pair of consecutive frames")
    shape, dtype = samples[0].shape, samples[0].dtype
    for s in samples + [f for p in pairs for f in p]:
        if s.shape != shape or s.ndim != 2:
            raise TrackError(f"background frames must be 2-D frames of one size; got "
                             f"{s.shape} and {shape}")
    if np.dtype(dtype).kind not in "u" or np.dtype(dtype).itemsize > 2:
        raise TrackError(f"background frames must be 8- or 16-bit unsigned, got {dtype}")
    image = median_images(samples).astype(np.float32)
    diffs = [np.abs(b.astype(np.float32) - a) for a, b in pairs[:4]]
    sigma = _noise_from_diffs(diffs)
    repeats = _repeats(diffs)
    floor, edge = sample_spread(samples, image, sigma, repeats=repeats)
    sigma = max(sigma, floor)
    noise_map = _pair_noise_map(pairs, sigma)
    return Background(image=image, noise_sigma=float(sigma), noise_map=noise_map,
                      n_samples=len(samples), frames=tuple(int(f) for f in frames),
                      dtype=np.dtype(dtype), edge_noise=edge)


def sample_indices(n_frames, samples):
    """``samples`` source indices spread evenly over ``n_frames`` (odd count when possible).

    Parameters
    ----------
    n_frames : int
        Frames in the source.
    samples : int
        Wanted number of samples (>= 3).

    Returns
    -------
    numpy.ndarray of int
    """
    k = min(int(samples), int(n_frames))
    if k % 2 == 0 and k > 3:
        k -= 1
    return np.unique(np.round(np.linspace(0, n_frames - 1, k)).astype(int))


def sample_background(source, *, samples=25, first=0):
    """Background of a frame source from frames spread over its whole length (from frame
    ``first`` on).

    Parameters
    ----------
    source : vidtrack.footage.base.FrameSource
        An open frame source (random access ``source[i]``).
    samples : int, optional
        Frames in the median (default 25).
    first : int, optional
        The first frame the samples may come from (default 0).

    Returns
    -------
    Background

    Raises
    ------
    TrackError
        The source has fewer than 3 frames.

    Notes
    -----
    Random access into a compressed video decodes from the preceding key frame, so on
    such footage this costs more than the frames it keeps; :func:`vidtrack.track.tracker.track`
    instead takes its background from frames it decodes anyway (the first part of the
    footage) unless given one.
    """
    n = len(source)
    if n < 3:
        raise TrackError(f"{getattr(source, 'path', 'source')}: the background needs at least "
                         f"3 frames, the footage has {n}")
    idx, frames, pairs = gather_samples(lambda i: source[i], n, samples=samples, first=first)
    return estimate_background(frames, pairs=pairs, frames=idx)


def gather_samples(get, n_frames, *, samples=25, first=0):
    """The frames a background is taken from: ``samples`` spread over frames
    ``first..n_frames - 1``, and pairs of consecutive frames for the noise (every other
    sample with the frame after it).

    Parameters
    ----------
    get : callable
        ``get(i)`` is source index ``i``'s frame.
    n_frames : int
        Frames in the source (at least 3).

    Returns
    -------
    (numpy.ndarray, list, list)
        The samples' source indices, the samples, the pairs.
    """
    n = int(n_frames)
    first = int(np.clip(first, 0, n - 3))
    idx = first + sample_indices(n - first, samples)
    frames = [get(int(i)) for i in idx]
    pairs = [(f, get(int(i) + 1 if i + 1 < n else int(i) - 1))
             for i, f in zip(idx[::2], frames[::2])]
    return idx, frames, pairs


def without_object(background, samples, discs, *, stood_share=STOOD_SHARE,
                   min_left=MIN_LEFT):
    """The background taken again where the tracked object stood.

    The median of the samples is the object's wherever it stood still in half of them
    or more (a ball held before it is dropped, lying where it landed): there it hides
    the object from the detection, and the object's leaving shows as a "ghost". Once
    the object is known, each pixel it covers in at least ``stood_share`` of the samples
    gets the median of the samples that show it without the object.

    Parameters
    ----------
    background : Background
    samples : sequence of numpy.ndarray, or callable
        The frames the background's median was taken over, in its order, or
        ``samples(k)`` giving the k-th (read only where a pixel is taken again: footage
        too long to hold need not keep them).
    discs : numpy.ndarray
        ``(len(samples), 3)``: where the object lies in each sample, a disc ``(u, v,
        radius)`` in px.
    stood_share : float, optional
        :data:`STOOD_SHARE`.
    min_left : int, optional
        :data:`MIN_LEFT`.

    Returns
    -------
    (Background, numpy.ndarray, numpy.ndarray)
        The background (the same object where no pixel is taken again), the pixels
        taken again and the pixels ``held``: covered in all but fewer than ``min_left``
        samples, which no sample shows without the object (their value is kept).
    """
    discs = np.asarray(discs, float).reshape(-1, 3)
    k = discs.shape[0]
    get = samples if callable(samples) else samples.__getitem__
    if not callable(samples) and k != len(samples):
        raise ValueError(f"{k} discs for {len(samples)} samples")
    rows, cols = background.shape
    count = np.zeros((rows, cols), np.int32)
    for u, v, r in discs:
        # (over the disc's bounding box only: memory and time of a frame, not k)
        r0, r1 = max(int(np.floor(v - r)), 0), min(int(np.ceil(v + r)) + 1, rows)
        c0, c1 = max(int(np.floor(u - r)), 0), min(int(np.ceil(u + r)) + 1, cols)
        if r0 >= r1 or c0 >= c1:
            continue
        yy, xx = np.ogrid[r0:r1, c0:c1]
        count[r0:r1, c0:c1] += (xx - u) ** 2 + (yy - v) ** 2 <= r * r
    stood = count >= max(stood_share * k, 1.0)
    held = stood & (k - count < min_left)
    redo = stood & ~held
    if not redo.any():
        return background, redo, held
    ys, xs = np.nonzero(redo)
    covered = ((xs[None, :] - discs[:, :1]) ** 2 + (ys[None, :] - discs[:, 1:2]) ** 2
               <= discs[:, 2:] ** 2)
    values = np.stack([np.asarray(get(i))[ys, xs] for i in range(k)]).astype(np.float32)
    values[covered] = np.nan
    image = background.image.copy()
    image[ys, xs] = np.nanmedian(values, axis=0)
    return replace(background, image=image), redo, held
