"""What :func:`vidtrack.run.pipeline.fit_run` returns: :class:`RunFit`, one run's fit.

k1..k4 as pandas objects (``params``, ``bse``, ``conf_int()``), a ``summary()`` (and the
tables a notebook shows), the tracks and the world track as DataFrames with a ``frame``
column (read from the run's tracks.h5 when first asked for), and ``to_dict()``: what
fit.json holds. As a read-only mapping it is the record ``fit_run`` always returned
(fit.json's fields, with ``stages_reused`` and ``fitted_at`` as this call found them),
so ``fit["coefficients"]["k1"]["value"]`` keeps working.

>>> from vidtrack import fit_run                                   # doctest: +SKIP
>>> fit = fit_run("datasets/run42")                                # doctest: +SKIP
>>> fit.params                                                     # doctest: +SKIP
coefficient
k1     2.201
...
>>> fit.tracks["front"].head()        # frame, t_s, u_px, v_px, ..., flags  # doctest: +SKIP
>>> fit.world.head()                  # frame, t_s, x_m, y_m, z_m          # doctest: +SKIP
"""

import copy
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

from fits._text import HtmlSummary

from vidtrack.errors import FitError

__all__ = ["RunFit", "K_NAMES"]

#: The coefficients of fit.json, in order.
K_NAMES = ("k1", "k2", "k3", "k4")


