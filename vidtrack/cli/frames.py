"""``vidtrack frames``: extract the frames of a video, image folder or .cine to image files."""

HELP = "extract frames to numbered image files plus frames.csv (frame, t_s, file)"

DESCRIPTION = """\
Write the frames of SOURCE (a video, a folder of images, or a Phantom .cine) to OUT as
frame_000123.png ... (numbered by the 0-based frame index in the source file) and
OUT/frames.csv with columns frame, t_s (s, relative to the file's first frame), file.

Bit depth is kept: a 16-bit source (a .cine, 16-bit png/tif) stays 16-bit in png and
tiff, with its stored values unchanged (a 12-bit camera gives 0..4095). jpg holds only
8 bits and is refused for 16-bit sources. Colour is converted to grey: BT.601 luma, or
with --channel one colour channel or the one "auto" chooses (as scene.toml's channel).

Times: a .cine's per-image time stamps are used when present (and checked against
--fps or the setup frame rate); otherwise --fps, the CAPTURE rate, wins over the rate
a video container claims (exported high-speed videos say 30 fps). An image folder
needs --fps. Notes about the time base go to stderr.

Nothing is written unless every selected frame could be read; frames.csv is written
last.

examples:
  vidtrack frames run42/front.avi out/front --fps 1200
  vidtrack frames shot.cine out/shot --range 100:400 --every 2 --format tiff
"""


def add_arguments(parser):
    parser.add_argument("source", metavar="SOURCE",
                        help="video file, image folder or .cine file, e.g. run42/front.avi")
    parser.add_argument("out", metavar="OUT", help="output folder, e.g. out/front")
    parser.add_argument("--range", dest="range", metavar="A:B",
                        help="half-open range of 0-based frame indices, e.g. 100:400 "
                             "(A: or :B leave one end open)")
    parser.add_argument("--every", type=int, default=1, metavar="N",
                        help="keep every N-th frame of the range, e.g. --every 10 (default 1)")
    parser.add_argument("--format", dest="fmt", choices=("png", "jpg", "tiff"), default="png",
                        help="image format (default png; jpg only for 8-bit sources)")
    parser.add_argument("--fps", type=float, metavar="FPS",
                        help="capture rate in frames/s, e.g. --fps 1200; wins over a video "
                             "container's rate (a .cine's time stamps are kept and checked "
                             "against it)")
    parser.add_argument("--channel", default="luma", metavar="CHANNEL",
                        help="the grey image written from colour footage: luma (default, "
                             "BT.601), red, green, blue, chroma (max - min of R, G, B: "
                             "how far from grey), or auto (the channel in which "
                             "moving things stand out most, noted on stderr)")
    parser.add_argument("--no-time-stamps", action="store_true",
                        help="time a .cine by --fps (or its setup frame rate) instead of its "
                             "per-image time stamps")


def _parse_range(text):
    from vidtrack.errors import VidtrackError

    if text is None:
        return None
    parts = text.split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        a = int(parts[0]) if parts[0].strip() else 0
        b = int(parts[1]) if parts[1].strip() else None
    except ValueError:
        raise VidtrackError(f"--range must be A:B with integer frame indices, e.g. 100:400, "
                            f"got {text!r}") from None
    if a < 0 or (b is not None and b <= a):
        raise VidtrackError(f"--range must be A:B with 0 <= A < B, got {text!r}")
    return a, b


def run(args):
    import logging

    from vidtrack.errors import VidtrackError
    from vidtrack.footage import export_frames, open_source
    from vidtrack.footage.timebase import check_time_base

    frames = _parse_range(args.range)
    if args.every < 1:
        raise VidtrackError(f"--every must be >= 1, got {args.every}")
    with open_source(args.source, fps=args.fps, frames=frames, channel=args.channel,
                     use_time_stamps=not args.no_time_stamps) as source:
        report = check_time_base(source, duplicates=False)
        result = export_frames(source, args.out, every=args.every, fmt=args.fmt,
                               quiet=args.quiet)
    log = logging.getLogger(__name__)
    for note in report.warnings:
        log.warning("%s", note, extra={"label": "note"})
    depth = (f"{result.dtype}, {result.bit_depth} significant bits")
    print(f"wrote {len(result.files)} frames ({result.format}, {depth}) and frames.csv to "
          f"{result.out}; times from {result.time_source}")
    return 0
