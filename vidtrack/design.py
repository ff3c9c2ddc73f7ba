"""A designed experiment laid out as an experiment folder (``vidtrack design``).

:func:`write_design` takes a :class:`fits.design.Design` (a central composite design or an
orthogonal array, from :func:`fits.design.central_composite` or
:func:`fits.design.orthogonal_design`) and writes::

    OUT/
      design.csv          the run sheet in run order: run (the run folder's name),
                          run_order, std_order, point, coded levels (A, B, ...), natural
                          levels (n_rpm, ...)
      design.json         what made it: design, factors, alpha or array and columns, seed
      experiment.toml     schema 1 (docs/scene.md): design, responses, runs = "runs/*",
                          [factors.A] name, centre, step
      runs/01/scene.toml  one run folder per row, numbered in run order, its setting in
      runs/02/scene.toml  [factors] (where `vidtrack report` reads it), no views yet
      ...

The folder appears whole or not at all: everything is written into a hidden staging
folder beside OUT, read back (experiment.toml through
:func:`vidtrack.scene.load_experiment`), then renamed to OUT.
"""

import contextlib
import json
import os
import shutil
import tempfile
import textwrap
from dataclasses import dataclass
from pathlib import Path

from vidtrack._atomic import _umask, check_output, disk_full
from vidtrack.errors import VidtrackError

__all__ = ["write_design", "DesignFolder", "RESPONSES", "DESIGN_CSV", "DESIGN_JSON"]

#: The responses experiment.toml names (what each run's fit.json gives).
RESPONSES = ("k1", "k2", "k3", "k4")
DESIGN_CSV = "design.csv"
DESIGN_JSON = "design.json"
RUNS = "runs"
#: Digits a number keeps in design.csv (natural levels are already rounded to 12).
CSV_FLOAT_FORMAT = "%.12g"


@dataclass(frozen=True)
class DesignFolder:
    """What :func:`write_design` wrote.

    Attributes
    ----------
    folder : pathlib.Path
        The experiment folder (OUT).
    run_dirs : tuple of pathlib.Path
        The run folders, in run order.
    sheet : pandas.DataFrame
        design.csv's content.
    """

    folder: Path
    run_dirs: tuple
    sheet: object

    def to_dict(self):
        return {"folder": str(self.folder), "design_csv": str(self.folder / DESIGN_CSV),
                "experiment_toml": str(self.folder / "experiment.toml"),
                "runs": [str(p) for p in self.run_dirs]}


def check_design_output(out):
    """Refuse OUT before anything is computed: it must be new or an empty folder.

    Raises
    ------
    VidtrackError
        OUT is a file, a folder that is not empty, or cannot be written.
    """
    out = Path(out)
    if out.is_dir() and any(out.iterdir()):
        raise VidtrackError(f"{out}: exists and is not empty; expected a new or empty folder "
                            "for the experiment (a design is never written over one)")
    check_output(out, label=str(out), folder=True)


def _toml_string(text):
    return json.dumps(str(text), ensure_ascii=False)


def _number(v):
    v = float(v)
    return str(int(v)) if v.is_integer() and abs(v) < 2 ** 53 else repr(v)


def experiment_text(design, *, responses=RESPONSES):
    """The experiment.toml of a design (schema 1), with a comment on how it was made."""
    if design.kind == "ccd":
        how = (f"central composite design, {len(design.factors)} factors, alpha = "
               f"{design.alpha:.6g}, {design.centre_points} centre points")
    else:
        cols = ", ".join(f"{f.name} on column {design.columns[f.letter]}"
                         for f in design.factors)
        how = f"orthogonal array {design.array}: {cols}"
    seed = "" if design.seed is None else f", run order from seed {design.seed}"
    about = textwrap.wrap(f"Written by `vidtrack design`: {how}; {len(design.table)} "
                          f"runs{seed}. The run sheet is design.csv; runs/NN/scene.toml "
                          "holds each run's setting.", width=86)
    lines = [*(f"# {t}" for t in about),
             "schema = 1",
             f"design = {_toml_string(design.kind)}",
             f"responses = [{', '.join(_toml_string(r) for r in responses)}]",
             f"runs = {_toml_string(RUNS + '/*')}"]
    for f in design.factors:
        lines += ["", f"[factors.{f.letter}]", f"name = {_toml_string(f.name)}"]
        if design.kind == "ccd":
            lines += [f"centre = {_number(f.centre)}", f"step = {_number(f.step)}"]
    return "\n".join(lines) + "\n"


