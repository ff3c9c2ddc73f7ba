"""``vidtrack design``: the run sheet of a designed experiment, as an experiment folder."""

HELP = "the run sheet of a central composite design or an orthogonal array, as an experiment folder"

DESCRIPTION = """\
Lay out a designed experiment and write it as OUT/design.csv (the run sheet in the
randomised run order: run, run_order, std_order, point, the coded levels in columns
named by the factors' letters, the natural levels in columns named by their names),
OUT/design.json (how it was made, with the seed) and an experiment folder:
OUT/experiment.toml (design, responses k1..k4, runs = "runs/*", the factors) and one run
folder per row, OUT/runs/01/ ... numbered in run order, each with a scene.toml holding
the run's setting in [factors]. Film each run into its folder, run 'vidtrack init' on
it (it adds the views and keeps the factors), fill in what it marks, then
'vidtrack report OUT'.

Central composite design (--ccd, one per factor, coded = (natural - centre) / step):
the 2^k factorial points at +-1, the 2k axial points at +-alpha, --centre-points at 0.
--alpha is a number > 0 or rotatable ((2^k)^(1/4), the default: 1.682 for 3 factors),
orthogonal (2 for 3 factors with 18 centre points, Chen 2018 Table 2) or face (1).

Orthogonal array (--orthogonal L27, or L9, L81 with 3 levels; L4, L8, L16, L32 with 2):
each --factor gives its levels in natural units and, after '@', its column of the array
(numbered as Taguchi's tables print them). Without '@' the factors take the basic
columns first (L27: 1, 2, 5), then those that keep the first factors' two-factor
interactions clear (L27: 9, 10, 12, 13), so four factors on the L27 are laid out as
Hou 2019 Table 3. Letters A, B, ... in the order given unless written (D=...).

OUT must be new or an empty folder; it appears whole or not at all. Bad input gives
one line on stderr and exit code 2, with nothing written.

Examples:
  vidtrack design --ccd A=n_rpm:550:100 --ccd B=blade_angle_deg:0:5 \\
      --ccd C=speed_kmh:7.2:1.8 --alpha orthogonal --centre-points 18 --seed 1 exp2016
  vidtrack design --ccd A=n_rpm:550:100 --ccd B=speed_kmh:7.2:1.8 --alpha face exp2
  vidtrack design --orthogonal L27 --factor rho0_mm:150,200,250 \\
      --factor tau0_deg:20,30,40 --factor vm_kmh:3.6,5.4,7.2 \\
      --factor omega_rad_s:42,52.5,63 --seed 7 hou2019
"""


def add_arguments(parser):
    parser.add_argument("out", metavar="OUT",
                        help="the experiment folder to create (new or empty), e.g. exp2016")
    parser.add_argument("--ccd", action="append", default=[],
                        metavar="LETTER=NAME:CENTRE:STEP",
                        help="a factor of a central composite design, repeat in order, "
                             "e.g. --ccd A=n_rpm:550:100")
    parser.add_argument("--alpha", default="rotatable", metavar="ALPHA",
                        help="ccd: axial distance in coded units, a number > 0 or "
                             "rotatable (default), orthogonal or face, e.g. --alpha 2")
    parser.add_argument("--centre-points", "--center-points", dest="centre_points",
                        type=int, default=6, metavar="N",
                        help="ccd: runs at the centre (default 6), e.g. --centre-points 18")
    parser.add_argument("--orthogonal", metavar="ARRAY",
                        help="an orthogonal array instead: L4, L8, L16, L32, L9, L27 or L81, "
                             "e.g. --orthogonal L27")
    parser.add_argument("--factor", action="append", default=[],
                        metavar="[LETTER=]NAME:L1,L2,L3[@COLUMN]",
                        help="orthogonal: a factor's levels (and its array column), "
                             "repeat in order, e.g. --factor rho0_mm:150,200,250 or "
                             "--factor omega_rad_s:42,52.5,63@9")
    parser.add_argument("--seed", type=int, metavar="S",
                        help="seed of the randomised run order (default: a fresh one, "
                             "printed and kept in design.json), e.g. --seed 1")
    parser.add_argument("--json", action="store_true",
                        help="print what was written (the design and its files) as JSON")


