"""Background and noise against known truth: the static scene a moving rod was drawn
over, the Gaussian noise that was added, numpy's median."""

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rod_render import compose, disc_coverage, rod_coverage, texture

from vidtrack.track.background import (MIN_LEFT, estimate_background, measure_noise,
                                       median_images, sample_background, sample_indices,
                                       without_object)
from vidtrack.errors import TrackError
from vidtrack.footage import open_source


@settings(max_examples=40, deadline=None)
@given(k=st.integers(1, 19), rows=st.integers(1, 70), cols=st.integers(1, 9),
       bits=st.sampled_from([8, 16]), seed=st.integers(0, 2 ** 31 - 1))
def test_median_images_is_numpys_median(k, rows, cols, bits, seed):
    rng = np.random.default_rng(seed)
    dtype = np.uint8 if bits == 8 else np.uint16
    top = np.iinfo(dtype).max
    imgs = [rng.integers(0, top, (rows, cols), endpoint=True).astype(dtype) for _ in range(k)]
    got = median_images(imgs, rows_per_chunk=16)
    want = np.sort(np.stack(imgs), axis=0)[k // 2]   # upper median for even k
    assert got.dtype == dtype
    assert np.array_equal(got, want)


def _moving_rod_frames(rng, n=41, noise=2.0):
    shape = (90, 150)
    scene = texture(shape, rng=rng, contrast=40.0)
    frames = []
    for i in range(n):
        cov = rod_coverage(shape, 10 + 3.2 * i, 45 + 10 * np.sin(i / 7), 20.0, 3.0, 0.1 * i)
        frames.append(compose(scene, cov, 235.0, rng=rng, noise=noise))
    return scene, frames


def test_background_recovers_the_static_scene_and_the_noise():
    rng = np.random.default_rng(11)
    scene, frames = _moving_rod_frames(rng)
    idx = sample_indices(len(frames), 25)
    bg = estimate_background([frames[i] for i in idx],
                             pairs=[(frames[i], frames[i + 1]) for i in range(0, 40, 4)],
                             frames=idx)
    assert bg.shape == scene.shape and bg.n_samples == len(idx) == 25
    err = bg.image - scene
    assert np.sqrt(np.mean(err ** 2)) < 1.0        # the median of noisy samples
    assert np.max(np.abs(err)) < 6.0               # the rod is nowhere left in it
    assert bg.noise_sigma == pytest.approx(2.0, rel=0.12)
    assert np.median(bg.noise_map) == pytest.approx(2.0, rel=0.25)
    thr = bg.threshold(k=5.0)
    assert np.all(thr >= 5.0 * bg.noise_sigma)


def test_noise_map_ignores_a_blade_that_passes_often():
    # a dark bar covers the middle columns in 40 % of the frames (a rotor): the spread of
    # the samples there is huge, the frame-to-frame noise is not
    rng = np.random.default_rng(12)
    scene = texture((60, 80), rng=rng, contrast=20.0)
    frames = []
    for i in range(40):
        img = scene.copy()
        if (i // 4) % 5 < 2:
            img[:, 30:50] = 40.0
        frames.append(compose(img, np.zeros(img.shape), 0.0, rng=rng, noise=1.5))
    pairs = [(frames[i], frames[i + 1]) for i in range(0, 39, 3)]
    bg = estimate_background(frames[::2], pairs=pairs)
    inside = bg.noise_map[:, 30:50]
    assert np.median(inside) < 3.0 * 1.5
    assert np.max(bg.noise_map) <= 5.0 * bg.noise_sigma + 1e-6


def test_measure_noise_gaussian_and_quantised():
    rng = np.random.default_rng(13)
    base = np.full((200, 200), 100.0)
    frames = [np.clip(np.rint(base + rng.normal(0, 3.0, base.shape)), 0, 255).astype(np.uint8)
              for _ in range(4)]
    assert measure_noise(frames) == pytest.approx(3.0, rel=0.08)
    still = [np.full((50, 50), 7, np.uint8)] * 3
    assert measure_noise(still) == 0.5          # quantisation floor
    with pytest.raises(TrackError):
        measure_noise(frames[:1])


def test_bad_input():
    a = np.zeros((10, 10), np.uint8)
    with pytest.raises(TrackError, match="at least 3"):
        estimate_background([a, a], pairs=[(a, a)])
    with pytest.raises(TrackError, match="pair"):
        estimate_background([a, a, a], pairs=[])
    with pytest.raises(TrackError, match="one size"):
        estimate_background([a, a, np.zeros((10, 11), np.uint8)], pairs=[(a, a)])
    with pytest.raises(TrackError, match="unsigned"):
        f = np.zeros((10, 10), np.float32)
        estimate_background([f, f, f], pairs=[(f, f)])


def test_sample_background_from_a_video_file(tmp_path):
    rng = np.random.default_rng(14)
    scene, frames = _moving_rod_frames(rng, n=41, noise=1.0)
    path = tmp_path / "rod.avi"
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), 30.0,
                         (scene.shape[1], scene.shape[0]), False)
    for f in frames:
        vw.write(f)
    vw.release()
    with open_source(path, fps=1000) as src:
        bg = sample_background(src, samples=15)
    assert bg.n_samples == 15 and bg.frames[0] == 0 and bg.frames[-1] == 40
    assert np.sqrt(np.mean((bg.image - scene) ** 2)) < 1.0
    assert bg.noise_sigma == pytest.approx(1.0, rel=0.25)
    assert bg.to_dict()["n_samples"] == 15
    # from the last part only (the tracker's background without an object resting at
    # the start): its frames from there to the end
    with open_source(path, fps=1000) as src:
        tail = sample_background(src, samples=9, first=24)
    assert tail.frames[0] == 24 and tail.frames[-1] == 40 and tail.n_samples == 9
    assert np.sqrt(np.mean((tail.image - scene) ** 2)) < 1.0


