"""Test footage made here, independently of the tracker: an opaque rod over a texture.

A rod (a rectangle of given length and width, centre (u, v), angle) is drawn with its
exact coverage of every pixel, computed by supersampling each pixel on an ``ss x ss``
grid inside the rod's bounding box. Pixel (col, row) has its centre at (u, v) =
(col, row) (OpenCV's convention). ``frame = background + coverage * (level -
background)`` then noise, so the true centroid is the rod's centre.
"""

import numpy as np


def texture(shape, *, rng, mean=110.0, contrast=60.0, scale=4.0):
    """A smooth random texture (float64) of given ``shape``: machine-like clutter."""
    import cv2

    noise = rng.standard_normal(shape).astype(np.float32)
    smooth = cv2.GaussianBlur(noise, (0, 0), scale)
    smooth /= smooth.std() + 1e-12
    return np.clip(mean + contrast * smooth.astype(np.float64), 5.0, 250.0)


def rod_coverage(shape, u, v, length, width, angle, *, ss=8):
    """Exact-ish (``ss x ss`` supersampled) coverage of a rod, and its bounding box.

    Returns
    -------
    cov : numpy.ndarray
        ``(rows, cols)`` float64 in [0, 1].
    """
    rows, cols = shape
    cov = np.zeros(shape)
    ext = 0.5 * (abs(length * np.cos(angle)) + abs(width * np.sin(angle))) + 1.5
    eyt = 0.5 * (abs(length * np.sin(angle)) + abs(width * np.cos(angle))) + 1.5
    c0, c1 = max(0, int(np.floor(u - ext))), min(cols, int(np.ceil(u + ext)) + 1)
    r0, r1 = max(0, int(np.floor(v - eyt))), min(rows, int(np.ceil(v + eyt)) + 1)
    if c1 <= c0 or r1 <= r0:
        return cov
    offs = (np.arange(ss) + 0.5) / ss - 0.5
    cc = (np.arange(c0, c1)[:, None] + offs[None, :]).reshape(-1)
    rr = (np.arange(r0, r1)[:, None] + offs[None, :]).reshape(-1)
    X, Y = np.meshgrid(cc - u, rr - v)
    ca, sa = np.cos(angle), np.sin(angle)
    along = X * ca + Y * sa
    across = -X * sa + Y * ca
    inside = (np.abs(along) <= length / 2) & (np.abs(across) <= width / 2)
    block = inside.reshape(r1 - r0, ss, c1 - c0, ss).mean(axis=(1, 3))
    cov[r0:r1, c0:c1] = block
    return cov


def compose(background, cov, level, *, rng=None, noise=0.0, dtype=np.uint8):
    """``background + cov * (level - background)`` plus Gaussian noise, as ``dtype``."""
    img = background + cov * (level - background)
    if rng is not None and noise > 0:
        img = img + rng.normal(0.0, noise, img.shape)
    top = np.iinfo(dtype).max
    return np.clip(np.rint(img), 0, top).astype(dtype)


def disc_coverage(shape, u, v, radius, *, ss=8):
    """Exact-ish (``ss x ss`` supersampled) coverage of a disc of centre (u, v)."""
    rows, cols = shape
    cov = np.zeros(shape)
    c0, c1 = max(0, int(np.floor(u - radius - 1))), min(cols, int(np.ceil(u + radius + 1)) + 1)
    r0, r1 = max(0, int(np.floor(v - radius - 1))), min(rows, int(np.ceil(v + radius + 1)) + 1)
    if c1 <= c0 or r1 <= r0:
        return cov
    offs = (np.arange(ss) + 0.5) / ss - 0.5
    cc = (np.arange(c0, c1)[:, None] + offs[None, :]).reshape(-1)
    rr = (np.arange(r0, r1)[:, None] + offs[None, :]).reshape(-1)
    X, Y = np.meshgrid(cc - u, rr - v)
    inside = X * X + Y * Y <= radius * radius
    cov[r0:r1, c0:c1] = inside.reshape(r1 - r0, ss, c1 - c0, ss).mean(axis=(1, 3))
    return cov


def ellipse_coverage(shape, u, v, a, b, angle, *, ss=4):
    """Supersampled coverage of an ellipse (semi-axes ``a`` along ``angle``, ``b``)."""
    rows, cols = shape
    cov = np.zeros(shape)
    r = max(a, b) + 1
    c0, c1 = max(0, int(np.floor(u - r))), min(cols, int(np.ceil(u + r)) + 1)
    r0, r1 = max(0, int(np.floor(v - r))), min(rows, int(np.ceil(v + r)) + 1)
    if c1 <= c0 or r1 <= r0:
        return cov
    offs = (np.arange(ss) + 0.5) / ss - 0.5
    cc = (np.arange(c0, c1)[:, None] + offs[None, :]).reshape(-1)
    rr = (np.arange(r0, r1)[:, None] + offs[None, :]).reshape(-1)
    X, Y = np.meshgrid(cc - u, rr - v)
    ca, sa = np.cos(angle), np.sin(angle)
    p, q = (X * ca + Y * sa) / a, (-X * sa + Y * ca) / b
    cov[r0:r1, c0:c1] = (p * p + q * q <= 1.0).reshape(r1 - r0, ss, c1 - c0, ss).mean(axis=(1, 3))
    return cov


def shadow_factor(cov, *, darkness, blur_px):
    """Multiplicative shading of a shadow cast by an object of coverage ``cov``: 1 where
    the light is unobstructed, ``1 - darkness`` in the umbra, a Gaussian penumbra of
    ``blur_px``."""
    import cv2

    soft = cv2.GaussianBlur(cov.astype(np.float32), (0, 0), blur_px).astype(np.float64)
    return 1.0 - darkness * soft


def write_avi(path, frames, fps=30.0):
    """Grey ``(rows, cols)`` or BGR colour ``(rows, cols, 3)`` ``frames`` (uint8) to a
    lossless FFV1 AVI at ``path`` (OpenCV); returns it."""
    import cv2

    h, w = frames[0].shape[:2]
    colour = frames[0].ndim == 3
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), fps, (w, h), colour)
    assert vw.isOpened()
    for f in frames:
        vw.write(f)
    vw.release()
    return path


def read_video(path):
    """Every frame of the video at ``path`` as OpenCV decodes it (BGR), in order."""
    import cv2

    cap = cv2.VideoCapture(str(path), cv2.CAP_FFMPEG)
    frames = []
    while True:
        ok, img = cap.read()
        if not ok:
            break
        frames.append(img)
    cap.release()
    return frames
