"""A rehearsal of a designed experiment on synthetic footage, and its score.

A lab rehearses the whole chain before it films: ``vidtrack design`` lays out the runs,
``vidtrack synth EXP --regression EQUATIONS`` renders every run at the k the equations
give at its setting (each throw spread about it), ``vidtrack report EXP`` fits every run
and analyses the table, and ``vidtrack score EXP`` pairs each throw's truth with its fit
and the regression on the fitted k with the one on the true k. The modules:

- ``equations``: k1..k4 per run from regression equations (TOML, CSV, ``vidtrack anova
  --json``, the shipped Chen 2018 eqs. 20-23) or a k table, at each run's setting;
- ``render``: :func:`render_experiment`, every run rendered with ``vidtrack.synth``;
- ``score``: :func:`score_experiment` and :func:`write_score`.

The public names below are importable from ``vidtrack.rehearsal`` itself, each loaded
from its module on first use.
"""

from vidtrack._lazy import lazy_exports

_EXPORTS = {
    "vidtrack.rehearsal.equations": ("KEquations", "KTable", "RunSetting", "read_equations",
                                     "read_k_table", "run_settings", "k_of_runs",
                                     "BUILTIN_EQUATIONS"),
    "vidtrack.rehearsal.render": ("Rehearsal", "RenderedRun", "render_experiment",
                                  "DEFAULT_K_SPREAD"),
    "vidtrack.rehearsal.score": ("RehearsalScore", "score_experiment", "write_score"),
}
__getattr__, __dir__, _NAMES = lazy_exports(__name__, _EXPORTS)

__all__ = ["KEquations", "KTable", "RunSetting", "read_equations", "read_k_table",
           "run_settings", "k_of_runs", "BUILTIN_EQUATIONS", "Rehearsal", "RenderedRun",
           "render_experiment", "DEFAULT_K_SPREAD", "RehearsalScore", "score_experiment",
           "write_score"]
