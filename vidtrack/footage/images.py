"""Image folders: :class:`ImageFolderSource`, one frame per image file in natural order.

The sizes and bit depths of all the files are checked when the folder is opened, from
the file headers (png, bmp, jpeg, tiff) where they say it clearly, without decoding.
"""

import struct

import numpy as np

from vidtrack.errors import SourceError
from vidtrack.footage.base import FrameSource, _cv2, natural_key

__all__ = ["IMAGE_SUFFIXES", "ImageFolderSource"]

#: File name endings an image folder source reads (case-insensitive).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")


def _sniff_png(head):
    if head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return None
    cols, rows = struct.unpack(">II", head[16:24])
    return rows, cols, (16 if head[24] == 16 else 8)


def _sniff_bmp(head):
    if head[:2] != b"BM" or len(head) < 30:
        return None
    cols, rows = struct.unpack("<ii", head[18:26])
    return abs(rows), abs(cols), 8


def _sniff_jpeg(f):
    f.seek(0)
    if f.read(2) != b"\xff\xd8":
        return None
    while True:
        b = f.read(1)
        while b and b != b"\xff":
            b = f.read(1)
        while b == b"\xff":
            b = f.read(1)
        if not b:
            return None
        marker = b[0]
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
            continue
        raw = f.read(2)
        if len(raw) < 2:
            return None
        (length,) = struct.unpack(">H", raw)
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            seg = f.read(5)
            if len(seg) < 5:
                return None
            precision, rows, cols = struct.unpack(">BHH", seg)
            return (rows, cols, 8) if precision == 8 else None
        f.seek(length - 2, 1)


def _sniff_tiff(f):
    f.seek(0)
    head = f.read(8)
    if head[:4] == b"II*\x00":
        e = "<"
    elif head[:4] == b"MM\x00*":
        e = ">"
    else:
        return None
    (ifd,) = struct.unpack(e + "I", head[4:8])
    f.seek(ifd)
    raw = f.read(2)
    if len(raw) < 2:
        return None
    (count,) = struct.unpack(e + "H", raw)
    tags = {}
    for _ in range(count):
        entry = f.read(12)
        if len(entry) < 12:
            return None
        tag, typ, n = struct.unpack(e + "HHI", entry[:8])
        if typ == 3:  # SHORT: the first of possibly several values
            tags[tag] = (struct.unpack(e + "H", entry[8:10])[0], n)
        elif typ == 4:  # LONG
            tags[tag] = (struct.unpack(e + "I", entry[8:12])[0], n)
    if 256 not in tags or 257 not in tags:
        return None
    bits, nbits = tags.get(258, (1, 1))
    if nbits > 2:  # several samples with a pointer to their sizes: let the decoder tell
        return None
    fmt = tags.get(339, (1, 1))[0]  # SampleFormat: 1 unsigned integer
    if fmt != 1 or bits not in (1, 2, 4, 8, 16):
        return None
    return tags[257][0], tags[256][0], (16 if bits == 16 else 8)


def _sniff_image(path):
    """``(rows, cols, bits)`` from an image file's header without decoding it, or None."""
    try:
        with open(path, "rb") as f:
            head = f.read(32)
            for sniff in (_sniff_png, _sniff_bmp):
                got = sniff(head)
                if got is not None:
                    return got
            if head[:2] == b"\xff\xd8":
                return _sniff_jpeg(f)
            if head[:4] in (b"II*\x00", b"MM\x00*"):
                return _sniff_tiff(f)
    except (OSError, struct.error):
        return None
    return None


