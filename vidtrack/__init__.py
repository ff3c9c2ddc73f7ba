"""vidtrack: high-speed footage of a thrown straw to k1..k4 and the published ANOVA.

The package that touches footage and the user; the only one that imports the other
two (``fits`` for numbers, ``calibration`` for pixels to metres). Modules:

- ``vidtrack.frames``: ``open_source`` (videos, image folders, Phantom .cine via
  ``vidtrack.cine``), ``export_frames``; ``vidtrack.timebase``: time-base checks.
- ``vidtrack.scene``: ``load_scene``, ``write_scene``, ``load_experiment``.
- ``vidtrack.tracker``: ``track`` -> ``Track``; ``vidtrack.stereo``: ``merge_tracks``;
  ``vidtrack.tracks_io``: ``write_tracks``, ``read_tracks``.
- ``vidtrack.pipeline``: ``fit_run``, ``fit_runs`` (what ``vidtrack fit`` runs);
  ``vidtrack.experiment``: the coefficient table and its analysis.
- ``vidtrack.synth``: ``render_run`` (synthetic runs with known truth);
  ``vidtrack.predict``: ``predict``.
- reports: ``vidtrack.run_report``, ``vidtrack.anova_report``; benchmarks:
  ``vidtrack.bench``; the command line: ``vidtrack.cli``.
"""

__version__ = "0.1.0"

__all__ = ["VidtrackError", "__version__"]


def __getattr__(name):
    # lazily: importing the package loads nothing heavy, so that the command line
    # (vidtrack.cli) can set its environment before numpy loads
    if name == "VidtrackError":
        from vidtrack.errors import VidtrackError

        return VidtrackError
    raise AttributeError(f"module 'vidtrack' has no attribute {name!r}")
