"""Polynomial terms of a response-surface model: names, order, hierarchy, expansion.

A term is a tuple of non-negative integer exponents, one per factor, in factor order
(A, B, C, ...): ``(1, 0, 0)`` is A, ``(1, 1, 0)`` is A:B, ``(2, 0, 0)`` is A^2 and
``(0, 0, 0)`` is the intercept. Coded names use the factor letters, natural names the
factor names joined the same way (``n_rpm:blade_angle_deg``, ``n_rpm^2``).
"""

import itertools
import math

import numpy as np

from fits.errors import InputError

INTERCEPT = "Intercept"
#: Largest magnitude of a factor value in a model matrix: its square terms and their
#: products stay far from overflow (a CCD's coded values lie within a few units of 0).
MAX_ABS_FACTOR = 1e12


def term_name(exponents, labels):
    """Name of a term: ``Intercept``, ``A``, ``A:B``, ``A^2`` (``A^2:B`` in general)."""
    parts = []
    for label, e in zip(labels, exponents):
        if e == 1:
            parts.append(label)
        elif e > 1:
            parts.append(f"{label}^{e}")
    return ":".join(parts) if parts else INTERCEPT


def sort_key(exponents):
    """Design-Expert's order: intercept, main effects, interactions, then powers."""
    degree = sum(exponents)
    distinct = sum(1 for e in exponents if e)
    return (degree, -distinct, tuple(-e for e in exponents))


def sorted_terms(terms):
    """``terms`` in Design-Expert's order, without duplicates."""
    return sorted(set(map(tuple, terms)), key=sort_key)


def second_order_terms(k):
    """The full second-order model in k factors (without the intercept).

    Returns the k linear terms, the k (k - 1) / 2 two-factor interactions and the k pure
    quadratic terms, in Design-Expert's order.
    """
    terms = []
    for i in range(k):
        terms.append(tuple(1 if j == i else 0 for j in range(k)))
    for i, j in itertools.combinations(range(k), 2):
        terms.append(tuple(1 if m in (i, j) else 0 for m in range(k)))
    for i in range(k):
        terms.append(tuple(2 if j == i else 0 for j in range(k)))
    return sorted_terms(terms)


def parse_term(name, labels):
    """Exponent tuple of a coded term name (``A``, ``A:B``, ``A^2``, ``Intercept``)."""
    k = len(labels)
    if name == INTERCEPT:
        return (0,) * k
    exps = [0] * k
    for part in name.split(":"):
        base, _, power = part.partition("^")
        if base not in labels:
            raise InputError(f"term {name!r}: unknown factor {base!r} "
                             f"(factors: {', '.join(labels)})")
        try:
            p = int(power) if power else 1
        except ValueError:
            raise InputError(f"term {name!r}: power {power!r} is not an integer") from None
        if p < 1:
            raise InputError(f"term {name!r}: power must be >= 1, got {p}")
        exps[labels.index(base)] += p
    return tuple(exps)


def contains(inner, outer):
    """True if term ``inner`` is a proper part of ``outer`` (A is in A:B and in A^2)."""
    return inner != outer and all(a <= b for a, b in zip(inner, outer))


def protected_by_hierarchy(term, model_terms):
    """True if a higher-order term of ``model_terms`` contains ``term``."""
    return any(contains(term, other) for other in model_terms)


def model_matrix(coded, terms):
    """Columns of the model: intercept first, then one column per term.

    Parameters
    ----------
    coded : (n, k) ndarray
        Coded factor values.
    terms : sequence of exponent tuples (without the intercept)
    """
    coded = np.asarray(coded, dtype=float)
    big = np.abs(coded) > MAX_ABS_FACTOR
    if np.any(big):
        i, j = (int(v) for v in np.argwhere(big)[0])
        raise InputError(f"row {i + 1}, factor {chr(ord('A') + j)}: the value "
                         f"{coded[i, j]:g} is beyond +-{MAX_ABS_FACTOR:g}; expected coded "
                         "values within a few units of 0 (check the factor column and its "
                         "centre and step)")
    cols = [np.ones(coded.shape[0])]
    for t in terms:
        col = np.ones(coded.shape[0])
        for j, e in enumerate(t):
            if e:
                col = col * coded[:, j] ** e
        cols.append(col)
    return np.column_stack(cols)


