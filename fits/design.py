"""Run sheets of designed experiments: central composite designs and orthogonal arrays.

Numbers only: :func:`central_composite` lays out a CCD (the 2^k factorial points at
coded +-1, the 2k axial points at +-alpha, the centre points) and
:func:`orthogonal_design` assigns factors to the columns of a standard orthogonal array
(:func:`orthogonal_array`, Taguchi's L4, L8, L16, L32, L9, L27, L81 built from linear
combinations over GF(2) or GF(3)). Each gives a :class:`Design` whose ``table`` holds
the coded levels (columns named by the factors' letters), the natural levels (columns
named by the factors' names), the standard order and a run order randomised from the
``rng`` given. Writing it as an experiment folder is :mod:`vidtrack.design`.

Chen et al. (2018, Table 2) is the CCD of three factors with alpha = 2 and 18 centre
points (32 runs): ``alpha="orthogonal"`` with 18 centre points gives alpha = 2 exactly.
Hou et al. (2019, Table 3) is the L27 with its four factors on columns 1, 2, 5 and 9,
which :func:`orthogonal_design` picks by default.
"""

import itertools
import math
import numbers
import re
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from fits.errors import InputError
from fits.rsm import Factor

__all__ = ["Design", "LevelFactor", "ALPHA_RULES", "ccd_alpha", "central_composite",
           "orthogonal_array", "orthogonal_design", "default_columns"]

#: Named rules for the axial distance of a CCD (coded units), see :func:`ccd_alpha`.
ALPHA_RULES = ("rotatable", "orthogonal", "face")
#: Most factors a CCD lays out (its full 2^k factorial: 1024 runs at 10).
MAX_CCD_FACTORS = 10
#: Most centre points a CCD takes (a typing slip beyond that).
MAX_CENTRE_POINTS = 1000
#: Significant digits a natural level keeps: centre + coded * step without the binary
#: noise of the product (7.2 + 2 * 1.8 is 10.8, not 10.799999999999999).
NATURAL_DIGITS = 12
#: Standard orthogonal arrays by name: (levels p, basic columns m); L{p^m} rows.
ARRAYS = {"L4": (2, 2), "L8": (2, 3), "L16": (2, 4), "L32": (2, 5),
          "L9": (3, 2), "L27": (3, 3), "L81": (3, 4)}
_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class LevelFactor:
    """A factor of an orthogonal array: its levels in natural units, its array column.

    Parameters
    ----------
    letter : str
        Coded name (``A``): the design table's column of level numbers 1..p.
    name : str
        Natural name, the column of natural levels (``rho0_mm``).
    levels : tuple of float
        The natural value of level 1, 2, ..., p (distinct).
    column : int or None
        The array column (1-based, as printed tables number them); None: chosen by
        :func:`default_columns`.
    """

    letter: str
    name: str
    levels: tuple
    column: int | None = None

    def __post_init__(self):
        for what, v in (("letter", self.letter), ("name", self.name)):
            if not isinstance(v, str) or not _NAME_RE.match(v):
                raise InputError(f"factor {what} must be a name of letters, digits and "
                                 f"'_', got {v!r}")
        levels = tuple(float(v) for v in self.levels)
        if not all(math.isfinite(v) for v in levels):
            raise InputError(f"factor {self.name}: levels must be finite numbers, got "
                             f"{list(self.levels)}")
        if len(set(levels)) != len(levels):
            raise InputError(f"factor {self.name}: levels must differ, got "
                             f"{', '.join(f'{v:g}' for v in levels)}")
        object.__setattr__(self, "levels", levels)
        if self.column is not None and (isinstance(self.column, bool) or not isinstance(
                self.column, numbers.Integral) or self.column < 1):
            raise InputError(f"factor {self.name}: array column must be a whole number "
                             f">= 1, got {self.column!r}")

    @classmethod
    def parse(cls, text, letter=None):
        """A factor from ``[LETTER=]NAME:L1,L2,L3[@COLUMN]``.

        Example
        -------
        >>> LevelFactor.parse("omega_rad_s:42,52.5,63@9", letter="D")
        LevelFactor(letter='D', name='omega_rad_s', levels=(42.0, 52.5, 63.0), column=9)
        """
        expected = ("expected [LETTER=]NAME:LEVEL1,LEVEL2,...[@COLUMN], e.g. "
                    "rho0_mm:150,200,250 or D=omega_rad_s:42,52.5,63@9")
        head, eq, rest = str(text).partition("=")
        if eq:
            letter = head.strip()
        else:
            rest = head
        name, colon, levels = rest.partition(":")
        levels, at, column = levels.partition("@")
        if not colon or not levels.strip():
            raise InputError(f"factor {text!r}: {expected}")
        try:
            values = tuple(float(v) for v in levels.split(","))
        except ValueError:
            raise InputError(f"factor {text!r}: levels must be numbers; {expected}") from None
        col = None
        if at:
            try:
                col = int(column)
            except ValueError:
                raise InputError(f"factor {text!r}: the column after '@' must be a whole "
                                 f"number, got {column!r}") from None
        return cls(letter or "", name.strip(), values, col)


