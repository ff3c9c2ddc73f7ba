"""The tracker on scenes that fool a tracker made for straws, rendered here with exact
coverage (``rod_render``) and a truth the tracker never sees: an object with its shadow,
a second object riding along and crossing, a dark ball with a highlight, a person moving
at the side, two objects flying alike (the tracker must ask), an object named by a
``target`` (followed both ways in time), a small ball among a crowd in footage strewn
with compression specks, a textured toy with its shadow attached. Every unflagged frame
must be within 0.5 px of the truth (the textured toy with its shadow: 2 px, where a
shadow measured with it puts it 5-7 px off): a frame the tracker cannot measure must be
flagged, not guessed."""

import re

import numpy as np
import pytest
from rod_render import (compose, disc_coverage, ellipse_coverage, rod_coverage,
                        shadow_factor, texture, write_avi)

from vidtrack.errors import TrackError
from vidtrack.footage import open_source
from vidtrack.track.tracker import MERGED, track

SHAPE = (180, 240)


def _ballistic(n, start, vel, g=0.06):
    """(n, 2) pixel path: constant velocity in u, gravity in v (px/frame^2)."""
    t = np.arange(n, dtype=float)
    return np.column_stack([start[0] + vel[0] * t, start[1] + vel[1] * t + 0.5 * g * t * t])


def _track(tmp_path, frames, fps=500.0, name="scene.avi", **kw):
    path = write_avi(tmp_path / name, frames)
    with open_source(path, fps=fps) as src:
        return track(src, view="front", **kw)


def _errors(tr, truth):
    d = tr.data
    return np.hypot(d["u_px"].to_numpy() - truth[:, 0], d["v_px"].to_numpy() - truth[:, 1])


def _check(tr, truth, *, min_usable, where=None):
    """Unflagged frames within 0.5 px of the truth, and enough of them."""
    ok = tr.usable if where is None else tr.usable & where
    err = _errors(tr, truth)
    assert ok.sum() >= min_usable, (int(ok.sum()), tr.flag_counts())
    assert np.all(err[tr.usable] <= 0.5), np.round(err[tr.usable].max(), 3)
    return err


# --------------------------------------------------------------------- a shadow
@pytest.mark.parametrize("engine", ["rules", "flight"])
@pytest.mark.parametrize("ball_level", [225.0, 60.0])
def test_a_shadow_is_never_part_of_the_ball(tmp_path, ball_level, engine):
    """A ball before a light wall and its shadow, a blurred darker copy a few pixels
    below and to the right that touches it and falls behind it (a launcher's lamp
    above the camera). Bright ball: the shadow is of the other polarity, more of the
    detection than the ball (the flight tracker took it for a dark body with the ball
    its highlight, every unflagged frame 4-6 px towards the shadow, until it told a
    highlight, inside its body, from a bright object beside its shadow). Dark ball: of
    the same polarity, lighter than the ball and blurred (the flight tracker read it as
    part of the ball's coverage, 2.2-3.9 px towards it, until the pixels a shadow could
    dim beyond the ball's rim were no longer its: 0.29 px median, 0.41 at most)."""
    rng = np.random.default_rng(1)
    n = 70
    wall = texture(SHAPE, rng=rng, mean=185.0, contrast=12.0, scale=6.0)
    path = _ballistic(n, (30.0, 130.0), (2.6, -2.4), g=0.06)
    frames = []
    for i, (u, v) in enumerate(path):
        off = 5.0 + 0.06 * i                      # the shadow falls behind: 5 to 9 px
        shade = shadow_factor(disc_coverage(SHAPE, u + off, v + 0.6 * off, 6.0),
                              darkness=0.45, blur_px=1.8)
        frames.append(compose(wall * shade, disc_coverage(SHAPE, u, v, 6.0), ball_level,
                              rng=rng, noise=1.5))
    tr = _track(tmp_path, frames, engine=engine)
    _check(tr, path, min_usable=0.6 * n)


def _toy(rng, n, *, darkness, blur_px, radius=14.0, shadow_at=(6.0, 9.0)):
    """A textured toy (its own smooth texture, parts brighter and parts darker than the
    wall, carried with it) flying before a lightly textured wall, and its shadow: the
    toy's disc moved by ``shadow_at``, darkening the wall by ``darkness``, blurred by
    ``blur_px``. The truth is the disc's centre."""
    import cv2

    wall = texture(SHAPE, rng=rng, mean=150.0, contrast=12.0, scale=6.0)
    skin = texture((64, 64), rng=rng, mean=150.0, contrast=60.0, scale=3.0).astype(np.float32)
    path = _ballistic(n, (40.0, 40.0), (2.4, 0.5), g=0.03)
    frames = []
    for u, v in path:
        lit = wall
        if darkness > 0:
            lit = wall * shadow_factor(disc_coverage(SHAPE, u + shadow_at[0], v + shadow_at[1],
                                                     radius), darkness=darkness, blur_px=blur_px)
        own = cv2.warpAffine(skin, np.float32([[1, 0, u - 32], [0, 1, v - 32]]),
                             (SHAPE[1], SHAPE[0]), flags=cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REFLECT).astype(np.float64)
        img = lit + disc_coverage(SHAPE, u, v, radius) * (own - lit)
        frames.append(np.clip(np.rint(img + rng.normal(0.0, 1.5, SHAPE)), 0, 255)
                      .astype(np.uint8))
    return frames, path


