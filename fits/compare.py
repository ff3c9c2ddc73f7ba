"""Side by side with a published table: every printed number against the computed one.

A printed value matches when the computed value rounds to it (to the digits printed).
Where a printed value does not match, the published table itself is examined and the
difference explained where its own numbers show why:

- an F printed as the ratio of the *rounded* mean squares (Chen 2018, Table 3, k2:
  F = 2.39 / 0.14 = 17.07, against 17.27 from the unrounded values);
- rows that do not add up (Chen 2018, Table 3, k2: pure error 1.96, but residual minus
  lack of fit is 3.59 - 1.67 = 1.92);
- a table that adds up in itself but was not computed from the printed data (Hou 2019,
  Table 4, power: total 41.19 against 41.46 from the printed Table 3);
- a value that is one unit off in its last printed digit (truncated, not rounded);
- a p-value printed as a bound (``< 0.0001``).

Two kinds of published CSV are read: ANOVA tables (columns ``response``, ``source``
and some of ``ss``, ``df``, ``ms``, ``f``, ``p``) and coefficient tables (``response``,
``term``, ``coefficient``, natural-unit term names as in ``RsmFit.coefficients_natural``).
"""

import math
from dataclasses import dataclass
from decimal import ROUND_DOWN, ROUND_HALF_UP, Decimal
from pathlib import Path

import pandas as pd

from fits.rsm._table import match_name
from fits._text import Report, Table
from fits.errors import InputError

__all__ = ["Comparison", "ComparisonRow", "compare", "printed_unit", "read_published"]

QUANTITIES = ("ss", "df", "ms", "f", "p")
_SYNONYMS = {"model": "regression", "lack of fit": "lack_of_fit", "lof": "lack_of_fit",
             "pure error": "pure_error", "residual error": "residual"}
_ORTHO_SYNONYMS = {"residual": "error", "regression": "model"}


