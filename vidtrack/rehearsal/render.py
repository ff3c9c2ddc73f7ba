"""Render every run of a designed experiment at known k (``vidtrack synth EXP --regression``).

:func:`render_experiment` reads an experiment folder (``vidtrack design`` wrote it), takes
each run's k1..k4 from regression equations or a k table at the run's setting
(:mod:`vidtrack.rehearsal.equations`), and renders the run into its folder with
:func:`vidtrack.synth.render_run`: footage, scene.toml (the run's ``[factors]`` kept)
and truth.json. Each throw's k is drawn about the setting's k with a relative standard
deviation per k (``k_spread``), from a seed of its own per run derived from one seed,
so the same command renders the same experiment.

Every run folder is checked before the first is rendered: it holds only the scene.toml
``vidtrack design`` planned, or (with ``force``) a synthetic run rendered before. Each run
appears whole or not at all; an interrupted rehearsal leaves the runs rendered so far
and is run again with ``force``.
"""

import dataclasses
import logging
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vidtrack.rehearsal.equations import RESPONSES, k_of_runs, run_settings

__all__ = ["DEFAULT_K_SPREAD", "SPEC_FACTORS", "RenderedRun", "Rehearsal", "run_spec",
           "render_experiment"]

log = logging.getLogger(__name__)

#: The relative standard deviation of each throw's k about its setting's k, per k,
#: unless told (the spread synth gives replicate throws' k by default).
DEFAULT_K_SPREAD = (0.03, 0.03, 0.03, 0.03)
#: Factors that are SynthSpec fields too: a run's setting of them goes into its render
#: (speed_kmh is the machine's speed in the footage; n_rpm, blade_angle_deg are recorded).
SPEC_FACTORS = ("n_rpm", "blade_angle_deg", "speed_kmh")


@dataclass(frozen=True)
class RenderedRun:
    """One run of a rehearsal: its folder, setting, the setting's k, throws and seed."""

    name: str
    folder: Path
    factors: dict
    k: tuple
    throws: int
    seed: int

    def to_dict(self):
        return {"run": self.name, "folder": str(self.folder), "factors": dict(self.factors),
                "k": dict(zip(RESPONSES, self.k)), "throws": self.throws, "seed": self.seed}


@dataclass(frozen=True)
class Rehearsal:
    """What :func:`render_experiment` rendered.

    Attributes
    ----------
    folder : pathlib.Path
        The experiment folder.
    runs : tuple of RenderedRun
        In run order.
    source : str
        Where the k's came from (the equations' or the table's file).
    k_spread : tuple
        Relative standard deviations of the throws' k1..k4 about their setting's.
    elapsed_s : float
    """

    folder: Path
    runs: tuple
    source: str
    k_spread: tuple
    elapsed_s: float

    def __repr__(self):
        return (f"Rehearsal(folder={str(self.folder)!r}, runs={len(self.runs)}, "
                f"throws={sum(r.throws for r in self.runs)}, source={self.source!r})")

    def table(self):
        """A DataFrame: ``run``, the factors (natural), the setting's ``k1`` .. ``k4``."""
        import pandas as pd

        return pd.DataFrame([{"run": r.name, **r.factors, **dict(zip(RESPONSES, r.k))}
                             for r in self.runs])

    def to_dict(self):
        return {"folder": str(self.folder), "source": self.source,
                "k_spread": dict(zip(RESPONSES, self.k_spread)),
                "runs": [r.to_dict() for r in self.runs], "elapsed_s": self.elapsed_s}


def _run_seed(seed, index):
    """The seed of the run at ``index``: independent streams from one seed."""
    return int(np.random.SeedSequence([int(seed), int(index)]).generate_state(1)[0])


def run_spec(base, setting, k, *, k_spread, seed):
    """The SynthSpec of one run: ``base`` at the run's k, setting and seed.

    The run's factors named as SynthSpec fields (:data:`SPEC_FACTORS`) set them; its run
    name is the folder's (or its scene.toml's ``[run] name``).
    """
    numeric = {n: float(v) for n, v in setting.factors.items()
               if n in SPEC_FACTORS and not isinstance(v, (bool, str))}
    return dataclasses.replace(base, k=tuple(k), k_spread=tuple(k_spread), seed=seed,
                               run_name=setting.name, **numeric)


def _clear_experiment_outputs(folder):
    """Remove what `vidtrack report` and `vidtrack score` computed from the old runs."""
    from vidtrack.experiment import OUTPUTS as REPORT_OUTPUTS
    from vidtrack.rehearsal.score import OUTPUTS as SCORE_OUTPUTS

    for name in (*REPORT_OUTPUTS, *SCORE_OUTPUTS):
        (folder / "vidtrack" / name).unlink(missing_ok=True)


def render_experiment(exp_dir, source, spec=None, *, k_spread=DEFAULT_K_SPREAD, force=False,
                      quiet=True):
    """Render every run of an experiment folder at the k its setting gives.

    Parameters
    ----------
    exp_dir : str or os.PathLike
        The experiment folder (``experiment.toml``, runs from ``vidtrack design``).
    source : KEquations or KTable
        Where each run's k1..k4 come from (:func:`read_equations`, :func:`read_k_table`).
    spec : SynthSpec, optional
        Everything else of the render (views, sizes, flight, noise, throws per run,
        seed): each run gets it with its k, its setting and a seed of its own.
        Equations that name n_rpm, blade_angle_deg or speed_kmh where the design does not
        vary them take the spec's values.
    k_spread : float or sequence of 4 floats, keyword-only
        Relative standard deviation of each throw's k1..k4 about the run's k (0: every
        throw at the run's k).
    force : bool, keyword-only
        Render again over runs rendered before (their footage, truth and results are
        replaced; the experiment's report and score are removed).
    quiet : bool, keyword-only
        No progress bar.

    Returns
    -------
    Rehearsal

    Raises
    ------
    VidtrackError
        A bad experiment folder, a run folder that holds more than its planned
        scene.toml (without ``force``, or not a synthetic run), an equation naming a
        factor the experiment does not have, a k <= 0 at a run, a run missing from a k
        table; all before anything is rendered.
    """
    from vidtrack._progress import progress
    from vidtrack.scene import load_experiment
    from vidtrack.synth import SynthSpec, check_out_dir, render_run

    started = time.perf_counter()
    base = SynthSpec() if spec is None else spec
    spread = tuple(float(v) for v in np.broadcast_to(np.asarray(k_spread, dtype=float), 4))
    experiment = load_experiment(exp_dir)
    settings = run_settings(experiment)
    fixed = {n: float(getattr(base, n)) for n in SPEC_FACTORS}
    ks = k_of_runs(experiment, source, settings, fixed=fixed)
    specs = [run_spec(base, s, k, k_spread=spread, seed=_run_seed(base.seed, i))
             for i, (s, k) in enumerate(zip(settings, ks), start=1)]
    for s, run in zip(settings, specs):
        check_out_dir(s.folder, run, force=force)
    _clear_experiment_outputs(experiment.folder)
    bar = progress(total=len(specs), desc="synth", quiet=quiet, unit="run")
    runs = []
    try:
        for s, k, run in zip(settings, ks, specs):
            log.info("run %s: k = %s", s.folder.name, ", ".join(f"{v:.4g}" for v in k))
            render_run(s.folder, run, force=force, quiet=True, factors=s.factors)
            runs.append(RenderedRun(s.name, s.folder, dict(s.factors), k, run.throws,
                                    run.seed))
            bar.update()
    finally:
        bar.close()
    return Rehearsal(experiment.folder, tuple(runs), source.source, spread,
                     time.perf_counter() - started)
