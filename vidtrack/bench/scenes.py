"""The synthetic distractor scenes of the tracker scoreboard, and how a view is scored.

:data:`CASES` is the table of ``vidtrack synth`` distractor scenes (what real footage
taught: a shadow, a rider beside or across the straw, a dark straw with a highlight, a
person at the side, a post or an arm before the front camera, small and compact
objects), each rendered at the small scale :data:`BASE` (320 x 150 front, 320 x 96 top,
372 frames a view). ``tests/test_synth_distractors.py`` fits the same scenes end to end.

A scene is rendered by the real ``vidtrack synth`` command (its options are the table's)
into a temporary folder; each view is tracked and scored against ``truth.json`` (written
by the renderer from geometry): the flight is the frames from the release on
(``phase == "flight"``); distances are from the straw's own coverage centroid
(``u_coverage_px, v_coverage_px``: what a perfect tracker measures) on the clean frames
(wholly in view, in flight, touching neither the blade nor another straw); the figure
(``|a| px/s2``) is the acceleration of a drag-free 2-D parabola fitted to the track's
unflagged clean points and to the truth's on every clean frame.
"""

import subprocess
import sys

import numpy as np

from vidtrack.bench._score import Score, accel_2d

__all__ = ["BASE", "CASES", "VIEWS", "scene_view_names", "render_scene", "clean_frames",
           "score_view"]

#: The views every scene has.
VIEWS = ("front", "top")

#: The run every end-to-end case renders (the scale of tests/test_cli_fit.py), 372
#: frames a view, then the case's options.
BASE = ["--size", "320x150", "--top-size", "320x96", "--straw-length-m", "0.25",
        "--straw-diameter-m", "0.025", "--quality", "60", "--noise", "1.0",
        "--flight-s", "0.3"]

#: case -> (options, the distractor columns of truth.json it adds)
CASES = {
    "shadow": (["--shadow", "4,0.4,1.5"], ("shadow",)),
    "rider_riding": (["--rider", "riding"], ("rider",)),
    "rider_crossing": (["--rider", "crossing"], ("rider",)),
    "dark": (["--straw-polarity", "dark"], ()),
    "dark_highlight": (["--straw-polarity", "dark", "--highlight", "0.95"], ()),
    "dark_highlight_riding": (["--straw-polarity", "dark", "--highlight", "0.95",
                               "--rider", "riding"], ("rider",)),
    "person": (["--person-at-side"], ("person",)),
    "post": (["--post", "0.6,10"], ()),
    "arm": (["--post", "0.6,10,-1.5"], ()),
    # passing the straw the way it flies: 16 px, 2.5 px a frame
    "arm_passing": (["--post", "0.5,16,2.5"], ()),
    # moving with it, 1 px a frame: 25-37 % of it hidden for 60 frames
    "arm_along": (["--post", "0.6,10,1.0"], ()),
    # an object 4 px across (3 cm) going behind the post and out
    "small_post": (["--straw-length-m", "0.03", "--straw-diameter-m", "0.03",
                    "--post", "0.6,10"], ()),
    # a compact object (7 by 6 cm: 10 by 8 px) with an arm moving along with it
    "compact_arm_along": (["--straw-length-m", "0.07", "--straw-diameter-m", "0.06",
                           "--post", "0.6,10,1.0"], ()),
    # the same object with its shadow 4 px off, half under it (a ball before a lit
    # wall: before, the object and its shadow were taken as one object of both
    # polarities, the front view's frames 2.5 px off, exit 0)
    "compact_shadow": (["--straw-length-m", "0.07", "--straw-diameter-m", "0.06",
                        "--shadow", "4,0.4,1.5"], ("shadow",)),
    # dark with a highlight, a steel ball (before its measurement of one grey level with
    # a spot, measure_spotted: 122 of 335 front frames 0.5 to 1.95 px off, k1 -4 %,
    # k4 +4 %, exit 0), and one 17 by 14 px (before the highlight was held to be part
    # of it: the highlight taken, every frame flagged MERGED, exit 2)
    "compact_dark_highlight": (["--straw-length-m", "0.07", "--straw-diameter-m", "0.06",
                                "--straw-polarity", "dark", "--highlight", "0.95"], ()),
    "ball_dark_highlight": (["--straw-length-m", "0.12", "--straw-diameter-m", "0.10",
                             "--straw-polarity", "dark", "--highlight", "0.95"], ()),
    # and one 6 by 5 px, too small for an interior beside its highlight (before its
    # level was read off its plateau: 249 of 372 front frames kept, up to 2.13 px off,
    # k1 -2.3 %, k4 -2.6 %, exit 0)
    "small_dark_highlight": (["--straw-length-m", "0.04", "--straw-diameter-m", "0.035",
                              "--straw-polarity", "dark", "--highlight", "0.95"], ()),
}


