"""Numbers only: throw models, blade release, least squares, response surfaces, ANOVA.

Modules (import what you use; ``import fits`` stays light):

- ``fits.throw``: ``position``, ``velocity``, ``apex``, ``terminal_speed``,
  ``flight_y``, ``flight_drag`` (stable closed forms; Chen 2018 eqs. 11-18, Liao 2021,
  Hou 2019); ``fits.throw.ode.solve_throw`` (the ODE reference);
  ``fits.throw.printed.printed_position`` (the printed forms, for comparison);
  ``fits.throw.mp.position_mp`` (50-digit truth).
- ``fits.blade``: the slide along the blade and the release (eqs. 1-10).
- ``fits.lsq``: ``fit_throw``, ``compare_models`` (least squares of a world track); the
  ``ThrowFit`` they return is defined in ``fits.lsq_results``.
- ``fits.rsm``: ``Factor``, ``fit_rsm``, ``read_table`` (response surfaces, Table 3).
- ``fits.orthogonal``: ``fit_orthogonal`` (Hou 2019 Table 4).
- ``fits.compare``: ``compare``, ``read_published`` (side by side with a paper).
- ``fits.metrics``: the field measures.

This package imports numpy, scipy and pandas; never cv2, never ``vidtrack`` or
``calibration``.

Messages (what was eliminated, what a fit could not determine) are log records under the
``fits`` logger, which has only a ``NullHandler``: configure logging to see them, e.g.
``logging.basicConfig(level=logging.INFO)``.
"""

import logging

from fits.errors import ConvergenceError, InputError

logging.getLogger(__name__).addHandler(logging.NullHandler())

__all__ = ["ConvergenceError", "InputError"]
