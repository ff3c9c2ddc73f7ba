"""``vidtrack synth OUT``: render a synthetic run with known truth."""

import argparse

HELP = "render a synthetic run (front/top views, ruler, noise, blur) with truth.json"

DESCRIPTION = """\
Render a run folder from known coefficients: scene.toml, the footage of a front and/or
top view (or of two pinhole cameras at any angle: --cameras perspective) of a straw
thrown on the quadratic-drag model (k1..k4, Cp, release state) with
a textured background, machine parts, a ruler, the straw riding a rotor tooth before
release, motion blur, sensor noise and MJPG compression, and truth.json (every
parameter; per view and frame: time, world position, true centroid in pixels, flags).
Docs: docs/synth.md.

A rehearsal of a designed experiment: with --regression (or --k-table) OUT is an
experiment folder from 'vidtrack design', and every run is rendered into its folder at
the k1..k4 the equations give at its setting (its [factors] kept in scene.toml), each
throw's k drawn about them with --k-spread; then 'vidtrack report OUT' and
'vidtrack score OUT'. Equations: a .toml file (a table [k1] .. [k4] of term =
coefficient, terms by factor letter for coded levels, A, A:B, A^2, or by name for
natural levels, n_rpm, n_rpm^2), a .csv (response,term,coefficient), the JSON of
'vidtrack anova --json', or chen2018 (the published eqs. 20-23, natural units). Docs:
docs/user-guide.md, "Rehearse it".

examples:
  vidtrack synth run42
  vidtrack synth runs/small --size 320x240 --flight-s 0.2 --format png
  vidtrack synth runs/cross --second-straw --views front --codec ffv1
  vidtrack synth runs/rep --throws 10 --seed 7
  vidtrack synth runs/hard --shadow 4,0.4,1.5 --rider crossing --person-at-side
  vidtrack synth runs/dark --straw-polarity dark --highlight 0.95
  vidtrack synth runs/persp --cameras perspective --camera-distance-m 1.5 --camera-angle-deg 70
  vidtrack synth runs/square --cameras square --camera-distance-m 1.5
  vidtrack synth exp2 --regression chen2018 --throws 2 --k-spread 0.02 --size 300x140
  vidtrack synth exp2 --k-table k_per_run.csv --seed 3
"""

#: k1..k4 rendered when --k is not given.
DEFAULT_K = (2.2, 2.5, 4.6, 21.3)


def _floats(n, what):
    """A parser of ``n`` comma-separated numbers (or any count of the tuple ``n``)."""
    counts = n if isinstance(n, tuple) else (n,)
    said = " or ".join(str(c) for c in counts)

    def parse(text):
        try:
            values = tuple(float(v) for v in text.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {said} comma-separated numbers "
                                             f"({what}), got {text!r}") from None
        if len(values) not in counts:
            raise argparse.ArgumentTypeError(f"expected {said} comma-separated numbers "
                                             f"({what}), got {len(values)} in {text!r}")
        return values
    return parse


def _size(text):
    parts = text.lower().split("x")
    try:
        w, h = (int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels like 480x360, "
                                         f"got {text!r}") from None
    return (w, h)


def _views(text):
    names = tuple(v.strip() for v in text.split(",") if v.strip())
    if not names or any(v not in ("front", "top") for v in names) or len(set(names)) != len(names):
        raise argparse.ArgumentTypeError(f"expected front, top or front,top, got {text!r}")
    return names


def _dlt_views(text):
    if text.strip().lower() == "none":
        return ()
    names = tuple(v.strip() for v in text.split(",") if v.strip())
    if not names or any(v not in ("cam1", "cam2") for v in names) or len(set(names)) != len(names):
        raise argparse.ArgumentTypeError(f"expected cam1, cam2, cam1,cam2 or none, got {text!r}")
    return names


def _axes(text):
    return tuple(a.strip() for a in text.split(","))


