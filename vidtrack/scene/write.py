"""Writing a ``scene.toml``: :func:`scene_to_toml` and :func:`write_scene`.

:func:`write_scene` is the writer (used by ``vidtrack synth``): it validates the same way
as the loader (:func:`~vidtrack.scene.read.parse_scene`) before writing, so what is
written is what the loader reads. Numpy scalars and arrays, tuples and paths in the dict
are written as TOML values.
"""

import tomllib
from pathlib import Path

import numpy as np

from vidtrack.scene.model import _TOP_KEYS, SCENE_FILE
from vidtrack.scene.read import parse_scene


def _plain(obj, path="scene"):
    """Numpy scalars, tuples and paths to what TOML can hold; None entries dropped."""
    if isinstance(obj, dict):
        return {str(k): _plain(v, f"{path}.{k}") for k, v in obj.items() if v is not None}
    if isinstance(obj, (list, tuple)):
        return [_plain(v, path) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_plain(v, path) for v in obj.tolist()]
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return obj.as_posix()
    return obj


def scene_to_toml(scene_dict):
    """Validate a scene dict and return its ``scene.toml`` text.

    Parameters
    ----------
    scene_dict : dict
        Schema-1 content (as :meth:`Scene.to_dict` gives it). Numpy scalars and arrays,
        tuples and paths are accepted; keys whose value is None are left out.

    Returns
    -------
    str
        TOML text (written with ``tomli_w``) that :func:`load_scene` reads back to the
        same content.

    Raises
    ------
    SceneError
        The dict is not a valid scene (same checks and messages as the loader;
        calibration files are not opened: :func:`write_scene` does that).
    """
    import tomli_w

    data = _plain(scene_dict)
    parse_scene(data, folder=None, label="scene (to write)")
    ordered = {k: data[k] for k in _TOP_KEYS if k in data}
    from calibration.calibration_file import compact_toml

    return "# vidtrack scene, schema 1 (docs/scene.md)\n" + compact_toml(tomli_w.dumps(ordered))


def write_scene(path, scene_dict):
    """Validate a scene dict and write it as ``scene.toml``, atomically.

    Parameters
    ----------
    path : str or pathlib.Path
        A run folder (``scene.toml`` is written in it; created if missing) or the path
        of the file to write.
    scene_dict : dict
        Schema-1 content; see :func:`scene_to_toml`.

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    SceneError
        Not a valid scene (checked with the run folder, so calibration files named
        must already exist there). Nothing is written then.
    """
    from vidtrack._atomic import write_text

    p = Path(path)
    target = p if p.suffix.lower() == ".toml" else p / SCENE_FILE
    text = scene_to_toml(scene_dict)
    parse_scene(tomllib.loads(text), folder=target.parent, label=str(target), path=target)
    write_text(target, text)
    return target
