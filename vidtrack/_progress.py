"""Progress bars: on a terminal (stderr) and in Jupyter (widgets), never with ``--quiet``.

Bars come from ``tqdm``: in a Jupyter kernel from ``tqdm.auto`` (a widget bar when
ipywidgets is installed), on a terminal from ``tqdm`` itself (what ``tqdm.auto`` picks
there too, without loading asyncio). When stderr is not a terminal and no kernel is
running (scripts, CI logs, worker processes of a pipe) there is no bar and tqdm is not
even imported: 70 ms of every worker's start.
"""

import sys


class _NoBar:
    """What a disabled bar needs to offer: counting and closing, silently."""

    def update(self, n=1):
        pass

    def close(self):
        pass


def in_notebook():
    """True inside an IPython kernel (Jupyter, VS Code, Colab): checked without importing it."""
    return "ipykernel" in sys.modules


def _stderr_is_terminal():
    try:
        return sys.stderr is not None and sys.stderr.isatty()
    except (AttributeError, ValueError):      # replaced or closed stderr
        return False


def bars_enabled(quiet=False):
    """Whether :func:`progress` shows a bar: not ``quiet``, and a terminal or a notebook."""
    return not quiet and (_stderr_is_terminal() or in_notebook())


def progress(iterable=None, *, total=None, desc=None, quiet=False, unit="it"):
    """Wrap ``iterable`` in a progress bar (without one: a bar to update).

    Parameters
    ----------
    iterable : iterable, optional
        What to iterate over; None gives a bar with ``update(n)`` and ``close()``.
    total : int, optional
        Number of items (when ``iterable`` has no length).
    desc : str, optional
        The bar's label.
    quiet : bool
        No bar at all (``--quiet``).
    unit : str
        What an item is called.

    Returns
    -------
    iterable or bar
        A tqdm bar; or, when bars are off (``quiet``, or stderr not a terminal outside
        a notebook), ``iterable`` itself or a silent stand-in with ``update`` and
        ``close``. A bar appears only for work that lasts over a second and is removed
        when done.
    """
    if not bars_enabled(quiet):
        return _NoBar() if iterable is None else iterable
    if in_notebook():
        from tqdm.auto import tqdm
    else:
        from tqdm import tqdm

    return tqdm(iterable, total=total, desc=desc, unit=unit, file=sys.stderr,
                delay=1.0, leave=False)
