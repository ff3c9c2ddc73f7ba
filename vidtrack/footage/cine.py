"""Phantom .cine files (Vision Research): a lazy numpy reader and a writer.

The layout, from Vision Research's published description of the format ("The Cine
File Format"), all little-endian:

- ``CINEFILEHEADER`` (44 bytes at 0): ``"CI"``, header size, Compression (0 grey or
  interpolated colour, 1 JPEG, 2 uninterpolated raw), Version, FirstMovieImage,
  TotalImageCount, FirstImageNo (number of the first saved image relative to the
  trigger, negative for images before it), ImageCount, and the offsets of the
  ``BITMAPINFOHEADER``, the ``SETUP`` and the image-offset table, then TriggerTime.
- ``BITMAPINFOHEADER`` (40 bytes, Windows): width, height (> 0: rows stored
  bottom-up; < 0: top-down), bit count, compression (0 plain; 256 packed 10-bit,
  1024 packed 12-bit), image size.
- ``SETUP`` (packed structure; its ``Length`` field gives its size, which grew with
  the software version): the frame rate (FrameRate, frames/s, an integer), CFA (the
  colour filter pattern, 0 for a grey sensor), RealBPP (significant bits), ...
- Tagged information blocks from ``OffSetup + SETUP.Length`` up to the image-offset
  table, each ``(DWORD size, WORD type, WORD reserved, data)``: 1002 holds one TIME64
  per image (time only), 1003 one exposure per image, 1001 image times (older
  software).
- The image-offset table: one 64-bit file offset per image; at each offset an
  annotation (``DWORD AnnotationSize``, annotation bytes, ending with ``DWORD
  ImageSize``) followed by the image.

TIME64 is 32.32 fixed point: seconds since 1970-01-01 in the high 32 bits, the
fraction of a second times 2**32 in the low 32 bits. Exposures in block 1003 are
fractions of a second times 2**32.

Supported: grey images stored as 8 or 16 bits, packed 10- and 12-bit grey (four
pixels in five bytes / two in three, most significant bits first), interpolated
colour (24- or 48-bit BGR, converted to grey). Refused with a message: JPEG-compressed
files and colour raw (uninterpolated CFA mosaic) files.
"""

import datetime
import os
import struct
from pathlib import Path

import numpy as np

from vidtrack._atomic import atomic_path
from vidtrack.errors import SourceError
from vidtrack.footage.base import FrameSource
from vidtrack.footage.timebase import stamp_rate

__all__ = ["CineSource", "write_cine", "pack_10bit", "unpack_10bit", "pack_12bit",
           "unpack_12bit"]

_HEADER = struct.Struct("<2sHHHiIiIIIIQ")
_HEADER_NAMES = ("type", "header_size", "compression", "version", "first_movie_image",
                 "total_image_count", "first_image_no", "image_count", "off_image_header",
                 "off_setup", "off_image_offsets", "trigger_time")
_BITMAP = struct.Struct("<IiiHHIIiiII")
_BITMAP_NAMES = ("size", "width", "height", "planes", "bit_count", "compression",
                 "size_image", "x_pels_per_meter", "y_pels_per_meter", "clr_used",
                 "clr_important")

#: SETUP fields this module reads and writes: name -> (byte offset, struct code).
SETUP_FIELDS = {
    "frame_rate_16": (0, "H"),      # obsolete 16-bit frame rate
    "mark": (140, "2s"),            # "ST"
    "length": (142, "H"),           # size of the SETUP structure in bytes
    "im_width": (737, "H"),
    "im_height": (739, "H"),
    "frame_rate": (768, "I"),       # frames/s
    "enable_color": (788, "i"),
    "software_version": (800, "I"),
    "cfa": (808, "I"),              # low byte: colour filter pattern, 0 = grey sensor
    "real_bpp": (896, "I"),         # significant bits per pixel
    "black_level": (5732, "i"),
    "white_level": (5736, "i"),
}
_SETUP_WRITE_LENGTH = 5740          # through WhiteLevel

