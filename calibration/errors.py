"""The one exception of the ``calibration`` package for bad input."""


class InputError(ValueError):
    """A calibration input is not what was expected (file, key, value).

    Subclasses ``ValueError``; the command line turns it into exit code 2.
    """
