"""Names from the user's files made safe where they end up: a terminal, a CSV cell.

A run's name (``[run] name``), a folder's name or a view's name is the user's text: it
may hold control characters (a terminal's escape sequences, a newline that splits a
one-line message) or start like a spreadsheet formula (``=HYPERLINK(...)``).
:func:`printable` escapes control characters for a terminal; :func:`csv_cell`
neutralises a formula as OWASP advises for CSV injection (a leading apostrophe).
"""

import re

__all__ = ["printable", "csv_cell", "FORMULA_STARTS"]

#: First characters that make a spreadsheet take a cell for a formula (OWASP).
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")

_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")


def _escape(match):
    c = match.group(0)
    return {"\n": "\\n", "\r": "\\r", "\t": "\\t"}.get(c, f"\\x{ord(c):02x}")


def printable(text, *, keep=""):
    """``text`` with its control characters escaped (``\\x1b``, ``\\n``), for a terminal.

    Parameters
    ----------
    text : str
    keep : str, keyword-only
        Control characters to leave as they are (``"\\n"`` for a multi-line table).

    Example
    -------
    >>> printable("run\\x1b[31m\\nred")
    'run\\\\x1b[31m\\\\nred'
    """
    text = str(text)
    if keep:
        return "".join(c if c in keep else _CONTROL.sub(_escape, c) for c in text)
    return _CONTROL.sub(_escape, text)


def csv_cell(value):
    """A text cell a spreadsheet shows as text: a leading apostrophe before a value
    that starts like a formula (``=``, ``+``, ``-``, ``@``, tab, CR); other values as
    they are.

    Example
    -------
    >>> csv_cell('=HYPERLINK("http://x")'), csv_cell("run42")
    ('\\'=HYPERLINK("http://x")', 'run42')
    """
    if isinstance(value, str) and value.startswith(FORMULA_STARTS):
        return "'" + value
    return value
