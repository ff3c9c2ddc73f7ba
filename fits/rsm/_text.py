"""Plain-text tables for the ANOVA summaries (rounded for reading; JSON keeps full precision)."""

import math


def fmt_num(x, *, sig=6):
    """A number rounded to ``sig`` significant digits; blank for None."""
    if x is None:
        return ""
    if isinstance(x, int):
        return str(x)
    if not math.isfinite(x):
        return "inf" if x > 0 else ("-inf" if x < 0 else "nan")
    return f"{x:.{sig}g}"


def fmt_f(x):
    """An F ratio: two decimals like the papers print them (more digits when tiny)."""
    if x is None:
        return ""
    if not math.isfinite(x):
        return "inf"
    return f"{x:.2f}" if abs(x) >= 0.01 else f"{x:.3g}"


def fmt_p(p):
    """A p-value: four decimals, or ``<0.0001``."""
    if p is None:
        return ""
    return "<0.0001" if p < 1e-4 else f"{p:.4f}"


def format_table(headers, rows, *, align=None):
    """Aligned text table: ``align`` is a string of 'l'/'r' per column (default: l then r)."""
    ncol = len(headers)
    if align is None:
        align = "l" + "r" * (ncol - 1)
    cells = [[str(h) for h in headers]] + [["" if c is None else str(c) for c in r]
                                           for r in rows]
    widths = [max(len(r[j]) for r in cells) for j in range(ncol)]
    lines = []
    for i, r in enumerate(cells):
        parts = [c.ljust(w) if a == "l" else c.rjust(w) for c, w, a in zip(r, widths, align)]
        lines.append("  ".join(parts).rstrip())
        if i == 0:
            lines.append("  ".join("-" * w for w in widths))
    return "\n".join(lines)