def add_arguments(parser):
    p = parser
    p.add_argument("out", metavar="OUT",
                   help="run folder to write (new or empty; see --force), or with "
                        "--regression/--k-table the experiment folder whose runs to render")
    p.add_argument("--force", action="store_true",
                   help="write into a non-empty OUT that holds a synthetic run (its marker "
                        "vidtrack-synth.toml), replacing what that run wrote (scene.toml, "
                        "truth.json, footage, throws/) and vidtrack/; a folder without "
                        "the marker is never written into")
    p.add_argument("--json", action="store_true", help="print what was written as JSON")
    g = p.add_argument_group("throw")
    g.add_argument("--k", type=_floats(4, "k1,k2,k3,k4"), default=None,
                   help="k1,k2,k3,k4 (default 2.2,2.5,4.6,21.3)")
    g.add_argument("--k-spread", type=_floats((1, 4), "relative sd of k, or of k1,k2,k3,k4"),
                   default=None, metavar="SD[,SD,SD,SD]",
                   help="each throw's k drawn about --k with this relative standard "
                        "deviation (one for all, or one per k), a single throw included "
                        "(default: replicate throws spread by 0.03; with --regression "
                        "0.03), e.g. 0.02 or 0.02,0.02,0.03,0.05")
    g.add_argument("--cp", type=float, default=0.115, help="drag parameter Cp, s/m (0.115)")
    g.add_argument("--state", type=_floats(6, "x0,y0,z0,vx0,vy0,vz0 in m and m/s"),
                   default=(0.24, -0.05, 0.0, 7.3, 2.6, 2.0),
                   help="release state x0,y0,z0,vx0,vy0,vz0 in m and m/s, vz0 absolute "
                        "(default 0.24,-0.05,0,7.3,2.6,2.0)")
    g.add_argument("--speed-kmh", type=float, default=7.2, help="machine speed v1, km/h (7.2)")
    g.add_argument("--model", default="quadratic", choices=("quadratic", "linear", "free"),
                   help="throw model (quadratic)")
    g = p.add_argument_group("rehearsal: every run of an experiment folder (vidtrack design)")
    g.add_argument("--regression", metavar="EQUATIONS",
                   help="k1..k4 of each run from regression equations at its setting: a "
                        ".toml, .csv or .json file, or chen2018 (the published eqs. "
                        "20-23), e.g. --regression chen2018")
    g.add_argument("--k-table", metavar="FILE.csv",
                   help="k1..k4 of each run from a CSV with columns run, k1, k2, k3, k4 "
                        "(run: the run folder's name, e.g. 01)")
    g = p.add_argument_group("straw and machine")
    g.add_argument("--straw-length-m", type=float, default=0.10, help="rod length (0.10)")
    g.add_argument("--straw-diameter-m", type=float, default=0.006, help="rod diameter (0.006)")
    g.add_argument("--spin-rad-s", type=float, default=None,
                   help="spin rate after release, rad/s (default: the rotor's rate)")
    g.add_argument("--spin-axis", type=_floats(3, "a world direction x,y,z"),
                   default=(0.0, 0.0, 1.0),
                   help="axis the straw spins about, x,y,z (0,0,1: tumbling in XOY)")
    g.add_argument("--straw-grey", type=float, default=0.85,
                   help="straw grey level 0..1: 0.85 bright (default), e.g. 0.1 dark")
    g.add_argument("--n-rpm", type=float, default=550.0, help="factor n, r/min (550)")
    g.add_argument("--blade-angle-deg", type=float, default=0.0, help="factor delta1 (0)")
    g.add_argument("--blade-rpm", type=float, default=None,
                   help="rotor rate in the footage (default: continuous with the release)")
    g.add_argument("--release-frame", type=int, default=12,
                   help="frames of the straw riding the tooth before release (12)")
    g = p.add_argument_group("cameras")
    g.add_argument("--views", type=_views, default=("front", "top"),
                   help="front, top or front,top (default)")
    g.add_argument("--size", type=_size, default=(480, 360), help="WxH pixels (480x360)")
    g.add_argument("--top-size", type=_size, default=None,
                   help="WxH of the top view (default: --size)")
    g.add_argument("--fps", type=float, default=1200.0,
                   help="capture rate, 0.1..1e7 frames/s (1200)")
    g.add_argument("--playback-fps", type=float, default=30.0,
                   help="rate stated in the AVI container (30)")
    g.add_argument("--flight-s", type=float, default=0.4, help="seconds of flight (0.4)")
    g.add_argument("--frames", type=int, default=None,
                   help="frames per view, at most 100000 (default: release frame + "
                        "flight)")
    g.add_argument("--top-delay-s", type=float, default=0.0,
                   help="the top view's frames are this much later, s (0)")
    g.add_argument("--front-axes", type=_axes, default=("+x", "-y"),
                   help="world axes along column,row of the front view (+x,-y)")
    g.add_argument("--top-axes", type=_axes, default=("+x", "+z"),
                   help="world axes along column,row of the top view (+x,+z)")
    g.add_argument("--m-per-px", type=float, default=None,
                   help="scale (default: fit the rotor and the whole flight)")
    g.add_argument("--leave-frame", action="store_true",
                   help="frame only the first 55%% of the flight: the straw leaves the image")
    g.add_argument("--exposure", type=float, default=0.5,
                   help="exposure time / frame interval, 0 = no motion blur (0.5)")
    g.add_argument("--exposure-samples", type=int, default=8,
                   help="renders averaged per frame (8)")
    g = p.add_argument_group("pinhole cameras (docs/synth.md, \"Perspective cameras\")")
    g.add_argument("--cameras", default="orthographic",
                   choices=("orthographic", "perspective", "square"),
                   help="orthographic (default): ideal cameras square to the axes; "
                        "perspective: pinhole cameras cam1, cam2 at an angle, a calibrated "
                        "scene; square: pinhole cameras square to the axes, a front/top "
                        "scene with camera_distance_m")
    g.add_argument("--camera-distance-m", type=float, default=2.0,
                   help="perspective: from each camera to the middle of the flight; square: "
                        "to the plane Z = 0 / Y = 0, m (2.0; 1 to 3 typical)")
    g.add_argument("--camera-angle-deg", type=float, default=90.0,
                   help="perspective: the angle between the cameras' optical axes, degrees "
                        "(90; 60 to 120 typical)")
    g.add_argument("--distortion", type=_floats(5, "k1,k2,p1,p2,k3"), default=None,
                   help="perspective: the lens of the views written as projection, OpenCV's "
                        "k1,k2,p1,p2,k3 (default: none), e.g. -0.12,0.03,0.0005,-0.0003,0")
    g.add_argument("--dlt-views", type=_dlt_views, default=("cam2",),
                   help="perspective: views written as an 11-parameter DLT with "
                        "pixel_origin bottom-left (no lens): cam1, cam2, cam1,cam2 or none "
                        "(default cam2)")
    g.add_argument("--no-camera-distance-in-scene", action="store_true",
                   help="square: leave camera_distance_m out of scene.toml (perspective "
                        "then not corrected)")
    g = p.add_argument_group("scene and sensor")
    g.add_argument("--texture", type=float, default=0.06,
                   help="background texture standard deviation, fraction of full scale (0.06)")
    g.add_argument("--vignetting", type=float, default=0.08,
                   help="illumination fall-off towards the corners (0.08)")
    g.add_argument("--no-machine", action="store_true", help="no housing, rotor or hub")
    g.add_argument("--no-ruler", action="store_true",
                   help="no ruler (scene.toml then gives m_per_px)")
    g.add_argument("--noise", type=float, default=1.5,
                   help="Gaussian read noise sigma, 8-bit grey levels (1.5)")
    g.add_argument("--full-well-e", type=float, default=None,
                   help="electrons at full scale for shot noise (default: none)")
    g.add_argument("--second-straw", action="store_true",
                   help="a second straw crossing the first")
    g.add_argument("--second-cross-s", type=float, default=0.10,
                   help="time at which the second straw crosses the first, s (0.10)")
    g.add_argument("--second-flight-s", type=float, default=0.35,
                   help="how long the second straw has flown when it crosses, s (0.35)")
    g = p.add_argument_group("distractors (docs/synth.md, \"Distractors\"; orthographic only)")
    g.add_argument("--shadow", type=_floats(3, "offset_px,darken,blur_px"), default=None,
                   metavar="OFFSET_PX,DARKEN,BLUR_PX",
                   help="the straw's shadow on the background: moved OFFSET_PX down-right, "
                        "darkening by the fraction DARKEN, blurred by BLUR_PX "
                        "(default: none), e.g. 4,0.4,1.5")
    g.add_argument("--rider", choices=("riding", "crossing"), default=None,
                   help="a thinner, dimmer rod flying with the straw from the release: "
                        "riding beside it, or crossing it at mid-flight (default: none)")
    g.add_argument("--straw-polarity", choices=("bright", "dark"), default=None,
                   help="draw the straw bright or dark against the background (its "
                        "--straw-grey mirrored about the background if on the other side)")
    g.add_argument("--highlight", type=float, default=None, metavar="GREY",
                   help="a specular stripe of grey level GREY along the straw's upper-left "
                        "side (default: none), e.g. 0.95 on a dark straw")
    g.add_argument("--person-at-side", action="store_true",
                   help="a person swaying and swinging an arm at the side of each view, "
                        "clear of the straw's path")
    g.add_argument("--shake", type=_floats(2, "amplitude_px,freq_hz"), default=None,
                   metavar="AMPLITUDE_PX,FREQ_HZ",
                   help="the cameras vibrate: each whole image moved by up to AMPLITUDE_PX "
                        "at FREQ_HZ (default: still), e.g. 1.5,9")
    g.add_argument("--post", type=_floats((2, 3), "at,width_px[,speed_px]"), default=None,
                   metavar="AT,WIDTH_PX[,SPEED_PX]",
                   help="a post in front of everything in the front view, upright, "
                        "WIDTH_PX wide, its centre at the fraction AT of the view's width "
                        "in the middle frame; with SPEED_PX it moves that many px a frame "
                        "(rightwards when positive: an arm passing) (default: none), "
                        "e.g. 0.6,8 or 0.6,10,-1.5")
    g = p.add_argument_group("output")
    g.add_argument("--format", default="avi", choices=("avi", "png", "cine"),
                   help="footage: AVI video (default), png image folders or Phantom .cine")
    g.add_argument("--codec", default="mjpg", choices=("mjpg", "ffv1", "raw"),
                   help="AVI codec: mjpg (lossy, default), ffv1 (lossless), raw")
    g.add_argument("--quality", type=int, default=75, help="MJPG quality 1..100 (75)")
    g.add_argument("--bit-depth", type=int, default=8,
                   help="8 (default); png: 16; cine: 10, 12, 16")
    g.add_argument("--cine-packed", action="store_true",
                   help="pack 10- or 12-bit .cine pixels")
    g.add_argument("--throws", type=int, default=1,
                   help="replicate throws: N > 1 writes throws/01 .. (1)")
    g.add_argument("--seed", type=int, default=42, help="random seed (42)")
    g.add_argument("--sync-in-scene", action="store_true",
                   help="write each view's release frame as sync_frame (default: auto)")


