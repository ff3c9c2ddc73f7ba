"""``vidtrack calibrate``: write a calibration file (ruler scale or checkerboard camera)."""

import argparse
from pathlib import Path

HELP = "build a calibration file: ruler scale, or checkerboard intrinsics and distortion"

DESCRIPTION = """\
Build a calibration file (TOML, schema 1; docs/calibration.md) that scene.toml can name
as  calibration = "FILE"  in a [views.NAME] table.

  ruler         the scale k = W / N of a ruler of length W spanning N pixels
                (prints k; writes [scale] with -o)
  checkerboard  camera intrinsics and lens distortion from images of a printed
                checkerboard (OpenCV), with the reprojection error; with --plane-image,
                also the scale of the throw plane (writes [camera] and [scale])

examples:
  vidtrack calibrate ruler --length-m 0.5 --from 80,482 --to 205,482 -o calibration/front.toml
  vidtrack calibrate checkerboard board_images/ --pattern 9x6 --square-m 0.025 \\
      --plane-image board_images/in_plane.png -o calibration/front.toml
"""


def _type(parse, what):
    """An argparse type from a library parser: its InputError becomes a usage error."""
    def convert(text):
        from calibration.errors import InputError

        try:
            return parse(text)
        except InputError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    convert.__name__ = what
    return convert


def _point(option):
    def parse(text):
        from calibration.scale import pixel_point

        return pixel_point(text, option)
    return _type(parse, "point")


def _positive(option):
    def parse(text):
        from calibration.errors import InputError

        try:
            value = float(text)
        except ValueError:
            raise InputError(f"{option} must be a number, got {text!r}") from None
        if not (value > 0 and value != float("inf")):
            raise InputError(f"{option} must be a finite number > 0, got {text!r}")
        return value
    return _type(parse, "number")


def _pattern(text):
    from calibration.checkerboard import parse_pattern

    return parse_pattern(text)


def add_arguments(parser):
    """Register the ``ruler`` and ``checkerboard`` modes."""
    from vidtrack.cli import add_common_options

    modes = parser.add_subparsers(dest="mode", metavar="MODE", required=True)

    r = modes.add_parser(
        "ruler", help="scale k = W / N from a ruler of known length",
        description="The scale k = W / N (m per pixel) of a ruler of length W whose ends "
                    "are at two pixel positions. Example: vidtrack calibrate ruler "
                    "--length-m 0.5 --from 80,482 --to 205,482 -o calibration/front.toml")
    r.add_argument("--length-m", required=True, type=_positive("--length-m"), metavar="W",
                   help="the ruler's length in metres, e.g. --length-m 0.5")
    r.add_argument("--from", dest="from_px", required=True, type=_point("--from"),
                   metavar="U,V", help="pixel (column,row) of one end, e.g. --from 80,482 "
                                       "(negative values: --from=-3,482)")
    r.add_argument("--to", dest="to_px", required=True, type=_point("--to"), metavar="U,V",
                   help="pixel (column,row) of the other end, e.g. --to 205,482")
    r.add_argument("-o", "--output", type=Path, metavar="FILE.toml",
                   help="write the calibration file here, e.g. -o calibration/front.toml "
                        "(default: only print k)")
    add_common_options(r, level=2)

    c = modes.add_parser(
        "checkerboard", help="intrinsics and distortion from checkerboard images",
        description="Camera intrinsics and lens distortion from several images of a flat "
                    "checkerboard in different poses (OpenCV findChessboardCorners, "
                    "cornerSubPix, calibrateCamera), with the reprojection error overall "
                    "and per image. Example: vidtrack calibrate checkerboard board/ "
                    "--pattern 9x6 --square-m 0.025 -o calibration/front.toml")
    c.add_argument("images", nargs="+", type=Path, metavar="IMAGES_OR_FOLDER",
                   help="image files, or one folder of images (natural order), "
                        "e.g. board/ or board/*.png")
    c.add_argument("--pattern", required=True, type=_type(_pattern, "pattern"),
                   metavar="COLSxROWS",
                   help="inner corners per row x per column, e.g. --pattern 9x6")
    c.add_argument("--square-m", required=True, type=_positive("--square-m"), metavar="S",
                   help="side of one square in metres, e.g. --square-m 0.025")
    c.add_argument("--plane-image", type=Path, metavar="IMAGE",
                   help="an image of the board lying in the throw plane, square to the "
                        "camera: adds the plane's scale (m per pixel), e.g. "
                        "--plane-image board/in_plane.png")
    c.add_argument("--fix-k3", action="store_true",
                   help="hold the radial term k3 at 0 (few images or a mild lens)")
    c.add_argument("-o", "--output", required=True, type=Path, metavar="FILE.toml",
                   help="the calibration file to write, e.g. -o calibration/front.toml")
    add_common_options(c, level=2)


