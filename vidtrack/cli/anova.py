"""``vidtrack anova``: response-surface or orthogonal-array ANOVA of a table of runs."""

HELP = "response-surface (CCD) or orthogonal-array ANOVA of a table of runs"

DESCRIPTION = """\
Analyse a table of runs (CSV, one row per run) as Design-Expert does.

--design ccd (default): full second-order model in the coded factors, backward
elimination at --alpha (hierarchy kept: a main effect stays while a higher-order term
containing it stays), ANOVA with regression, residual, lack of fit (distinct design
points), pure error (replicates) and total; R2, adjusted and predicted R2, adequate
precision, condition number; coefficients in coded and natural units (natural ones by
exact expansion of the coded polynomial); canonical analysis. Factors come from
--factor LETTER=COLUMN:CENTRE:STEP (coded = (natural - centre) / step; the table may
hold the natural column, the coded column named by the letter, or both). Without
--factor, the table's coded columns A, B, C, ... are used as they are (centre 0, step
1, so natural units are coded units). A design without replicated points has no pure
error: the lack-of-fit row is left out and a note says so.

--design orthogonal: fixed-effects ANOVA with the --categorical factor columns and any
--interaction a:b (RESPONSE=a:b for one response only), range analysis (level means,
range R), order of influence, percent contribution.

--compare PUBLISHED.csv puts every printed number beside the computed one and explains
the differences the published table shows (F from rounded mean squares, rows that do
not add up, a table not computed from the printed data, truncated digits); differences
are reported, not errors (exit code 0). --json prints a list with one object per
response (numbers in full precision); bad input gives one line on stderr and exit 2.

Examples:
  vidtrack anova datasets/published/chen2018_table2_ccd.csv --response k1 \\
      --response k2 --factor A=n_rpm:550:100 --factor B=blade_angle_deg:0:5 \\
      --factor C=speed_kmh:7.2:1.8 \\
      --compare datasets/published/chen2018_table3_anova_published.csv
  vidtrack anova datasets/published/hou2019_table3_l27.csv --design orthogonal \\
      --response winding --response vibration_m_s2 \\
      --categorical rho0_mm,tau0_deg,vm_kmh,omega_rad_s \\
      --interaction winding=tau0_deg:vm_kmh --report hou2019.html
"""


def add_arguments(parser):
    """Options of ``vidtrack anova`` (docs/analysis.md)."""
    parser.add_argument("table", metavar="TABLE.csv",
                        help="CSV table of runs with a header row, e.g. "
                             "datasets/published/chen2018_table2_ccd.csv")
    parser.add_argument("--response", action="append", default=[], metavar="COLUMN",
                        help="response column to analyse; repeat or comma-separate for "
                             "several, e.g. --response k1 --response k2")
    parser.add_argument("--design", choices=("ccd", "orthogonal"), default="ccd",
                        help="ccd: response-surface regression (default); orthogonal: "
                             "fixed-effects ANOVA of categorical factors")
    parser.add_argument("--factor", action="append", default=[],
                        metavar="LETTER=COLUMN:CENTRE:STEP",
                        help="ccd factor and its coding, repeat in order A, B, C, e.g. "
                             "--factor A=n_rpm:550:100 (default: the table's coded "
                             "columns A, B, C, ... as they are)")
    parser.add_argument("--categorical", action="append", default=[], metavar="COLS",
                        help="orthogonal: the factor columns, comma-separated, e.g. "
                             "--categorical rho0_mm,tau0_deg,vm_kmh,omega_rad_s")
    parser.add_argument("--interaction", action="append", default=[],
                        metavar="[RESPONSE=]A:B",
                        help="orthogonal: add the interaction of two factor columns, for "
                             "every response or only RESPONSE, e.g. "
                             "--interaction winding=tau0_deg:vm_kmh")
    parser.add_argument("--alpha", type=float, default=0.05,
                        help="significance level of the elimination and of the marks "
                             "(default 0.05), e.g. --alpha 0.1")
    parser.add_argument("--full", action="store_true",
                        help="ccd: keep every term of the second-order model (no "
                             "elimination)")
    parser.add_argument("--no-hierarchy", action="store_true",
                        help="ccd: let the elimination drop a main effect even while a "
                             "higher-order term containing it stays")
    parser.add_argument("--compare", action="append", default=[], metavar="PUBLISHED.csv",
                        help="published table to compare with (ANOVA rows response,source,"
                             "ss,df,ms,f[,p] or coefficients response,term,coefficient), "
                             "e.g. --compare datasets/published/chen2018_table3_anova_"
                             "published.csv")
    parser.add_argument("--json", action="store_true",
                        help="print a JSON list, one object per response, full precision")
    parser.add_argument("--report", metavar="FILE.html",
                        help="write a self-contained HTML report with tables and plots, "
                             "e.g. --report anova.html (never one of the input files)")
    parser.add_argument("--allow-duplicate-rows", action="store_true",
                        help="accept a row equal to another in every column (two real runs "
                             "with equal results); refused by default as a copy-paste slip")