def spec_from_args(args):
    """The :class:`vidtrack.synth.SynthSpec` that parsed options describe."""
    from vidtrack.synth import SynthSpec

    return SynthSpec(
        k=DEFAULT_K if args.k is None else args.k, cp_s_per_m=args.cp, state=args.state,
        speed_kmh=args.speed_kmh,
        model=args.model, straw_length_m=args.straw_length_m,
        straw_diameter_m=args.straw_diameter_m, spin_rad_s=args.spin_rad_s,
        spin_axis=args.spin_axis, straw_grey=args.straw_grey, n_rpm=args.n_rpm,
        blade_angle_deg=args.blade_angle_deg, blade_rpm=args.blade_rpm,
        release_frame=args.release_frame, views=args.views, size_px=args.size,
        top_size_px=args.top_size, fps=args.fps, playback_fps=args.playback_fps,
        flight_s=args.flight_s, frames=args.frames, top_delay_s=args.top_delay_s,
        front_axes=args.front_axes, top_axes=args.top_axes, m_per_px=args.m_per_px,
        leave_frame=args.leave_frame, exposure_fraction=args.exposure,
        exposure_samples=args.exposure_samples, texture_amplitude=args.texture,
        vignetting=args.vignetting, draw_machine=not args.no_machine,
        draw_ruler=not args.no_ruler, read_noise_dn=args.noise,
        full_well_e=args.full_well_e, second_straw=args.second_straw,
        second_cross_s=args.second_cross_s, second_flight_s=args.second_flight_s,
        output_format=args.format, video_codec=args.codec, jpeg_quality=args.quality,
        bit_depth=args.bit_depth, cine_packed=args.cine_packed, throws=args.throws,
        seed=args.seed, scale_in_scene="m_per_px" if args.no_ruler else "ruler",
        sync_in_scene=args.sync_in_scene, cameras=args.cameras,
        camera_distance_m=args.camera_distance_m, camera_angle_deg=args.camera_angle_deg,
        distortion=args.distortion, dlt_views=args.dlt_views,
        camera_distance_in_scene=not args.no_camera_distance_in_scene,
        shadow=args.shadow, rider=args.rider, straw_polarity=args.straw_polarity,
        highlight_grey=args.highlight, person_at_side=args.person_at_side,
        shake=args.shake, post=args.post,
        k_spread=None if args.k_spread is None else _four(args.k_spread))


