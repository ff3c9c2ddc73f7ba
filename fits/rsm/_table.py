"""Reading and checking a table of runs (CSV) for the ANOVA of a designed experiment."""

import math
from pathlib import Path

import numpy as np
import pandas as pd

from fits.errors import InputError

#: Largest magnitude of a number in a table: squares and their sums over the runs must
#: stay finite (1e150 squared is 1e300, near the largest float).
MAX_ABS_VALUE = 1e150

#: Columns that identify a run: each value may occur once.
ID_COLUMNS = ("run", "Run", "std", "Std")


def _raw_header(path):
    """The header row's names as written (pandas renames a repeated ``k1`` to ``k1.1``)."""
    import csv

    with open(path, encoding="utf-8-sig", newline="") as f:
        for row in csv.reader(f, skipinitialspace=True):
            if any(c.strip() for c in row):
                return [c.strip() for c in row]
    return []


def _cell_key(value):
    """A cell for comparing rows: numbers by value (``1`` equals ``1.0``), else the text."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    text = str(value).strip()
    try:
        return float(text)
    except ValueError:
        return text


def _check_duplicates(df, path, allow_duplicate_rows):
    """Refuse a run id given twice and (unless allowed) a row repeated in every column."""
    first = {}
    for i, row in enumerate(df.itertuples(index=False, name=None)):
        key = tuple(_cell_key(v) for v in row)
        j = first.setdefault(key, i)
        if j != i and not allow_duplicate_rows:
            raise InputError(
                f"{path}: row {i + 1} (line {i + 2}) repeats row {j + 1} (line {j + 2}) in "
                "every column; expected each run once (two real runs with equal results: "
                "allow_duplicate_rows, on the command line --allow-duplicate-rows)")
    for column in ID_COLUMNS:
        if column not in df.columns:
            continue
        seen = {}
        for i, v in enumerate(df[column]):
            key = _cell_key(v)
            if key == "":
                continue
            j = seen.setdefault(key, i)
            if j != i and tuple(map(_cell_key, df.iloc[i])) != tuple(map(_cell_key,
                                                                        df.iloc[j])):
                raise InputError(
                    f"{path}: rows {j + 1} and {i + 1} (lines {j + 2} and {i + 2}) have the "
                    f"same {column} {str(v).strip()!r}; expected each {column} once")


def read_table(path, *, allow_duplicate_rows=False):
    """Read a CSV table of runs, every cell kept as text; nothing is modified.

    Parameters
    ----------
    path : str or Path
        A comma-separated file with a header row.
    allow_duplicate_rows : bool, keyword-only
        Accept a row equal to another in every column (two real runs with equal
        results); by default it is refused as a copy-paste slip, since it weighs that
        run twice in the ANOVA.

    Returns
    -------
    pandas.DataFrame
        Columns as in the file (stripped of surrounding spaces), values as strings
        (empty cells are NaN). ``df.attrs["source"]`` holds the file name for messages.

    Raises
    ------
    InputError
        The file is missing, unreadable, empty, or has duplicate column names; a run id
        (column ``run``, ``Run``, ``std`` or ``Std``) given to two different rows; a row
        repeated in every column (unless ``allow_duplicate_rows``).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    try:
        # only an empty cell is missing: 'nan', 'NA' or 'null' are said as they are
        df = pd.read_csv(path, dtype=str, skipinitialspace=True, encoding="utf-8-sig",
                         keep_default_na=False, na_values=[""])
    except pd.errors.EmptyDataError:
        raise InputError(f"{path}: the file is empty; expected a CSV table with a "
                         "header row") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{path}: not a readable CSV table ({first})") from None
    names = [str(c).strip() for c in df.columns]
    raw = _raw_header(path)                  # pandas has renamed a repeated k1 to k1.1
    for j, name in enumerate(raw):
        if name and name in raw[:j]:
            raise InputError(f"{path}: the header row names column {name!r} twice "
                             f"(columns {raw.index(name) + 1} and {j + 1}); expected each "
                             "column name once")
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise InputError(f"{path}: duplicate column name(s) {', '.join(dupes)}")
    if any(n.startswith("Unnamed:") for n in names):
        raise InputError(f"{path}: a column has an empty name in the header row")
    df.columns = names
    if len(df) == 0:
        raise InputError(f"{path}: the table has a header but no rows")
    _check_duplicates(df, path, allow_duplicate_rows)
    df.attrs["source"] = str(path)
    return df