@pytest.mark.parametrize("engine", ["rules", "flight"])
@pytest.mark.parametrize("darkness, blur_px", [(0.15, 4.0), (0.25, 3.0), (0.4, 2.0)])
def test_a_shadow_attached_to_a_textured_toy_is_cut_off(tmp_path, darkness, blur_px, engine):
    """A toy of many grey levels with its shadow attached below it all through:
    measured with it, the centroid lies 5-7 px towards the shadow on every frame,
    unflagged (as it was before either tracker looked for such a shadow). The rules
    tracker's first pass finds a soft, weak, darker part attached on the same side in
    most of the clean frames; a second pass measures the toy without it: median 0.44 to
    0.68 px, at most 0.76 to 1.45 px. The flight tracker measures the toy by its matte
    over the walls it crosses, where the shadow only dims the wall: 0.12 to 0.22 px
    median, 0.14 to 0.25 at most, its note saying how far the matte moved the outline's
    points (away from the shadow, at (6, 9) px: 2.6 to 6.4 px)."""
    n = 70
    frames, path = _toy(np.random.default_rng(3), n, darkness=darkness, blur_px=blur_px)
    tr = _track(tmp_path, frames, engine=engine)
    if engine == "rules":
        notes = [x for x in tr.notes if x.startswith("shadow:")]
        assert len(notes) == 1, tr.notes
        pull = [float(x) for x in re.search(r"by \(([-+0-9.]+), ([-+0-9.]+)\) px",
                                            notes[0]).groups()]
        assert pull[0] > 2.0 and pull[1] > 3.0   # what the shadow did to the whole (6, 9 away)
    else:
        notes = [x for x in tr.notes if x.startswith("matte:")]
        assert len(notes) == 1, tr.notes
        move = np.array([float(x) for x in re.search(r"by \(([-+0-9.]+), ([-+0-9.]+)\) px",
                                                     notes[0]).groups()])
        assert move @ np.array([6.0, 9.0]) / np.hypot(6.0, 9.0) < -2.0, move
    err = _errors(tr, path)
    ok = tr.usable
    assert ok.sum() >= 0.6 * n, tr.flag_counts()
    assert np.median(err[ok]) <= 1.0
    assert err[ok].max() <= 2.0, np.round(err[ok].max(), 2)


def test_a_second_pass_that_fails_leaves_the_first_passs_track(tmp_path, monkeypatch):
    """Where the rules tracker's second pass (without the shadow) cannot follow the
    object, the track is the first pass's, measured with the shadow, and its notes say
    so (the flight tracker makes one pass)."""
    from vidtrack.track import _pass

    run = _pass.Pass.run

    def run_or_fail(self):
        if self.shadow == "cut":
            raise TrackError("view front: lost without its shadow")
        return run(self)

    monkeypatch.setattr(_pass.Pass, "run", run_or_fail)
    frames, path = _toy(np.random.default_rng(3), 70, darkness=0.25, blur_px=3.0)
    tr = _track(tmp_path, frames, engine="rules")
    said = [x for x in tr.notes if x.startswith("shadow:")]
    assert len(said) == 1 and "measured with it" in said[0] and "lost without" in said[0]
    err = _errors(tr, path)
    assert np.median(err[tr.usable]) > 5.0         # the shadow's pull, as before the cut


@pytest.mark.parametrize("engine", ["rules", "flight"])
def test_a_textured_toy_without_a_shadow_is_measured_whole(tmp_path, engine):
    """The toy alone: within half a pixel of its centre on 90 % of its frames (the
    flight tracker by its matte: 0.05 px median, 0.08 at most; by its outline it was
    1.7 px off, the weights following its tones against the wall)."""
    n = 70
    frames, path = _toy(np.random.default_rng(3), n, darkness=0.0, blur_px=0.0)
    tr = _track(tmp_path, frames, engine=engine)
    if engine == "rules":
        assert not any(x.startswith("shadow:") for x in tr.notes), tr.notes
    _check(tr, path, min_usable=0.9 * n)


