"""``vidtrack predict``: k1..k4, the release and the throw for one machine setting."""

import argparse
import math

HELP = "predict k1..k4, the release and the 3-D throw (and place the recovery device)"

DESCRIPTION = """\
From a machine setting (blade speed, blade rake angle, travel speed) predict the
correction coefficients k1..k4 from a regression (Chen et al. 2018 eqs. 20-23 by
default, or a JSON written by 'vidtrack anova --json'), the straw's release from the
blade (eqs. 1-10, solved exactly), and the 3-D throw until it reaches the ground
(y = -H) or an inlet plane. With --device, also place the straw recovery device: H1
and H2 of its impeller centre from the blade shaft (section 4; docs/predict.md gives
the rule and its assumptions). A setting outside the design region is predicted with
a warning; a setting where the straw is not thrown (eqs. 5-7) is refused (exit 2).

examples:
  vidtrack predict --n-rpm 450 --blade-angle-deg -10 --speed-kmh 6
  vidtrack predict --n-rpm 450 --blade-angle-deg -10 --speed-kmh 6 --device --json
  vidtrack predict --n-rpm 600 --blade-angle-deg 5 --speed-kmh 8 \\
      --regression anova.json --plot throw.png
"""

#: The values a user may type (option dest -> (low, high, unit), ends included): far
#: outside anything physical is a typo or an overflow (1e300), refused (exit 2) before
#: any work; --help lists them.
LIMITS = {
    "n_rpm": (1.0, 1e5, "r/min"), "speed_kmh": (0.0, 100.0, "km/h"),
    "blade_radius_m": (0.01, 10.0, "m"), "start_m": (-10.0, 10.0, "m"),
    "friction": (0.0, 10.0, ""),
    "phase_deg": (-360.0, 360.0, "deg"), "cp_s_per_m": (0.0, 10.0, "s/m"),
    "straw_mass_kg": (1e-6, 100.0, "kg"), "straw_area_m2": (1e-6, 10.0, "m^2"),
    "drag_coefficient": (0.0, 100.0, ""), "shaft_height_m": (0.001, 100.0, "m"),
    "inlet_x_m": (-1000.0, 1000.0, "m"), "inlet_offset_m": (0.0, 100.0, "m"),
    "inlet_low_m": (-100.0, 100.0, "m"), "inlet_high_m": (-100.0, 100.0, "m"),
    "housing_bottom_m": (0.0, 100.0, "m"), "blade_clearance_m": (0.0, 100.0, "m"),
    "ground_clearance_m": (0.0, 100.0, "m"), "points": (2, 1_000_000, "samples"),
}


def _num(value):
    return str(value) if isinstance(value, int) else f"{value:g}"


def _limits_text():
    items = [f"--{k.replace('_', '-')} {_num(lo)}..{_num(hi)}{' ' + u if u else ''}"
             for k, (lo, hi, u) in LIMITS.items()]
    return "\nlimits (ends included; outside them exit 2):\n  " + "\n  ".join(
        ", ".join(items[i:i + 3]) for i in range(0, len(items), 3)) + "\n"


DESCRIPTION += _limits_text()


def _check_limits(args):
    """Every given option within :data:`LIMITS`, else InputError naming it (one line)."""
    from fits.errors import InputError

    for key, (lo, hi, unit) in LIMITS.items():
        value = getattr(args, key, None)
        if value is not None and not lo <= value <= hi:
            raise InputError(f"--{key.replace('_', '-')} must be between {_num(lo)} and "
                             f"{_num(hi)}{' ' + unit if unit else ''}, got {_num(value)}")


def _number(option, *, positive=False, nonnegative=False):
    def parse(text):
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{option} must be a number, got {text!r}") \
                from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{option} must be finite, got {text!r}")
        if positive and value <= 0:
            raise argparse.ArgumentTypeError(f"{option} must be > 0, got {text!r}")
        if nonnegative and value < 0:
            raise argparse.ArgumentTypeError(f"{option} must be >= 0, got {text!r}")
        return value
    parse.__name__ = "number"
    return parse


