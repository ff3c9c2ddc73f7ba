"""``vidtrack overlay``: the footage with the measured point, the fitted path and the flags."""

HELP = "write each view's footage with the tracked point, the fitted path and the flags drawn"

DESCRIPTION = """\
Write RUN/vidtrack/overlay_<view>.mp4 for every view with footage: each frame in colour
with the measured centroid (a ring: green when the frame is unflagged, else the colour
of its first flag), the fitted path projected into the view (a white line over the
flight, the frame's fitted point a white cross), the trail (the measured points of the
last --trail frames as pale yellow dots that fade), the scene where scene.toml gives it
(origin O, the world axes as arrows, the ruler with its length, in pale blue), and in
the top-left corner the view, the frame number, its time and the flag names (e.g.
MERGED|PRE_RELEASE).

The tracks and the fit are read from RUN/vidtrack (tracks.h5, fit.json). When they are
missing or stale (the scene, the footage or vidtrack changed since, or a file was
edited), the run is fitted first, exactly as 'vidtrack fit RUN' does (with the model
fit.json names); that fit's refusals (exit 2) stop the overlay too.

Calibrated views that give points instead of footage have nothing to draw on: they are
skipped with a note. With throws/, each throw's overlays go to RUN/vidtrack/<throw>/.
The video is H.264 MP4 (yuv420p, even sizes, index at the front) that browsers play
inline, encoded by the ffmpeg inside the imageio-ffmpeg wheel; each file appears whole
or not at all.

Examples:
  vidtrack overlay runs/07
  vidtrack overlay runs/07 --view top --every 4 --scale 0.5 --range 100:400
  vidtrack overlay runs/07 --trail 0
"""


def add_arguments(parser):
    parser.add_argument("run", metavar="RUN", help="the run folder (with scene.toml)")
    parser.add_argument("--view", metavar="NAME", action="append",
                        help="only this view (repeat for more), e.g. --view front")
    parser.add_argument("--every", metavar="N", type=int, default=1,
                        help="every N-th frame only (1 to 100000; default 1: all)")
    parser.add_argument("--scale", metavar="F", type=float, default=1.0,
                        help="output size / footage size (0.1 to 4; e.g. 0.5 for big "
                             "footage; default 1)")
    parser.add_argument("--range", metavar="A:B", dest="frame_range",
                        help="only the file's frames A to B-1 (0-based, half-open; A: or "
                             ":B for open ends), e.g. --range 100:400")
    parser.add_argument("--trail", metavar="N", type=int, default=None,
                        help="the measured points of the last N frames drawn as a fading "
                             "trail (0: none; default 30), e.g. --trail 60")


def parse_range(text):
    """``"a:b"`` -> (a, b or None); VidtrackError (one line) when malformed."""
    from vidtrack.errors import VidtrackError

    if text is None:
        return None
    a, sep, b = str(text).partition(":")
    try:
        if not sep:
            raise ValueError
        first = int(a) if a.strip() else 0
        end = int(b) if b.strip() else None
    except ValueError:
        raise VidtrackError(f"--range {text}: expected A:B, two frame numbers (0-based, "
                            "half-open), e.g. --range 100:400") from None
    if first < 0 or (end is not None and end <= first):
        raise VidtrackError(f"--range {text}: expected 0 <= A < B, e.g. --range 100:400")
    return first, end


def check_options(args):
    """The numbers typed, within bounds (VidtrackError naming the option)."""
    import math

    from vidtrack.errors import VidtrackError
    from vidtrack.report.overlay import MAX_EVERY, MAX_SCALE, MAX_TRAIL, MIN_SCALE

    if not 1 <= args.every <= MAX_EVERY:
        raise VidtrackError(f"--every {args.every}: expected a whole number of frames from 1 "
                            f"to {MAX_EVERY}")
    if not (math.isfinite(args.scale) and MIN_SCALE <= args.scale <= MAX_SCALE):
        raise VidtrackError(f"--scale {args.scale:g}: expected a factor from {MIN_SCALE:g} "
                            f"to {MAX_SCALE:g} (output size / footage size)")
    if args.trail is not None and not 0 <= args.trail <= MAX_TRAIL:
        raise VidtrackError(f"--trail {args.trail}: expected a whole number of frames from 0 "
                            f"to {MAX_TRAIL}")
    return parse_range(args.frame_range)


def run(args):
    from vidtrack.run.overlay_run import overlay_run

    frame_range = check_options(args)
    results, notes = overlay_run(args.run, views=args.view, every=args.every,
                                 scale=args.scale, frame_range=frame_range,
                                 trail=args.trail, quiet=args.quiet)
    for note in notes:
        import logging

        logging.getLogger("vidtrack").warning(note, extra={"label": "note"})
    for r in results:
        print(f"wrote {r.path} ({r.frames} frames, {r.size[0]} x {r.size[1]} px, "
              f"{r.codec}, {r.seconds:.1f} s)")
    return 0