@pytest.mark.parametrize("engine", ["rules", "flight"])
@pytest.mark.parametrize("seed", [4, 7, 10, 14, 24])
def test_toys_of_other_textures_are_measured_whole_or_flagged(tmp_path, seed, engine):
    """Textures whose parts fooled the tracker: a thin bright crescent round a dark toy's
    rim taken for a straight rod riding a blade, and the toy's dark texture, fading into
    the wall, for the crescent's blurred shadow (4: every frame MERGED), long dark
    patches taken for a rod on a blade (7: a bright part followed alone, 4 px off on 53
    unflagged frames), the whole missed in one frame while a part was taken for the
    object (10: 21 unflagged frames 3.7-3.9 px off), a part of a third of the whole
    whose other part was never joined (14: every frame MERGED), a part taken until the
    whole was found (24: 19 MERGED). Each unflagged frame is the whole, within 1 px; the
    flagged ones are the part's."""
    n = 70
    frames, path = _toy(np.random.default_rng(seed), n, darkness=0.0, blur_px=0.0)
    tr = _track(tmp_path, frames, engine=engine)
    err = _errors(tr, path)
    assert tr.usable.sum() >= 0.55 * n, tr.flag_counts()
    assert err[tr.usable].max() <= 1.0, np.round(err[tr.usable].max(), 2)


# --------------------------------------------------------------------- a rider
@pytest.mark.parametrize("engine", ["rules", "flight"])
@pytest.mark.parametrize("start_apart", [True, False])
def test_a_second_rod_riding_along_and_crossing_is_never_measured_with_the_straw(
        tmp_path, start_apart, engine):
    """A thinner, dimmer rod flies with the straw at the same speed and drifts across
    it (a rendered run once gave 99 % unflagged frames at 5.3 px RMS: the two measured
    as one). Apart at first, or touching it from the first frame on. Where the two
    overlap, the straw is either told apart from the rider (flagged MERGED: the rules
    tracker, which measures a rod by its coverage centroid, 7 frames, 73 unflagged
    within 0.25 px) or measured without it (the flight tracker's bar: all 80 frames
    unflagged, the 58 where they overlap included, within 0.032 px)."""
    rng = np.random.default_rng(2)
    n = 80
    bg = texture(SHAPE, rng=rng, contrast=30.0)
    path = _ballistic(n, (40.0, 120.0), (1.8, -1.2), g=0.02)
    frames, overlap = [], []
    for i, (u, v) in enumerate(path):
        ang = 0.4 + 0.004 * i
        cov = rod_coverage(SHAPE, u, v, 30.0, 3.0, ang)
        # the rider: 1.5 px thick, level 170, crossing the straw at 40 degrees,
        # drifting across it (perpendicular offset from -14 to +14 px, or from 0)
        side = (-14.0 + 0.36 * i) if start_apart else (0.0 + 0.18 * i)
        nu, nv = -np.sin(ang), np.cos(ang)
        rider = rod_coverage(SHAPE, u + side * nu, v + side * nv, 24.0, 1.5, ang + 0.7)
        overlap.append(np.any((cov > 0) & (rider > 0)))
        img = compose(bg, rider, 170.0)
        frames.append(compose(img.astype(float), cov, 225.0, rng=rng, noise=1.5))
    tr = _track(tmp_path, frames, engine=engine)
    err = _check(tr, path, min_usable=5)
    # where the two touch the frame is flagged (or measured right)
    flags = tr.data["flags"].to_numpy()
    assert np.all((flags != 0) | (err <= 0.5))
    if start_apart:
        overlap = np.array(overlap)
        assert overlap.sum() >= 20
        told_apart = np.count_nonzero(flags & MERGED) >= 5
        assert told_apart or np.all(err[overlap] <= 0.1), np.round(err[overlap].max(), 3)


# --------------------------------------------------------------------- a highlight
def test_a_dark_ball_with_a_highlight_is_one_object(tmp_path):
    """A dark steel ball on a dark, textured background with a bright specular
    highlight: one object of both polarities (once: nothing found for 160 frames, then
    every frame merged), measured by its silhouette."""
    rng = np.random.default_rng(3)
    n = 70
    bg = texture(SHAPE, rng=rng, mean=70.0, contrast=12.0)
    path = _ballistic(n, (40.0, 30.0), (2.2, 0.4), g=0.05)
    yy, xx = np.mgrid[0:SHAPE[0], 0:SHAPE[1]]
    frames = []
    for u, v in path:
        img = compose(bg, disc_coverage(SHAPE, u, v, 9.0), 25.0).astype(float)
        hi = 220.0 * np.exp(-((xx - u + 3.0) ** 2 + (yy - v + 3.0) ** 2) / (2 * 1.3 ** 2))
        frames.append(np.clip(np.rint(img + hi + rng.normal(0, 1.5, SHAPE)), 0, 255)
                      .astype(np.uint8))
    tr = _track(tmp_path, frames)
    _check(tr, path, min_usable=0.8 * n)