def _four(values):
    """One relative spread for every k, or one per k."""
    return tuple(values) * 4 if len(values) == 1 else tuple(values)


def _rehearse(args):
    """Render every run of the experiment folder OUT (--regression or --k-table)."""
    import json

    from vidtrack._text import printable
    from vidtrack.errors import VidtrackError
    from vidtrack.rehearsal import (DEFAULT_K_SPREAD, read_equations, read_k_table,
                                    render_experiment)

    if args.regression and args.k_table:
        raise VidtrackError("--regression and --k-table both give the runs' k; give one")
    if args.k is not None:
        raise VidtrackError("--k gives one run's k; with --regression or --k-table each run's "
                            "k comes from its setting")
    source = (read_equations(args.regression) if args.regression
              else read_k_table(args.k_table))
    spread = DEFAULT_K_SPREAD if args.k_spread is None else _four(args.k_spread)
    done = render_experiment(args.out, source, spec_from_args(args), k_spread=spread,
                             force=args.force, quiet=args.quiet)
    if args.json:
        print(json.dumps(done.to_dict(), indent=1))
        return 0
    print(printable(done.table().to_string(index=False, float_format=lambda v: f"{v:.4g}"),
                    keep="\n"))
    throws = sum(r.throws for r in done.runs)
    print(printable(f"\nwrote {len(done.runs)} runs ({throws} throws) of {args.out} at the k "
                    f"of {done.source}, each throw's k spread by "
                    f"{', '.join(f'{v:g}' for v in done.k_spread)} (relative sd of k1..k4), "
                    f"in {done.elapsed_s:.1f} s\nnext: 'vidtrack report {args.out}', then "
                    f"'vidtrack score {args.out}'", keep="\n"))
    return 0


