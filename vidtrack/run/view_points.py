"""A view's track from points digitized elsewhere (a calibrated view's ``points``).

Such a view is read, not tracked: its pixels are in its camera's convention, one row per
frame the file has, cut to the view's ``frames`` range when it gives one.
"""

import dataclasses

from vidtrack.errors import SceneError

__all__ = ["points_track"]


def points_track(scene, folder, name):
    """The track of view ``name``, read from its points file for ``folder``.

    Raises
    ------
    SceneError
        The file cannot be read, or ``frames`` holds none of its frames.
    """
    from vidtrack.run._workers import source_of
    from vidtrack.track.digitized import read_points

    view = scene.views[name]
    p = view.points
    track = read_points(source_of(view, scene, folder), fps=view.fps, fmt=p.format,
                        camera=p.camera, point=p.point, view=name)
    if view.frames is None:
        return track
    first, end = view.frames
    keep = (track.data["frame"] >= first) & (track.data["frame"] < end)
    if not keep.any():
        raise SceneError(f"{scene.path}: views.{name}.frames = [{first}, {end}) holds none of "
                         f"the points' frames (0..{int(track.data['frame'].max())})")
    return dataclasses.replace(track, data=track.data[keep].reset_index(drop=True))