@dataclass(frozen=True)
class Design:
    """A designed experiment's run sheet.

    Attributes
    ----------
    kind : str
        ``"ccd"`` or ``"orthogonal"``.
    factors : tuple
        :class:`fits.rsm.Factor` (ccd) or :class:`LevelFactor` (orthogonal), in order.
    table : pandas.DataFrame
        One row per run in standard order: ``std_order`` (1..n), ``run_order`` (1..n,
        the randomised order to perform them in), ``point`` (ccd: ``factorial``,
        ``axial`` or ``centre``; orthogonal: ``array``), the coded levels (one column
        per factor letter: coded units for a ccd, level numbers 1..p for an array)
        and the natural levels (one column per factor name).
    alpha : float or None
        ccd: the axial distance in coded units.
    centre_points : int or None
        ccd: the number of centre points.
    array : str or None
        orthogonal: the array's name (``"L27"``).
    columns : dict
        orthogonal: the array column (1-based) of each factor, by letter.
    seed : int or None
        The seed the run order came from, when given as an integer.
    """

    kind: str
    factors: tuple
    table: pd.DataFrame = field(repr=False)
    alpha: float | None = None
    centre_points: int | None = None
    array: str | None = None
    columns: dict = field(default_factory=dict)
    seed: int | None = None

    def __repr__(self):
        what = (f"alpha={self.alpha:.6g}, centre_points={self.centre_points}"
                if self.kind == "ccd" else f"array={self.array!r}, columns={self.columns}")
        names = ", ".join(f.name for f in self.factors)
        return f"Design(kind={self.kind!r}, runs={len(self.table)}, factors=[{names}], {what})"

    @property
    def letters(self):
        """The factors' letters, in order."""
        return [f.letter for f in self.factors]

    @property
    def names(self):
        """The factors' names, in order."""
        return [f.name for f in self.factors]

    def run_sheet(self):
        """The table in run order (the order to perform the runs in)."""
        return self.table.sort_values("run_order").reset_index(drop=True)

    def to_dict(self):
        """What made the design (JSON-ready): kind, factors, alpha, array, seed."""
        if self.kind == "ccd":
            factors = [{"letter": f.letter, **f.to_dict()} for f in self.factors]
        else:
            factors = [{"letter": f.letter, "name": f.name, "levels": list(f.levels),
                        "column": self.columns[f.letter]} for f in self.factors]
        out = {"design": self.kind, "runs": int(len(self.table)), "factors": factors,
               "seed": self.seed}
        if self.kind == "ccd":
            out.update(alpha=self.alpha, centre_points=self.centre_points)
        else:
            out["array"] = self.array
        return out