@pytest.mark.parametrize("off, quality", [(0.5, 0), (1.6, 0), (0.5, 80), (1.6, 80)],
                         ids=["inside", "to-the-edge", "inside-jpeg80", "to-the-edge-jpeg80"])
def test_a_dark_straw_with_a_highlight_along_it_is_measured_whole(tmp_path, off, quality):
    """A dark straw turning in flight with a bright highlight stripe along it, inside its
    edge or reaching it (the edge then shows the stripe's blur, not the straw), the
    frames lossless or through JPEG at quality 80 (its ringing round the bright stripe
    is as strong as the straw's thin rim): one rod of both polarities, centred on the
    straw's own centre (before: the stripe taken for the object, the straw measured
    0.8 to 1.9 px off or not found at all)."""
    import cv2

    rng = np.random.default_rng(11)
    n = 80
    bg = texture(SHAPE, rng=rng, mean=120.0, contrast=10.0)
    path = _ballistic(n, (40.0, 40.0), (2.0, 0.3), g=0.04)
    length, width = 36.0, 5.0
    frames = []
    for k, (u, v) in enumerate(path):
        ang = 0.2 + 0.03 * k
        ca, sa = np.cos(ang), np.sin(ang)
        rod = rod_coverage(SHAPE, u, v, length, width, ang)
        stripe = rod_coverage(SHAPE, u - off * sa, v + off * ca, 0.8 * length, 1.8, ang)
        img = compose(bg, rod, 30.0).astype(float) + stripe * (230.0 - 30.0)
        f = np.clip(np.rint(img + rng.normal(0, 1.0, SHAPE)), 0, 255).astype(np.uint8)
        if quality:
            ok, buf = cv2.imencode(".jpg", f, [cv2.IMWRITE_JPEG_QUALITY, quality])
            f = cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE)
        frames.append(f)
    tr = _track(tmp_path, frames)
    _check(tr, path, min_usable=0.85 * n)


def test_a_rider_across_a_straw_with_a_highlight_is_never_measured_with_it(tmp_path):
    """The rider of the test above (1.5 px thick, at 40 degrees, drifting across), dark,
    touching a dark straw with a highlight along it from the first frame: the straw is
    measured by its body within its core's band, which leaves the rider out: 72 of 80
    frames unflagged, within 0.34 px (median 0.07). Before the band the rider's arms
    beyond the body's band flagged 40 or more frames; before that, 51 of 80 frames were
    unflagged, 25 of them 0.5-5.6 px off."""
    rng = np.random.default_rng(11)
    n = 80
    bg = texture(SHAPE, rng=rng, mean=120.0, contrast=10.0)
    path = _ballistic(n, (40.0, 40.0), (2.0, 0.3), g=0.04)
    frames = []
    for k, (u, v) in enumerate(path):
        ang = 0.2 + 0.03 * k
        ca, sa = np.cos(ang), np.sin(ang)
        side = 0.18 * k
        img = compose(bg, rod_coverage(SHAPE, u - side * sa, v + side * ca, 28.0, 1.5,
                                       ang + 0.7), 80.0).astype(float)
        rod = rod_coverage(SHAPE, u, v, 36.0, 5.0, ang)
        stripe = rod_coverage(SHAPE, u - 0.5 * sa, v + 0.5 * ca, 0.8 * 36.0, 1.8, ang)
        img = img + rod * (30.0 - img) + stripe * (230.0 - 30.0)
        frames.append(np.clip(np.rint(img + rng.normal(0, 1.0, SHAPE)), 0, 255)
                      .astype(np.uint8))
    tr = _track(tmp_path, frames)
    _check(tr, path, min_usable=60)


# --------------------------------------------------------------------- a slow object
def _slow_ball(speed, n=400):
    """A bright ball 12 px across going ``speed`` px a frame (a slow object filmed at
    10 000 frames/s) before a textured wall."""
    rng = np.random.default_rng(5)
    wall = texture(SHAPE, rng=rng, mean=120.0, contrast=12.0, scale=6.0)
    path = _ballistic(n, (40.0, 120.0), (speed, -speed), g=0.0002)
    return [compose(wall, disc_coverage(SHAPE, u, v, 6.0), 220.0, rng=rng, noise=1.5)
            for u, v in path], path


