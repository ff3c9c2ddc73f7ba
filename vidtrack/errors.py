"""The exception family of vidtrack: bad input or usage (exit code 2 on the CLI)."""

import calibration.errors
import fits.errors


class VidtrackError(Exception):
    """Bad input or usage: one clear message (what, where, what was expected)."""


class SceneError(VidtrackError):
    """``scene.toml`` or ``experiment.toml`` is missing a key, has a bad value, etc."""


class SourceError(VidtrackError):
    """A frame source (video, image folder, .cine) is missing, unreadable or empty."""


class TrackError(VidtrackError):
    """A view could not be tracked (nothing moves, the straw never appears)."""


class FitError(VidtrackError):
    """A fit did not converge or the data cannot support it."""


class DisagreementError(VidtrackError):
    """The inputs of a run disagree with each other or with physics (the views on the X
    they share, one footage for two views, implausible accelerations): the fit would
    be wrong. ``vidtrack fit --accept-disagreement`` fits anyway, with a warning."""


class DiskFullError(VidtrackError):
    """An output could not be written: no space left on the device (or the quota is
    used up). Nothing of the output is kept (:func:`vidtrack._atomic.disk_full`)."""


#: Every exception the command line reports as bad input (exit code 2).
INPUT_ERRORS = (VidtrackError, fits.errors.InputError, calibration.errors.InputError)
