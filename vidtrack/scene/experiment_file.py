"""An experiment folder's ``experiment.toml``: :func:`load_experiment` and what it gives.

:func:`load_experiment` reads and validates the file (schema 1: the design, the responses,
the glob of the run folders, the factors and their coding) into a frozen
:class:`Experiment` of :class:`Factor`, with the same key-by-key messages as scene.toml.
The analysis over the runs is :mod:`vidtrack.experiment`.
"""

import dataclasses
import errno
import os
from dataclasses import dataclass, field
from pathlib import Path

from vidtrack.errors import SceneError
from vidtrack.scene._check import _canonical_hash, _Checker, _read_toml, _show
from vidtrack.scene.folders import _natural_key
from vidtrack.scene.model import MAX_ABS_FACTOR, SCENE_FILE, SCHEMA

EXPERIMENT_FILE = "experiment.toml"


@dataclass(frozen=True)
class Factor:
    """One factor of an experiment: coded = (natural - centre) / step."""

    letter: str
    name: str
    centre: float | None = None
    step: float | None = None

    def code(self, natural):
        """Coded level of a natural value (needs centre and step)."""
        if self.centre is None or self.step is None:
            raise SceneError(f"factor {self.letter} ({self.name}) has no centre/step to code by")
        return (natural - self.centre) / self.step

    def to_dict(self):
        """The ``[factors.LETTER]`` table."""
        out = {"name": self.name}
        if self.centre is not None:
            out["centre"] = self.centre
        if self.step is not None:
            out["step"] = self.step
        return out


@dataclass(frozen=True)
class Experiment:
    """A validated ``experiment.toml`` (an experiment folder: docs/scene.md).

    Attributes
    ----------
    path, folder : pathlib.Path
        The file and the experiment folder.
    design : str
        ``"ccd"`` (central composite) or ``"orthogonal"`` (orthogonal array).
    responses : tuple of str
        Responses to analyse (``"k1"`` ...).
    runs : str
        Glob of the run folders, relative to the experiment folder.
    factors : dict of str to Factor
        By letter (``"A"``, ``"B"``, ...), in the file's order.
    hash : str
        sha256 of the canonical content.
    """

    path: Path
    folder: Path
    design: str
    responses: tuple
    runs: str
    factors: dict
    hash: str = field(default="", compare=False)

    def run_dirs(self):
        """The run folders the ``runs`` glob matches, in natural order (2 before 10).

        Raises
        ------
        SceneError
            The glob matches no folder, a link that leads nowhere (dangling or a loop),
            or a matched folder has no scene.toml.
        """
        matched = list(self.folder.glob(self.runs))
        for p in matched:
            if p.is_symlink() and not p.exists():
                target = os.readlink(p)
                why = ("which leads back to itself (a loop)" if _loops(p) else
                       "which does not exist")
                raise SceneError(f"{self.path}: runs = {self.runs!r} matches {p}, a link to "
                                 f"{target}, {why}; expected every run folder there to be "
                                 "a folder (or a link to one)")
        found = sorted((p for p in matched if p.is_dir()),
                       key=lambda p: _natural_key(str(p.relative_to(self.folder))))
        if not found:
            raise SceneError(f"{self.path}: runs = {self.runs!r} matches no run folder "
                             f"in {self.folder}")
        for p in found:
            if not (p / SCENE_FILE).is_file():
                raise SceneError(f"{self.path}: run folder {p} (matched by runs = "
                                 f"{self.runs!r}) has no {SCENE_FILE}")
        return found

    def to_dict(self):
        """The experiment as a schema-1 dict."""
        return {"schema": SCHEMA, "design": self.design, "responses": list(self.responses),
                "runs": self.runs,
                "factors": {k: f.to_dict() for k, f in self.factors.items()}}


def _loops(path):
    try:
        Path(path).resolve(strict=True)
    except RuntimeError:
        return True
    except OSError as exc:
        return exc.errno == errno.ELOOP
    return False