def ccd_alpha(k, rule, *, centre_points):
    """The axial distance of a CCD of ``k`` factors in coded units.

    Parameters
    ----------
    k : int
        Number of factors (a full 2^k factorial).
    rule : float or str
        A number (> 0), or ``"rotatable"``: (2^k)^(1/4) (1.682 for k = 3);
        ``"orthogonal"``: the alpha that makes the quadratic terms' columns orthogonal,
        ``(F (sqrt(N) - sqrt(F))^2 / 4)^(1/4)`` with F = 2^k and N the runs (2 for
        k = 3 with 18 centre points, Chen 2018); ``"face"``: 1 (face-centred).
    centre_points : int

    Returns
    -------
    float

    Raises
    ------
    InputError
        A number that is not > 0, or an unknown rule.
    """
    if isinstance(rule, str):
        if rule == "rotatable":
            return float(2 ** k) ** 0.25
        if rule == "face":
            return 1.0
        if rule == "orthogonal":
            f = 2 ** k
            n = f + 2 * k + centre_points
            return float(f * (math.sqrt(n) - math.sqrt(f)) ** 2 / 4) ** 0.25
        raise InputError(f"alpha must be a number > 0 or one of {', '.join(ALPHA_RULES)}, "
                         f"got {rule!r}")
    if isinstance(rule, bool) or not isinstance(rule, numbers.Real) \
            or not math.isfinite(rule) or rule <= 0:
        raise InputError(f"alpha must be > 0 (the axial distance in coded units, e.g. 2 "
                         f"or rotatable), got {rule!r}")
    return float(rule)


def _natural(values):
    return np.array([float(f"{v:.{NATURAL_DIGITS}g}") for v in values])


def _order(n, rng):
    """A random permutation of 1..n from ``rng`` (a Generator or a seed), and the seed."""
    seed = int(rng) if isinstance(rng, numbers.Integral) and not isinstance(rng, bool) \
        else None
    gen = np.random.default_rng(rng)
    return gen.permutation(n) + 1, seed


def _check_names(factors):
    for what in ("letter", "name"):
        seen = [getattr(f, what) for f in factors]
        dup = next((v for v in seen if seen.count(v) > 1), None)
        if dup is not None:
            raise InputError(f"two factors have the {what} {dup!r}; expected each once")
    clash = set(f.letter for f in factors) & set(f.name for f in factors)
    clash |= set(f.letter for f in factors) & {"std_order", "run_order", "point", "run"}
    clash |= set(f.name for f in factors) & {"std_order", "run_order", "point", "run"}
    if clash:
        raise InputError(f"factor letter or name {sorted(clash)[0]!r} names two columns of "
                         "the run sheet; expected letters (A, B, ...) and names (n_rpm, "
                         "...) that differ from each other and from std_order, run_order, "
                         "point, run")


