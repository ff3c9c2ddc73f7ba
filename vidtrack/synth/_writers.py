"""Writing the footage of a view, frame by frame as it is rendered.

Compression and formats: MJPG AVI at a quality, lossless FFV1 or raw AVI, png folders,
Phantom .cine (through :func:`vidtrack.footage.cine.write_cine`). AVI files carry
``playback_fps`` (30) in the container, as exported high-speed videos do; ``scene.toml``
carries the capture rate. No frame is kept after it is written, so memory does not grow
with the number of frames.
"""

import os

from vidtrack.errors import VidtrackError

def _source_name(spec, view):
    return {"avi": f"{view}.avi", "png": view, "cine": f"{view}.cine"}[spec.output_format]


def _write_avi(path, renderer, n, spec, tick):
    import cv2

    from vidtrack._atomic import atomic_path, check_video_written

    w, h = renderer.view.width, renderer.view.height
    with atomic_path(path) as tmp:
        video = tmp.with_name(tmp.name + ".avi")
        try:
            if spec.video_codec == "mjpg":
                # OpenCV's own MJPEG writer honours the quality; it needs 3 channels.
                writer = cv2.VideoWriter(str(video), cv2.CAP_OPENCV_MJPEG,
                                         cv2.VideoWriter_fourcc(*"MJPG"), spec.playback_fps,
                                         (w, h), [cv2.VIDEOWRITER_PROP_IS_COLOR, 1])
                colour = True
            else:
                fourcc = cv2.VideoWriter_fourcc(*("FFV1" if spec.video_codec == "ffv1"
                                                  else "Y800"))
                writer = cv2.VideoWriter(str(video), cv2.CAP_FFMPEG, fourcc, spec.playback_fps,
                                         (w, h), [cv2.VIDEOWRITER_PROP_IS_COLOR, 0])
                colour = False
            if not writer.isOpened():
                raise VidtrackError(f"{path}: this OpenCV cannot write "
                                    f"{spec.video_codec.upper()} AVI files; use --codec or "
                                    "--format png|cine")
            if spec.video_codec == "mjpg":
                writer.set(cv2.VIDEOWRITER_PROP_QUALITY, float(spec.jpeg_quality))
            try:
                for i in range(n):
                    frame = renderer.frame(i)
                    writer.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR) if colour else frame)
                    tick()
            finally:
                writer.release()
            check_video_written(video, n, path)
            os.replace(video, tmp)
        finally:
            if video.exists():
                video.unlink()


def _write_png(folder, renderer, n, spec, tick):
    import cv2

    from vidtrack._atomic import write_bytes

    folder.mkdir(parents=True, exist_ok=False)
    for i in range(n):
        frame = renderer.frame(i)
        ok, data = cv2.imencode(".png", frame)
        if not ok:
            raise VidtrackError(f"{folder}: png encoding of frame {i} failed")
        write_bytes(folder / f"frame_{i:06d}.png", data.tobytes())
        tick()


class _LazyFrames:
    """A sequence of rendered frames for write_cine (renders on demand, keeps the last)."""

    def __init__(self, renderer, n, tick):
        self.renderer, self.n, self.tick = renderer, n, tick
        self._last = (None, None)

    def __len__(self):
        return self.n

    def __getitem__(self, k):
        if self._last[0] != k:
            self._last = (k, self.renderer.frame(k))
            self.tick()
        return self._last[1]


def _write_cine(path, renderer, n, spec, release_frame, tick):
    from vidtrack.footage.cine import write_cine

    write_cine(path, _LazyFrames(renderer, n, tick), fps=spec.fps, bit_depth=spec.bit_depth,
               packed=spec.cine_packed, first_image_no=-int(release_frame),
               timestamps_s=renderer.track.t)
