"""Throw models: closed forms, the ODE reference, the printed forms, 50-digit truth.

- ``fits.throw`` (this package): ``position``, ``velocity``, ``apex``, ``terminal_speed``,
  ``flight_y``, ``flight_drag`` — the stable closed forms (Chen 2018 eqs. 11-18, the
  linear-drag throw of Liao 2021, the drag-free throw), defined in
  ``fits.throw.closed_form``;
- ``fits.throw.jacobian``: ``flight_y_jacobian``, ``flight_drag_jacobian``, the closed
  forms' derivatives with respect to their parameters (the fit's Jacobian);
- ``fits.throw.ode``: ``solve_throw``, the same laws integrated numerically (the reference
  every closed form is tested against);
- ``fits.throw.printed``: ``printed_position``, the paper's equations as printed (for
  comparison only: they break where docs/throw-models.md says);
- ``fits.throw.mp``: ``position_mp``, the textbook solution in 50-digit arithmetic (needs
  mpmath: the ``bench`` extra).
"""

from fits.throw.closed_form import (G_STANDARD, MODELS, Apex, apex, flight_drag, flight_y,
                                    position, terminal_speed, velocity)

__all__ = ["G_STANDARD", "MODELS", "Apex", "apex", "position", "velocity", "terminal_speed",
           "flight_y", "flight_drag"]