CC_RGB, CC_JPEG, CC_UNINT = 0, 1, 2
BI_RGB, BI_PACKED10, BI_PACKED12 = 0, 256, 1024
TAG_IMAGE_TIME, TAG_TIME_ONLY, TAG_EXPOSURE_ONLY = 1001, 1002, 1003
_FRACTION = 2 ** 32
#: Largest time (s) between a .cine's TriggerTime and its first image's time stamp: a
#: recording's images are taken around its trigger (Phantom buffers at most minutes).
MAX_TRIGGER_GAP_S = 86400.0
#: TriggerTime of the files :func:`write_cine` makes: 2020-01-01 00:00:00 UTC.
WRITER_EPOCH_S = 1577836800


# ---------------------------------------------------------------------------------------
# Packed pixels
# ---------------------------------------------------------------------------------------
def unpack_10bit(data):
    """Unpack 10-bit pixels stored four in five bytes, most significant bits first.

    Parameters
    ----------
    data : bytes or numpy.ndarray of uint8
        ``5 k`` bytes.

    Returns
    -------
    numpy.ndarray of uint16
        ``4 k`` pixel values in ``0 .. 1023``.
    """
    b = np.frombuffer(data, dtype=np.uint8).reshape(-1, 5).astype(np.uint16)
    out = np.empty((b.shape[0], 4), dtype=np.uint16)
    out[:, 0] = (b[:, 0] << 2) | (b[:, 1] >> 6)
    out[:, 1] = ((b[:, 1] & 0x3F) << 4) | (b[:, 2] >> 4)
    out[:, 2] = ((b[:, 2] & 0x0F) << 6) | (b[:, 3] >> 2)
    out[:, 3] = ((b[:, 3] & 0x03) << 8) | b[:, 4]
    return out.reshape(-1)


def pack_10bit(pixels):
    """Pack 10-bit pixels (a multiple of four) into bytes; inverse of :func:`unpack_10bit`."""
    p = np.asarray(pixels, dtype=np.uint16).reshape(-1, 4)
    out = np.empty((p.shape[0], 5), dtype=np.uint8)
    out[:, 0] = p[:, 0] >> 2
    out[:, 1] = ((p[:, 0] & 0x03) << 6) | (p[:, 1] >> 4)
    out[:, 2] = ((p[:, 1] & 0x0F) << 4) | (p[:, 2] >> 6)
    out[:, 3] = ((p[:, 2] & 0x3F) << 2) | (p[:, 3] >> 8)
    out[:, 4] = p[:, 3] & 0xFF
    return out.reshape(-1)


def unpack_12bit(data):
    """Unpack 12-bit pixels stored two in three bytes, most significant bits first."""
    b = np.frombuffer(data, dtype=np.uint8).reshape(-1, 3).astype(np.uint16)
    out = np.empty((b.shape[0], 2), dtype=np.uint16)
    out[:, 0] = (b[:, 0] << 4) | (b[:, 1] >> 4)
    out[:, 1] = ((b[:, 1] & 0x0F) << 8) | b[:, 2]
    return out.reshape(-1)


def pack_12bit(pixels):
    """Pack 12-bit pixels (an even number) into bytes; inverse of :func:`unpack_12bit`."""
    p = np.asarray(pixels, dtype=np.uint16).reshape(-1, 2)
    out = np.empty((p.shape[0], 3), dtype=np.uint8)
    out[:, 0] = p[:, 0] >> 4
    out[:, 1] = ((p[:, 0] & 0x0F) << 4) | (p[:, 1] >> 8)
    out[:, 2] = p[:, 1] & 0xFF
    return out.reshape(-1)


# ---------------------------------------------------------------------------------------
# Reader
# ---------------------------------------------------------------------------------------
#: Storage layouts: name -> (bits per stored pixel, samples per pixel, packed).
_LAYOUTS = {
    "u8": (8, 1, False), "u16": (16, 1, False), "bgr8": (24, 3, False),
    "bgr16": (48, 3, False), "p10": (10, 1, True), "p12": (12, 1, True),
}