def _alpha(text):
    from fits.design import ALPHA_RULES
    from fits.errors import InputError

    if text in ALPHA_RULES:
        return text
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"--alpha {text}: expected a number > 0 or one of "
                         f"{', '.join(ALPHA_RULES)}") from None
    if not value > 0 or value == float("inf"):
        raise InputError(f"--alpha {text}: must be > 0 (the axial distance in coded units)")
    return value


def _design(args, seed):
    """The Design the options describe (every option checked)."""
    import string

    from fits.design import LevelFactor, central_composite, orthogonal_design
    from fits.errors import InputError
    from fits.rsm import Factor

    if bool(args.ccd) == bool(args.orthogonal):
        raise InputError("give the factors of a central composite design (--ccd "
                         "A=n_rpm:550:100 ...) or an orthogonal array (--orthogonal L27 "
                         "--factor rho0_mm:150,200,250 ...), one of the two")
    if args.ccd:
        if args.factor:
            raise InputError("--factor gives an orthogonal array's levels; a central "
                             "composite design takes --ccd LETTER=NAME:CENTRE:STEP")
        factors = []
        for spec in args.ccd:
            try:
                factors.append(Factor.parse(spec))
            except InputError as exc:
                raise InputError(f"--ccd {spec}: {exc}") from None
        return central_composite(factors, alpha=_alpha(args.alpha),
                                 centre_points=args.centre_points, rng=seed)
    if args.alpha != "rotatable" or args.centre_points != 6:
        raise InputError("--alpha and --centre-points apply to a central composite design "
                         "(--ccd); an orthogonal array takes --factor")
    if not args.factor:
        raise InputError(f"--orthogonal {args.orthogonal}: give its factors with --factor "
                         "NAME:LEVEL1,LEVEL2,LEVEL3, e.g. --factor rho0_mm:150,200,250")
    factors = []
    for i, spec in enumerate(args.factor):
        letter = string.ascii_uppercase[i] if i < 26 else f"F{i + 1}"
        try:
            factors.append(LevelFactor.parse(spec, letter=letter))
        except InputError as exc:
            raise InputError(f"--factor {spec}: {exc}") from None
    return orthogonal_design(factors, args.orthogonal, rng=seed)


def run(args):
    import json
    import secrets

    from vidtrack._text import printable
    from vidtrack.design import check_design_output, write_design
    from vidtrack.errors import VidtrackError

    if args.seed is not None and args.seed < 0:
        raise VidtrackError(f"--seed must be >= 0, got {args.seed}")
    check_design_output(args.out)           # a bad OUT costs nothing and leaves nothing
    seed = args.seed if args.seed is not None else secrets.randbelow(2 ** 31)
    design = _design(args, seed)
    written = write_design(args.out, design)
    if args.json:
        print(json.dumps({**design.to_dict(), "files": written.to_dict()}, indent=2))
        return 0
    sheet = written.sheet.drop(columns=["run_order"])
    print(printable(sheet.to_string(index=False, float_format=lambda v: f"{v:.6g}"),
                    keep="\n"))
    what = (f"central composite design, alpha = {design.alpha:.6g}, "
            f"{design.centre_points} centre points" if design.kind == "ccd" else
            f"orthogonal array {design.array}, columns "
            + ", ".join(f"{f.name} {design.columns[f.letter]}" for f in design.factors))
    first, last = written.run_dirs[0].name, written.run_dirs[-1].name
    print(printable(f"\n{what}; {len(sheet)} runs in random order (seed {seed})\n"
                    f"wrote {args.out}/: design.csv, design.json, experiment.toml, "
                    f"runs/{first} ... runs/{last} (scene.toml with each run's factors)\n"
                    f"next: film each run into its folder, 'vidtrack init "
                    f"{args.out}/runs/{first}', fill in what it marks, then "
                    f"'vidtrack report {args.out}'", keep="\n"))
    return 0
