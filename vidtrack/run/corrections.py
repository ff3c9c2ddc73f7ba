"""The scene's corrections of the tracker, for one run or throw folder.

Each view's ``exclude_frames`` and ``manual_points`` (docs/scene.md, "Correcting the
tracker") are read here once for the folder being fitted (:func:`read_corrections`; a
run with ``throws/`` has a manual points file per throw, resolved like ``source``; a file
the scene's reader already read is taken as read), checked against the footage's frames
when it is opened (:func:`check_in_footage`, from :mod:`vidtrack.run.preflight`), keyed
for the tracks stage's cache (:func:`corrections_key`: the ranges and the file's sha256,
so an edited CSV tracks again), and applied to the views' tracks after tracking and
before the reconstruction (:func:`correct_tracks`,
:func:`vidtrack.track.corrections.apply_corrections`).
"""

from vidtrack.errors import SceneError

__all__ = ["read_corrections", "correct_tracks", "corrections_key", "check_in_footage"]


def _manual(scene, folder, name):
    from vidtrack.scene.corrections import check_manual_frames, read_manual_points

    view = scene.views[name]
    path = view.manual_points_in(folder)
    if path is None:
        return None
    key = f"views.{name}.manual_points"
    points = view.manual_points_read
    if points is None or points.path != path:
        points = read_manual_points(path, label=str(scene.path), key=key,
                                    text=view.manual_points_text)
    check_manual_frames(points, label=str(scene.path), key=key, frames=view.frames,
                        exclude=view.exclude_frames)
    return points


def read_corrections(scene, folder, name):
    """``(exclude_frames, ManualPoints or None)`` of view ``name`` for ``folder``: its
    manual points file read (unless the scene's reader read it) and checked.

    Raises
    ------
    SceneError
        The manual points file is missing or not a valid ``frame,u_px,v_px`` CSV.
    """
    return tuple(scene.views[name].exclude_frames), _manual(scene, folder, name)


def correct_tracks(tracks, corrections):
    """The views' tracks with each view's ``corrections`` applied (a new dict).

    ``corrections``: view -> ``(exclude_frames, ManualPoints or None)``
    (:func:`read_corrections`)."""
    from vidtrack.track.corrections import apply_corrections

    out = {}
    for name, tr in tracks.items():
        exclude, manual = corrections[name]
        out[name] = apply_corrections(tr, exclude_frames=exclude, manual=manual)
    return out


def corrections_key(scene, folder, corrections):
    """What the corrections of ``folder``'s views are, for the tracks stage's key: the
    ranges and the manual points file's name and content digest (sha256 of its bytes)."""
    key = {}
    for name, view in scene.views.items():
        exclude, manual = corrections[name]
        path = view.manual_points_in(folder)
        if exclude or path is not None:
            key[name] = {"exclude_frames": [list(r) for r in exclude],
                         "manual_points": None if path is None else str(path),
                         "manual_sha256": None if manual is None else manual.sha256}
    return key


def check_in_footage(view, manual, first, last, source):
    """A view's manual points (``manual``: ManualPoints or None) and excluded ranges
    against the frames ``first..last`` of its opened footage ``source`` (SceneError
    naming the key and the frames)."""
    name = view.name
    rng = view.frames
    used = (f"the frames used, {first}..{last} (views.{name}.frames = [{rng[0]}, {rng[1]}])"
            if rng else f"its frames 0..{last}")
    for i, (a, b) in enumerate(view.exclude_frames):
        if a > last or b <= first:
            raise SceneError(f"views.{name}.exclude_frames[{i}] = [{a}, {b}] "
                             f"holds none of {used} in {source}; expected a range of the "
                             "footage")
    if manual is not None:
        for f in manual.frames:
            if not first <= f <= last:
                raise SceneError(f"views.{name}.manual_points "
                                 f"({view.manual_points_text}) has frame {f}, which is not "
                                 f"among {used} in {source}; expected frames of the footage")