def _about(design, row, n):
    coded = ", ".join(f"{f.letter} = {row[f.letter]:.6g}" for f in design.factors)
    what = (f"a {row['point']} point" if design.kind == "ccd"
            else f"row {row['std_order']} of {design.array}")
    return [f"Run {row['run']}, {row['run_order']} of {n} in run order; standard order "
            f"{row['std_order']}, {what}.", f"Coded levels: {coded}."]


def _write_all(stage, design, sheet, responses):
    from vidtrack.scene_template import plan_scene_text

    sheet.to_csv(stage / DESIGN_CSV, index=False, float_format=CSV_FLOAT_FORMAT)
    (stage / DESIGN_JSON).write_text(json.dumps(design.to_dict(), indent=2) + "\n",
                                     encoding="utf-8")
    (stage / "experiment.toml").write_text(experiment_text(design, responses=responses),
                                           encoding="utf-8")
    runs = stage / RUNS
    runs.mkdir()
    n = len(sheet)
    for _, row in sheet.iterrows():
        d = runs / row["run"]
        d.mkdir()
        factors = {f.name: float(row[f.name]) for f in design.factors}
        text = plan_scene_text(factors, folder=d, about=_about(design, row, n))
        (d / "scene.toml").write_text(text, encoding="utf-8")


def write_design(out, design, *, responses=RESPONSES):
    """Write a design's run sheet and its experiment folder.

    Parameters
    ----------
    out : str or os.PathLike
        The experiment folder to create (new, or an empty folder).
    design : fits.design.Design
    responses : sequence of str, keyword-only
        experiment.toml's responses (default k1..k4).

    Returns
    -------
    DesignFolder

    Raises
    ------
    VidtrackError
        OUT is a file or a folder that is not empty, or cannot be written (nothing is
        written then); a full disk (:class:`~vidtrack.errors.DiskFullError`, nothing
        kept).

    Notes
    -----
    Run folders are numbered in run order with at least two digits (``runs/01`` is the
    first run to perform); design.csv's ``run`` column names them.
    """
    from vidtrack.scene import load_experiment

    out = Path(out)
    check_design_output(out)
    sheet = design.run_sheet()
    width = max(2, len(str(len(sheet))))
    sheet.insert(0, "run", [f"{i:0{width}d}" for i in sheet["run_order"]])
    out.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".part", dir=out.parent))
    try:
        os.chmod(stage, 0o777 & ~_umask())      # an ordinary folder, not mkdtemp's 0700
        _write_all(stage, design, sheet, responses)
        exp = load_experiment(stage)            # what is written is what the reader reads
        found = exp.run_dirs()
        if len(found) != len(sheet):
            raise VidtrackError(f"internal: {len(found)} run folders written for "
                                f"{len(sheet)} runs")
        if out.is_dir() and any(out.iterdir()):  # filled meanwhile: never written over
            raise VidtrackError(f"{out}: exists and is not empty; expected a new or empty "
                                "folder for the experiment")
        os.replace(stage, out)                  # onto a new name or an empty folder
    except BaseException as exc:
        with contextlib.suppress(OSError):
            shutil.rmtree(stage)
        full = disk_full(exc, out)
        if full is not None:
            raise full from exc
        raise
    return DesignFolder(folder=out, run_dirs=tuple(out / RUNS / r for r in sheet["run"]),
                        sheet=sheet)