def _split(values):
    out = []
    for v in values:
        out += [p.strip() for p in v.split(",") if p.strip()]
    return out


def _interactions_for(specs, response, responses):
    """The interactions that apply to ``response`` from ``[RESPONSE=]a:b`` specs."""
    from fits.rsm._table import match_name
    from fits.errors import InputError
    from fits.orthogonal import parse_interaction

    out = []
    for spec in specs:
        target, eq, pair = spec.partition("=")
        if not eq:
            out.append(parse_interaction(spec))
            continue
        name = match_name(target.strip(), responses)
        if name is None:
            raise InputError(f"--interaction {spec}: {target!r} is not one of the "
                             f"responses ({', '.join(responses)})")
        if name == response:
            out.append(parse_interaction(pair))
    return out


def _fit_all(args, table, responses):
    import warnings

    from fits.errors import InputError
    from fits.orthogonal import fit_orthogonal
    from fits.rsm import Factor, default_factors, fit_rsm

    if args.design == "ccd":
        if args.categorical or args.interaction:
            raise InputError("--categorical and --interaction apply to --design orthogonal; "
                             "a ccd analysis takes --factor")
        factors = [Factor.parse(s) for s in args.factor] or default_factors(table)
        fits = []
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for r in responses:
                fits.append(fit_rsm(table, r, factors, alpha=args.alpha,
                                    eliminate=not args.full,
                                    hierarchy=not args.no_hierarchy))
        return fits, [str(w.message) for w in caught]
    if args.factor or args.full or args.no_hierarchy:
        raise InputError("--factor, --full and --no-hierarchy apply to --design ccd; an "
                         "orthogonal analysis takes --categorical and --interaction")
    factors = _split(args.categorical)
    if not factors:
        raise InputError("--design orthogonal needs the factor columns: --categorical "
                         "a,b,c,...")
    return [fit_orthogonal(table, r, factors,
                           interactions=_interactions_for(args.interaction, r, responses),
                           alpha=args.alpha) for r in responses], []


def run(args):
    """Parse, analyse, compare, write the report, print."""
    import json
    import logging

    from fits.compare import compare, read_published
    from fits.errors import InputError
    from fits.rsm import read_table
    from vidtrack.errors import VidtrackError

    if args.report:
        from vidtrack._atomic import check_output
        check_output(args.report, inputs=[args.table, *args.compare],
                     label=f"--report {args.report}")
    table = read_table(args.table, allow_duplicate_rows=args.allow_duplicate_rows)
    responses = _split(args.response)
    if not responses:
        raise InputError(f"give the response column(s) with --response (the table has: "
                         f"{', '.join(table.columns)})")
    dupes = sorted({r for r in responses if responses.count(r) > 1})
    if dupes:
        raise InputError(f"--response {dupes[0]} is given twice")
    for r in responses:
        if r not in table.columns:
            raise InputError(f"{args.table}: unknown response {r!r} (the table has: "
                             f"{', '.join(table.columns)})")
    published = [read_published(p) for p in args.compare]
    fits, warnings_ = _fit_all(args, table, responses)
    comparisons = [compare(fits, p) for p in published]
    if args.report:
        from vidtrack.report.anova_page import write_anova_report
        try:
            write_anova_report(args.report, fits, comparisons=comparisons,
                               source=str(args.table))
        except OSError as exc:
            raise VidtrackError(f"cannot write the report {args.report}: "
                                f"{exc.strerror or exc}") from None
    log = logging.getLogger(__name__)
    for w in warnings_:
        log.warning("%s", w)
    if args.json:
        out = []
        for fit in fits:
            d = fit.to_dict()
            if comparisons:
                d["comparison"] = [r.to_dict() for c in comparisons
                                   for r in c.rows_for(fit.response)]
            out.append(d)
        print(json.dumps(out, indent=2, allow_nan=False))
    else:
        blocks = []
        for fit in fits:
            block = fit.summary()
            for c in comparisons:
                if c.rows_for(fit.response):
                    block += "\n\n" + c.summary(fit.response)
            blocks.append(block)
        text = ("\n\n" + "=" * 78 + "\n\n").join(blocks)
        for c in comparisons:
            text += "".join(f"\nNote ({c.source}): {n}" for n in c.notes)
        print(text)
        if args.report:
            print(f"\nReport written to {args.report}")
    return 0