class CineSource(FrameSource):
    """A Phantom .cine file, read lazily frame by frame with numpy.

    Parameters
    ----------
    path : str or os.PathLike
        The .cine file.
    fps : float, optional
        Nominal capture rate in frames/s (``scene.toml``). Without time stamps the
        frames are timed by it; with time stamps it is what they are checked against.
    frames : (int, int), optional
        Half-open range of 0-based file frame indices (not image numbers).
    use_time_stamps : bool, optional
        Time frames by the per-image time stamps when the file has them (default).
    channel : str, optional
        ``"luma"`` (default), ``"red"``, ``"green"``, ``"blue"`` or ``"auto"``
        (:mod:`vidtrack.footage.channel`); a colour channel needs interpolated colour.

    Attributes
    ----------
    header, bitmap, setup : dict
        The fields read from CINEFILEHEADER, BITMAPINFOHEADER and SETUP.
    first_image_no : int
        Image number of the file's first image, relative to the trigger (image 0).
    image_numbers : numpy.ndarray
        Trigger-relative image number of every source frame: ``first_image_no + k``
        for file frame ``k``, as the header numbers saved images. When a save kept only
        every n-th image, ``trigger_times_s`` (from the stamps) is the reliable
        measure of when an image was taken.
    trigger_times_s : numpy.ndarray or None
        Time stamp of every source frame in s relative to the trigger (TriggerTime);
        None when the file has no usable stamps.
    exposures_s : numpy.ndarray or None
        Exposure of every source frame in s (tagged block 1003), if present.
    fps_time_stamps : float or None
        Rate the stamps show, frames/s: 1 / mean interval, leaving out gaps (intervals
        over 1.5 times the median, i.e. dropped frames).
    time_stamps_used : bool
        True when ``times_s`` come from the stamps.

    Raises
    ------
    SourceError
        Not a .cine file, a damaged header, a truncated file (the message names the
        first frame that is cut off), or a variant that is not supported (JPEG
        compressed, colour raw).

    Notes
    -----
    Rows stored bottom-up (positive ``biHeight``, the camera's usual way) are flipped
    so that row 0 is the top of the picture. Packed 10- and 12-bit images are stored
    top-down (as Vision Research's packed formats are; the PIMS and pycine readers
    rely on the same) and are not flipped. Pixel values are returned as stored: no
    black/white level or gain is applied, and the packed 10-bit (P10) codes are not
    passed through the camera's 10-to-12-bit linearisation table. The 16-bit
    ``bit_depth`` is the setup's RealBPP (e.g. 12 or 14).
    """

    kind = "cine"

    def __init__(self, path, *, fps=None, frames=None, use_time_stamps=True, channel="luma"):
        super().__init__(path, fps=fps, channel=channel)
        if not self.path.is_file():
            raise SourceError(f"{self.path}: no such file")
        try:
            self._f = open(self.path, "rb")
        except OSError as exc:
            raise SourceError(f"{self.path}: cannot be read ({exc.strerror})") from None
        try:
            self._parse(use_time_stamps)
            self._set_range(self.header["image_count"], frames)
            self._check_complete()
            self._settle_channel()
        except BaseException:
            self._f.close()
            raise

    # -- parsing --------------------------------------------------------------------
    def _fail(self, what):
        return SourceError(f"{self.path}: {what}")

    def _read_at(self, offset, size):
        self._f.seek(offset)
        return self._f.read(size)

    def _parse(self, use_time_stamps):
        size = os.fstat(self._f.fileno()).st_size
        self._file_size = size
        raw = self._read_at(0, _HEADER.size)
        if len(raw) < _HEADER.size or raw[:2] != b"CI":
            raise self._fail("not a Phantom .cine file (it does not start with the 'CI' header)")
        h = dict(zip(_HEADER_NAMES, _HEADER.unpack(raw)))
        h["type"] = h["type"].decode("ascii")
        self.header = h
        n = h["image_count"]
        if n == 0:
            raise self._fail("the .cine file holds no images (ImageCount = 0)")
        if h["compression"] == CC_JPEG:
            raise self._fail("JPEG-compressed .cine files are not supported; save the cine "
                             "uncompressed in Phantom Camera Control")
        for name, need in (("off_image_header", _BITMAP.size), ("off_setup", 144),
                           ("off_image_offsets", 8 * n)):
            if h[name] + need > size:
                raise self._fail(f"damaged header: {name} = {h[name]} points past the end of the "
                                 f"file ({size} bytes)")
        self.bitmap = dict(zip(_BITMAP_NAMES,
                               _BITMAP.unpack(self._read_at(h["off_image_header"], _BITMAP.size))))
        self.setup = self._parse_setup(size)
        self._parse_layout()
        self._offsets = np.frombuffer(self._read_at(h["off_image_offsets"], 8 * n), dtype="<i8")
        self._parse_image_size()
        self._parse_tags(use_time_stamps)
        rate = self.setup.get("frame_rate") or self.setup.get("frame_rate_16") or 0
        self._fps_container = float(rate) if rate > 0 else None
        self.first_image_no = int(h["first_image_no"])

    def _parse_setup(self, size):
        off = self.header["off_setup"]
        head = self._read_at(off, 144)
        mark, length = head[140:142], struct.unpack("<H", head[142:144])[0]
        if mark != b"ST" or length < 144:
            self.notes += ("the SETUP block has no 'ST' mark or length; frame rate and bit "
                           "depth are not known from it",)
            self._setup_length = None
            return {}
        length = min(length, size - off)
        self._setup_length = length
        block = self._read_at(off, length)
        setup = {}
        for name, (offset, code) in SETUP_FIELDS.items():
            width = struct.calcsize("<" + code)
            if offset + width <= length:
                (value,) = struct.unpack_from("<" + code, block, offset)
                setup[name] = value.decode("latin-1") if isinstance(value, bytes) else value
        return setup

    def _parse_layout(self):
        bi, h = self.bitmap, self.header
        cols, rows = bi["width"], abs(bi["height"])
        if cols <= 0 or rows == 0:
            raise self._fail(f"damaged image header: {cols} x {bi['height']} pixels")
        pattern = self.setup.get("cfa", 0) & 0xFF
        if bi["compression"] == BI_RGB:
            layout = {8: "u8", 10: "p10", 12: "p12", 16: "u16", 24: "bgr8",
                      48: "bgr16"}.get(bi["bit_count"])
            if layout is None:
                raise self._fail(f"{bi['bit_count']}-bit images are not supported (expected 8 or "
                                 "16 bits grey, packed 10 or 12 bits, or 24/48-bit colour)")
        elif bi["compression"] == BI_PACKED10:
            layout = "p10"
        elif bi["compression"] == BI_PACKED12:
            layout = "p12"
        else:
            raise self._fail(f"image compression {bi['compression']} is not supported (expected 0 "
                             "uncompressed, 256 packed 10-bit or 1024 packed 12-bit)")
        if _LAYOUTS[layout][1] == 1 and pattern != 0 and h["compression"] == CC_UNINT:
            raise self._fail(
                f"colour raw (uninterpolated CFA pattern {pattern}) .cine files are not supported; "
                "save the cine as interpolated colour or grey in Phantom Camera Control")
        self._layout = layout
        self._rows, self._cols = rows, cols
        self._top_down = bi["height"] < 0 or _LAYOUTS[layout][2]

    def _expected_bytes(self, layout):
        bits = _LAYOUTS[layout][0]
        return self._rows * self._cols * bits // 8

    def _parse_image_size(self):
        """Settle the per-image byte count from image 0's annotation (and packing, row padding)."""
        ann, size = self._annotation(0)
        layout = self._layout
        if layout == "u16" and size != self._expected_bytes("u16"):
            for packed in ("p10", "p12"):  # packed pixels declared as 16-bit (older files)
                if size == self._expected_bytes(packed) and (self._rows * self._cols
                                                              * _LAYOUTS[packed][0]) % 8 == 0:
                    layout = packed
                    self._top_down = True
        self._layout = layout
        bits, samples, packed = _LAYOUTS[layout]
        self._row_bytes = self._cols * bits // 8
        if packed and (self._rows * self._cols * bits) % 8:
            raise self._fail(f"packed {bits}-bit images of {self._cols} x {self._rows} pixels "
                             "do not fill whole bytes")
        padded = (self._cols * bits + 31) // 32 * 4
        if size == self._expected_bytes(layout):
            self._stride = self._row_bytes
        elif not packed and size == padded * self._rows:
            self._stride = padded
        else:
            raise self._fail(
                f"frame 0 (image number {self.header['first_image_no']}): image size {size} bytes, "
                f"expected {self._expected_bytes(layout)} for {self._cols} x {self._rows} pixels "
                f"of {bits} bits")
        self._image_bytes = size
        if layout in ("u8", "bgr8"):
            self._dtype, depth = np.dtype(np.uint8), 8
        elif layout in ("p10", "p12"):
            self._dtype, depth = np.dtype(np.uint16), bits
        else:
            self._dtype = np.dtype(np.uint16)
            real = self.setup.get("real_bpp", 0)
            depth = real if 8 < real <= 16 else 16
        self._bit_depth = int(depth)
        self._shape = (self._rows, self._cols)

    def _annotation(self, k):
        """``(AnnotationSize, ImageSize)`` of file frame ``k``."""
        off = int(self._offsets[k])
        number = self.header["first_image_no"] + k
        raw = self._read_at(off, 4) if 0 <= off < self._file_size else b""
        if len(raw) < 4:
            raise self._fail(f"truncated: frame {k} (image number {number}) starts at byte {off}, "
                             f"past the end of the file ({self._file_size} bytes)")
        (ann,) = struct.unpack("<I", raw)
        if ann < 8 or ann > 1 << 20:
            raise self._fail(f"frame {k} (image number {number}): damaged annotation "
                             f"(size {ann} bytes)")
        raw = self._read_at(off + ann - 4, 4)
        if len(raw) < 4:
            raise self._fail(f"truncated: frame {k} (image number {number}) is cut off in its "
                             "annotation")
        return ann, struct.unpack("<I", raw)[0]

    def _parse_tags(self, use_time_stamps):
        h = self.header
        stamps = exposures = None
        found = []
        if self._setup_length is not None:
            p = h["off_setup"] + self._setup_length
            end = h["off_image_offsets"]
            n = h["image_count"]
            while p + 8 <= end:
                bsize, btype, _ = struct.unpack("<IHH", self._read_at(p, 8))
                if bsize < 8 or p + bsize > end:
                    break
                found.append(int(btype))
                payload = bsize - 8
                if btype in (TAG_TIME_ONLY, TAG_IMAGE_TIME) and payload == 8 * n:
                    if btype == TAG_TIME_ONLY or stamps is None:
                        stamps = np.frombuffer(self._read_at(p + 8, payload), dtype="<u8")
                elif btype == TAG_EXPOSURE_ONLY and payload == 4 * n:
                    exposures = np.frombuffer(self._read_at(p + 8, payload), dtype="<u4")
                p += bsize
        self.tagged_blocks = tuple(found)
        self._exposures = None if exposures is None else exposures / _FRACTION
        self._stamps = None
        self.fps_time_stamps = None
        if stamps is not None:
            ticks = stamps.astype(np.int64)
            steps = np.diff(ticks)
            if np.all(steps > 0):
                self._stamps = ticks
                self.fps_time_stamps = stamp_rate((ticks - ticks[0]) / _FRACTION)
            else:
                k = int(np.flatnonzero(steps <= 0)[0]) + 1
                self.notes += (f"time stamps do not increase at frame {k}; frames are timed by the "
                               "frame rate instead",)
        self.time_stamps_used = bool(use_time_stamps and self._stamps is not None)
        self._check_trigger()

    def _check_trigger(self):
        """TriggerTime must be a TIME64 near the images' own stamps (a flipped byte is not)."""
        t = int(self.header["trigger_time"])
        if self._stamps is None:
            return
        first = int(self._stamps[0])
        gap = abs(first - t) / _FRACTION
        if gap > MAX_TRIGGER_GAP_S:
            raise self._fail(
                f"damaged header: trigger_time (TriggerTime, bytes 36-43) is {t >> 32} s after "
                f"1970, {gap:.4g} s from the first image's time stamp ({first >> 32} s); "
                f"expected the trigger within {MAX_TRIGGER_GAP_S:g} s of the images it "
                "triggered (the file is damaged; export it again from the camera)")

    def _check_complete(self):
        """A truncated file fails at open, naming the first frame that is cut off."""
        ks = np.arange(self._start, self._stop)
        ends = self._offsets[ks] + 8 + self._image_bytes
        bad = np.flatnonzero((ends > self._file_size) | (self._offsets[ks] < 0))
        if bad.size:
            k = int(ks[bad[0]])
            raise self._fail(
                f"truncated: frame {k} (image number {self.first_image_no + k}) needs bytes up to "
                f"{int(ends[bad[0]])} but the file has {self._file_size}")

    # -- time base ------------------------------------------------------------------
    def _native_fps(self):
        if self.time_stamps_used and self.fps_time_stamps is not None:
            return self.fps_time_stamps
        return self._fps_container

    @property
    def time_source(self):
        if self.time_stamps_used:
            return "time stamps"
        return super().time_source

    def _file_times_s(self, ks):
        if self.time_stamps_used:
            return (self._stamps[ks] - self._stamps[0]) / _FRACTION
        return super()._file_times_s(ks)

    @property
    def image_numbers(self):
        return self.first_image_no + self.frame_numbers

    @property
    def trigger_times_s(self):
        if self._stamps is None:
            return None
        return (self._stamps[self._start:self._stop] - self.header["trigger_time"]) / _FRACTION

    @property
    def exposures_s(self):
        if self._exposures is None:
            return None
        return self._exposures[self._start:self._stop]

    @property
    def trigger_time(self):
        """TriggerTime as a timezone-aware UTC datetime (the file stores no zone)."""
        t = self.header["trigger_time"]
        return (datetime.datetime.fromtimestamp(t >> 32, tz=datetime.timezone.utc)
                + datetime.timedelta(seconds=(t & 0xFFFFFFFF) / _FRACTION))

    # -- frames ---------------------------------------------------------------------
    def _read_file_frame(self, k):
        ann, size = self._annotation(k)
        number = self.first_image_no + k
        if size != self._image_bytes:
            raise self._fail(f"frame {k} (image number {number}): image size {size} bytes, "
                             f"frame 0 has {self._image_bytes}")
        data = self._read_at(int(self._offsets[k]) + ann, size)
        if len(data) < size:
            raise self._fail(f"truncated: frame {k} (image number {number}) has {len(data)} of its "
                             f"{size} bytes")
        return self._decode(data)

    def _decode(self, data):
        layout, rows, cols = self._layout, self._rows, self._cols
        buf = np.frombuffer(data, dtype=np.uint8)
        if self._stride != self._row_bytes:
            buf = buf.reshape(rows, self._stride)[:, :self._row_bytes].reshape(-1)
        if layout == "p10":
            image = unpack_10bit(buf).reshape(rows, cols)
        elif layout == "p12":
            image = unpack_12bit(buf).reshape(rows, cols)
        elif layout in ("u8", "bgr8"):
            image = buf.reshape(rows, cols, -1)
        else:
            image = buf.view("<u2").reshape(rows, cols, -1)
        if not self._top_down:
            image = image[::-1]
        if image.ndim == 3 and image.shape[2] == 3:
            return self._grey(np.ascontiguousarray(image).astype(self._dtype, copy=False))
        if image.ndim == 3:
            image = image[:, :, 0]
        return self._grey(np.array(image, dtype=self._dtype, order="C"))

    def _close(self):
        self._f.close()

    def to_dict(self):
        out = super().to_dict()
        out.update({
            "first_image_no": self.first_image_no,
            "image_numbers": [int(self.image_numbers[0]), int(self.image_numbers[-1])],
            "fps_setup": self._fps_container,
            "fps_time_stamps": self.fps_time_stamps,
            "time_stamps_used": self.time_stamps_used,
            "layout": self._layout,
            "bottom_up": not self._top_down,
            "real_bpp": self.setup.get("real_bpp"),
            "software_version": self.setup.get("software_version"),
            "tagged_blocks": list(self.tagged_blocks),
        })
        return out