class ImageFolderSource(FrameSource):
    """A folder of images (png, jpg, tif, bmp), one frame per file in natural order.

    Parameters
    ----------
    path : str or os.PathLike
        The folder. Files ending in :data:`IMAGE_SUFFIXES` are frames; other files,
        hidden files and subfolders are ignored. Names sort naturally (``2`` before
        ``10``).
    fps : float, optional
        Capture rate in frames/s (an image folder has no rate of its own).
    frames : (int, int), optional
        Half-open range of 0-based indices into the sorted file list.
    channel : str, optional
        ``"luma"`` (default), ``"red"``, ``"green"``, ``"blue"`` or ``"auto"``
        (:mod:`vidtrack.footage.channel`).

    Raises
    ------
    SourceError
        The folder has no images, an image cannot be decoded, or the images differ in
        size or dtype (the message names the first offending file and the first file);
        a colour channel of grey images.

    Notes
    -----
    Files are read with ``IMREAD_UNCHANGED``: 16-bit png/tif stay ``uint16``
    (``bit_depth`` 16), 8-bit stay ``uint8``; colour is converted to grey (or to the
    ``channel`` given). Sizes and
    bit depths are checked for every file when the folder is opened, from the file
    headers (png, bmp, jpeg, tiff; a file whose header says nothing clear is decoded).
    Only ``uint8`` and ``uint16`` images are accepted.
    """

    kind = "image folder"

    def __init__(self, path, *, fps=None, frames=None, channel="luma"):
        super().__init__(path, fps=fps, channel=channel)
        if not self.path.is_dir():
            raise SourceError(f"{self.path}: no such folder")
        files = [p for p in self.path.iterdir()
                 if p.suffix.lower() in IMAGE_SUFFIXES and not p.name.startswith(".")
                 and p.is_file()]
        if not files:
            raise SourceError(f"{self.path}: no images ({', '.join(IMAGE_SUFFIXES)}) in the folder")
        self._files = sorted(files, key=natural_key)
        first = self._decode(self._files[0])
        self._shape, self._dtype = first.shape, first.dtype
        self._bit_depth = 8 * first.dtype.itemsize
        self._fps_container = None
        self._check_all()
        self._set_range(len(self._files), frames)
        self._settle_channel()

    @property
    def files(self):
        """The image files of the source frames, in order."""
        return self._files[self._start:self._stop]

    def _decode(self, path):
        cv2 = _cv2()
        try:
            data = np.fromfile(path, dtype=np.uint8)
        except OSError as exc:
            raise SourceError(f"{path}: cannot be read ({exc.strerror})") from None
        image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
        if image is None:
            raise SourceError(f"{path}: cannot be decoded as an image (empty, truncated or "
                              "not an image)")
        if image.dtype not in (np.uint8, np.uint16):
            raise SourceError(f"{path}: {image.dtype} pixels are not supported; expected 8- or "
                              "16-bit unsigned integer images")
        try:
            return self._grey(image)
        except SourceError as exc:       # a grey image among colour ones
            raise SourceError(f"{path}: {exc}") from None

    def _mismatch(self, path, shape, dtype):
        first = self._files[0]
        return SourceError(
            f"{path}: image is {shape[1]}x{shape[0]} {np.dtype(dtype)}, but {first.name} "
            f"(the first image) is {self._shape[1]}x{self._shape[0]} {self._dtype}: an image "
            "folder needs one size and bit depth")

    def _check_all(self):
        bits0 = 8 * self._dtype.itemsize
        sniff0 = _sniff_image(self._files[0])
        trust = sniff0 == (self._shape[0], self._shape[1], bits0)
        for path in self._files[1:]:
            got = _sniff_image(path) if trust else None
            if got is None:
                image = self._decode(path)
                got = (image.shape[0], image.shape[1], 8 * image.dtype.itemsize)
            if got != (self._shape[0], self._shape[1], bits0):
                raise self._mismatch(path, got[:2], np.uint8 if got[2] == 8 else np.uint16)

    def _read_file_frame(self, k):
        path = self._files[k]
        image = self._decode(path)
        if image.shape != self._shape or image.dtype != self._dtype:
            raise self._mismatch(path, image.shape, image.dtype)
        return image

    def to_dict(self):
        out = super().to_dict()
        out["first_file"] = self.files[0].name
        return out
