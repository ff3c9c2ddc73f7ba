"""Calibration files (TOML, schema 1): a camera, a plane scale, or both.

:class:`CalibrationFile` is a file's content; :func:`calibration_to_toml` writes its
text and :func:`load_calibration` reads and checks it (:func:`parse_calibration` checks
content already parsed). The format is documented in ``docs/calibration.md``.
"""

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from calibration.camera import CameraCalibration
from calibration.errors import InputError
from calibration.scale import Scale, check_m_per_px, ruler_scale

__all__ = [
    "CalibrationFile", "calibration_to_toml", "calibration_to_dict", "load_calibration",
    "parse_calibration", "compact_toml", "CALIBRATION_SCHEMA",
]

#: Version of the calibration file format written and read here.
CALIBRATION_SCHEMA = 1

_DIST_LENGTHS = (4, 5, 8, 12, 14)


@dataclass(frozen=True)
class CalibrationFile:
    """The content of a calibration file: a camera, a plane scale, or both.

    Attributes
    ----------
    camera : CameraCalibration or None
        Intrinsics and distortion (``[camera]``).
    scale : Scale or None
        Metric scale of the throw plane (``[scale]``).
    path : pathlib.Path or None
        The file it was read from.
    """

    camera: CameraCalibration | None = None
    scale: Scale | None = None
    path: Path | None = field(default=None, compare=False)

    def to_dict(self):
        """The file's content as a dict (``schema``, ``[camera]``, ``[scale]``)."""
        return calibration_to_dict(camera=self.camera, scale=self.scale)


def calibration_to_dict(*, camera=None, scale=None):
    """The content of a calibration file (schema 1) as a dict.

    Parameters
    ----------
    camera : CameraCalibration, optional
    scale : Scale, optional
        At least one of the two.

    Returns
    -------
    dict
        ``{"schema": 1, "camera": {...}, "scale": {...}}`` (absent parts left out).
    """
    if camera is None and scale is None:
        raise InputError("a calibration file needs a camera, a scale, or both")
    out = {"schema": CALIBRATION_SCHEMA}
    if scale is not None:
        out["scale"] = scale.to_dict()
    if camera is not None:
        out["camera"] = camera.to_dict()
    return out


_ARRAY_RE = re.compile(r"\[\n((?:[ ]+[^\[\]{}\n]*,\n)+)[ ]*\]")


def compact_toml(text):
    """Put tomli_w's one-item-per-line arrays of plain values on one line.

    The result is checked to parse to the same content; if it would not, the text is
    returned unchanged.
    """
    def join(m):
        items = [line.strip().rstrip(",") for line in m.group(1).splitlines()]
        return "[" + ", ".join(items) + "]"

    compact = _ARRAY_RE.sub(join, text)
    try:
        same = tomllib.loads(compact) == tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        same = False
    return compact if same else text


def calibration_to_toml(*, camera=None, scale=None):
    """A calibration file's text (TOML, schema 1); write it with an atomic writer.

    Parameters
    ----------
    camera : CameraCalibration, optional
    scale : Scale, optional

    Returns
    -------
    str
        TOML text that :func:`load_calibration` reads back to the same values.
    """
    import tomli_w

    head = ("# vidtrack calibration file (schema 1); see docs/calibration.md\n"
            "# [scale]: metres per pixel on the throw plane; [camera]: intrinsics and\n"
            "# distortion (OpenCV model, pixels).\n")
    return head + compact_toml(tomli_w.dumps(calibration_to_dict(camera=camera, scale=scale)))


def _num(d, key, where, *, positive=False, nonneg=False, required=True):
    if key not in d:
        if required:
            raise InputError(f"{where}{key} is required")
        return None
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{where}{key} must be a finite number, got {v!r}")
    if positive and not v > 0:
        raise InputError(f"{where}{key} must be > 0, got {v!r}")
    if nonneg and not v >= 0:
        raise InputError(f"{where}{key} must be >= 0, got {v!r}")
    return float(v)


def _num_list(d, key, where, *, length=None, lengths=None, integer=False, required=True):
    if key not in d:
        if required:
            raise InputError(f"{where}{key} is required")
        return None
    v = d[key]
    want = (f"{length} " if length else "") + ("integers" if integer else "numbers")
    if not isinstance(v, list) or any(isinstance(x, bool) or not isinstance(x, (int, float))
                                      or not math.isfinite(x) for x in v):
        raise InputError(f"{where}{key} must be a list of {want}, got {v!r}")
    if integer and any(not isinstance(x, int) for x in v):
        raise InputError(f"{where}{key} must be a list of {want}, got {v!r}")
    if length is not None and len(v) != length:
        raise InputError(f"{where}{key} must be a list of {want}, got {len(v)}: {v!r}")
    if lengths is not None and len(v) not in lengths:
        raise InputError(f"{where}{key} must have {', '.join(map(str, lengths))} values "
                         f"(OpenCV's distortion models), got {len(v)}")
    return tuple(int(x) if integer else float(x) for x in v)


def _str_list(d, key, where):
    v = d.get(key, [])
    if not isinstance(v, list) or any(not isinstance(x, str) for x in v):
        raise InputError(f"{where}{key} must be a list of strings, got {v!r}")
    return tuple(v)


