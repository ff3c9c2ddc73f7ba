"""vidtrack: high-speed footage of a thrown straw to k1..k4 and the published ANOVA.

The package that touches footage and the user; the only one that imports the other two
(``fits`` for numbers, ``calibration`` for pixels to metres). Its sub-packages follow the
data, each importing only those before it (docs/architecture.md):

- ``vidtrack.footage``: frame sources (videos, image folders, Phantom .cine), the time
  base, frame export;
- ``vidtrack.track``: one view's footage to a per-frame ``Track``;
- ``vidtrack.world``: the views to a ``WorldTrack`` in metres (the orthogonal merge);
- ``vidtrack.report``: the run page and the ANOVA page;
- ``vidtrack.run``: ``fit_run``/``fit_runs`` (what ``vidtrack fit`` runs), the stage cache,
  tracks.h5 and fit.json;
- ``vidtrack.experiment``: many runs to the coefficient table and its ANOVA;
- ``vidtrack.synth``: synthetic runs with known truth; ``vidtrack.predict``: the forward
  model from settings to a throw;
- ``vidtrack.scene`` (scene.toml, experiment.toml) and ``vidtrack.errors`` serve them all;
  ``vidtrack.bench`` and ``vidtrack.cli`` sit on top.

Messages are log records under the ``vidtrack`` logger and its children (one per
module); the package adds only a ``NullHandler``, so nothing is printed unless logging is
configured (``logging.basicConfig(level=logging.INFO)``, or ``vidtrack -v`` on the
command line). Progress bars appear on a terminal and in Jupyter (``vidtrack._progress``).
"""

import logging

from vidtrack import _moved

logging.getLogger(__name__).addHandler(logging.NullHandler())

#: The loggers of the three packages (vidtrack, and the two it imports): what the
#: command line prints, and what a worker process sends back to its caller.
LOGGERS = ("vidtrack", "fits", "calibration")

_moved.install()

__version__ = "0.2.0"

__all__ = ["LOGGERS", "VidtrackError", "__version__"]


def __getattr__(name):
    # lazily: importing the package loads nothing heavy, so that the command line
    # (vidtrack.cli) can set its environment before numpy loads
    if name == "VidtrackError":
        from vidtrack.errors import VidtrackError

        return VidtrackError
    raise AttributeError(f"module 'vidtrack' has no attribute {name!r}")
