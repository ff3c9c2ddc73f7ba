"""``vidtrack init``: write a run's first scene.toml from the footage in its folder."""

HELP = "write a commented scene.toml for a run folder from the footage found in it"

DESCRIPTION = """\
Look in RUN for footage (video files such as .avi .mp4 .mov .mkv, folders of images,
Phantom .cine files; with throws/, in the first throw folder), open each to record its
frame count, image size and the frame rate its container states, and write RUN/scene.toml
with a [views.front] and/or [views.top] table for them, every other table and key shown
as a comment.

Footage whose name contains "front" or "top" goes to that view; --front FILE and
--top FILE say it outright (a path from the working folder or inside RUN). If the names
do not tell, nothing is written and the flags to give are shown.

What only you know is marked TODO(user): the CAPTURE rate (fps; the rate a video's
container states is usually its playback rate), the image axes, the origin's pixel and
the scale (a ruler, or m_per_px). The marked values are ones vidtrack refuses, so
'vidtrack fit RUN' stops with a one-line message naming the first key to fill in until
they are real. Set the straw's Cp in [straw] too (needed for k3 and k4), and
[machine] speed_kmh if the machine moved.

An existing scene.toml is never overwritten, except the one 'vidtrack design' wrote for a
planned run (no views yet): its [run] and [factors] are kept in the template. Nothing
else in RUN is written or changed.

Examples:
  vidtrack init runs/07
  vidtrack init runs/07 --front runs/07/cam1.avi --top runs/07/cam2.avi
"""


def add_arguments(parser):
    parser.add_argument("run", metavar="RUN",
                        help="the run folder holding the footage, e.g. runs/07")
    parser.add_argument("--front", metavar="FILE",
                        help="the front view's footage (video, image folder or .cine), "
                             "e.g. --front cam1.avi")
    parser.add_argument("--top", metavar="FILE",
                        help="the top view's footage, e.g. --top cam2.avi")
    parser.add_argument("--json", action="store_true",
                        help="print what was written and found as JSON")


def run(args):
    import json

    from vidtrack.scene_template import write_scene_template

    t = write_scene_template(args.run, front=args.front, top=args.top)
    if args.json:
        print(json.dumps(t.to_dict(), indent=2))
        return 0
    print(f"wrote {t.path}")
    for f in t.views.values():
        rate = (f"the file states {f.fps_container:g} fps" if f.fps_container
                else "no frame rate stated")
        print(f"  {f.view}: {f.source_text} ({f.kind}, {f.frames} frames, "
              f"{f.width_px} x {f.height_px} px, {rate})")
    for p in t.unused:
        print(f"  not used: {p.name} (give it with --front or --top if it is a view)")
    print("Fill in the lines marked TODO(user): for each view fps (the CAPTURE rate, not the "
          "rate a video states), axes, origin_px and a scale; and the straw's Cp in [straw].")
    print(f"Then: vidtrack fit {args.run}")
    return 0
