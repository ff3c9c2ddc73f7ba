"""``scene.toml`` (schema 1) and ``experiment.toml``: read, validate, write.

A run folder's ``scene.toml`` says where the footage is, at what capture rate, how its
pixels map to the world frame, and what straw and machine the run had; an experiment
folder's ``experiment.toml`` says which runs it holds and how its factors are coded.
Every key is documented in ``docs/scene.md``. The modules:

- ``model``: the frozen :class:`Scene` and its parts (:class:`ViewSpec`, :class:`Ruler`,
  :class:`Physics`, :class:`Straw`) and the schema's constants;
- ``read``: :func:`load_scene` and :func:`parse_scene`, every key checked;
- ``write``: :func:`scene_to_toml` and :func:`write_scene`, checked the same way;
- ``experiment_file``: :func:`load_experiment`, :class:`Experiment`, :class:`Factor`;
- ``folders``: :func:`find_throw_dirs` (a run's replicate throws), natural order,
  :func:`is_planned_scene` (a run `vidtrack design` planned, not filmed yet);
- ``throw_file``: :func:`throw_scene`, a throw's own corrections (``throw.toml``) applied;
- ``_check``: the key-by-key checker behind every one-line message.

The public names below are importable from ``vidtrack.scene`` itself; each is loaded from
its module on first use (PEP 562), so reading a scene (``load_scene``) loads neither the
writer nor the experiment file.
"""

from vidtrack._lazy import lazy_exports

_EXPORTS = {
    "vidtrack.scene.model": ("Scene", "ViewSpec", "Ruler", "Physics", "Straw", "SCENE_FILE",
                             "SCHEMA", "VIEW_AXES"),
    "vidtrack.scene.read": ("load_scene", "parse_scene"),
    "vidtrack.scene.write": ("scene_to_toml", "write_scene"),
    "vidtrack.scene.experiment_file": ("Experiment", "Factor", "load_experiment",
                                       "EXPERIMENT_FILE"),
    "vidtrack.scene.folders": ("find_throw_dirs", "is_planned_scene", "PLAN_MARK"),
    "vidtrack.scene.throw_file": ("throw_scene", "THROW_FILE"),
}
__getattr__, __dir__, _NAMES = lazy_exports(__name__, _EXPORTS)

__all__ = [
    "Scene", "ViewSpec", "Ruler", "Physics", "Straw", "Experiment", "Factor",
    "load_scene", "parse_scene", "scene_to_toml", "write_scene", "load_experiment",
    "find_throw_dirs", "is_planned_scene", "PLAN_MARK", "SCENE_FILE", "EXPERIMENT_FILE",
    "SCHEMA", "VIEW_AXES", "throw_scene", "THROW_FILE",
]
