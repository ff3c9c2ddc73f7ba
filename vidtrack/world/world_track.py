"""The world track: what every reconstruction of a run returns.

Two reconstructions give it: the orthogonal front/top merge
(:func:`vidtrack.world.orthogonal.merge_tracks`, ``kind = "orthogonal"``) and the
triangulation of calibrated cameras at any angle
(:func:`vidtrack.world.calibrated.triangulate_views`, ``kind = "calibrated"``). Both give
rows with a ``frame`` column (the reference view's file frame) and ``t_s``, ``x_m``,
``y_m``, ``z_m``; each kind has fields the other has no use for, and those are None or
empty in a world track of the other kind (see :class:`WorldTrack`).
"""

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

__all__ = ["WorldTrack", "KINDS"]

#: The reconstructions a world track comes from.
KINDS = ("orthogonal", "calibrated")
_AXES = ("x", "y", "z")


@dataclass(frozen=True, eq=False)
class WorldTrack:
    """The straw's world track from the views of one run.

    Attributes
    ----------
    data : pandas.DataFrame
        One row per frame of the reference view: ``frame`` (the reference view's 0-based
        file frame; -1 for a time at no frame of it, in a ``/world`` edited by hand),
        ``t_s`` (s since t = 0), ``x_m``, ``y_m``, ``z_m`` (world frame, m; NaN where not
        measured or flagged). A calibrated world track has besides ``views`` (how many
        saw the row), ``flags`` (:data:`vidtrack.world.calibrated.REPROJECTION`),
        ``reprojection_px_<view>`` (each view's reprojection distance), ``X_m, Y_m, Z_m``
        (the calibration's frame) and, with the rod correction, ``rod_shift_px_<view>``.
        Either kind as reconstructed for a run ends with the straw's attitude:
        ``axis_x``, ``axis_y``, ``axis_z`` (its unit axis, throw frame) and
        ``spin_rad_s`` (the rate the axis turns at), NaN where not measured
        (:mod:`vidtrack.world.attitude`).
    t0_s : dict
        View -> time in that view's source clock (``Track.data["t_s"]``) that is t = 0.
        Orthogonal only; empty for a calibrated world track (its clocks are
        :attr:`offsets_s`).
    sync : dict
        View -> how its t = 0 was found (``"sync_frame 12"``, ``"release"``,
        ``"shared x"``, ``"first usable frame"``; calibrated: ``"reference"``,
        ``"reprojection (+3.45 frames against cam1)"``).
    reference : str
        The view whose frames are the rows.
    kind : {"orthogonal", "calibrated"}
        The reconstruction that made it (:data:`KINDS`).
    x_rms_m, x_rms_px : float or None
        RMS disagreement of the shared X between the orthogonal views (None with one
        view, no overlap, or calibrated cameras); in px of the coarser view.
    x_points : int
        Points in that comparison (0 when not made).
    warnings : tuple of str
        Disagreement beyond the pixel scale, missing releases, a calibration that
        disagrees with its points, and the like.
    tracks : dict of str to vidtrack.track.tracker.Track or None
        The views' tracks as reconstructed (orthogonal: frames before each view's t = 0
        flagged PRE_RELEASE, the release carried over to a view that had none of its
        own). None when read back from a file.
    shared_x : vidtrack.world.shared_x.SharedScale or None
        The orthogonal views' relative scale and offset measured on the shared X, and
        whether their scales were reconciled; None when not measured (one view,
        calibrated cameras, or :func:`vidtrack.world.orthogonal.merge_tracks` alone).
    offsets_s : dict
        Calibrated only (empty otherwise): view -> its clock's offset (s), the view's
        frame f at f / fps - offset before the first triangulated row's time is
        subtracted.
    rotation : numpy.ndarray, shape (3, 3), or None
        Calibrated only: rows are the throw frame's X, Y, Z axes in the calibration's
        frame.
    forward_from : str or None
        Calibrated only: where X came from (``"given"``, ``"initial velocity"``,
        ``"displacement"``, ``"none"``).
    median_reprojection_px, flag_threshold_px : float or None
        Calibrated only: the median reprojection distance over every view and unflagged
        row, and the distance beyond which a row is flagged.
    rod : dict or None
        Calibrated only: the rod correction's settings (``taper``, ``length_m``,
        ``radius_m``, ...); None when none was made or asked for.
    """

    data: pd.DataFrame
    t0_s: dict
    sync: dict
    reference: str
    kind: str = "orthogonal"
    x_rms_m: float | None = None
    x_rms_px: float | None = None
    x_points: int = 0
    warnings: tuple = ()
    tracks: dict | None = None
    shared_x: object | None = None
    offsets_s: dict = field(default_factory=dict)
    rotation: np.ndarray | None = None
    forward_from: str | None = None
    median_reprojection_px: float | None = None
    flag_threshold_px: float | None = None
    rod: dict | None = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")

    @property
    def calibrated(self):
        """True for a world track triangulated from calibrated cameras."""
        return self.kind == "calibrated"

    def __repr__(self):
        if self.calibrated:
            ok = int(np.count_nonzero(self.data["flags"].to_numpy() == 0))
            return (f"WorldTrack(kind='calibrated', rows={len(self.data)}, unflagged={ok}, "
                    f"reference={self.reference!r}, "
                    f"median_reprojection_px={self.median_reprojection_px:.3g})")
        x = "" if self.x_rms_m is None else f", x_rms_mm={1000 * self.x_rms_m:.3g}"
        return (f"WorldTrack(rows={len(self.data)}, reference={self.reference!r}, "
                f"views={', '.join(self.t0_s)}, measured x/y/z={self._measured_text()}"
                f"{x}, warnings={len(self.warnings)})")

    def _measured_text(self):
        return "/".join(str(int(np.count_nonzero(np.isfinite(self.data[f"{a}_m"]))))
                        if f"{a}_m" in self.data else "0" for a in _AXES)

    def to_dict(self):
        """A JSON-ready summary (not the rows): fit.json's ``world``."""
        if self.calibrated:
            return self._calibrated_dict()
        return {"rows": int(len(self.data)), "t0_s": dict(self.t0_s), "sync": dict(self.sync),
                "reference": self.reference, "x_rms_m": self.x_rms_m,
                "x_rms_px": self.x_rms_px, "x_points": int(self.x_points),
                "measured": {a: int(np.count_nonzero(np.isfinite(self.data[f"{a}_m"])))
                             for a in _AXES},
                "warnings": list(self.warnings),
                **({"shared_x": self.shared_x.to_dict()} if self.shared_x is not None
                   else {}), **self._attitude_dict()}

    def _attitude_dict(self):
        from vidtrack.world.attitude import attitude_summary

        summary = attitude_summary(self.data)
        return {} if summary is None else {"attitude": summary}

    def _calibrated_dict(self):
        flags = self.data["flags"].to_numpy()
        return {"rows": int(len(self.data)), "reference": self.reference,
                "flagged": int(np.count_nonzero(flags)),
                "offsets_s": {k: float(v) for k, v in self.offsets_s.items()},
                "sync": dict(self.sync), "rotation": np.asarray(self.rotation).tolist(),
                "forward_from": self.forward_from,
                "median_reprojection_px": float(self.median_reprojection_px),
                "flag_threshold_px": float(self.flag_threshold_px),
                "warnings": list(self.warnings),
                **({"rod_correction": rc} if (rc := self.rod_summary()) else {}),
                **self._attitude_dict()}

    def rod_summary(self):
        """The rod correction in numbers, or None where none was made: ``rows_corrected``
        and ``rows_not_corrected`` (triangulated rows whose axis was not determined),
        ``median_px`` and ``max_px`` (the views' corrections' lengths), per view
        ``median_px_<view>``; with the settings (:attr:`rod`) when known."""
        cols = [c for c in self.data.columns if c.startswith("rod_shift_px_")]
        if not cols:
            return None
        shifts = self.data[cols].to_numpy(dtype=np.float64)
        done = np.isfinite(shifts).any(axis=1)
        vals = shifts[np.isfinite(shifts)]
        out = {**(self.rod or {}), "rows_corrected": int(done.sum()),
               "rows_not_corrected": int((~done).sum()),
               "median_px": float(np.median(vals)) if vals.size else None,
               "max_px": float(np.max(vals)) if vals.size else None}
        for c in cols:
            v = self.data[c].to_numpy(dtype=np.float64)
            v = v[np.isfinite(v)]
            out[f"median_px_{c[len('rod_shift_px_'):]}"] = float(np.median(v)) if v.size \
                else None
        return out

    def mappings(self, mappings):
        """The views' mappings as this world track was merged with: ``mappings`` (the
        scene's) with the scales moved where the views were reconciled."""
        if self.shared_x is None or not self.shared_x.reconciled:
            return dict(mappings)
        return self.shared_x.mappings(mappings)