def test_repr_is_short():
    rng = np.random.default_rng(11)
    _, frames = _moving_rod_frames(rng)
    bg = estimate_background(frames[:25], pairs=[(frames[i], frames[i + 1]) for i in range(4)])
    text = repr(bg)                # the image and noise map were printed in full
    assert len(text) < 300 and "array" not in text
    assert text.startswith(f"Background(shape={bg.shape}, noise_sigma=")


def _shaken(rng, n=30, jitter_px=0.3, shape=(90, 150)):
    """A textured scene seen by a camera that sways by a fraction of a pixel."""
    scene = texture(shape, rng=rng, contrast=50.0, scale=2.0).astype(np.float32)
    frames = []
    for i in range(n):
        # a slow sway: consecutive frames nearly alike, the median far from some
        dx, dy = jitter_px * np.sin(2 * np.pi * i / 20), jitter_px * np.cos(2 * np.pi * i / 27)
        m = np.float32([[1, 0, dx], [0, 1, dy]])
        img = cv2.warpAffine(scene, m, (shape[1], shape[0]), flags=cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REFLECT)
        frames.append(np.clip(np.rint(img + rng.normal(0.0, 1.0, shape)), 0, 255)
                      .astype(np.uint8))
    return scene, frames


def test_edge_noise_of_a_shaking_camera_raises_the_threshold_where_the_scene_has_edges():
    rng = np.random.default_rng(21)
    _, frames = _shaken(rng)
    idx = sample_indices(len(frames), 25)
    pairs = [(frames[i], frames[i + 1]) for i in range(0, 28, 3)]
    bg = estimate_background([frames[i] for i in idx], pairs=pairs, frames=idx)
    assert bg.edge_noise and "edge_noise" in repr(bg)
    thr = bg.threshold(k=5.0)
    # a frame of the shaking camera with nothing moving: almost nothing is "changed"
    late = frames[-1].astype(np.float32)
    changed = np.abs(late - bg.image) > thr
    assert changed.mean() < 0.002
    # with the flat noise alone it would be: the edges flicker beyond 5 sigma
    flat = np.abs(late - bg.image) > 5.0 * bg.noise_sigma * 1.03
    assert flat.mean() > 20 * max(changed.mean(), 1e-4)