@pytest.mark.parametrize("engine", ["rules", "flight"])
@pytest.mark.parametrize("speed", [0.1, 0.2])
def test_a_slow_object_is_found(tmp_path, speed, engine):
    """Too slow for the frame-to-frame motion the rules tracker's search asks (0.3 px a
    frame): before, "the straw never appears". Nothing moving faster, that search looks
    again for an object moving steadily over 40 frames, and takes it where it went far
    enough for the background not to hold it (3 and 6.5 times its size). The flight
    tracker links the ball's detections whatever its speed: every frame unflagged,
    within 0.5 px."""
    frames, path = _slow_ball(speed)
    tr = _track(tmp_path, frames, fps=10000.0, engine=engine)
    if engine == "rules":
        assert any(x.startswith("search:") and "not taken" not in x
                   for x in tr.notes), tr.notes
    _check(tr, path, min_usable=0.95 * len(path))


def test_a_slow_object_in_the_background_is_not_taken(tmp_path):
    """At 0.05 px a frame the ball goes twice its size over the frames the background is
    taken from: the median holds it where it lingers, and what is seen is the ball
    against itself, a crescent 2 to 5 px off (taken, 315 of 400 frames were so,
    unflagged). The slow search says so and does not take it; the 7 frames of such
    crescents the search at 0.3 px a frame took (4.7 to 6.6 px off, unflagged before)
    are flagged, being on it. The flight tracker stops (exit 2): nothing travelled 2 of
    its sizes along a smooth path, and the message names the ``target`` line."""
    frames, path = _slow_ball(0.05)
    with pytest.raises(TrackError, match=r"never appears in flight(.|\n)*target = "):
        _track(tmp_path, frames, fps=10000.0, engine="flight")
    tr = _track(tmp_path, frames, fps=10000.0, engine="rules")
    said = [x for x in tr.notes if x.startswith("search:")]
    assert len(said) == 1 and "not taken" in said[0], tr.notes
    assert "first search are on it" in said[0]
    assert np.all(_errors(tr, path)[tr.usable] <= 0.5)


@pytest.mark.parametrize("engine", ["rules", "flight"])
def test_a_slower_object_held_by_the_background_is_flagged(tmp_path, engine):
    """At 0.03 px a frame the ball goes its own size over the 400 frames, and the first
    search takes it as it is: before, 381 frames unflagged, 0.2 to 4.5 px off (the ball
    against the background that holds it, its area 46 to 205 px for 113). Where it lay
    within its radius of a frame's place in more than half of the background's frames,
    that frame is flagged, and the notes say why."""
    frames, path = _slow_ball(0.03)
    tr = _track(tmp_path, frames, fps=10000.0, engine=engine)
    assert any(x.startswith("background: it lay where it is") for x in tr.notes), tr.notes
    assert np.all(_errors(tr, path)[tr.usable] <= 0.5)
    assert tr.flag_counts()["appearance"] >= 300


# --------------------------------------------------------------------- a person
def test_a_person_moving_at_the_side_is_never_followed(tmp_path):
    """A person-sized blob sways and swings an arm at the side while a small ball
    flies across: the ball is tracked, never the person."""
    rng = np.random.default_rng(4)
    n = 80
    bg = texture(SHAPE, rng=rng, mean=120.0, contrast=25.0)
    path = _ballistic(n, (60.0, 140.0), (2.0, -2.6), g=0.06)
    frames = []
    for i, (u, v) in enumerate(path):
        body = ellipse_coverage(SHAPE, 22.0 + 4.0 * np.sin(i / 9.0), 100.0, 45.0, 16.0,
                                np.pi / 2 + 0.1 * np.sin(i / 7.0))
        arm = rod_coverage(SHAPE, 40.0 + 8.0 * np.sin(i / 5.0), 90.0 + 10.0 * np.cos(i / 5.0),
                           34.0, 7.0, 0.8 * np.sin(i / 5.0))
        person = np.clip(body + arm, 0.0, 1.0)
        img = compose(bg, person, 45.0).astype(float)
        frames.append(compose(img, disc_coverage(SHAPE, u, v, 4.0), 235.0, rng=rng, noise=1.5))
    tr = _track(tmp_path, frames)
    err = _check(tr, path, min_usable=0.7 * n)
    measured = np.isfinite(tr.data["u_px"].to_numpy())
    assert np.all(err[measured] < 6.0)          # never on the person (40+ px away)


