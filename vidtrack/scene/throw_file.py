"""A replicate throw's own corrections: ``throws/<throw>/throw.toml`` (docs/scene.md,
"Replicate throws")::

    # run42/throws/02/throw.toml: this throw only
    [views.front]
    target = { frame = 30, at_px = [150.0, 60.0] }
    exclude_frames = [[40, 52]]
    manual_points = "front_manual.csv"     # in this throw's folder

The run's scene.toml holds what every throw shares (capture rate, axes, origin, scale,
straw, machine). A throw's file may give, per view of the scene, the three keys that
correct the tracker (:data:`THROW_KEYS`); each one given replaces the run's value of
that view for this throw only (``exclude_frames = []`` takes no frame out). They are
checked as scene.toml's are (the file, the key, what was expected), the manual points
file read and checked here too. :func:`throw_scene` gives the throw's
:class:`~vidtrack.scene.model.Scene`: the run's with those values in place, and a hash of
its own (so only that throw is tracked again when its file changes).
"""

import dataclasses
from pathlib import Path

from vidtrack.scene._check import _Checker, _read_toml, _show, _type_name
from vidtrack.scene.corrections import parse_exclude, parse_manual_points, parse_target
from vidtrack.scene.model import SCENE_FILE, SCHEMA

__all__ = ["THROW_FILE", "THROW_KEYS", "throw_scene", "apply_throw"]

#: A throw folder's own file of corrections.
THROW_FILE = "throw.toml"
#: What it may give per view: the corrections of the tracker.
THROW_KEYS = ("target", "exclude_frames", "manual_points")


def _check_view_keys(ck, table, path):
    for key in table:
        if key not in THROW_KEYS:
            shared = "; the rest of the view is the run's, in " + SCENE_FILE
            ck.fail(f"{path}.{key}", f"is not a key a throw may set{shared}; expected "
                    f"one of: {', '.join(THROW_KEYS)}")


def throw_scene(scene, folder):
    """The scene of the throw in ``folder``: the run's, with its ``throw.toml`` applied.

    Parameters
    ----------
    scene : vidtrack.scene.model.Scene
        The run's scene.
    folder : str or pathlib.Path
        The throw's folder (``<run>/throws/02``).

    Returns
    -------
    vidtrack.scene.model.Scene
        ``scene`` itself when the folder has no ``throw.toml``; else a copy whose views
        have the throw's ``target``, ``exclude_frames`` and ``manual_points`` where the
        file gives them, and whose ``hash`` holds them.

    Raises
    ------
    SceneError
        A file that is not TOML, a view the scene does not have, a key a throw may not
        set, a bad value; one line naming the throw's file, the key and what was expected.
    """
    folder = Path(folder)
    path = folder / THROW_FILE
    if not path.exists():
        return scene
    return apply_throw(scene, _read_toml(path), folder, label=str(path))


def apply_throw(scene, data, folder, *, label):
    """:func:`throw_scene` of a throw's file already parsed (``data``, as ``tomllib``
    gives it; ``label`` names it in messages); manual points resolve in ``folder``."""
    from vidtrack.scene.read import scene_digest

    ck = _Checker(label)
    ck.keys(data, ("schema", "views"), "")
    if "schema" in data and (isinstance(data["schema"], bool) or data["schema"] != SCHEMA):
        ck.fail("schema", f"must be {SCHEMA} (as scene.toml), got {_show(data['schema'])}")
    tables = ck.table(data, "views", "views") or {}
    views = dict(scene.views)
    for name, table in tables.items():
        key = f"views.{name}"
        if name not in views:
            ck.fail(key, f"is not a view of {scene.path}; expected one of: "
                    f"{', '.join(scene.view_names)}")
        if not isinstance(table, dict):
            ck.fail(key, f"must be a table, got {_type_name(table)} {_show(table)}")
        _check_view_keys(ck, table, key)
        view = views[name]
        frames = getattr(view, "frames", None)
        changes = {}
        if "target" in table:
            changes["target"] = parse_target(ck, table, key, frames)
        if "exclude_frames" in table:
            changes["exclude_frames"] = parse_exclude(ck, table, key, frames)
        if "manual_points" in table:
            exclude = changes.get("exclude_frames", view.exclude_frames)
            manual, text, points = parse_manual_points(ck, table, key, folder, frames,
                                                       exclude)
            changes.update(manual_points=manual, manual_points_text=text,
                           manual_points_read=points)
        views[name] = dataclasses.replace(view, **changes)
    out = dataclasses.replace(scene, views=views)
    return dataclasses.replace(out, hash=scene_digest(out))