def read_published(path):
    """Read a published table (CSV) keeping every cell as printed text.

    Raises
    ------
    InputError
        Missing file, unreadable CSV, or columns that are neither an ANOVA table
        (``response, source, ss|df|ms|f|p``) nor a coefficient table
        (``response, term, coefficient``).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    try:
        df = pd.read_csv(path, dtype=str, skipinitialspace=True, keep_default_na=False)
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not a readable CSV table ({type(exc).__name__})") from None
    df.columns = [str(c).strip().lower() for c in df.columns]
    cols = set(df.columns)
    if "response" in cols and "source" in cols and cols & set(QUANTITIES):
        kind = "anova"
    elif {"response", "term", "coefficient"} <= cols:
        kind = "coefficients"
    else:
        raise InputError(f"{path}: expected columns response, source and some of "
                         "ss, df, ms, f, p (an ANOVA table) or response, term, coefficient "
                         f"(a coefficient table); got {', '.join(df.columns)}")
    if len(df) == 0:
        raise InputError(f"{path}: the table has no rows")
    for i, row in df.iterrows():
        for q in [c for c in df.columns if c in QUANTITIES or c == "coefficient"]:
            text = row[q].strip()
            if text and _parse(text) is None:
                raise InputError(f"{path}: row {i + 1} (line {i + 2}), column {q!r}: "
                                 f"{text!r} is not a number")
    df.attrs["source"] = str(path)
    df.attrs["kind"] = kind
    return df


def _parse(text):
    try:
        v = float(text.replace(" ", "").lstrip("<"))
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def _last_digit_exponent(text):
    t = text.strip().lower().replace(" ", "").lstrip("<+-")
    mant, _, exp = t.partition("e")
    e = int(exp) if exp else 0
    return e - len(mant.partition(".")[2])


def printed_unit(text):
    """One unit in the last printed digit: ``"8.44"`` -> 0.01, ``"1.508e-5"`` -> 1e-8."""
    return 10.0 ** _last_digit_exponent(text)


def _last_digit_story(computed, text):
    """Why a value is one unit off in its last printed digit: truncation or double rounding."""
    e = _last_digit_exponent(text)
    units = Decimal(repr(float(computed))).scaleb(-e)
    printed = Decimal(text.strip().replace(" ", "").lstrip("<")).scaleb(-e)
    if units.to_integral_value(rounding=ROUND_DOWN) == printed:
        return f"truncated, not rounded: exact {computed:.7g}"
    for extra in (1, 2):
        step = units.quantize(Decimal(1).scaleb(-extra), rounding=ROUND_HALF_UP)
        if step.quantize(Decimal(1), rounding=ROUND_HALF_UP) == printed:
            middle = float(step.scaleb(e))
            return (f"double rounding: exact {computed:.7g} -> {middle:.{extra + 3}g} -> "
                    f"{text.strip()}")
    return f"one unit off in the last printed digit (exact {computed:.7g})"


def _fmt(x, sig=6):
    return "" if x is None else f"{x:.{sig}g}"


@dataclass(frozen=True)
class ComparisonRow:
    """One printed number against the computed one.

    ``status`` is ``match`` (the computed value rounds to the printed one),
    ``last digit`` (one unit off in the last printed digit), ``differs``, or
    ``missing`` (the analysis has no such row). ``note`` explains a difference where
    the published table shows its cause.
    """

    response: str
    source: str
    quantity: str
    printed: str
    published: float
    computed: float | None
    difference: float | None
    status: str
    note: str = ""

    def to_dict(self):
        """JSON-ready dict."""
        return {"response": self.response, "source": self.source, "quantity": self.quantity,
                "printed": self.printed, "published": self.published,
                "computed": self.computed, "difference": self.difference,
                "status": self.status, "note": self.note}


@dataclass(frozen=True)
class Comparison:
    """All compared numbers of a published table, with table-level notes."""

    source: str
    rows: tuple
    notes: tuple = ()

    def __repr__(self):
        from pathlib import PurePath

        return (f"Comparison(source={PurePath(self.source).name!r}, rows={len(self.rows)}, "
                f"flagged={len(self.flagged)}, notes={len(self.notes)})")

    @property
    def flagged(self):
        """Rows whose status is not ``match``."""
        return tuple(r for r in self.rows if r.status != "match")

    def to_frame(self, response=None):
        """The compared numbers as a DataFrame, one row per printed number.

        Parameters
        ----------
        response : str, optional
            Only this analysed response's rows.

        Returns
        -------
        pandas.DataFrame
            Columns ``response``, ``source`` (the ANOVA row or term), ``quantity``,
            ``printed`` (the text as published), ``published``, ``computed``,
            ``difference`` (computed - published; NaN when missing), ``status`` and
            ``note``.
        """
        import pandas as pd

        rows = self.rows if response is None else self.rows_for(response)
        cols = ["response", "source", "quantity", "printed", "published", "computed",
                "difference", "status", "note"]
        return pd.DataFrame([[getattr(r, c) for c in cols] for r in rows], columns=cols)

    def rows_for(self, response):
        """Rows of one analysed response (the fit's response name)."""
        return tuple(r for r in self.rows if r.response == response)

    def to_dict(self):
        """JSON-ready dict."""
        return {"published": self.source, "rows": [r.to_dict() for r in self.rows],
                "flagged": len(self.flagged), "notes": list(self.notes)}

    def summary(self, response=None):
        """A text table: published, computed, difference, status and note per number."""
        return self._report(response).text()

    def _repr_html_(self):
        """The :meth:`summary` as an HTML table (what a Jupyter notebook shows)."""
        return self._report().html()

    def _report(self, response=None):
        rows = self.rows if response is None else self.rows_for(response)
        body = [[r.response, r.source, r.quantity, r.printed, _fmt(r.computed),
                 _fmt(r.difference, 3), r.status, r.note] for r in rows]
        head = f"Compared with {self.source}: {len(rows)} numbers, " \
               f"{sum(r.status != 'match' for r in rows)} flagged"
        parts = [head, Table(["Response", "Source", "Qty", "Published", "Computed", "Diff",
                              "Status", "Note"], body, align="lllrrrll")]
        if response is None and self.notes:
            parts += [f"Note: {n}" for n in self.notes]
        return Report(parts)


def _status(quantity, text, published, computed):
    if computed is None:
        return "missing", None
    diff = computed - published
    if quantity == "df":
        return ("match" if round(computed) == round(published) else "differs"), diff
    unit = printed_unit(text)
    tol = 1e-9 * max(abs(published), unit)
    if abs(diff) <= unit / 2 + tol:
        return "match", diff
    if quantity == "p" and (text.strip().startswith("<") or abs(published - unit) <= tol) \
            and 0.0 <= computed < published:
        return "match", diff
    if abs(diff) <= unit + tol:
        return "last digit", diff
    return "differs", diff


class _Printed:
    """The published rows of one response: printed values and their units."""

    def __init__(self, rows):
        self.rows = rows              # {source: {quantity: text}}

    def value(self, source, q):
        t = self.rows.get(source, {}).get(q, "")
        return _parse(t) if t else None

    def unit(self, source, q):
        t = self.rows.get(source, {}).get(q, "")
        return printed_unit(t) if t else None


def _sum_relations(kind, fit, keys):
    """(whole, parts) relations between SS rows that must add up."""
    if kind == "rsm":
        return [("total", ["regression", "residual"]),
                ("residual", ["lack_of_fit", "pure_error"])]
    terms = [keys[t] for t in fit.term_names if t in keys]
    rel = [("total", ["model", "error"])]
    if not any("not orthogonal" in n for n in fit.notes) and terms:
        rel.append(("model", terms))
    return rel


def _explain_ss(source, printed, relations, computed):
    """Why a printed SS differs: rows that do not add up, or the data themselves."""
    for whole, parts in relations:
        if source != whole and source not in parts:
            continue
        vals = {s: printed.value(s, "ss") for s in [whole] + parts}
        if any(v is None for v in vals.values()):
            continue
        slack = sum(printed.unit(s, "ss") / 2 for s in [whole] + parts) * (1 + 1e-9)
        if abs(sum(vals[p] for p in parts) - vals[whole]) <= slack:
            continue
        if source == whole:
            expr = " + ".join(f"{vals[p]:g}" for p in parts)
            implied = sum(vals[p] for p in parts)
            what = f"{' + '.join(parts)} = {expr} = {implied:.4g}"
        else:
            others = [p for p in parts if p != source]
            implied = vals[whole] - sum(vals[p] for p in others)
            what = (f"{whole} - {' - '.join(others)} = {vals[whole]:g} - "
                    + " - ".join(f"{vals[p]:g}" for p in others) + f" = {implied:.4g}")
        return (f"the printed rows do not add up: {what}, not the printed "
                f"{vals[source]:g}; computed {computed:.4g}")
    return None


def _explain_f(source, printed, den_of, computed):
    """An F printed as the ratio of the rounded mean squares."""
    f = printed.value(source, "f")
    num = printed.value(source, "ms")
    den_source = den_of(source)
    den = printed.value(den_source, "ms") if den_source else None
    if f is None or num is None or not den:
        return None
    r = num / den
    half = printed.unit(source, "f") / 2 * (1 + 1e-9)
    ss_n, df_n = printed.value(source, "ss"), printed.value(source, "df")
    ss_d, df_d = printed.value(den_source, "ss"), printed.value(den_source, "df")
    if None not in (ss_n, df_n, ss_d, df_d) and df_n > 0 and df_d > 0 and ss_d > 0:
        if abs((ss_n / df_n) / (ss_d / df_d) - f) <= half:
            return None          # the printed SS give the printed F as well: not rounding
    if abs(r - f) <= half:
        return (f"printed F = {num:g} / {den:g} = {r:.4g}, the ratio of the rounded mean "
                f"squares; from the unrounded values F = {computed:.4g}")
    return None


def _explain_ms(source, printed, computed):
    ss, df, ms = (printed.value(source, q) for q in ("ss", "df", "ms"))
    if None in (ss, df, ms) or df <= 0:
        return None
    lo = (ss - printed.unit(source, "ss") / 2) / df
    hi = (ss + printed.unit(source, "ss") / 2) / df
    u = printed.unit(source, "ms") / 2 * (1 + 1e-9)
    if ms + u < lo or ms - u > hi:
        return (f"the printed MS is not the printed SS / df = {ss:g} / {df:g} = "
                f"{ss / df:.4g}; computed {computed:.4g}")
    return None


def _fit_kind(fit):
    return "rsm" if hasattr(fit, "coefficients_natural") else "orthogonal"


def _anova_lookup(fit, source):
    """The fit's ANOVA row (or term test) for a published source name, or None."""
    key = source.strip()
    low = key.lower()
    if _fit_kind(fit) == "rsm":
        low = _SYNONYMS.get(low, low).replace(" ", "_")
        if low in fit.anova:
            return low, fit.anova[low]
        for t in fit.term_tests:
            if t.term == key:
                return key, t
        return None, None
    low = _ORTHO_SYNONYMS.get(low, low)
    if low in ("model", "error", "total"):
        return low, fit.anova.get(low)
    parts = [p.strip() for p in key.split(":")]
    matched = [match_name(p, list(fit.factors)) for p in parts]
    if None in matched:
        return None, None
    name = ":".join(matched)
    if name in fit.anova:
        return name, fit.anova[name]
    if len(matched) == 2:
        rev = f"{matched[1]}:{matched[0]}"
        if rev in fit.anova:
            return rev, fit.anova[rev]
    return None, None


def _row_values(row):
    """ss, df, ms, f, p of an ANOVA row or a single-df term test (None where undefined)."""
    if row is None:
        return {}
    vals = {q: getattr(row, q, None) for q in QUANTITIES}
    if vals["df"] is None:                      # a TermTest: one degree of freedom
        vals["df"], vals["ms"] = 1, row.ss
    return {q: (None if v is None else float(v)) for q, v in vals.items()}


def _compare_anova(fit, resp_name, group):
    kind = _fit_kind(fit)
    printed = _Printed({r["source"].strip(): {q: r.get(q, "").strip() for q in QUANTITIES}
                        for _, r in group.iterrows()})
    keys = {}
    for src in printed.rows:
        k, _ = _anova_lookup(fit, src)
        if k is not None:
            keys[k] = src
    relations_fit = _sum_relations(kind, fit, keys)
    relations = [(keys.get(w, w), [keys.get(p, p) for p in ps]) for w, ps in relations_fit]

    def den_of(src):
        k, _ = _anova_lookup(fit, src)
        if kind == "rsm":
            d = {"regression": "residual", "lack_of_fit": "pure_error"}.get(k)
            if d is None and k is not None and k not in fit.anova:
                d = "residual"
        else:
            d = None if k in ("error", "total", None) else "error"
        return keys.get(d) if d else None

    rows = []
    data_differ = None
    total_src = keys.get("total")
    for src, vals in printed.rows.items():
        _, row = _anova_lookup(fit, src)
        for q in QUANTITIES:
            text = vals.get(q, "")
            if not text:
                continue
            pub = _parse(text)
            comp = _row_values(row).get(q)
            status, diff = _status(q, text, pub, comp)
            note = ""
            if status == "match" and q == "p" and diff is not None \
                    and abs(diff) > printed_unit(text) / 2 * (1 + 1e-9):
                note = f"a bound: exact p = {comp:.3g} (the paper prints < {text.lstrip('<')})"
            if status == "missing":
                note = "no such row in the analysis"
            elif status != "match":
                if q == "df":
                    note = "different degrees of freedom: a different model or design"
                elif q == "ss":
                    note = _explain_ss(src, printed, relations, comp) or ""
                    if not note and src == total_src:
                        parts = relations[0][1]
                        pv = [printed.value(p, "ss") for p in parts]
                        adds = (None not in pv and abs(sum(pv) - pub) <= sum(
                            printed.unit(p, "ss") for p in parts) / 2 + printed.unit(src, "ss"))
                        data_differ = comp
                        note = ("the total SS depends on the data alone: the printed data "
                                f"give {comp:.6g}, the table prints {text}"
                                + (f" (its rows add up: {' + '.join(f'{v:g}' for v in pv)} "
                                   f"= {sum(pv):.4g}), so the printed ANOVA was not "
                                   "computed from the printed data" if adds else ""))
                elif q == "ms":
                    note = _explain_ms(src, printed, comp) or ""
                elif q == "f":
                    note = _explain_f(src, printed, den_of, comp) or ""
            rows.append(ComparisonRow(resp_name, src, q, text, pub, comp, diff, status, note))
    if data_differ is not None:
        fixed = []
        for r in rows:
            if r.status != "match" and not r.note:
                r = ComparisonRow(r.response, r.source, r.quantity, r.printed, r.published,
                                  r.computed, r.difference, r.status,
                                  "follows from the data difference shown by the total "
                                  f"(printed data: total SS {data_differ:.6g})")
            fixed.append(r)
        rows = fixed
    out = []
    for r in rows:
        if r.status != "match" and not r.note:
            if r.quantity == "p":
                note = "follows from the F above" if any(
                    x.source == r.source and x.quantity == "f" and x.status != "match"
                    for x in rows) else f"exact p = {r.computed:.4g}"
            elif r.status == "last digit":
                note = _last_digit_story(r.computed, r.printed)
            else:
                note = f"exact value {r.computed:.6g}"
            r = ComparisonRow(r.response, r.source, r.quantity, r.printed, r.published,
                              r.computed, r.difference, r.status, note)
        out.append(r)
    return out


def _compare_coefficients(fit, resp_name, group):
    rows = []
    coefs = getattr(fit, "coefficients_natural", None)
    if coefs is not None:
        # natural-unit names (n_rpm:blade_angle_deg) unless the table uses coded ones (A:B)
        named = [t.strip() for t in group["term"] if t.strip() != "Intercept"]
        if named and not any(t in coefs for t in named) and all(
                t in fit.coefficients_coded for t in named):
            coefs = fit.coefficients_coded
    for _, r in group.iterrows():
        term = r["term"].strip()
        text = r["coefficient"].strip()
        if not text:
            continue
        pub = _parse(text)
        comp = None
        if coefs is not None:
            if term in ("(Intercept)", "intercept", "const"):
                term_key = "Intercept"
            else:
                term_key = term
            comp = coefs.get(term_key)
        status, diff = _status("coefficient", text, pub, comp)
        note = ""
        if status == "missing":
            note = "term not in the fitted model"
        elif status == "last digit":
            note = _last_digit_story(comp, text)
        elif status == "differs":
            note = f"exact value {comp:.7g}"
        rows.append(ComparisonRow(resp_name, term, "coefficient", text, pub,
                                  None if comp is None else float(comp), diff, status, note))
    return rows


def compare(fits, published):
    """Compare fitted results with a published table.

    Parameters
    ----------
    fits : sequence of RsmFit or OrthogonalFit
        The analysed responses.
    published : pandas.DataFrame
        From :func:`read_published`. A published response name matches a fit's
        response exactly or as the name without its unit suffix (``power`` ->
        ``power_kw``); sources match factor columns the same way (``rho0`` ->
        ``rho0_mm``, ``tau0:vm`` -> ``tau0_deg:vm_kmh``).

    Returns
    -------
    Comparison

    Raises
    ------
    InputError
        None of the published rows belongs to an analysed response.
    """
    fits = list(fits)
    source = published.attrs.get("source", "published table")
    kind = published.attrs.get("kind")
    if kind is None:
        raise InputError("compare: read the published table with fits.compare.read_published")
    by_name = {f.response: f for f in fits}
    rows = []
    notes = []
    skipped = []
    for resp, group in published.groupby("response", sort=False):
        name = match_name(resp.strip(), list(by_name))
        if name is None:
            skipped.append(resp)
            continue
        fit = by_name[name]
        if kind == "anova":
            rows += _compare_anova(fit, name, group)
        else:
            rows += _compare_coefficients(fit, name, group)
    if not rows:
        have = ", ".join(sorted(set(published["response"])))
        raise InputError(f"{source}: no published rows for the analysed response(s) "
                         f"{', '.join(by_name)} (the table has: {have})")
    if skipped:
        notes.append(f"published rows of {', '.join(skipped)} not compared (not analysed)")
    return Comparison(source=source, rows=tuple(rows), notes=tuple(notes))
