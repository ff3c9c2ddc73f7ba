"""The one exception of the ``fits`` package for bad input."""


class InputError(ValueError):
    """An argument or a table is not what a function of ``fits`` expects.

    Subclasses ``ValueError`` so plain Python callers can catch that; the command
    line turns it into one line on stderr and exit code 2.
    """