# --------------------------------------------------------------------- which one
def _two_balls(rng, n=60):
    bg = texture(SHAPE, rng=rng, mean=100.0, contrast=20.0)
    a = _ballistic(n, (30.0, 60.0), (2.0, -0.5), g=0.05)
    b = _ballistic(n, (30.0, 140.0), (2.1, -1.4), g=0.05)
    frames = []
    for (ua, va), (ub, vb) in zip(a, b):
        cov = np.clip(disc_coverage(SHAPE, ua, va, 5.0) + disc_coverage(SHAPE, ub, vb, 5.0),
                      0.0, 1.0)
        frames.append(compose(bg, cov, 230.0, rng=rng, noise=1.5))
    return frames, a, b


def test_two_objects_flying_alike_are_not_picked_but_named(tmp_path):
    frames, a, b = _two_balls(np.random.default_rng(5))
    with pytest.raises(TrackError) as err:
        _track(tmp_path, frames)
    msg = str(err.value)
    assert "\n" not in msg and "view front" in msg
    assert "target = { frame = " in msg and "at_px = [" in msg


def test_a_target_names_the_object_and_it_is_followed_both_ways(tmp_path):
    frames, a, b = _two_balls(np.random.default_rng(5))
    f = 30
    tr = _track(tmp_path, frames, target=(f, (b[f, 0] + 2.0, b[f, 1] - 1.0)))
    err = _check(tr, b, min_usable=0.8 * len(b))
    ok = tr.usable
    assert ok[:f].sum() >= 0.8 * f                # before the target's frame too
    assert np.all(err[np.isfinite(err)] < 1.0)   # never the other ball