def _check_output(path, inputs):
    from calibration.errors import InputError

    if path.suffix.lower() != ".toml":
        raise InputError(f"-o {path}: expected a .toml file name")
    if path.is_dir():
        raise InputError(f"-o {path}: is a folder; expected a .toml file name")
    from vidtrack._atomic import check_output

    check_output(path, inputs=inputs, label=f"-o {path}")   # not an input, writable


def _run_ruler(args):
    from calibration.calibration_file import calibration_to_toml
    from calibration.scale import ruler_scale
    from vidtrack._atomic import write_text

    if args.output is not None:
        _check_output(args.output, [])
    scale = ruler_scale(args.length_m, args.from_px, args.to_px)
    print(f"k = {scale.m_per_px:.10g} m/px  ({scale.length_m:g} m over {scale.span_px:.6g} px "
          f"from {_pt(scale.from_px)} to {_pt(scale.to_px)})")
    if args.output is not None:
        write_text(args.output, calibration_to_toml(scale=scale))
        print(f"wrote {args.output}")
    return 0


def _pt(p):
    return f"({p[0]:g}, {p[1]:g})"


def _run_checkerboard(args):
    from calibration.calibration_file import calibration_to_toml
    from calibration.checkerboard import checkerboard_calibration
    from vidtrack._atomic import write_text
    from vidtrack._progress import progress

    _check_output(args.output, [*args.images, args.plane_image])
    images = args.images[0] if len(args.images) == 1 else args.images
    quiet = getattr(args, "quiet", False)
    result = checkerboard_calibration(
        images, args.pattern, args.square_m, plane_image=args.plane_image,
        fix_k3=args.fix_k3,
        progress=lambda it, total: progress(it, total=total, desc="corners", quiet=quiet))
    cam = result.camera
    n_all = len(cam.images) + len(cam.rejected)
    names = ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")
    dist = "  ".join(f"{n} = {v:.6g}" for n, v in zip(names, cam.dist_coeffs))
    print(f"board {cam.pattern[0]}x{cam.pattern[1]}, square {cam.square_m:g} m: found in "
          f"{len(cam.images)} of {n_all} images")
    print(f"image size {cam.image_size[0]}x{cam.image_size[1]} px")
    print(f"fx = {cam.fx:.6g} px  fy = {cam.fy:.6g} px  cx = {cam.cx:.6g} px  "
          f"cy = {cam.cy:.6g} px")
    print(f"distortion: {dist}")
    print(f"reprojection error: {cam.rms_px:.4f} px RMS over all corners")
    for name, err in zip(cam.images, cam.per_image_rms_px):
        print(f"  {err:.4f} px  {name}")
    for name in cam.rejected:
        print(f"  (board not found)  {name}")
    if result.scale is not None:
        print(f"plane scale: {result.scale.m_per_px:.10g} m/px (from {args.plane_image})")
    write_text(args.output, calibration_to_toml(camera=cam, scale=result.scale))
    print(f"wrote {args.output}")
    return 0


def run(args):
    """Run the chosen mode; returns the exit code."""
    if args.mode == "ruler":
        return _run_ruler(args)
    return _run_checkerboard(args)