#: Texts of a cell that mean "not a number" (said as NaN, not as an empty cell).
_NAN_TEXTS = ("nan", "-nan", "+nan")


def source_of(table):
    """The name used in messages for ``table`` (its file, or "table")."""
    return table.attrs.get("source", "table")


def require_columns(table, columns, *, what="column"):
    """Raise InputError naming the first of ``columns`` that ``table`` lacks."""
    missing = [c for c in columns if c not in table.columns]
    if missing:
        have = ", ".join(map(str, table.columns))
        raise InputError(f"{source_of(table)}: no {what} {missing[0]!r} "
                         f"(the table has: {have})")


def numeric_column(table, column):
    """The values of ``column`` as float64, or InputError naming row and column.

    Rows are numbered from 1 (the first data row); the file line is that plus one.
    """
    require_columns(table, [column])
    values = table[column]
    out = np.empty(len(values), dtype=float)
    for i, v in enumerate(values):
        where = f"{source_of(table)}: row {i + 1} (line {i + 2}), column {column!r}"
        if v is None or (isinstance(v, float) and math.isnan(v)) or str(v).strip() == "":
            raise InputError(f"{where}: the cell is empty; expected a number")
        if str(v).strip().lower() in _NAN_TEXTS:
            raise InputError(f"{where}: the cell is NaN ({str(v).strip()!r}); expected a "
                             "number")
        if isinstance(v, (int, float, np.integer, np.floating)):
            x = float(v)
        else:
            try:
                x = float(str(v).strip())
            except ValueError:
                raise InputError(f"{where}: {str(v)!r} is not a number") from None
        if not math.isfinite(x):
            raise InputError(f"{where}: {str(v)!r} is not a finite number")
        if abs(x) > MAX_ABS_VALUE:
            raise InputError(f"{where}: {str(v).strip()!r} is too large; expected a number "
                             f"within +-{MAX_ABS_VALUE:g} (its square must not overflow "
                             "the sums of squares)")
        out[i] = x
    return out


def label_column(table, column):
    """The values of a categorical ``column`` as level labels (no empty cells).

    Labels are the stripped cell texts; when every cell is a number, cells with equal
    values share one label (the first text seen), so ``42`` and ``42.0`` are one level.
    """
    require_columns(table, [column])
    out = []
    for i, v in enumerate(table[column]):
        if v is None or (isinstance(v, float) and math.isnan(v)) or str(v).strip() == "":
            raise InputError(f"{source_of(table)}: row {i + 1} (line {i + 2}), column "
                             f"{column!r}: the cell is empty; expected a factor level")
        out.append(str(v).strip())
    try:
        values = [float(t) for t in out]
    except ValueError:
        return out
    first = {}
    return [first.setdefault(x, t) for x, t in zip(values, out)]


def run_labels(table):
    """Run labels for plots and messages: the ``run`` column if any, else 1..n."""
    for name in ("run", "Run", "std", "Std"):
        if name in table.columns:
            return [str(v) for v in table[name]]
    return [str(i + 1) for i in range(len(table))]


def match_name(short, candidates):
    """The candidate equal to ``short`` or starting with ``short + '_'`` (unit suffix).

    ``rho0`` matches the column ``rho0_mm``, ``power`` matches ``power_kw``. Returns None
    when nothing or more than one candidate matches.
    """
    if short in candidates:
        return short
    hits = [c for c in candidates if c.startswith(short + "_")]
    return hits[0] if len(hits) == 1 else None