def add_arguments(parser):
    """Register the setting, regression, blade, flight, device and output options."""
    s = parser.add_argument_group("machine setting (the paper's factors)")
    s.add_argument("--n-rpm", required=True, type=_number("--n-rpm", positive=True),
                   metavar="N", help="blade speed n in r/min, e.g. --n-rpm 450")
    s.add_argument("--blade-angle-deg", required=True, type=_number("--blade-angle-deg"),
                   metavar="D", help="blade rake angle delta1 in degrees (> 0 leans back), "
                                     "e.g. --blade-angle-deg -10")
    s.add_argument("--speed-kmh", required=True, type=_number("--speed-kmh"), metavar="V",
                   help="machine travel speed v1 in km/h, e.g. --speed-kmh 6")
    s.add_argument("--regression", metavar="FILE.json",
                   help="k1..k4 regressions as written by 'vidtrack anova --json' "
                        "(default: the published eqs. 20-23, no covariance), "
                        "e.g. --regression anova.json")

    b = parser.add_argument_group("blade model (not published: defaults are assumptions, "
                                  "see docs/predict.md)")
    b.add_argument("--blade-radius-m", type=_number("--blade-radius-m", positive=True),
                   default=0.25, metavar="R",
                   help="tip radius R in m (default 0.25), e.g. --blade-radius-m 0.23")
    b.add_argument("--start-m", type=_number("--start-m"), default=0.10, metavar="L1",
                   help="the straw's coordinate l1 along the blade at the impact, m "
                        "(default 0.10), e.g. --start-m 0.08")
    b.add_argument("--friction", type=_number("--friction", nonnegative=True), default=0.5,
                   metavar="MU", help="equivalent friction coefficient mu (default 0.5), "
                                      "e.g. --friction 0.4")
    b.add_argument("--phase-deg", type=_number("--phase-deg"), default=-30.0,
                   metavar="ALPHA0",
                   help="initial phase alpha0: the blade's angle from straight down at the "
                        "impact, degrees, in the direction of rotation (default -30), "
                        "e.g. --phase-deg -45")
    b.add_argument("--release-method", choices=("exact", "series"), default="exact",
                   help="release from the exact slide (default) or the paper's series "
                        "eqs. 3, 4, 8, e.g. --release-method series")

    f = parser.add_argument_group("flight")
    f.add_argument("--cp-s-per-m", type=_number("--cp-s-per-m", nonnegative=True),
                   default=None, metavar="CP",
                   help="straw drag parameter Cp in s/m (default 0.115; or give "
                        "--straw-mass-kg), e.g. --cp-s-per-m 0.12")
    f.add_argument("--straw-mass-kg", type=_number("--straw-mass-kg", positive=True),
                   metavar="M", help="compute Cp = sqrt(C a rho / (2 m g)) from the straw's "
                                     "mass, e.g. --straw-mass-kg 0.08")
    f.add_argument("--straw-area-m2", type=_number("--straw-area-m2", positive=True),
                   default=0.0172, metavar="A",
                   help="straw characteristic area a_s in m^2 for Cp (default 0.0172, "
                        "the paper's mean straw), e.g. --straw-area-m2 0.015")
    f.add_argument("--drag-coefficient", type=_number("--drag-coefficient", nonnegative=True),
                   default=1.0, metavar="C",
                   help="drag coefficient C for Cp (default 1.0), e.g. --drag-coefficient 1.2")
    f.add_argument("--shaft-height-m", type=_number("--shaft-height-m", positive=True),
                   metavar="H", help="height of the blade shaft above the ground, m; the "
                                     "ground is y = -H (default R - 0.05: the tip works 50 mm "
                                     "deep), e.g. --shaft-height-m 0.2")
    f.add_argument("--inlet-x-m", type=_number("--inlet-x-m"), metavar="X",
                   help="end the throw at the vertical plane x = X (an inlet) instead of "
                        "the ground, e.g. --inlet-x-m 0.5")
    f.add_argument("--points", type=int, default=101, metavar="N",
                   help="trajectory samples, 2..1000000 (default 101), e.g. --points 201")

    d = parser.add_argument_group("recovery device (section 4, Fig. 5; docs/predict.md)")
    d.add_argument("--device", action="store_true",
                   help="place the recovery device: report H1, H2 (the throw then ends at "
                        "its inlet)")
    d.add_argument("--inlet-offset-m", type=_number("--inlet-offset-m", nonnegative=True),
                   default=0.15, metavar="A",
                   help="horizontal distance from the inlet plane out to the impeller "
                        "centre O1 (default 0.15), e.g. --inlet-offset-m 0.2")
    d.add_argument("--inlet-low-m", type=_number("--inlet-low-m"), default=-0.10,
                   metavar="LOW", help="inlet's lower edge relative to O1's height "
                                       "(default -0.10), e.g. --inlet-low-m -0.15")
    d.add_argument("--inlet-high-m", type=_number("--inlet-high-m"), default=0.10,
                   metavar="HIGH", help="inlet's upper edge relative to O1's height "
                                        "(default 0.10), e.g. --inlet-high-m 0.05")
    d.add_argument("--housing-bottom-m", type=_number("--housing-bottom-m", nonnegative=True),
                   default=0.20, metavar="B",
                   help="how far the housing reaches below O1 (default 0.20), "
                        "e.g. --housing-bottom-m 0.25")
    d.add_argument("--blade-clearance-m",
                   type=_number("--blade-clearance-m", nonnegative=True), default=0.05,
                   metavar="C", help="least gap between the blade circle and the inlet "
                                     "plane (default 0.05), e.g. --blade-clearance-m 0.08")
    d.add_argument("--ground-clearance-m",
                   type=_number("--ground-clearance-m", nonnegative=True), default=0.05,
                   metavar="G", help="least gap between the housing and the ground "
                                     "(default 0.05), e.g. --ground-clearance-m 0.1")

    o = parser.add_argument_group("output")
    o.add_argument("--json", action="store_true",
                   help="print the prediction as JSON (keys: coefficients, release, "
                        "trajectory, ...)")
    o.add_argument("--plot", metavar="FILE.png",
                   help="write the front and top views of the throw, e.g. --plot throw.png")


