"""The fitted path of a run in one view's pixels: for the overlay and the contact sheet.

A view's frame is put on the fit's clock and the fitted world position at that time is
projected into the view's image (top-left pixels, as the tracker measures them):

- **orthogonal views** (``front``/``top``): world t = the frame's time on the view's
  clock (``t_s`` of tracks.h5) minus the view's t = 0 (fit.json ``world.t0_s``); the
  view's two world axes go through its mapping (:meth:`calibration.views.ViewMapping.
  world_to_pixel`, lens included). With ``camera_distance_m`` the perspective is put
  back: a point ``depth`` nearer the camera is imaged d / (d - depth) farther from the
  principal point (the inverse of :meth:`~calibration.views.ViewMapping.
  pixel_to_world_at_depth`).
- **calibrated views** (a ``[world]`` table): the fit runs in the throw's frame, whose
  t = 0 is the first triangulated frame; view v's frame f is at f / fps_v - offset_v on
  the common clock (fit.json ``world.offsets_s``). The throw frame's point is rotated
  back into the calibration's frame (``world.rotation``: rows are the throw frame's
  axes) and projected through the view's camera, lens included; a camera counted from
  the bottom-left (DLTdv) is turned to top-left pixels with the frame height.

The fitted positions come from the fit itself (:meth:`fits.lsq.ThrowFit.predict`, in the
run) or from fit.json (:func:`record_positions`: ``fits.throw.position`` with the
record's initial state and k1..k4).
"""

from dataclasses import dataclass, field

import numpy as np

__all__ = ["ViewPath", "view_paths", "record_positions", "MODELS"]

#: fit.json's ``model`` -> the model name of ``fits.throw``.
MODELS = {"quadratic-drag": "quadratic", "linear-drag": "linear", "drag-free": "free"}
_STATE = ("x0_m", "y0_m", "z0_m", "vx0_m_s", "vy0_m_s", "vz0_m_s")


def record_positions(record, *, g, v1):
    """A function t -> fitted (N, 3) positions (m) from a fit.json record.

    ``fits.throw.position`` with the record's ``initial_state``, ``coefficients``,
    ``cp_s_per_m`` and ``model``. Times before t = 0 give NaN. What the record cannot
    give is NaN too, and said in the function's ``notes``: an axis whose initial state
    is null (not measured), y when neither k1 nor k2 has a value. A k without a value
    whose effect the fit did not need is taken from its partner (k1 from k2 when no
    ascent was seen, k2 from k1 when no descent was: the fit used that law), or is 1
    where it has no effect (k3, k4 without drag).

    Parameters
    ----------
    record : dict
        A fit.json record of one throw.
    g, v1 : float
        Gravity (m/s²) and the machine's travel speed (m/s) of the scene.
    """
    from fits.throw import position

    model = MODELS.get(record.get("model"), record.get("model"))
    cp = float(record.get("cp_s_per_m") or 0.0)
    st = record.get("initial_state") or {}
    k = {n: (c or {}).get("value") for n, c in (record.get("coefficients") or {}).items()}
    notes = []
    bad_axes = set()
    state = []
    for i, name in enumerate(_STATE):
        v = st.get(name)
        if v is None or not np.isfinite(v):
            bad_axes.add("xyz"[i % 3])
            v = 0.0
        state.append(float(v))
    k1, k2 = k.get("k1"), k.get("k2")
    if k1 is None and k2 is None:
        bad_axes.add("y")
        notes.append("y is not drawn: fit.json gives neither k1 nor k2")
    k1 = k1 if k1 is not None else k2
    k2 = k2 if k2 is not None else k1
    drag = model != "free" and cp > 0
    ks = [k1 or 1.0, k2 or 1.0]
    for name, axis in (("k3", "x"), ("k4", "z")):
        v = k.get(name)
        if v is None and drag and axis not in bad_axes:
            bad_axes.add(axis)
            notes.append(f"{axis} is not drawn: fit.json gives no value of {name}")
        ks.append(v if v is not None else 1.0)
    mask = np.array([a in bad_axes for a in "xyz"])

    def positions(t):
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        out = np.full((t.size, 3), np.nan)
        ok = np.isfinite(t) & (t >= 0)
        if ok.any():
            out[ok] = position(t[ok], state, ks, cp, g=g, v1=v1, model=model)
        out[:, mask] = np.nan
        return out

    positions.notes = tuple(notes)
    return positions


