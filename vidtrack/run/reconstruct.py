"""The views' tracks of a run -> its world track, whatever the scene's cameras.

Orthogonal front/top views are merged with their scales measured on the shared X and
reconciled where the rulers' stated uncertainty explains their ratio
(:func:`vidtrack.world.shared_x.merge_reconciled`); calibrated cameras at any angle are
triangulated into the throw's own frame (:func:`vidtrack.world.calibrated.triangulate_views`).
Both give a :class:`vidtrack.world.world_track.WorldTrack` whose ``tracks`` are the views
as reconstructed, with the straw's attitude per row (its axis and the rate it turns
at, :mod:`vidtrack.world.attitude`). Used on fresh tracks and on the views of a
tracks.h5 edited by hand (the world track is always rebuilt from its views).
"""

import logging

log = logging.getLogger(__name__)

__all__ = ["reconstruct", "calibration_of", "DISAGREEMENT_PX"]

#: Median reprojection error (px) above which the calibration and the points are said
#: to disagree: a calibration that fits its points leaves about a pixel.
DISAGREEMENT_PX = 3.0


def reconstruct(scene, tracks):
    """The world track of the views' ``tracks`` (corrected by the scene already).

    Parameters
    ----------
    scene : vidtrack.scene.Scene
    tracks : dict of str to vidtrack.track.tracker.Track

    Returns
    -------
    vidtrack.world.world_track.WorldTrack
        Its ``tracks`` are the views as reconstructed (orthogonal: the frames before each
        view's t = 0 flagged, the release carried over).
    """
    if scene.calibrated:
        return _triangulated(scene, tracks)
    import dataclasses

    from vidtrack.world.attitude import orthogonal_attitude
    from vidtrack.world.shared_x import merge_reconciled

    views = scene.views
    mappings = {n: v.mapping() for n, v in views.items()}
    world = merge_reconciled(tracks, mappings,
                             sync={n: v.sync_frame for n, v in views.items()},
                             rel={n: v.scale_rel_uncertainty[0] for n, v in views.items()},
                             ruler_px={n: v.scale.span_px if v.ruler is not None and v.scale
                                       else None for n, v in views.items()})
    # the straw's attitude from the views' image lines (vidtrack.world.attitude)
    data = world.data.assign(**orthogonal_attitude(world, world.mappings(mappings)))
    return dataclasses.replace(world, data=data)


def _triangulated(scene, tracks):
    import dataclasses

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
        note = (f"the calibration and the points disagree: median reprojection error "
                f"{world.median_reprojection_px:.1f} px (a calibration that fits its points "
                f"leaves about 1 px); positions may be off by centimetres")
        log.warning(note)
        world = dataclasses.replace(world, warnings=world.warnings + (note,))
    return world


def calibration_of(scene):
    """What the views were reconstructed with, for tracks.h5's ``calibration``
    attribute: each view's mapping, or each calibrated view's camera."""
    if scene.calibrated:
        return {n: v.camera.to_dict() for n, v in scene.views.items()}
    return {n: v.to_dict() for n, v in scene.views.items()}
