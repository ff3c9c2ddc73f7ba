"""Old import paths of modules that moved in 0.2, kept working for one release.

``import vidtrack.pipeline`` still gives ``vidtrack.run.pipeline`` (the same module object,
with a ``DeprecationWarning`` that names the new path). Installed by ``vidtrack/__init__``;
the table is the whole list of moves (``docs/architecture.md`` prints it for users).
"""

import importlib
import importlib.machinery
import sys
import warnings

#: old dotted path -> new dotted path (modules moved in 0.2; the aliases go in 0.3)
MOVED = {
    "vidtrack.frames": "vidtrack.footage",
    "vidtrack.cine": "vidtrack.footage.cine",
    "vidtrack.timebase": "vidtrack.footage.timebase",
    "vidtrack.background": "vidtrack.track.background",
    "vidtrack.tracker": "vidtrack.track.tracker",
    "vidtrack.stereo": "vidtrack.world.orthogonal",
    "vidtrack.pipeline": "vidtrack.run.pipeline",
    "vidtrack.tracks_io": "vidtrack.run.tracks_file",
    "vidtrack.fit_record": "vidtrack.run.fit_record",
    "vidtrack.run_report": "vidtrack.report.run_page",
    "vidtrack.anova_report": "vidtrack.report.anova_page",
}


class _Alias:
    """Finds an old path and loads it as the module at its new path (a meta path finder
    and its loader, by protocol: importlib.abc costs 10 ms of every command's start)."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname not in MOVED:
            return None
        return importlib.machinery.ModuleSpec(fullname, self)

    def create_module(self, spec):
        return None

    def exec_module(self, module):
        old = module.__name__
        new = MOVED[old]
        warnings.warn(f"{old} moved to {new} in vidtrack 0.2; the old path goes in 0.3",
                      DeprecationWarning, stacklevel=2)
        # the import system returns what sys.modules holds under the old name
        sys.modules[old] = importlib.import_module(new)


def install():
    """Put the alias finder on ``sys.meta_path`` once."""
    if not any(isinstance(f, _Alias) for f in sys.meta_path):
        sys.meta_path.append(_Alias())