def _check_keys(d, allowed, where):
    unknown = sorted(set(d) - set(allowed))
    if unknown:
        raise InputError(f"{where}{unknown[0]} is not a known key (expected one of: "
                         f"{', '.join(sorted(allowed))})")


def parse_calibration(data, *, name="calibration file"):
    """Validate a calibration file's parsed content.

    Parameters
    ----------
    data : dict
        As ``tomllib`` reads it.
    name : str
        The file's name, for messages (``front.toml: camera.fx must be > 0, got 0``).

    Returns
    -------
    CalibrationFile

    Raises
    ------
    InputError
        Unknown or missing keys, wrong types, impossible values.
    """
    pre = f"{name}: "
    if not isinstance(data, dict):
        raise InputError(f"{pre}expected a TOML table")
    _check_keys(data, {"schema", "scale", "camera"}, pre)
    if "schema" not in data:
        raise InputError(f"{pre}schema is required (schema = {CALIBRATION_SCHEMA})")
    if data["schema"] != CALIBRATION_SCHEMA or isinstance(data["schema"], bool):
        raise InputError(f"{pre}schema must be {CALIBRATION_SCHEMA}, got {data['schema']!r}")
    if "scale" not in data and "camera" not in data:
        raise InputError(f"{pre}needs a [scale] table, a [camera] table, or both")
    scale = camera = None
    if "scale" in data:
        s = data["scale"]
        w = pre + "scale."
        if not isinstance(s, dict):
            raise InputError(f"{w[:-1]} must be a table, got {s!r}")
        _check_keys(s, {"method", "m_per_px", "length_m", "from_px", "to_px", "span_px"}, w)
        method = s.get("method", "given")
        if method not in ("ruler", "given", "checkerboard"):
            raise InputError(f"{w}method must be one of 'ruler', 'given', 'checkerboard', "
                             f"got {method!r}")
        m = _num(s, "m_per_px", w, positive=True)
        if method == "ruler":
            length = _num(s, "length_m", w, positive=True)
            fr = _num_list(s, "from_px", w, length=2)
            to = _num_list(s, "to_px", w, length=2)
            try:
                scale = ruler_scale(length, fr, to)
            except InputError as exc:
                raise InputError(f"{w[:-1]}: {exc}") from None
            if not math.isclose(scale.m_per_px, m, rel_tol=1e-9):
                raise InputError(f"{w}m_per_px = {m!r} disagrees with length_m / span of "
                                 f"from_px..to_px = {scale.m_per_px!r}")
        else:
            extra = sorted({"length_m", "from_px", "to_px", "span_px"} & set(s))
            if extra:
                raise InputError(f"{w}{extra[0]} applies only to method = 'ruler'")
            try:
                scale = Scale(m_per_px=check_m_per_px(m), method=method)
            except InputError as exc:
                raise InputError(f"{w}{exc}") from None
    if "camera" in data:
        c = data["camera"]
        w = pre + "camera."
        if not isinstance(c, dict):
            raise InputError(f"{w[:-1]} must be a table, got {c!r}")
        _check_keys(c, {"fx", "fy", "cx", "cy", "dist_coeffs", "image_size", "rms_px",
                        "images", "per_image_rms_px", "rejected", "pattern", "square_m"}, w)
        images = _str_list(c, "images", w)
        per = _num_list(c, "per_image_rms_px", w, required=False) or ()
        if len(per) != len(images):
            raise InputError(f"{w}per_image_rms_px has {len(per)} values for "
                             f"{len(images)} images")
        size = _num_list(c, "image_size", w, length=2, integer=True, required=False)
        if size is not None and min(size) <= 0:
            raise InputError(f"{w}image_size must be two integers > 0, got {list(size)}")
        pattern = _num_list(c, "pattern", w, length=2, integer=True, required=False)
        if pattern is not None and min(pattern) < 2:
            raise InputError(f"{w}pattern must be two integers >= 2, got {list(pattern)}")
        camera = CameraCalibration(
            fx=_num(c, "fx", w, positive=True), fy=_num(c, "fy", w, positive=True),
            cx=_num(c, "cx", w), cy=_num(c, "cy", w),
            dist_coeffs=_num_list(c, "dist_coeffs", w, lengths=_DIST_LENGTHS),
            image_size=size, rms_px=_num(c, "rms_px", w, nonneg=True, required=False),
            per_image_rms_px=per, images=images, rejected=_str_list(c, "rejected", w),
            pattern=pattern, square_m=_num(c, "square_m", w, positive=True, required=False),
        )
    return CalibrationFile(camera=camera, scale=scale)


def load_calibration(path):
    """Read and validate a calibration file (TOML, schema 1).

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    CalibrationFile

    Raises
    ------
    InputError
        Missing or unreadable file, invalid TOML (with line), any bad key or value
        (named with the file and the key).
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except FileNotFoundError:
        raise InputError(f"{path}: no such calibration file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the calibration file ({exc})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    parsed = parse_calibration(data, name=path.name)
    return CalibrationFile(camera=parsed.camera, scale=parsed.scale, path=path)