def load_experiment(exp_dir):
    """Read and validate an experiment folder's ``experiment.toml``.

    Parameters
    ----------
    exp_dir : str or pathlib.Path
        The experiment folder, or the ``experiment.toml`` file.

    Returns
    -------
    Experiment

    Raises
    ------
    SceneError
        Missing file, invalid TOML, unknown or missing keys, bad values (named with
        the file and key).

    Notes
    -----
    Keys (schema 1): ``schema``; ``design`` = ``"ccd"`` or ``"orthogonal"``;
    ``responses`` (non-empty list of distinct names); ``runs`` (glob of run folders,
    default ``"runs/*"``); ``[factors.LETTER]`` with ``name`` and, for ``ccd``
    (required there), ``centre`` and ``step`` (> 0): coded = (natural - centre) / step
    (Chen 2018, Table 1).
    """
    p = Path(exp_dir)
    if p.is_dir():
        path = p / EXPERIMENT_FILE
        if not path.is_file():
            raise SceneError(f"{p}: no {EXPERIMENT_FILE} in this experiment folder")
    elif p.exists():
        path = p
    else:
        raise SceneError(f"{p}: no such experiment folder or file")
    data = _read_toml(path)
    ck = _Checker(str(path))
    ck.keys(data, ("schema", "design", "responses", "runs", "factors"), "")
    if "schema" not in data:
        ck.fail("schema", f"is required: write schema = {SCHEMA} as the first line")
    if isinstance(data["schema"], bool) or data["schema"] != SCHEMA:
        ck.fail("schema", f"must be {SCHEMA}, got {_show(data['schema'])}")
    design = ck.string(data, "design", "design", required=True)
    if design not in ("ccd", "orthogonal"):
        ck.fail("design", f"must be \"ccd\" or \"orthogonal\", got {_show(design)}")
    if "responses" not in data:
        ck.fail("responses", "is required: a list like [\"k1\", \"k2\", \"k3\", \"k4\"]")
    resp = data["responses"]
    if not isinstance(resp, list) or not resp or any(
            not isinstance(r, str) or not r.strip() for r in resp):
        ck.fail("responses", f"must be a non-empty list of names, got {_show(resp)}")
    if len(set(resp)) != len(resp):
        dup = next(r for r in resp if resp.count(r) > 1)
        ck.fail("responses", f"names {dup!r} twice")
    runs = ck.string(data, "runs", "runs", default="runs/*")
    if Path(runs).is_absolute() or ".." in Path(runs).parts:
        ck.fail("runs", f"must be a glob inside the experiment folder, got {_show(runs)}")
    ftable = ck.table(data, "factors", "factors", required=design == "ccd")
    factors = {}
    for letter, f in (ftable or {}).items():
        fp = f"factors.{letter}"
        if not isinstance(f, dict):
            ck.fail(fp, f"must be a table with name, centre, step, got {_show(f)}")
        ck.keys(f, ("name", "centre", "step"), fp)
        need = design == "ccd"
        factors[letter] = Factor(
            letter=letter, name=ck.string(f, "name", f"{fp}.name", required=True),
            centre=ck.number(f, "centre", f"{fp}.centre", required=need,
                             within=(-MAX_ABS_FACTOR, MAX_ABS_FACTOR, "(natural units)")),
            step=ck.number(f, "step", f"{fp}.step", required=need, gt=0,
                           within=(1 / MAX_ABS_FACTOR, MAX_ABS_FACTOR, "(natural units)")))
    if design == "ccd" and not factors:
        ck.fail("factors", "must name at least one factor for a ccd design")
    names = [f.name for f in factors.values()]
    for n in names:
        if names.count(n) > 1:
            ck.fail("factors", f"name {n!r} is used by two factors")
    exp = Experiment(path=path, folder=path.parent, design=design, responses=tuple(resp),
                     runs=runs, factors=factors)
    return dataclasses.replace(exp, hash=_canonical_hash(exp.to_dict()))
