"""The scene's corrections of the tracker, for one run or throw folder.

Each view's ``exclude_frames`` and ``manual_points`` (docs/scene.md, "Correcting the
tracker") are read here for the folder being fitted (a run with ``throws/`` has a manual
points file per throw, resolved like ``source``), checked against the footage's frames
when it is opened (:func:`check_in_footage`, from :mod:`vidtrack.run.preflight`), keyed
for the tracks stage's cache (:func:`corrections_key`: the ranges and the file's sha256,
so an edited CSV tracks again), and applied to the views' tracks after tracking and
before the merge or triangulation (:func:`correct_tracks`,
:func:`vidtrack.track.corrections.apply_corrections`).
"""

from pathlib import Path

from vidtrack.errors import SceneError

__all__ = ["view_corrections", "correct_tracks", "corrections_key", "check_in_footage"]


def _manual(scene, folder, name):
    from vidtrack.scene.corrections import check_manual_frames, read_manual_points

    view = scene.views[name]
    path = view.manual_points_in(folder)
    if path is None:
        return None
    key = f"views.{name}.manual_points"
    points = read_manual_points(path, label=str(scene.path), key=key,
                                text=view.manual_points_text)
    check_manual_frames(points, label=str(scene.path), key=key,
                        frames=getattr(view, "frames", None),
                        exclude=getattr(view, "exclude_frames", ()))
    return points


def view_corrections(scene, folder, name):
    """``(exclude_frames, ManualPoints or None)`` of view ``name`` for ``folder``.

    Raises
    ------
    SceneError
        The manual points file is missing or not a valid ``frame,u_px,v_px`` CSV.
    """
    return tuple(getattr(scene.views[name], "exclude_frames", ())), _manual(scene, folder,
                                                                             name)


def correct_tracks(scene, folder, tracks):
    """The views' tracks with each view's corrections applied (a new dict)."""
    from vidtrack.track.corrections import apply_corrections

    out = {}
    for name, tr in tracks.items():
        exclude, manual = view_corrections(scene, folder, name)
        out[name] = apply_corrections(tr, exclude_frames=exclude, manual=manual)
    return out


def corrections_key(scene, folder):
    """What the corrections of ``folder``'s views are, for the tracks stage's key: the
    ranges and the manual points file's name and content digest (sha256 of its bytes;
    None when a named file is not there, which the preflight refuses)."""
    import hashlib

    key = {}
    for name, view in scene.views.items():
        exclude = [list(r) for r in getattr(view, "exclude_frames", ())]
        path = view.manual_points_in(folder) if hasattr(view, "manual_points_in") else None
        digest = None
        if path is not None:
            try:
                digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
            except OSError:
                digest = None
        if exclude or path is not None:
            key[name] = {"exclude_frames": exclude,
                         "manual_points": None if path is None else str(path),
                         "manual_sha256": digest}
    return key


def check_in_footage(scene, folder, name, first, last, source):
    """A view's manual points and excluded ranges against the frames ``first..last`` of
    its opened footage ``source`` (SceneError naming the key and the frames)."""
    view = scene.views[name]
    rng = getattr(view, "frames", None)
    used = (f"the frames used, {first}..{last} (views.{name}.frames = [{rng[0]}, {rng[1]}])"
            if rng else f"its frames 0..{last}")
    for i, (a, b) in enumerate(getattr(view, "exclude_frames", ())):
        if a > last or b <= first:
            raise SceneError(f"views.{name}.exclude_frames[{i}] = [{a}, {b}] "
                             f"holds none of {used} in {source}; expected a range of the "
                             "footage")
    manual = _manual(scene, folder, name)
    if manual is not None:
        for f in manual.frames:
            if not first <= f <= last:
                raise SceneError(f"views.{name}.manual_points "
                                 f"({view.manual_points_text}) has frame {f}, which is not "
                                 f"among {used} in {source}; expected frames of the footage")