@dataclass(frozen=True, eq=False, repr=False)
class RunFit(HtmlSummary, Mapping):
    """One run's fit: k1..k4 with their errors, the tracks it rests on, fit.json.

    Attributes
    ----------
    record : dict
        The run's record, what the mapping reads: fit.json's fields, with
        ``stages_reused`` (``["tracks", "fit"]`` when nothing was computed again) and
        ``fitted_at`` as this call found them.
    fit_json : dict
        fit.json as written (:meth:`to_dict` gives a copy).
    folder : pathlib.Path
        The run's output folder (``<run>/vidtrack``, or ``<run>/vidtrack/<throw>``).
    throws : dict of str to RunFit
        Each throw of a run with ``throws/`` (the run's own k are their mean), in order;
        empty for a run of one throw.
    """

    record: dict
    fit_json: dict
    folder: Path
    throws: dict = field(default_factory=dict)

    @classmethod
    def of(cls, record, folder, throws=None):
        """The result of a run whose outputs are in ``folder`` (its fit.json read now)."""
        folder = Path(folder)
        try:
            saved = json.loads((folder / "fit.json").read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise FitError(f"{folder / 'fit.json'}: cannot be read back ({exc})") from None
        return cls(record=record, fit_json=saved, folder=folder, throws=dict(throws or {}))

    # ---------------------------------------------------------------- the old record
    def __getitem__(self, key):
        return self.record[key]

    def __iter__(self):
        return iter(self.record)

    def __len__(self):
        return len(self.record)

    def to_dict(self):
        """What fit.json holds (a copy; docs/fit-outputs.md describes every field).

        Returns
        -------
        dict
        """
        return copy.deepcopy(self.fit_json)

    # ---------------------------------------------------------------- k1..k4
    @property
    def run(self):
        """The run's name (fit.json ``run``)."""
        return self.record["run"]

    def _coefficient_series(self, field_name, name):
        import numpy as np
        import pandas as pd

        coeffs = self.record["coefficients"]
        s = pd.Series({k: (coeffs[k][field_name] if coeffs[k]["determined"]
                           and coeffs[k][field_name] is not None else np.nan)
                       for k in K_NAMES}, name=name, dtype=float)
        s.index.name = "coefficient"
        return s

    @property
    def params(self):
        """k1..k4 as a Series (NaN where not determined), like statsmodels' ``params``.

        Returns
        -------
        pandas.Series
            Indexed ``k1`` .. ``k4``, named ``value``.
        """
        return self._coefficient_series("value", "value")

    @property
    def bse(self):
        """Standard errors of k1..k4 as a Series (NaN where not determined): fit.json's
        ``stderr``, of fit and calibration together where the calibration's part is known.

        Returns
        -------
        pandas.Series
            Indexed ``k1`` .. ``k4``, named ``stderr``.
        """
        return self._coefficient_series("stderr", "stderr")

    def conf_int(self, alpha=0.05):
        """The 95 % intervals of k1..k4 that fit.json holds (NaN where not determined).

        Parameters
        ----------
        alpha : float, default 0.05
            1 - the confidence level. fit.json keeps the 95 % interval only (a
            t-quantile or bootstrap interval, widened by the calibration's part where it
            is known); for another level fit the world track with
            :func:`fits.lsq.fit_throw` and use :meth:`fits.lsq_results.ThrowFit.conf_int`.

        Returns
        -------
        pandas.DataFrame
            Indexed ``k1`` .. ``k4``, columns ``lower`` and ``upper``.

        Raises
        ------
        FitError
            ``alpha`` other than 0.05.
        """
        import numpy as np
        import pandas as pd

        if not (isinstance(alpha, (int, float)) and math.isclose(alpha, 0.05)):
            raise FitError(f"alpha must be 0.05: fit.json keeps the 95 % intervals, got "
                           f"{alpha!r} (fits.lsq.fit_throw gives a ThrowFit with any level)")
        coeffs = self.record["coefficients"]
        rows = {k: (tuple(coeffs[k]["ci95"]) if coeffs[k]["determined"] and coeffs[k]["ci95"]
                    else (np.nan, np.nan)) for k in K_NAMES}
        out = pd.DataFrame.from_dict(rows, orient="index", columns=["lower", "upper"])
        out.index.name = "coefficient"
        return out

    # ---------------------------------------------------------------- the tracks
    @cached_property
    def _tracks_file(self):
        from vidtrack.run.tracks_file import read_tracks

        if self.throws:
            raise FitError(f"{self.run}: a run of {len(self.throws)} throws has tracks per "
                           f"throw: .throws[{next(iter(self.throws))!r}].tracks")
        return read_tracks(self.folder / "tracks.h5")

    @property
    def tracks(self):
        """Each view's track as a DataFrame (read from tracks.h5 when first asked for).

        Returns
        -------
        dict of str to pandas.DataFrame
            :attr:`vidtrack.track.tracker.Track.data` of each view: ``frame`` (0-based
            file frame), ``t_s``, ``u_px``, ``v_px``, ..., ``flags``
            (:class:`vidtrack.track._flags.TrackFlag` bits).

        Raises
        ------
        FitError
            A run with throws (its tracks are its throws': ``throws[name].tracks``).
        """
        return {v: tr.data.copy() for v, tr in self._tracks_file.tracks.items()}

    @property
    def world(self):
        """The world track as a DataFrame: ``frame`` (the reference view's file frame),
        ``t_s`` (s since the release), ``x_m``, ``y_m``, ``z_m``; more columns for
        calibrated cameras (:attr:`vidtrack.world.world_track.WorldTrack.data`).

        Raises
        ------
        FitError
            A run with throws (``throws[name].world``).
        """
        return self._tracks_file.world.data.copy()

    # ---------------------------------------------------------------- text
    def _report(self):
        from fits._text import Report, Table
        from fits.lsq_results import coefficient_rows

        r = self.record
        throws = f"; mean over {r['throws']} throws" if r.get("throws", 1) > 1 else ""
        cp = r.get("cp_s_per_m")
        head = (f"Run {r['run']}: {r['model']}, Cp = "
                f"{'n/a' if cp is None else f'{cp:g}'} s/m{throws}")
        rms = r.get("residual_rms_m") or {}
        pts = r.get("points") or {}
        axes = [[a, pts.get(a, 0),
                 "" if rms.get(a) is None else f"{1000 * rms[a]:.3g}"] for a in "xyz"]
        reused = ("Reused: " + ", ".join(r["stages_reused"])) if r.get("stages_reused") else ""
        parts = [head, f"Outputs: {self.folder}", "",
                 Table(["Coefficient", "Value", "Std err", "95 % interval", "Note"],
                       coefficient_rows(r["coefficients"]), align="lrrrl"),
                 "", Table(["Axis", "Points", "Residual RMS (mm)"], axes, align="lrr")]
        if reused:
            parts += ["", reused]
        return Report(parts)

    def summary(self):
        """The run's fit as text: model, Cp, k1..k4 with standard error and 95 %
        interval (or why not determined), the points and residual RMS per axis.

        Returns
        -------
        str
        """
        return self._report().text()

    def __repr__(self):
        from fits._text import fmt_pm

        coeffs = self.record["coefficients"]
        ks = ", ".join(f"{k}={fmt_pm(coeffs[k]['value'], coeffs[k]['stderr'])}"
                       for k in K_NAMES)
        more = f", throws={len(self.throws)}" if self.throws else ""
        return f"RunFit(run={self.run!r}, {ks}{more})"