@pytest.mark.parametrize("engine", ["rules", "flight"])
def test_a_small_ball_among_a_crowd_and_compression_specks(tmp_path, engine):
    """What the badminton cameras taught: footage compressed so hard that blocks of the
    static scene jump by a few grey levels (thousands of specks a frame at the noise that
    frame differences measure), two dozen people moving, larger than the ball, and a
    ball of 4 px radius named by a ``target``. The rules tracker's threshold rises above
    the specks (and says so); the ball is looked for first where it was named, however
    many larger things move (88 of 90 frames unflagged, at most 0.04 px off). The flight
    tracker links the specks too (2028 tracklets) and follows the ball through its
    ``target``: 90 of 90 unflagged, at most 0.03 px off."""
    rng = np.random.default_rng(11)
    n, shape = 90, (240, 320)
    bg = texture(shape, rng=rng, mean=35.0, contrast=10.0, scale=6.0)
    path = _ballistic(n, (40.0, 120.0), (2.8, -1.6), g=0.04)
    people = [(8.0 + 13.0 * k, 205.0 + 8.0 * (k % 3), rng.uniform(0, 6)) for k in range(24)]
    frames = []
    for i, (u, v) in enumerate(path):
        img = bg.copy()
        cov = np.zeros(shape)
        for x, y, ph in people:
            cov = np.maximum(cov, ellipse_coverage(shape, x + 3.0 * np.sin(i / 6.0 + ph), y,
                                                   5.0, 11.0, 0.2 * np.sin(i / 4.0 + ph)))
        img = compose(img, cov, 140.0).astype(float)
        # 8 x 8 blocks re-encoded 3 to 6 grey levels off, a different set every frame
        # (after the first 30: the background's frames are clean of them)
        if i >= 30:
            for _ in range(250):
                by, bx = rng.integers(0, shape[0] // 8) * 8, rng.integers(0, shape[1] // 8) * 8
                img[by:by + 8, bx:bx + 8] += rng.choice([-1.0, 1.0]) * rng.uniform(3.0, 6.0)
        frames.append(compose(img, disc_coverage(shape, u, v, 4.0), 200.0, rng=rng, noise=0.8))
    f = 60
    tr = _track(tmp_path, frames, target=(f, (path[f, 0] + 1.0, path[f, 1])), engine=engine)
    err = _check(tr, path, min_usable=0.8 * n)
    assert np.all(err[np.isfinite(err)] < 2.0)          # never a person
    if engine == "rules":
        assert any(n.startswith("threshold raised to") for n in tr.notes), tr.notes


def test_a_target_where_nothing_moves_is_refused(tmp_path):
    frames, a, b = _two_balls(np.random.default_rng(5))
    with pytest.raises(TrackError, match="nothing moves at the target"):
        _track(tmp_path, frames, target=(30, (200.0, 20.0)))
    with pytest.raises(TrackError, match="not in the footage"):
        _track(tmp_path, frames, target=(500, (20.0, 20.0)))


# --------------------------------------------------------------------- scene.toml
_SCENE = """schema = 1
[views.front]
source = "front.avi"
fps = 240
axes = ["+x", "-y"]
origin_px = [458.0, 500.0]
m_per_px = 0.0021765
{extra}
"""


@pytest.mark.parametrize("extra, key, words", [
    ("target = 5", "views.front.target", "must be a table { frame = F, at_px = [u, v] }"),
    ("target = { frame = 3 }", "views.front.target.at_px", "is required"),
    ("target = { at_px = [1, 2] }", "views.front.target.frame", "is required"),
    ("target = { frame = -1, at_px = [1, 2] }", "views.front.target.frame", "must be >= 0"),
    ("target = { frame = 1.5, at_px = [1, 2] }", "views.front.target.frame",
     "must be a frame index"),
    ("target = { frame = 1, at_px = [1] }", "views.front.target.at_px", "must be two numbers"),
    ("target = { frame = 1, at_px = [1, 2], px = 3 }", "views.front.target.px",
     "is not a known key"),
    ("frames = [0, 50]\ntarget = { frame = 60, at_px = [1, 2] }", "views.front.target.frame",
     "must be inside frames [0, 50)"),
])
def test_scene_target_key_is_checked_with_one_line(tmp_path, extra, key, words):
    from vidtrack.errors import SceneError
    from vidtrack.scene import load_scene

    (tmp_path / "scene.toml").write_text(_SCENE.format(extra=extra))
    with pytest.raises(SceneError) as err:
        load_scene(tmp_path)
    msg = str(err.value)
    assert "\n" not in msg and f"{key} " in msg and words in msg


def test_scene_target_key_reads_and_writes_back(tmp_path):
    from vidtrack.scene import load_scene, write_scene

    (tmp_path / "scene.toml").write_text(
        _SCENE.format(extra="target = { frame = 200, at_px = [878.0, 320.0] }"))
    scene = load_scene(tmp_path)
    assert scene.views["front"].target == (200, (878.0, 320.0))
    write_scene(tmp_path / "copy", scene.to_dict())
    again = load_scene(tmp_path / "copy")
    assert again.views["front"].target == (200, (878.0, 320.0))


# --------------------------------------------------------------------- run42 by target
@pytest.mark.parametrize("frame", [60, 200, 330])
def test_a_target_anywhere_in_the_bundled_run_gives_the_automatic_track(frame):
    """The bundled run's straw named by a ``target`` at the rendered truth in an early,
    middle or late frame (once: 'could not be followed' at frame 200, where compression
    left a dark speck at the straw's edge and the straw was taken for a two-polarity
    object) is followed both ways and measured as without the hint."""
    import json
    from pathlib import Path

    run = Path(__file__).resolve().parents[1] / "datasets" / "run42"
    per = json.loads((run / "truth.json").read_text())["views"]["front"]["per_frame"]
    k = per["frame"].index(frame)
    at = (float(per["u_px"][k]), float(per["v_px"][k]))
    with open_source(run / "front.avi", fps=1200) as src:
        auto = track(src, view="front")
    with open_source(run / "front.avi", fps=1200) as src:
        hinted = track(src, view="front", target=(frame, at))
    a, h = auto.data, hinted.data
    both = (a["flags"] == 0) & (h["flags"] == 0)
    assert both.sum() >= 0.95 * (a["flags"] == 0).sum()
    assert np.max(np.abs(a["u_px"][both] - h["u_px"][both])) < 0.05
    truth_u = np.interp(h["frame"], per["frame"], per["u_px"])
    assert np.max(np.abs(h["u_px"][h["flags"] == 0] - truth_u[h["flags"] == 0])) < 0.5


# --------------------------------------------------------------------- something in front
POST = (100, 132)     # columns of a post standing before everything


def _behind_a_post(emerges, n=110):
    """A thin, light rod (1.5 px, level 180) flying across a textured wall, behind a post
    that stands before everything (the background holds it). ``emerges``: "same", it
    comes out on the other side; "other", it stays behind (caught) and a wide dark rod
    (4 px, level 20) comes out instead, 5 px beside its path. Returns the frames, the
    rod's true centre and whether it is whole in view."""
    rng = np.random.default_rng(21)
    bg = texture(SHAPE, rng=rng, mean=110.0, contrast=20.0)
    t = np.arange(n, dtype=float)
    path = np.column_stack([20.0 + 2.0 * t, 120.0 - 0.9 * t + 0.006 * t * t])
    frames, whole = [], np.zeros(n, bool)
    for i, (u, v) in enumerate(path):
        ang = 0.3 + 0.01 * i
        reach = 0.5 * (22.0 * abs(np.cos(ang)) + 1.5 * abs(np.sin(ang))) + 1.0
        whole[i] = u + reach < POST[0] or u - reach > POST[1]
        if u < POST[1] or emerges == "same":
            cov = rod_coverage(SHAPE, u, v, 22.0, 1.5, ang)
            img = compose(bg, cov, 180.0).astype(float)
        else:
            img = compose(bg, rod_coverage(SHAPE, u, v + 5.0, 22.0, 4.0, ang), 20.0)
            img = img.astype(float)
        img[:, POST[0]:POST[1]] = 60.0
        frames.append(np.clip(np.rint(img + rng.normal(0, 1.5, SHAPE)), 0, 255)
                      .astype(np.uint8))
    return frames, path, whole


@pytest.mark.parametrize("engine", ["rules", "flight"])
def test_a_rod_going_behind_a_post_and_out_is_flagged_while_part_of_it_is_hidden(
        tmp_path, engine):
    """Partly behind the post, the rod's centroid is its visible part's: it lags its
    centre going in and leads it coming out, by half what is hidden. Such frames are
    flagged (the rod shortened at one end, its centre off its path along its axis), and
    the rod is found again on the other side. Before: 5 frames going in unflagged 0.8 to
    5.9 px off; the lagging points bent the prediction and the rod was never found
    again (66 frames lost). Measured now: 85 unflagged, 49 of them past the post, within
    0.37 px. The flight tracker: two frames going in and one coming out, between frames
    flagged for the rod's shortening at a stroke, were unflagged 4.6 to 5.9 px off (they
    predicted each other on the path); a short run between flagged frames is now tested
    before it is trusted: 82 unflagged, within 0.09 px."""
    frames, path, whole = _behind_a_post("same")
    tr = _track(tmp_path, frames, engine=engine)
    err = _check(tr, path, min_usable=80)
    after = path[:, 0] > POST[1] + 12
    assert np.count_nonzero(tr.usable & after) >= 40
    # every unflagged frame partly behind the post is measured right (the flag is not
    # needed where under a tenth of a pixel is hidden)
    assert np.all(err[tr.usable & ~whole] <= 0.5)


@pytest.mark.parametrize("radius", [6.0, 10.0])
def test_a_ball_going_behind_a_post_and_out_is_flagged_while_part_of_it_is_hidden(
        tmp_path, radius):
    """A light ball on the rod's path behind the same post. Partly hidden, its centroid
    is its visible part's; such frames are flagged (smaller than its clean frames, its
    centroid off their path as far as a part hidden at one side moves it), and it is
    found again on the other side. Before: one frame going in unflagged 0.8 px off (15 %
    hidden), and the ball never found again; measured now (radius 6 and 10 px): 85 and
    79 unflagged, 46 and 42 past the post, within 0.09 and 0.07 px."""
    rng = np.random.default_rng(22)
    bg = texture(SHAPE, rng=rng, mean=110.0, contrast=20.0)
    n = 110
    t = np.arange(n, dtype=float)
    path = np.column_stack([20.0 + 2.0 * t, 120.0 - 0.9 * t + 0.006 * t * t])
    frames = []
    for u, v in path:
        img = compose(bg, disc_coverage(SHAPE, u, v, radius), 200.0).astype(float)
        img[:, POST[0]:POST[1]] = 60.0
        frames.append(np.clip(np.rint(img + rng.normal(0, 1.5, SHAPE)), 0, 255)
                      .astype(np.uint8))
    tr = _track(tmp_path, frames)
    _check(tr, path, min_usable=75)
    assert np.count_nonzero(tr.usable & (path[:, 0] > POST[1] + radius)) >= 40


@pytest.mark.parametrize("engine", ["rules", "flight"])
def test_another_rod_where_a_lost_rod_could_be_is_not_taken(tmp_path, engine):
    """The thin light rod stays behind the post; a wide dark one comes out where it could
    be. Two objects are never one track, and the notes name the one not taken. The rules
    tracker follows the first and finds a rod again only where it looks like it (its
    width and grey level): this one is 1.6 times as wide and of the other polarity, and is
    not taken (without that check it was: 48 frames unflagged, 5 px off the rod
    followed). The flight tracker joins no two chains of opposite polarities across a
    gap, takes the longer flight, the dark rod's (40 frames unflagged; before, it joined
    the two across the post and took the light rod for the dark one's ride on a blade),
    and names the light rod's frames with the target line that follows it."""
    frames, path, whole = _behind_a_post("other")
    tr = _track(tmp_path, frames, engine=engine)
    after = path[:, 0] > POST[1]
    notes = [x for x in tr.notes if "another object" in x and "not taken" in x]
    assert len(notes) == 1, tr.notes
    if engine == "rules":
        _check(tr, path, min_usable=30)
        assert not np.any(tr.usable & after)
        return
    # (the dark rod is drawn 5 px below the light rod's path)
    _check(tr, path + [0.0, 5.0], min_usable=35, where=after)
    assert not np.any(tr.usable & ~after)
    assert "target = { frame = " in notes[0]