def central_composite(factors, *, alpha="rotatable", centre_points=6, rng=None):
    """The run sheet of a central composite design.

    Parameters
    ----------
    factors : sequence of fits.rsm.Factor
        The factors (2 to :data:`MAX_CCD_FACTORS`), each with its centre and step
        (> 0): natural = centre + coded * step.
    alpha : float or str, keyword-only
        The axial distance in coded units, or a rule of :func:`ccd_alpha`
        (default ``"rotatable"``).
    centre_points : int, keyword-only
        Runs at the centre (default 6; Chen 2018 has 18).
    rng : int, numpy.random.Generator or None, keyword-only
        Seed or generator of the randomised run order (None: fresh entropy).

    Returns
    -------
    Design
        Standard order: the 2^k factorial points (the first factor changing fastest, as
        Yates' order and Chen 2018 Table 2 list them), the axial points (-alpha then
        +alpha for each factor in turn), then the centre points.

    Raises
    ------
    InputError
        Fewer than 2 or more than :data:`MAX_CCD_FACTORS` factors, a step that is not
        > 0, two factors with one letter or name, a bad ``alpha`` or ``centre_points``.

    Example
    -------
    >>> from fits.rsm import Factor
    >>> d = central_composite([Factor("A", "n_rpm", 550, 100), Factor("B", "blade_angle_deg",
    ...                        0, 5), Factor("C", "speed_kmh", 7.2, 1.8)], alpha=2,
    ...                       centre_points=18, rng=1)
    >>> len(d.table), float(d.table["n_rpm"].min()), float(d.table["speed_kmh"].max())
    (32, 350.0, 10.8)
    """
    factors = tuple(factors)
    k = len(factors)
    if not 2 <= k <= MAX_CCD_FACTORS:
        raise InputError(f"a central composite design needs 2 to {MAX_CCD_FACTORS} "
                         f"factors, got {k}")
    for f in factors:
        if not isinstance(f, Factor):
            raise InputError(f"expected fits.rsm.Factor objects, got {f!r}")
        if not f.step > 0:
            raise InputError(f"factor {f.letter}={f.name}: step must be > 0 (the natural "
                             f"change per coded unit), got {f.step:g}")
    _check_names(factors)
    if isinstance(centre_points, bool) or not isinstance(centre_points, numbers.Integral) \
            or not 0 <= centre_points <= MAX_CENTRE_POINTS:
        raise InputError(f"centre points must be a whole number from 0 to "
                         f"{MAX_CENTRE_POINTS}, got {centre_points!r}")
    a = ccd_alpha(k, alpha, centre_points=int(centre_points))
    rows, points = [], []
    for signs in itertools.product((-1.0, 1.0), repeat=k):
        rows.append(signs[::-1])        # the first factor changes fastest
        points.append("factorial")
    for i in range(k):
        for s in (-a, a):
            rows.append(tuple(s if j == i else 0.0 for j in range(k)))
            points.append("axial")
    rows += [(0.0,) * k] * int(centre_points)
    points += ["centre"] * int(centre_points)
    coded = np.array(rows, dtype=float)
    n = len(coded)
    order, seed = _order(n, rng)
    table = pd.DataFrame({"std_order": np.arange(1, n + 1), "run_order": order,
                          "point": points})
    for j, f in enumerate(factors):
        table[f.letter] = coded[:, j]
    for j, f in enumerate(factors):
        table[f.name] = _natural(f.centre + coded[:, j] * f.step)
    return Design(kind="ccd", factors=factors, table=table, alpha=a,
                  centre_points=int(centre_points), seed=seed)


def _array_spec(name):
    key = str(name).strip().upper()
    if key not in ARRAYS:
        raise InputError(f"orthogonal array {name!r} is not one this builds; expected one "
                         f"of {', '.join(ARRAYS)}")
    return key, ARRAYS[key]


def _generators(p, m):
    """The columns' coefficient vectors over GF(p), in the standard (Taguchi) order.

    Basic column j is the j-th run digit (the first the most significant); after it come
    v + e_j for every non-zero v in the span of the earlier basic columns, the first
    coefficient changing fastest: for L27 a, b, a+b, 2a+b, c, a+c, 2a+c, b+c, a+b+c,
    2a+b+c, 2b+c, a+2b+c, 2a+2b+c.
    """
    gens = []
    for j in range(m):
        for earlier in itertools.product(range(p), repeat=j):
            v = list(earlier[::-1]) + [1] + [0] * (m - j - 1)
            gens.append(v)
    return np.array(gens, dtype=int)


def orthogonal_array(name):
    """A standard orthogonal array, levels 1..p.

    Parameters
    ----------
    name : str
        ``L4``, ``L8``, ``L16``, ``L32`` (2 levels) or ``L9``, ``L27``, ``L81`` (3
        levels).

    Returns
    -------
    numpy.ndarray of int, shape (p^m, (p^m - 1) / (p - 1))
        Row i, column c: 1 + (g_c . d_i mod p), with d_i the base-p digits of i (the
        first the most significant) and g_c the column's coefficient vector over
        GF(p) (:func:`_generators`). These are the arrays as Taguchi's tables print them
        (L27: columns 1, 2, 5 basic; 3, 4 the interaction of 1 and 2; 6, 7 of 1 and 5;
        8, 11 of 2 and 5).

    Raises
    ------
    InputError
        An array not in :data:`ARRAYS`.
    """
    _, (p, m) = _array_spec(name)
    digits = np.array(list(itertools.product(range(p), repeat=m)), dtype=int)
    return 1 + (digits @ _generators(p, m).T) % p