def test_no_edge_noise_for_a_still_camera_with_sensor_noise():
    rng = np.random.default_rng(22)
    _, frames = _shaken(rng, jitter_px=0.0)
    idx = sample_indices(len(frames), 25)
    bg = estimate_background([frames[i] for i in idx],
                             pairs=[(frames[i], frames[i + 1]) for i in range(0, 28, 3)])
    assert bg.edge_noise == ()
    assert bg.noise_sigma == pytest.approx(1.0, rel=0.2)


def test_compressed_blocks_that_repeat_set_the_noise_floor():
    # consecutive frames repeat exactly (a codec's skipped blocks: their differences
    # say "no noise") while each refresh lands a few grey levels off the scene
    rng = np.random.default_rng(23)
    scene = np.full((60, 80), 120.0)
    frames = []
    for _ in range(20):
        f = np.clip(np.rint(scene + rng.normal(0.0, 2.0, scene.shape)), 0, 255).astype(np.uint8)
        frames += [f, f.copy()]
    idx = sample_indices(len(frames), 25)
    bg = estimate_background([frames[i] for i in idx],
                             pairs=[(frames[i], frames[i + 1]) for i in range(0, 38, 4)])
    assert bg.noise_sigma == pytest.approx(2.0, rel=0.2)    # not the 0.5 floor


# ------------------------------------------------------------------ without the object
def _held_ball_samples(rng, k=25, held=17, noise=1.5):
    """``k`` samples of a textured wall, a bright ball standing at one place in the first
    ``held`` of them and elsewhere (falling) in the rest; the wall, the samples, the
    discs ``(u, v, radius)`` where it lies and the same as masks."""
    shape = (70, 90)
    wall = texture(shape, rng=rng, mean=110.0, contrast=12.0)
    samples, discs = [], []
    for i in range(k):
        u, v = (30.0, 25.0) if i < held else (30.0 + 1.5 * i, 25.0 + 1.2 * i)
        samples.append(compose(wall, disc_coverage(shape, u, v, 5.0), 230.0, rng=rng,
                               noise=noise))
        discs.append((u, v, 8.0))
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    covered = np.array([(xx - u) ** 2 + (yy - v) ** 2 <= r * r for u, v, r in discs])
    return wall, samples, np.array(discs), covered


def test_the_background_is_taken_again_without_an_object_that_stood_still():
    """A ball standing still in 17 of 25 samples is the median's there (its grey level,
    120 over the wall); taken again from the 8 samples that show the wall, the background
    is the wall drawn, within the noise of a median of 8."""
    rng = np.random.default_rng(7)
    wall, samples, discs, covered = _held_ball_samples(rng)
    bg = estimate_background(samples, pairs=[(samples[0], samples[1])])
    where = covered[0]
    assert np.abs(bg.image[where] - wall[where]).max() > 100.0
    redone, taken, held = without_object(bg, samples, discs)
    assert not held.any()
    assert taken[where].all() and not taken[~covered.any(axis=0)].any()
    assert np.abs(redone.image[where] - wall[where]).max() < 3.0
    # elsewhere, the background as it was; the input not changed
    assert np.array_equal(redone.image[~taken], bg.image[~taken])
    assert np.abs(bg.image[where] - wall[where]).max() > 100.0


def test_no_sample_shows_the_wall_where_the_object_never_left():
    """A ball in 24 of 25 samples at one place: fewer than MIN_LEFT samples show the
    wall, so those pixels are held (kept as they were), not taken from one sample."""
    rng = np.random.default_rng(8)
    wall, samples, discs, covered = _held_ball_samples(rng, held=24)
    bg = estimate_background(samples, pairs=[(samples[0], samples[1])])
    redone, taken, held = without_object(bg, samples, discs)
    assert MIN_LEFT == 2
    assert held[covered[0]].all() and not held[~covered[0]].any()
    assert np.array_equal(redone.image[held], bg.image[held])
    # the samples read only where a pixel is taken again, by a function as well
    again = without_object(bg, lambda k: samples[k], discs)
    assert np.array_equal(again[0].image, redone.image)
    with pytest.raises(ValueError, match="24 discs for 25 samples"):
        without_object(bg, samples, discs[:24])
