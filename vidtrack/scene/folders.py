"""A run folder's replicate throws (:func:`find_throw_dirs`), whether it is only planned
(:func:`is_planned_scene`), and the natural order of names.

A run with a ``throws/`` folder has one sub-folder per replicate throw (``throws/01``,
``throws/02``, ...), each with its own sources; without one, the run folder holds the one
throw. Folder names sort naturally (2 before 10): the throws here, an experiment's run
folders in :meth:`~vidtrack.scene.experiment_file.Experiment.run_dirs`.
"""

import re
from pathlib import Path

from vidtrack.errors import SceneError


#: The first line of a scene.toml that `vidtrack design` writes for a run not filmed yet (no
#: views): `vidtrack init` completes such a file and `vidtrack synth` renders into its
#: folder, where they refuse any other scene.toml.
PLAN_MARK = "# vidtrack scene, schema 1: a run of a designed experiment, not filmed yet."


def is_planned_scene(path):
    """True when ``path`` is a file (not a link) whose first line is :data:`PLAN_MARK`."""
    path = Path(path)
    if not path.is_file() or path.is_symlink():
        return False
    try:
        with open(path, encoding="utf-8") as f:
            return f.readline().rstrip("\n") == PLAN_MARK
    except (OSError, UnicodeDecodeError):
        return False


def _natural_key(text):
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", text)]


def find_throw_dirs(run_dir):
    """The replicate-throw folders of a run: ``<run>/throws/*``, natural order.

    Parameters
    ----------
    run_dir : str or pathlib.Path

    Returns
    -------
    list of pathlib.Path
        Sub-folders of ``throws/`` (hidden ones skipped), 2 before 10; empty when the
        run has no ``throws/`` folder (then the run folder holds the one throw).

    Raises
    ------
    SceneError
        ``throws`` exists but is not a folder, or holds no throw folder.
    """
    throws = Path(run_dir) / "throws"
    if not throws.exists():
        return []
    if not throws.is_dir():
        raise SceneError(f"{throws}: expected a folder of replicate throws (throws/01, "
                         "throws/02, ...), got a file")
    dirs = sorted((p for p in throws.iterdir() if p.is_dir() and not p.name.startswith(".")),
                  key=lambda p: _natural_key(p.name))
    if not dirs:
        raise SceneError(f"{throws}: no throw folders in it (expected throws/01, throws/02, "
                         "... each with its own sources)")
    return dirs
