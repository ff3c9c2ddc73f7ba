"""The tracks stage of a scene with calibrated cameras (a ``[world]`` table).

Each view is tracked from its footage, or read from the points digitized elsewhere (no
tracking then), and the views are triangulated frame by frame into the throw's own frame
(:func:`vidtrack.world.calibrated.triangulate_views`). The outputs are those of any run:
tracks.h5 (one group per view, the triangulation's columns in ``/world``), tracks.csv
and world.csv (with each view's reprojection error), then the fit as usual.
"""

import logging
import time

log = logging.getLogger(__name__)

__all__ = ["calibrated_tracks", "triangulate_scene", "DISAGREEMENT_PX"]

#: Median reprojection error (px) above which the calibration and the points are said
#: to disagree: a calibration that fits its points leaves about a pixel.
DISAGREEMENT_PX = 3.0


def _view_track(scene, folder, name, settings, quiet):
    from vidtrack.run._workers import source_of, track_view
    from vidtrack.track.digitized import read_points

    view = scene.views[name]
    if view.points is None:
        # the view's target, if any, is passed to the tracker by track_view
        return track_view(scene, folder, name, settings, quiet=quiet)
    import dataclasses

    p = view.points
    track = read_points(source_of(view, scene, folder), fps=view.fps, fmt=p.format,
                        camera=p.camera, point=p.point, view=name)
    if view.frames is None:
        return track
    first, end = view.frames
    keep = (track.data["frame"] >= first) & (track.data["frame"] < end)
    if not keep.any():
        from vidtrack.errors import SceneError

        raise SceneError(f"{scene.path}: views.{name}.frames = [{first}, {end}) holds none of "
                         f"the points' frames (0..{int(track.data['frame'].max())})")
    return dataclasses.replace(track, data=track.data[keep].reset_index(drop=True))


def calibrated_tracks(scene, folder, settings, *, quiet=True, timings=None):
    """Track (or read) every view and triangulate them.

    Parameters
    ----------
    scene : vidtrack.scene.Scene
        A calibrated scene (``scene.calibrated``).
    folder : pathlib.Path
        The run folder or a throw's folder.
    settings : dict
        The tracker's settings.
    quiet : bool
    timings : dict, optional
        Filled with ``track`` and ``merge`` (s).

    Returns
    -------
    (dict, vidtrack.world.calibrated.CalibratedWorld)
        The views' tracks and the triangulated world track.
    """
    from vidtrack.run.corrections import correct_tracks

    timings = {} if timings is None else timings
    t0 = time.perf_counter()
    # points first: a bad points file stops the run before any footage is tracked
    order = sorted(scene.view_names, key=lambda n: scene.views[n].points is None)
    tracks = {n: _view_track(scene, folder, n, settings, quiet) for n in order}
    tracks = {n: tracks[n] for n in scene.view_names}
    # the scene's exclude_frames and manual_points, before the triangulation
    tracks = correct_tracks(scene, folder, tracks)
    timings["track"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    world = triangulate_scene(scene, tracks)
    timings["merge"] = time.perf_counter() - t0
    return tracks, world


def triangulate_scene(scene, tracks):
    """The views' tracks triangulated with the scene's cameras (the world track).

    Used on fresh tracks and on the views of a tracks.h5 edited by hand (the world track
    is rebuilt from them).
    """
    from vidtrack.world.calibrated import triangulate_views

    views = scene.views
    heights = {n: tr.frame_shape[0] for n, tr in tracks.items()
               if views[n].points is None and views[n].pixel_origin == "bottom-left"}
    world = triangulate_views(
        tracks, {n: v.camera for n, v in views.items()},
        fps={n: v.fps for n, v in views.items()},
        sync={n: v.sync_frame for n, v in views.items()}, image_heights=heights,
        up=scene.world.up, forward=scene.world.forward)
    if world.median_reprojection_px > DISAGREEMENT_PX:
        import dataclasses

        note = (f"the calibration and the points disagree: median reprojection error "
                f"{world.median_reprojection_px:.1f} px (a calibration that fits its points "
                f"leaves about 1 px); positions may be off by centimetres")
        log.warning(note)
        world = dataclasses.replace(world, warnings=world.warnings + (note,))
    return world
