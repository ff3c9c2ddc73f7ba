"""Text and HTML for the results' summaries: numbers rounded for reading, aligned tables.

A summary is built once as a :class:`Report` (lines and tables) and rendered either as
text (``summary()``, what ``vidtrack anova`` prints) or as HTML (``_repr_html_``, what a
notebook shows), so the two never disagree. JSON keeps full precision.
"""

import html
import math
import numbers


def fmt_num(x, *, sig=6, nonfinite=None):
    """A number rounded to ``sig`` significant digits; blank for None; an integer as
    it is; ``inf``/``-inf``/``nan``, or ``nonfinite`` when given, for a non-finite one."""
    if x is None:
        return ""
    if isinstance(x, numbers.Integral):
        return str(int(x))
    x = float(x)
    if not math.isfinite(x):
        if nonfinite is not None:
            return nonfinite
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


def fmt_pm(value, stderr):
    """``value±stderr`` for a short repr: 4 significant digits (kept: ``4.600``), the
    error 2; ``n.d.`` for a value that is not determined (None)."""
    if value is None:
        return "n.d."
    if stderr is None or not math.isfinite(stderr):
        return f"{value:#.4g}"
    return f"{value:#.4g}±{stderr:.2g}"


def _cells(headers, rows):
    return [[str(h) for h in headers]] + [["" if c is None else str(c) for c in r]
                                          for r in rows]


def format_table(headers, rows, *, align=None):
    """Aligned text table: ``align`` is a string of 'l'/'r' per column (default: l then r)."""
    ncol = len(headers)
    if align is None:
        align = "l" + "r" * (ncol - 1)
    cells = _cells(headers, rows)
    widths = [max(len(r[j]) for r in cells) for j in range(ncol)]
    lines = []
    for i, r in enumerate(cells):
        parts = [c.ljust(w) if a == "l" else c.rjust(w) for c, w, a in zip(r, widths, align)]
        lines.append("  ".join(parts).rstrip())
        if i == 0:
            lines.append("  ".join("-" * w for w in widths))
    return "\n".join(lines)


def html_table(headers, rows, *, align=None):
    """The same table as HTML (every cell escaped)."""
    ncol = len(headers)
    if align is None:
        align = "l" + "r" * (ncol - 1)
    cells = _cells(headers, rows)
    style = ['style="text-align:left"' if a == "l" else 'style="text-align:right"'
             for a in align]
    head = "".join(f"<th {s}>{html.escape(c)}</th>" for c, s in zip(cells[0], style))
    body = "".join("<tr>" + "".join(f"<td {s}>{html.escape(c)}</td>"
                                    for c, s in zip(r, style)) + "</tr>" for r in cells[1:])
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


class Table:
    """A table of a :class:`Report`: headers, rows of cells (text), alignment."""

    def __init__(self, headers, rows, *, align=None):
        self.headers, self.rows, self.align = list(headers), [list(r) for r in rows], align

    def text(self):
        return format_table(self.headers, self.rows, align=self.align)

    def html(self):
        return html_table(self.headers, self.rows, align=self.align)


class Report:
    """A summary as a list of parts: lines of text and :class:`Table` objects.

    ``text()`` joins them with newlines (a table is its aligned text); ``html()`` gives a
    paragraph per non-blank line (the first one bold: the title) and an HTML table per
    table. Every string is escaped.
    """

    def __init__(self, parts=()):
        self.parts = list(parts)

    def text(self):
        return "\n".join(p.text() if isinstance(p, Table) else p for p in self.parts)

    def html(self):
        out = ['<div class="fits-summary">']
        first = True
        for p in self.parts:
            if isinstance(p, Table):
                out.append(p.html())
            elif p.strip():
                text = html.escape(p.strip())
                out.append(f"<p><b>{text}</b></p>" if first else f"<p>{text}</p>")
            else:
                continue
            first = False
        out.append("</div>")
        return "".join(out)


class HtmlSummary:
    """A result whose ``summary()`` is a :class:`Report` (from its ``_report()``): a
    notebook shows it as HTML tables."""

    def _repr_html_(self):
        """The ``summary()`` as HTML tables (what a Jupyter notebook shows)."""
        return self._report().html()