def natural_expansion(terms, centres, steps):
    """The exact linear map from coded coefficients to natural-unit coefficients.

    With coded ``x_i = (z_i - c_i) / s_i`` every coded monomial expands by the binomial
    theorem: ``prod_i x_i^e_i = prod_i sum_k C(e_i, k) z_i^k (-c_i)^(e_i - k) / s_i^e_i``.

    Parameters
    ----------
    terms : sequence of exponent tuples, the model's terms *including* the intercept
        ``(0, ..., 0)`` first.
    centres, steps : sequences of float
        Factor centres and steps in natural units.

    Returns
    -------
    natural_terms : list of exponent tuples
        The natural monomials with a structurally non-zero coefficient, sorted.
    T : (len(natural_terms), len(terms)) ndarray
        ``beta_natural = T @ beta_coded``.

    Raises
    ------
    InputError
        A centre beyond +-MAX_ABS_FACTOR or a step outside 1/MAX_ABS_FACTOR ..
        MAX_ABS_FACTOR in magnitude (its powers would overflow or vanish).
    """
    for j, (c, s) in enumerate(zip(centres, steps)):
        letter = chr(ord("A") + j)
        if not abs(c) <= MAX_ABS_FACTOR:
            raise InputError(f"factor {letter}: centre {c:g} is beyond +-{MAX_ABS_FACTOR:g}; "
                             "expected the natural value at coded 0")
        if not 1 / MAX_ABS_FACTOR <= abs(s) <= MAX_ABS_FACTOR:
            raise InputError(f"factor {letter}: step {s:g} is outside {1 / MAX_ABS_FACTOR:g} "
                             f"to {MAX_ABS_FACTOR:g} in magnitude; expected the natural change "
                             "per coded unit")
    columns = {}
    for j, t in enumerate(terms):
        ranges = [range(e + 1) for e in t]
        for ks in itertools.product(*ranges):
            factor = 1.0
            for e, k, c, s in zip(t, ks, centres, steps):
                factor *= math.comb(e, k) * (-c) ** (e - k) / s ** e
            if factor != 0.0:
                columns.setdefault(tuple(ks), {})
                columns[tuple(ks)][j] = columns[tuple(ks)].get(j, 0.0) + factor
    natural_terms = [t for t in sorted_terms(columns) if any(columns[t].values())]
    T = np.zeros((len(natural_terms), len(terms)))
    for i, nt in enumerate(natural_terms):
        for j, v in columns[nt].items():
            T[i, j] = v
    return natural_terms, T


def estimable_columns(X, names, *, rtol=1e-9):
    """Split the model's columns into estimable ones and aliased ones.

    Columns are taken in order (intercept, main effects, interactions, powers); a column
    that lies in the span of the columns kept before it is aliased with them.

    Returns
    -------
    keep : list of int
        Indices of the estimable columns.
    aliased : dict
        ``{name: [(other name, coefficient), ...]}`` for each aliased column: the
        combination of kept columns it equals.
    """
    X = np.asarray(X, dtype=float)
    keep = []
    aliased = {}
    for j in range(X.shape[1]):
        col = X[:, j]
        norm = np.linalg.norm(col)
        if norm == 0.0:
            aliased[names[j]] = []
            continue
        if keep:
            B = X[:, keep]
            coef, *_ = np.linalg.lstsq(B, col, rcond=None)
            resid = np.linalg.norm(col - B @ coef)
            if resid <= rtol * norm * max(1.0, math.sqrt(X.shape[0])):
                scale = np.abs(coef).max() if coef.size else 1.0
                aliased[names[j]] = [(names[keep[i]], float(c)) for i, c in enumerate(coef)
                                     if abs(c) > 1e-8 * max(scale, 1e-300)]
                continue
        keep.append(j)
    return keep, aliased
