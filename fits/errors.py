"""The one exception of the ``fits`` package for bad input."""


class InputError(ValueError):
    """An argument or a table is not what a function of ``fits`` expects.

    Subclasses ``ValueError`` so plain Python callers can catch that; the command
    line turns it into one line on stderr and exit code 2.
    """


class ConvergenceError(InputError):
    """A fit did not converge on the data given; the message carries the diagnostics.

    An ``InputError`` because it is a property of the data (too few points, a track
    that is not a throw), reported as bad input (exit code 2), never as a result.
    """