# ---------------------------------------------------------------------------------------
# Writer
# ---------------------------------------------------------------------------------------
def _time64(seconds):
    """32.32 fixed-point TIME64 of absolute epoch seconds given as (int seconds, float rest)."""
    whole = np.floor(seconds).astype(np.int64)
    frac = np.round((seconds - whole) * _FRACTION).astype(np.int64)
    carry = frac >= _FRACTION
    whole, frac = whole + carry, np.where(carry, frac - _FRACTION, frac)
    return ((whole + WRITER_EPOCH_S) << 32) + frac


def write_cine(path, frames, *, fps, bit_depth=8, packed=False, first_image_no=0,
               timestamps_s=None, bottom_up=True, write_time_stamps=True):
    """Write frames as a Phantom .cine file that :class:`CineSource` (and Phantom
    software) can read.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write (atomically: it appears whole or not at all).
    frames : sequence of numpy.ndarray
        A ``(n, rows, cols)`` integer array or a sequence of ``(rows, cols)`` grey
        frames; ``(rows, cols, 3)`` BGR frames make an interpolated colour file.
        Values must lie in ``0 .. 2**bit_depth - 1``. A sequence without ``len`` is
        read into memory first.
    fps : float
        Frame rate in frames/s, written to the setup (FrameRate holds an integer: it
        is rounded) and used for the default time stamps.
    bit_depth : {8, 10, 12, 16}, optional
        Significant bits (RealBPP). 8 is stored in bytes; 10, 12 and 16 in 16-bit
        words unless ``packed``.
    packed : bool, optional
        Store 10- or 12-bit grey pixels packed (four pixels in five bytes,
        biCompression 256; two in three bytes, biCompression 1024); needs
        ``rows * cols`` divisible by 4 (10-bit) or 2 (12-bit).
    first_image_no : int, optional
        Trigger-relative number of the first image (negative: images before the
        trigger).
    timestamps_s : array_like, optional
        Time of every image in s relative to the trigger; default
        ``(first_image_no + arange(n)) / fps``. Stored as TIME64 (resolution 2**-32 s)
        in tagged block 1002, with TriggerTime at 2020-01-01 00:00:00 UTC.
    bottom_up : bool, optional
        Store uncompressed rows bottom-up with a positive biHeight, as the cameras do
        (False: top-down, negative biHeight). Packed images are always stored
        top-down, as Vision Research's packed formats are.
    write_time_stamps : bool, optional
        False leaves out the tagged blocks (time stamps and exposures), as older files
        may.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        Bad ``fps``, ``bit_depth`` or ``packed`` combination, frames of different
        shapes, non-integer frames or values out of range, bad ``timestamps_s``.
    """
    path = Path(path)
    fps = float(fps)
    if not np.isfinite(fps) or fps < 0.5:
        raise ValueError(f"fps must be a finite rate >= 0.5 frames/s, got {fps}")
    if bit_depth not in (8, 10, 12, 16):
        raise ValueError(f"bit_depth must be 8, 10, 12 or 16, got {bit_depth!r}")
    if packed and bit_depth not in (10, 12):
        raise ValueError(f"packed storage exists for 10- and 12-bit pixels, not {bit_depth}-bit")
    if not hasattr(frames, "__len__"):
        frames = list(frames)
    n = len(frames)
    if n == 0:
        raise ValueError("no frames to write")
    first = np.asarray(frames[0])
    colour = first.ndim == 3 and first.shape[2] == 3
    if first.ndim != 2 and not colour:
        raise ValueError("frames must be (rows, cols) grey or (rows, cols, 3) BGR, got "
                         f"{first.shape}")
    if colour and packed:
        raise ValueError("packed storage is for grey frames only")
    rows, cols = first.shape[:2]
    if rows > 65535 or cols > 65535:
        raise ValueError(f"frames of {cols} x {rows} pixels are too large for a .cine")
    if packed and (rows * cols) % (4 if bit_depth == 10 else 2):
        raise ValueError(f"packed {bit_depth}-bit storage needs rows * cols divisible by "
                         f"{4 if bit_depth == 10 else 2}, got {rows} x {cols}")

    if packed:
        layout = "p10" if bit_depth == 10 else "p12"
    elif colour:
        layout = "bgr8" if bit_depth == 8 else "bgr16"
    else:
        layout = "u8" if bit_depth == 8 else "u16"
    bits = _LAYOUTS[layout][0]
    image_bytes = rows * cols * bits // 8
    bi_compression = {"p10": BI_PACKED10, "p12": BI_PACKED12}.get(layout, BI_RGB)
    top_down = packed or not bottom_up

    if timestamps_s is None:
        times = (first_image_no + np.arange(n)) / fps
    else:
        times = np.asarray(timestamps_s, dtype=np.float64)
        if times.shape != (n,) or not np.all(np.isfinite(times)):
            raise ValueError(f"timestamps_s must be {n} finite times in s, got shape {times.shape}")
    stamps = _time64(times)

    header_size, bitmap_off, setup_off = _HEADER.size, _HEADER.size, _HEADER.size + _BITMAP.size
    tags = b""
    if write_time_stamps:
        exposure = min(int(round(0.5 / fps * _FRACTION)), _FRACTION - 1)
        tags += struct.pack("<IHH", 8 + 8 * n, TAG_TIME_ONLY, 1) + stamps.astype("<u8").tobytes()
        tags += (struct.pack("<IHH", 8 + 4 * n, TAG_EXPOSURE_ONLY, 0)
                 + np.full(n, exposure, dtype="<u4").tobytes())
    offsets_off = setup_off + _SETUP_WRITE_LENGTH + len(tags)
    first_image = offsets_off + 8 * n
    offsets = first_image + np.arange(n, dtype=np.int64) * (8 + image_bytes)

    trigger = WRITER_EPOCH_S << 32
    header = _HEADER.pack(b"CI", header_size, CC_RGB, 1, first_image_no, n, first_image_no, n,
                          bitmap_off, setup_off, offsets_off, trigger)
    bitmap = _BITMAP.pack(_BITMAP.size, cols, rows if not top_down or packed else -rows, 1, bits,
                          bi_compression, image_bytes, 0, 0, 0, 2 ** bit_depth)
    setup = bytearray(_SETUP_WRITE_LENGTH)
    values = {"frame_rate_16": min(int(round(fps)), 65535), "mark": b"ST",
              "length": _SETUP_WRITE_LENGTH, "im_width": cols, "im_height": rows,
              "frame_rate": int(round(fps)), "enable_color": int(colour), "software_version": 0,
              "cfa": 0, "real_bpp": bit_depth, "black_level": 0,
              "white_level": 2 ** bit_depth - 1}
    for name, value in values.items():
        offset, code = SETUP_FIELDS[name]
        struct.pack_into("<" + code, setup, offset, value)

    limit = 2 ** bit_depth
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        f.write(header + bitmap + bytes(setup) + tags + offsets.astype("<i8").tobytes())
        for k in range(n):
            frame = np.asarray(frames[k])
            if frame.shape != first.shape:
                raise ValueError(f"frame {k} has shape {frame.shape}, frame 0 {first.shape}")
            if not np.issubdtype(frame.dtype, np.integer):
                raise ValueError(f"frame {k}: frames must be integer arrays, got {frame.dtype}")
            if frame.size and (frame.min() < 0 or frame.max() >= limit):
                raise ValueError(f"frame {k}: values {frame.min()}..{frame.max()} do not fit "
                                 f"{bit_depth} bits (0..{limit - 1})")
            if not top_down:
                frame = frame[::-1]
            if layout == "p10":
                data = pack_10bit(frame.ravel()).tobytes()
            elif layout == "p12":
                data = pack_12bit(frame.ravel()).tobytes()
            elif bits in (8, 24):
                data = np.ascontiguousarray(frame, dtype=np.uint8).tobytes()
            else:
                data = np.ascontiguousarray(frame, dtype="<u2").tobytes()
            f.write(struct.pack("<II", 8, image_bytes))
            f.write(data)
    return path
