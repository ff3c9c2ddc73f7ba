"""Progress bars on stderr, shown only on a terminal and never with ``--quiet``."""

import sys


class _NoBar:
    """What a disabled bar needs to offer: counting and closing, silently."""

    def update(self, n=1):
        pass

    def close(self):
        pass


def progress(iterable=None, *, total=None, desc=None, quiet=False, unit="it"):
    """Wrap ``iterable`` in a progress bar on stderr (without one: a bar to update).

    The bar is disabled when ``quiet`` is true or stderr is not a terminal, so scripts
    and CI logs stay clean; tqdm is then not even loaded (70 ms of every worker's
    start). It appears only for work that lasts over a second.
    """
    if quiet or not sys.stderr.isatty():
        return _NoBar() if iterable is None else iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=desc, unit=unit, file=sys.stderr,
                delay=1.0, leave=False)
