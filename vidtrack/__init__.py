"""vidtrack: high-speed footage of a thrown straw to k1..k4 and the published ANOVA.

The package that touches footage and the user; the only one that imports the other two
(``fits`` for numbers, ``calibration`` for pixels to metres). Its sub-packages follow the
data, each importing only those before it (docs/architecture.md):

- ``vidtrack.footage``: frame sources (videos, image folders, Phantom .cine), the time
  base, frame export;
- ``vidtrack.track``: one view's footage to a per-frame ``Track``;
- ``vidtrack.world``: the views to a ``WorldTrack`` in metres (the orthogonal merge or
  the triangulation of calibrated cameras);
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

The calls a notebook needs are here, each loaded from its stage on first use (importing
``vidtrack`` loads neither numpy nor any stage's code)::

    from vidtrack import open_source, track, fit_run, read_tracks

    with open_source("run42/front.avi", fps=1200) as src:
        tr = track(src[100:400], view="front")     # a Track; tr.data has a frame column
    fit = fit_run("run42")                         # a RunFit: summary(), params, tracks
    tf = read_tracks("run42/vidtrack/tracks.h5")   # the tracks and the world track

``track`` is the subpackage ``vidtrack.track`` made callable: ``track(source, ...)`` is
:func:`vidtrack.track.tracker.track`, and ``vidtrack.track.tracker`` stays importable.
"""

import logging

from vidtrack import _moved
from vidtrack import _lazy

logging.getLogger(__name__).addHandler(logging.NullHandler())

#: The loggers of the three packages (vidtrack, and the two it imports): what the
#: command line prints, and what a worker process sends back to its caller.
LOGGERS = ("vidtrack", "fits", "calibration")

_moved.install()

__version__ = "0.2.0"

# The public API, loaded on first use: importing the package loads nothing heavy, so
# that the command line (vidtrack.cli) can set its environment before numpy loads.
_EXPORTS = {
    "vidtrack.errors": ("VidtrackError",),
    "vidtrack.footage.sources": ("open_source",),
    "vidtrack.track._flags": ("TrackFlag", "flag_names"),
    "vidtrack.run.tracks_file": ("read_tracks",),
    "vidtrack.run.pipeline": ("fit_run", "fit_runs", "FitOptions"),
    "vidtrack.run.results": ("RunFit",),
}
__getattr__, __dir__, _NAMES = _lazy.lazy_exports(__name__, _EXPORTS)

# ``from vidtrack import track``: the stage's package, called as its tracker
track = _lazy.callable_package("vidtrack.track", "vidtrack.track.tracker", "track")

__all__ = ["LOGGERS", "__version__", "track", *_NAMES]