def default_columns(name, count):
    """The array columns (1-based) for ``count`` factors when none are given.

    The basic columns first (L27: 1, 2, 5), then the columns that combine three or more
    basic ones, most first (L27: 9, 10, 12, 13; L16: 15, 7, ...), so that the two-factor
    interactions of the first factors stay clear; the columns of two-factor interactions
    last. For four factors on the L27 this is Hou 2019's layout (1, 2, 5, 9).
    """
    key, (p, m) = _array_spec(name)
    gens = _generators(p, m)
    weight = (gens != 0).sum(axis=1)
    rank = sorted(range(len(gens)),
                  key=lambda c: (0 if weight[c] == 1 else 2 if weight[c] == 2 else 1,
                                 -weight[c], c))
    if count > len(rank):
        raise InputError(f"{key} has {len(rank)} columns, got {count} factors")
    return [c + 1 for c in rank[:count]]


def orthogonal_design(factors, array="L27", *, rng=None):
    """The run sheet of an orthogonal-array experiment.

    Parameters
    ----------
    factors : sequence of LevelFactor
        Each with p levels (p the array's: 3 for L9, L27, L81; 2 for L4 ... L32) and
        optionally its column; the others take :func:`default_columns` not used yet.
    array : str
        The array's name (default ``"L27"``).
    rng : int, numpy.random.Generator or None, keyword-only
        Seed or generator of the randomised run order.

    Returns
    -------
    Design
        One row per array row in the array's order; the coded columns hold the level
        numbers 1..p, the natural columns the factors' levels.

    Raises
    ------
    InputError
        Levels not p in number, a column outside the array or used twice, two factors
        with one letter or name, more factors than columns.

    Example
    -------
    >>> d = orthogonal_design([LevelFactor("A", "rho0_mm", (150, 200, 250)),
    ...                        LevelFactor("B", "tau0_deg", (20, 30, 40))], "L9", rng=0)
    >>> d.columns
    {'A': 1, 'B': 2}
    """
    key, (p, m) = _array_spec(array)
    factors = tuple(factors)
    arr = orthogonal_array(key)
    if not factors:
        raise InputError(f"an orthogonal design needs at least one factor ({key} takes up "
                         f"to {arr.shape[1]})")
    for f in factors:
        if not isinstance(f, LevelFactor):
            raise InputError(f"expected LevelFactor objects, got {f!r}")
        if len(f.levels) != p:
            raise InputError(f"factor {f.name}: {key} has {p} levels per column, got "
                             f"{len(f.levels)} ({', '.join(f'{v:g}' for v in f.levels)})")
        if f.column is not None and f.column > arr.shape[1]:
            raise InputError(f"factor {f.name}: {key} has columns 1 to {arr.shape[1]}, "
                             f"got {f.column}")
    _check_names(factors)
    given = [f.column for f in factors if f.column is not None]
    dup = next((c for c in given if given.count(c) > 1), None)
    if dup is not None:
        raise InputError(f"two factors are on column {dup} of {key}; expected each column "
                         "used once")
    free = [c for c in default_columns(key, arr.shape[1]) if c not in given]
    columns = {}
    for f in factors:
        columns[f.letter] = f.column if f.column is not None else free.pop(0)
    n = len(arr)
    order, seed = _order(n, rng)
    table = pd.DataFrame({"std_order": np.arange(1, n + 1), "run_order": order,
                          "point": ["array"] * n})
    for f in factors:
        table[f.letter] = arr[:, columns[f.letter] - 1]
    for f in factors:
        table[f.name] = np.asarray(f.levels)[arr[:, columns[f.letter] - 1] - 1]
    return Design(kind="orthogonal", factors=factors, table=table, array=key,
                  columns=columns, seed=seed)