@dataclass(frozen=True, eq=False)
class ViewPath:
    """The fitted path in one view's image.

    Attributes
    ----------
    view : str
    t0_s : float
        The time on the view's clock that is the fit's t = 0.
    t_end_s : float
        The fit's last measured time (the end of the flight drawn).
    fps : float or None
        Calibrated views: the rate that gives the view's clock (frame / fps); None for
        orthogonal views (their clock is tracks.h5's ``t_s``).
    notes : tuple of str
    """

    view: str
    t0_s: float
    t_end_s: float
    fps: float | None
    _positions: object = field(repr=False)
    _project: object = field(repr=False)
    notes: tuple = ()

    def world_time(self, frames, t_s):
        """The fit's t (s) of the view's frames (file indices) at times ``t_s`` (the
        view's clock, used by orthogonal views)."""
        if self.fps is not None:
            return np.asarray(frames, dtype=np.float64) / self.fps - self.t0_s
        return np.asarray(t_s, dtype=np.float64) - self.t0_s

    def pixels_at(self, t):
        """Fitted image pixels (N, 2), top-left convention, at the fit's times ``t``;
        NaN before t = 0 and after :attr:`t_end_s` (plus a frame's worth)."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        xyz = self._positions(np.where(t <= self.t_end_s * 1.01 + 1e-3, t, np.nan))
        return self._project(xyz)

    def at_frames(self, frames, t_s):
        """Fitted pixels of the view's frames (see :meth:`world_time`)."""
        return self.pixels_at(self.world_time(frames, t_s))

    def polyline(self, n=240):
        """The path over the flight, t = 0 .. :attr:`t_end_s`, as (M, 2) pixels (only
        the finite ones)."""
        uv = self.pixels_at(np.linspace(0.0, self.t_end_s, n))
        return uv[np.all(np.isfinite(uv), axis=1)]


def _orthogonal_projector(view, frame_shape):
    """World (N, 3) -> image pixels of an orthogonal view, perspective put back."""
    from calibration.views import ViewMapping

    m = view.mapping()
    idx = ["xyz".index(a) for a in m.world_axes]
    d = m.camera_distance_m
    foot = axis = sign = None
    if d is not None:
        pp = m.principal_px
        if pp is None and frame_shape:
            pp = (0.5 * (frame_shape[1] - 1), 0.5 * (frame_shape[0] - 1))
        if pp is not None:
            ideal = ViewMapping(axes=m.axes, origin_px=m.origin_ideal_px, m_per_px=m.m_per_px)
            foot = ideal.pixel_to_world(np.asarray(pp, dtype=np.float64))
            axis_name, sign = m.toward_camera
            axis = "xyz".index(axis_name)

    def project(xyz):
        w = xyz[:, idx]
        if foot is not None:
            depth = sign * xyz[:, axis]
            with np.errstate(divide="ignore", invalid="ignore"):
                factor = d / (d - depth)
            factor[~(factor > 0)] = np.nan
            w = foot + (w - foot) * factor[:, None]
        return m.world_to_pixel(w)

    return project


def _calibrated_projector(view, rotation, frame_shape):
    """World (throw frame, N x 3) -> top-left image pixels of a calibrated view."""
    cam = view.camera
    rot = np.asarray(rotation, dtype=np.float64)
    height = frame_shape[0] if frame_shape else None

    def project(xyz):
        uv = cam.project(xyz @ rot)
        if cam.pixel_origin == "bottom-left":
            if height is None:
                return np.full_like(uv, np.nan)
            uv = uv.copy()
            uv[:, 1] = height - uv[:, 1]
        return uv

    return project


def view_paths(scene, record, world, *, frame_shapes=None, positions=None):
    """The fitted path in each view of the scene.

    Parameters
    ----------
    scene : vidtrack.scene.Scene
    record : dict
        The throw's fit.json record (``world`` gives each view's t = 0, or the
        calibrated cameras' offsets and rotation).
    world : mapping of str to array
        The world track's columns (``t_s``; calibrated: ``frame`` too).
    frame_shapes : dict of str to (rows, cols), optional
        Each view's frame size (tracks.h5 ``frame_shape``): the principal point of an
        orthogonal view with ``camera_distance_m`` and no calibration, the height of a
        calibrated view counted from the bottom-left.
    positions : callable, optional
        t -> (N, 3) fitted positions (e.g. ``ThrowFit.predict``); default from the record
        (:func:`record_positions`).

    Returns
    -------
    dict of str to ViewPath
    """
    frame_shapes = frame_shapes or {}
    if positions is None:
        positions = record_positions(record, g=scene.physics.gravity_m_s2, v1=scene.v1_m_s)
    notes = tuple(getattr(positions, "notes", ()))
    summary = record.get("world") or {}
    t = np.asarray(world["t_s"], dtype=np.float64)
    t_end = float(np.nanmax(t)) if np.isfinite(t).any() else 0.0
    out = {}
    if scene.calibrated:
        offsets = summary["offsets_s"]
        ref = summary["reference"]
        first = float(np.asarray(world["frame"])[0])
        t_first = first / scene.views[ref].fps - offsets[ref]
        for name, view in scene.views.items():
            out[name] = ViewPath(
                view=name, t0_s=offsets[name] + t_first, t_end_s=t_end, fps=float(view.fps),
                _positions=positions, notes=notes,
                _project=_calibrated_projector(view, summary["rotation"],
                                               frame_shapes.get(name)))
    else:
        t0 = summary.get("t0_s") or {}
        for name, view in scene.views.items():
            if name not in t0:
                continue
            out[name] = ViewPath(view=name, t0_s=float(t0[name]), t_end_s=t_end, fps=None,
                                 _positions=positions, notes=notes,
                                 _project=_orthogonal_projector(view, frame_shapes.get(name)))
    return out
