"""The key-by-key checks behind every scene.toml and experiment.toml message (private).

:class:`_Checker` refuses a bad value with a :class:`~vidtrack.errors.SceneError` that
names the file, the key and what was expected, in one line::

    runs/07/scene.toml: views.front.fps must be > 0, got 0

``_show`` and ``_type_name`` quote the value in such messages. Shared by both readers
too: ``_read_toml`` (a file that cannot be read, is not UTF-8 or not TOML, as a
SceneError), ``_resolve`` (a path against the run folder) and ``_canonical_hash``
(sha256 of content as sorted JSON, the ``hash`` of a Scene or an Experiment).
"""

import difflib
import hashlib
import json
import math
import re
import tomllib
from pathlib import Path

from vidtrack.errors import SceneError


#: Largest image coordinate (px) a scene may give: an origin, a ruler's end, a target
#: or a manual point. Beyond it squares and products overflow float64's reach in the
#: geometry; no camera has a frame a million pixels wide.
MAX_ABS_PX = 1e6


def _show(value):
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, (list, dict)):
        return json.dumps(value, default=str)
    return repr(value)


def _type_name(value):
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
            list: "an array", dict: "a table"}.get(type(value), type(value).__name__)


class _Checker:
    """Validation helpers that raise SceneError with the file label and key path."""

    def __init__(self, label):
        self.label = label

    def fail(self, key, message):
        where = f"{key} " if key else ""
        raise SceneError(f"{self.label}: {where}{message}")

    def keys(self, table, allowed, path):
        for key in table:
            if key not in allowed:
                near = difflib.get_close_matches(key, allowed, n=1)
                hint = f" (did you mean {near[0]!r}?)" if near else ""
                full = f"{path}.{key}" if path else key
                self.fail(full, f"is not a known key{hint}; expected one of: "
                          + ", ".join(allowed))

    def table(self, data, key, path, *, required=False):
        if key not in data:
            if required:
                self.fail(path, "is required")
            return None
        value = data[key]
        if not isinstance(value, dict):
            self.fail(path, f"must be a table, got {_type_name(value)} {_show(value)}")
        return value

    def number(self, table, key, path, *, required=False, default=None, gt=None, ge=None,
               within=None, what=None):
        """A finite number (``gt``/``ge`` bounds; ``within`` = (low, high, unit): a
        physically meaningful range, checked after the bounds)."""
        if key not in table:
            if required:
                self.fail(path, f"is required: {what}" if what else "is required")
            return default
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"must be a number, got {_type_name(value)} {_show(value)}")
        if not math.isfinite(value):
            self.fail(path, f"must be a finite number, got {value}")
        if gt is not None and not value > gt:
            self.fail(path, f"must be > {gt}, got {value}")
        if ge is not None and not value >= ge:
            self.fail(path, f"must be >= {ge}, got {value}")
        if within is not None and not within[0] <= value <= within[1]:
            low, high, unit = within
            self.fail(path, f"must be between {low:g} and {high:g} {unit}, got {value}")
        return float(value)

    def string(self, table, key, path, *, required=False, default=None, what=None):
        if key not in table:
            if required:
                self.fail(path, f"is required: {what}" if what else "is required")
            return default
        value = table[key]
        if not isinstance(value, str):
            self.fail(path, f"must be a string, got {_type_name(value)} {_show(value)}")
        if not value.strip():
            self.fail(path, "must not be empty")
        return value

    def choice(self, table, key, path, allowed, *, default):
        """One of the strings ``allowed`` (``default`` when the key is absent)."""
        if key not in table:
            return default
        value = table[key]
        if isinstance(value, str) and value in allowed:
            return value
        near = (difflib.get_close_matches(value.lower(), allowed, n=1)
                if isinstance(value, str) else [])
        hint = f" (did you mean {near[0]!r}?)" if near else ""
        self.fail(path, "must be one of " + ", ".join(f'"{a}"' for a in allowed)
                  + f", got {_type_name(value)} {_show(value)}{hint}")

    def pair(self, table, key, path, *, required=False, what="[u, v] in pixels"):
        if key not in table:
            if required:
                self.fail(path, f"is required: two numbers {what}")
            return None
        value = table[key]
        if not isinstance(value, list) or len(value) != 2 or any(
                isinstance(v, bool) or not isinstance(v, (int, float)) for v in value):
            self.fail(path, f"must be two numbers {what}, got {_show(value)}")
        if not all(math.isfinite(v) for v in value):
            self.fail(path, f"must be two finite numbers {what}, got {_show(value)}")
        if any(abs(v) > MAX_ABS_PX for v in value):
            self.fail(path, f"must be within +-{MAX_ABS_PX:g} px (an image position; "
                      f"larger ones overflow the geometry), got {_show(value)}")
        return (float(value[0]), float(value[1]))


def _resolve(folder, text):
    p = Path(text)
    return p if p.is_absolute() else Path(folder) / p


def _read_toml(path):
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise SceneError(f"{path}: cannot read ({exc.strerror or exc})") from None
    try:
        return tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: {_toml_problem(raw.decode('utf-8'), exc)}") from None


def _toml_problem(text, exc):
    """What a TOMLDecodeError means, naming the key or table given twice."""
    message = str(exc)
    at = re.search(r"\(at line (\d+), column \d+\)", message)
    line = int(at.group(1)) if at else None
    if line is not None and "Cannot overwrite a value" in message:
        key = _key_at(text, line)
        if key:
            return (f"{key} is given twice (line {line}); expected each key once "
                    "(TOML does not allow a key twice in a table)")
    twice = re.search(r"Cannot declare \(([^)]*)\) twice", message)
    if twice and line is not None:
        name = ".".join(re.findall(r"'([^']*)'", twice.group(1)))
        return (f"the table [{name}] is declared twice (line {line}); expected each table "
                "once (put its keys together)")
    return f"not valid TOML: {message}"


def _key_at(text, line):
    """The full dotted name of the key set on 1-based ``line`` (its table's name first)."""
    lines = text.splitlines()
    if not 0 < line <= len(lines):
        return None
    m = re.match(r"\s*([A-Za-z0-9_\-.\"' ]+?)\s*=", lines[line - 1])
    if not m:
        return None
    table = ""
    for previous in reversed(lines[:line - 1]):
        head = re.match(r"\s*\[+\s*([^\]]+?)\s*\]+", previous)
        if head:
            table = head.group(1)
            break
    key = m.group(1).strip()
    return f"{table}.{key}" if table else key


def _canonical_hash(obj):
    text = json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()