def _summary(d):
    lines = []
    s = d["setting"]
    lines.append(f"setting: n = {s['n_rpm']:g} r/min, delta1 = {s['blade_angle_deg']:g} deg, "
                 f"v1 = {s['speed_kmh']:g} km/h"
                 + ("  (EXTRAPOLATION)" if d["extrapolation"] else ""))
    lines.append(f"regression: {d['regression']['source']}")
    lines.append("coefficients:")
    for name, c in d["coefficients"].items():
        extra = ""
        if c["stderr"] is not None:
            extra = (f"  +- {c['stderr']:.3g} (se)  95% CI [{c['ci95'][0]:.4g}, "
                     f"{c['ci95'][1]:.4g}]")
        lines.append(f"  {name} = {c['value']:#.4g}{extra}")
    r = d["release"]
    lines.append(f"release ({r['method']} slide): t0 = {1e3 * r['release_time_s']:.2f} ms, "
                 f"blade turned {r['rotation_deg']:.1f} deg")
    lines.append(f"  v_r = {r['relative_speed_m_s']:.3f} m/s, v_e = "
                 f"{r['transport_speed_m_s']:.3f} m/s, v_a = {r['absolute_speed_m_s']:.3f} "
                 f"m/s, theta = {r['release_angle_deg']:.2f} deg")
    lines.append(f"  x0 = {r['x0_m']:.4f} m, y0 = {r['y0_m']:.4f} m; vx0 = "
                 f"{r['vx0_m_s']:.3f}, vy0 = {r['vy0_m_s']:.3f}, vz0 = {r['vz0_m_s']:.3f} m/s")
    t = d["trajectory"]
    e = t["end_point_m"]
    lines.append(f"throw (Cp = {t['cp_s_per_m']:.4g} s/m, ground y = {t['ground_y_m']:.3g} m): "
                 f"reaches the {t['end']} at t = {t['t_end_s']:.3f} s, x = {e['x']:.3f} m, "
                 f"y = {e['y']:.3f} m, z = {e['z']:.3f} m")
    if t["apex"]:
        lines.append(f"  apex: y = {t['apex']['y_m']:.3f} m at x = {t['apex']['x_m']:.3f} m, "
                     f"t = {t['apex']['t_s']:.3f} s")
    if t["end_sd_m"]:
        lines.append("  end point sd: " + ", ".join(f"{k[0]} {v:.3g} m"
                                                   for k, v in t["end_sd_m"].items()))
    if d["device"]:
        dv = d["device"]
        lines.append(f"recovery device: H1 = {1e3 * dv['h1_m']:.0f} mm, H2 = "
                     f"{1e3 * dv['h2_m']:.0f} mm (O1 {'above' if dv['h2_m'] >= 0 else 'below'}"
                     f" the shaft); inlet plane x = {dv['inlet_x_m']:.3f} m, opening y "
                     f"{dv['inlet_y_m'][0]:.3f}..{dv['inlet_y_m'][1]:.3f} m "
                     f"(set by {dv['binding']})")
    for note in d["notes"]:
        lines.append(f"note: {note}")
    return "\n".join(lines)


