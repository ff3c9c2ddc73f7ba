"""Progress bars on stderr, shown only on a terminal and never with ``--quiet``."""

import sys

from tqdm import tqdm


def progress(iterable=None, *, total=None, desc=None, quiet=False, unit="it"):
    """Wrap ``iterable`` in a progress bar on stderr.

    The bar is disabled when ``quiet`` is true or stderr is not a terminal, so scripts
    and CI logs stay clean. It appears only for work that lasts over a second.
    """
    enabled = not quiet and sys.stderr.isatty()
    return tqdm(iterable, total=total, desc=desc, unit=unit, file=sys.stderr,
                disable=not enabled, delay=1.0, leave=False)