def run(args):
    import json
    from pathlib import Path

    from vidtrack.errors import VidtrackError
    from vidtrack.synth import render_run

    if args.regression or args.k_table:
        return _rehearse(args)
    if (Path(args.out) / "experiment.toml").is_file():
        raise VidtrackError(f"{args.out}: is an experiment folder; give --regression "
                            "EQUATIONS or --k-table FILE to render its runs")
    spec = spec_from_args(args)
    result = render_run(args.out, spec, force=args.force, quiet=args.quiet)
    if args.json:
        print(json.dumps(result.to_dict(), indent=1))
        return 0
    at = {"orthographic": "", "perspective": " (at the flight's middle)",
          "square": " (at the scale plane)"}[spec.cameras]
    views = ", ".join(f"{v} {w}x{h} at {result.m_per_px[v] * 1000:.3g} mm/px{at}, release "
                      f"at frame {result.release_frame[v]}"
                      for v, (w, h) in result.size_px.items())
    throws = f", {result.throws} throws" if result.throws > 1 else ""
    print(f"wrote {result.out_dir}: {result.frames} frames per view at {spec.fps:g} fps "
          f"({views}){throws}; {len(result.files)} files, "
          f"{result.bytes_written / 1e6:.2f} MB in {result.elapsed_s:.1f} s")
    return 0