def run(args):
    """Predict, then print JSON or a summary; write the plot if asked."""
    import json
    import warnings

    from fits.errors import InputError
    from vidtrack.predict import (DEFAULT_CP_S_PER_M, ExtrapolationWarning, InletGeometry,
                                  drag_parameter, load_regression, plot_prediction, predict)

    _check_limits(args)
    if args.plot:
        from vidtrack._atomic import check_output
        check_output(args.plot, inputs=[args.regression], label=f"--plot {args.plot}")
    if args.straw_mass_kg is not None and args.cp_s_per_m is not None:
        raise InputError("give either --cp-s-per-m or --straw-mass-kg, not both")
    cp = args.cp_s_per_m if args.cp_s_per_m is not None else DEFAULT_CP_S_PER_M
    if args.straw_mass_kg is not None:
        cp = drag_parameter(args.straw_mass_kg, args.straw_area_m2,
                            drag_coefficient=args.drag_coefficient)
        if not cp <= LIMITS["cp_s_per_m"][1]:
            raise InputError(f"--straw-mass-kg {args.straw_mass_kg:g} gives Cp = {cp:.4g} "
                             f"s/m; expected Cp <= {LIMITS['cp_s_per_m'][1]:g} s/m")
    device = None
    if args.device:
        device = InletGeometry(offset_m=args.inlet_offset_m, low_m=args.inlet_low_m,
                               high_m=args.inlet_high_m, bottom_m=args.housing_bottom_m,
                               blade_clearance_m=args.blade_clearance_m,
                               ground_clearance_m=args.ground_clearance_m)
    regression = load_regression(args.regression)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)
        prediction = predict(
            args.n_rpm, args.blade_angle_deg, args.speed_kmh, regression=regression,
            radius_m=args.blade_radius_m, start_m=args.start_m, friction=args.friction,
            phase_deg=args.phase_deg, release_method=args.release_method, cp_s_per_m=cp,
            shaft_height_m=args.shaft_height_m, inlet_x_m=args.inlet_x_m, device=device,
            points=args.points)
    if args.plot:
        plot_prediction(prediction, args.plot)
    import logging

    log = logging.getLogger(__name__)
    for w in prediction.warnings:
        log.warning("%s", w)
    d = prediction.to_dict()
    if args.json:
        print(json.dumps(d, indent=2))
    else:
        print(_summary(d))
    return 0