def scene_view_names():
    """``synth:NAME/VIEW`` for every case and view, in the table's order."""
    return [f"synth:{name}/{view}" for name in CASES for view in VIEWS]


def render_scene(name, out_dir):
    """Render the scene ``name`` of :data:`CASES` into ``out_dir``; its truth.json (dict).

    Runs ``vidtrack synth OUT_DIR BASE... OPTIONS... -q`` (the command the tests run) in
    a child process, the interpreter of this one.

    Raises
    ------
    VidtrackError
        An unknown scene, or the render failed (its last line of stderr).
    """
    import json
    from pathlib import Path

    from vidtrack.errors import VidtrackError

    if name not in CASES:
        raise VidtrackError(f"no synthetic scene {name!r}; expected one of "
                            f"{', '.join(CASES)}")
    out_dir = Path(out_dir)
    res = subprocess.run([sys.executable, "-m", "vidtrack", "synth", str(out_dir), *BASE,
                          *CASES[name][0], "-q"], capture_output=True, text=True,
                         stdin=subprocess.DEVNULL)
    if res.returncode != 0:
        last = (res.stderr.strip().splitlines() or ["(no message)"])[-1]
        raise VidtrackError(f"vidtrack synth {name}: exit {res.returncode}: {last}")
    return json.loads((out_dir / "truth.json").read_text())


def _floats(values):
    return np.array([np.nan if x is None else float(x) for x in values])


def clean_frames(per_frame):
    """Boolean per frame of a truth.json view's ``per_frame``: the straw in free flight,
    wholly in view, touching neither the blade nor another straw."""
    n = len(per_frame["frame"])

    def flag(key, default):
        return np.array([bool(x) for x in per_frame.get(key, [default] * n)])

    return (np.array([p == "flight" for p in per_frame["phase"]])
            & flag("fully_in_view", True) & ~flag("blade_overlap", False)
            & ~flag("overlap", False))


def score_view(tr, about):
    """One view's track against its truth (``truth.json``'s ``views[view]``).

    Returns
    -------
    Score
        ``flight_frames``: frames from the release on; ``dist_px``: unflagged clean
        frames from the straw's coverage centroid; figure ``|a| px/s2`` (module notes).
    """
    pf = about["per_frame"]
    frames = np.asarray(pf["frame"], dtype=int)
    t = np.asarray(pf["t_s"], dtype=float)
    tu, tv = _floats(pf["u_coverage_px"]), _floats(pf["v_coverage_px"])
    flight = np.array([p == "flight" for p in pf["phase"]])
    clean = clean_frames(pf) & np.isfinite(tu) & np.isfinite(tv)
    d = tr.data
    pos = {int(f): i for i, f in enumerate(d["frame"].to_numpy(dtype=int))}
    rows = np.array([pos.get(int(f), -1) for f in frames])
    have = rows >= 0
    u = np.full(frames.size, np.nan)
    v = np.full(frames.size, np.nan)
    ok = np.zeros(frames.size, bool)
    u[have] = d["u_px"].to_numpy(dtype=float)[rows[have]]
    v[have] = d["v_px"].to_numpy(dtype=float)[rows[have]]
    ok[have] = tr.usable[rows[have]]
    scored = ok & clean
    return Score(flight_frames=int(flight.sum()), unflagged=int((ok & flight).sum()),
                 dist_px=np.hypot(u - tu, v - tv)[scored], fit="|a| px/s2",
                 fit_track=accel_2d(t[scored], u[scored], v[scored]),
                 fit_ref=accel_2d(t[clean], tu[clean], tv[clean]),
                 fit_ref_same=accel_2d(t[scored], tu[scored], tv[scored]),
                 note=f"{int(clean.sum())} clean frames")
