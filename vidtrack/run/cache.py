"""``stages.json``: what each stage of a run computed, from what, into which files.

Each stage (``views``, ``tracks``, ``fit``) has an entry::

    {"key": "<sha256 of the stage's inputs and settings>",
     "at": "2026-11-22T18:30:05Z",              # when it was computed (UTC)
     "files": {"fit.json": "<sha256 of the file>", "report.md": "...", ...}}

The ``views`` stage (each view's track as the tracker gave it, in views.h5) also keeps
each view's own key, ``"parts": {"front": "<sha256>", ...}``, so that a view whose
tracking reads what it read before is reused while another is tracked again.

A stage is reused only when its key is the one of this run and every file it wrote is
still there with the digest recorded: an output edited, truncated, emptied or replaced
since is never taken for the stage's result. A ``stages.json`` that is not such a
record (unreadable, not JSON, ``[]``, an entry of the wrong shape, or written by an
older vidtrack without digests) counts as no record: the stages are computed again.
:meth:`Stages.check` says why a stage is not reused when the reason is worth a note
(a file changed or went missing), and says nothing when the inputs simply changed.

The file is written whole or not at all (:mod:`vidtrack._atomic`), after the files of
the stage it records.
"""

import hashlib
import json
import os
import stat
import time
from pathlib import Path

from vidtrack._atomic import write_text

__all__ = ["STAGES_FILE", "Stages", "file_digest", "utc_now", "stage_key", "tracker_version",
           "FIT_ALGORITHM", "WORLD_ALGORITHM", "TRACK_ALGORITHM"]

#: Version of the algorithm of each stage (outside the tracker): change it whenever the
#: stage would compute something else from the same inputs and settings, so that no
#: result of the older code is reused. The fit stage: fits.lsq's fit and its record.
FIT_ALGORITHM = "fit-2026.11-5"
#: The world track: the merge of orthogonal views and the triangulation of cameras.
WORLD_ALGORITHM = "world-2026.11-3"
#: The tracker, when vidtrack.track.tracker has no ``ALGORITHM_VERSION`` of its own;
#: the digest of the tracker's source goes with it (:func:`tracker_version`).
TRACK_ALGORITHM = "track-2026.11-1"

STAGES_FILE = "stages.json"
#: Layout of stages.json (1: bare keys, no digests, before vidtrack 0.2.1).
SCHEMA = 2
_STAGES = ("views", "tracks", "fit")


def utc_now():
    """The time now, UTC, to the second, ISO 8601 (``2026-11-22T18:30:05Z``)."""
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())


def file_digest(path):
    """sha256 (hex) of a regular file's bytes; None when it is missing, not a regular
    file (never opened then: a FIFO would block) or unreadable."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return None
        h = hashlib.sha256()
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        return h.hexdigest()
    except OSError:
        return None


def stage_key(stage, *, algorithm, settings=None, inputs=None):
    """The cache key of a stage: sha256 of what computes it and what it computes from.

    Parameters
    ----------
    stage : str
        ``"view"``, ``"views"``, ``"tracks"`` or ``"fit"``.
    algorithm : str or dict
        The version(s) of the code that computes it (:data:`FIT_ALGORITHM`,
        :func:`tracker_version`, ...), never the package's version alone.
    settings : dict, optional
        Every setting that changes its result (the tracker's settings, the model...).
    inputs : dict, optional
        What it reads (the scene's hash, the footage's fingerprints, an earlier
        stage's key).

    Returns
    -------
    str
        64 hex digits; equal keys mean the stage would compute the same.
    """
    text = json.dumps({"stage": stage, "algorithm": algorithm, "settings": settings,
                       "inputs": inputs}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


_TRACKER_DIGEST = None


def tracker_version():
    """The tracker's version for the tracks stage's key.

    ``vidtrack.track.tracker.ALGORITHM_VERSION`` and its ``TrackerSettings`` defaults
    when the tracker has them; else :data:`TRACK_ALGORITHM` with the sha256 of the
    tracker package's source files, so that tracks made by other tracker code are
    never reused (read once per process, a few milliseconds).

    Returns
    -------
    dict
        JSON-able: ``{"algorithm": ..., "source": ..., "defaults": ...}``.
    """
    global _TRACKER_DIGEST
    import dataclasses

    import vidtrack.track.tracker as tracker

    own = getattr(tracker, "ALGORITHM_VERSION", None)
    settings = getattr(tracker, "TrackerSettings", None)
    defaults = None
    if settings is not None and dataclasses.is_dataclass(settings):
        try:
            defaults = dataclasses.asdict(settings())
        except TypeError:            # no defaults for some field
            defaults = None
    if own is not None:
        return {"algorithm": str(own), "defaults": defaults}
    if _TRACKER_DIGEST is None:
        h = hashlib.sha256()
        folder = Path(tracker.__file__).parent
        for path in sorted(folder.rglob("*.py")):
            h.update(path.relative_to(folder).as_posix().encode())
            h.update(path.read_bytes())
        _TRACKER_DIGEST = h.hexdigest()
    return {"algorithm": TRACK_ALGORITHM, "source": _TRACKER_DIGEST, "defaults": defaults}


def _valid_entry(entry):
    return (isinstance(entry, dict) and isinstance(entry.get("key"), str)
            and isinstance(entry.get("files"), dict) and entry["files"]
            and all(isinstance(k, str) and isinstance(v, str)
                    for k, v in entry["files"].items())
            and isinstance(entry.get("at", ""), str)
            and isinstance(entry.get("parts", {}), dict)
            and all(isinstance(v, str) for v in entry.get("parts", {}).values()))


class Stages:
    """The stages.json of one output folder (a run's or a throw's).

    Attributes
    ----------
    folder : pathlib.Path
    entries : dict
        Stage name -> its entry (valid ones only).
    problem : str or None
        Why the file as a whole was not taken as a record (None when it was, or when
        there is none).
    """

    def __init__(self, folder, entries=None, problem=None):
        self.folder = Path(folder)
        self.entries = dict(entries or {})
        self.problem = problem

    @classmethod
    def read(cls, folder):
        """Read ``folder/stages.json``; anything but a valid record is no record."""
        folder = Path(folder)
        path = folder / STAGES_FILE
        try:
            mode = os.stat(path).st_mode
        except FileNotFoundError:
            return cls(folder)
        except OSError as exc:
            return cls(folder, problem=f"{path} cannot be read ({exc.strerror or exc})")
        if not stat.S_ISREG(mode):
            return cls(folder, problem=f"{path} is not a regular file")
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            return cls(folder, problem=f"{path} is not valid JSON ({exc})")
        if not isinstance(data, dict):
            return cls(folder, problem=f"{path} is not a stages record (a JSON "
                                       f"{type(data).__name__}, expected an object)")
        if data.get("schema") != SCHEMA:
            return cls(folder, problem=f"{path} was written by an older vidtrack "
                                       "(no digests of the outputs)")
        entries = {k: v for k, v in data.items() if k in _STAGES and _valid_entry(v)}
        bad = [k for k in _STAGES if k in data and k not in entries]
        return cls(folder, entries,
                   problem=f"{path}: the {', '.join(bad)} entry is malformed" if bad else None)

    def at(self, stage):
        """When ``stage`` was computed (the recorded UTC time), or None."""
        entry = self.entries.get(stage)
        return entry.get("at") if entry else None

    def check(self, stage, key, files):
        """Whether ``stage`` may be reused: its key is ``key`` and each of ``files``
        (names in the folder) is recorded and still has the digest recorded.

        Returns
        -------
        (bool, str or None)
            Reusable, and when not, a reason worth a note (None when the stage simply
            has no record or other inputs).
        """
        entry = self.entries.get(stage)
        if entry is None:                  # no record (a malformed file is said once)
            return False, None
        if entry["key"] != key:
            return False, None
        when = entry.get("at") or "an earlier run"
        for name in files:
            recorded = entry["files"].get(name)
            if recorded is None:
                return False, (f"{name} was not written by the {stage} stage of "
                               f"{when}" if (self.folder / name).exists() else None)
            current = file_digest(self.folder / name)
            if current is None:
                return False, f"{name} (written at {when}) is missing"
            if current != recorded:
                return False, f"{name} changed since it was written at {when}"
        return True, None

    def changed(self, stage, key, name):
        """True when ``stage`` (with key ``key``) recorded ``name`` and the file is there
        with other content (rewritten or edited since, not missing)."""
        entry = self.entries.get(stage)
        if entry is None or entry["key"] != key or name not in entry["files"]:
            return False
        current = file_digest(self.folder / name)
        return current is not None and current != entry["files"][name]

    def file_matches(self, stage, name):
        """True when ``name`` is recorded by ``stage`` and has that digest now."""
        entry = self.entries.get(stage)
        recorded = entry and entry["files"].get(name)
        return bool(recorded) and file_digest(self.folder / name) == recorded

    def parts(self, stage):
        """The keys of ``stage``'s parts as recorded (``{}`` when none)."""
        entry = self.entries.get(stage)
        return dict(entry.get("parts", {})) if entry else {}

    def record(self, stage, key, files, *, at=None, parts=None):
        """Record ``stage`` as computed now from ``key`` into ``files`` (their digests
        taken now), with the keys of its ``parts`` (a dict) when given, and write
        stages.json."""
        self.entries[stage] = {"key": key, "at": at or utc_now(),
                               "files": {n: file_digest(self.folder / n) or "" for n in files}}
        if parts is not None:
            self.entries[stage]["parts"] = dict(parts)
        self.write()

    def drop(self, *stages):
        """Forget ``stages`` (their outputs are being replaced) and write stages.json
        when that changes it."""
        if any(s in self.entries for s in stages) or self.problem:
            for s in stages:
                self.entries.pop(s, None)
            self.write()

    def write(self):
        self.problem = None
        out = {"schema": SCHEMA}
        out.update({s: self.entries[s] for s in _STAGES if s in self.entries})
        write_text(self.folder / STAGES_FILE, json.dumps(out, indent=2) + "\n")
