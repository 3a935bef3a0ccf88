"""The MP4 of a render: H.264 (yuv420p) written by ``ffmpeg`` (through ``imageio-ffmpeg``)
from frames piped by a background thread, so encoding overlaps rendering; the file
appears under its final name only when complete."""

from __future__ import annotations

import os
import queue
import struct
import threading
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.errors import RenderError
from humanoid_ik.outputs.atomic import atomic_path
from humanoid_ik.run.metrics import FrameSamples

__all__ = ["VideoWriter", "mp4_complete"]


def mp4_complete(path: str | os.PathLike) -> bool:
    """True when the file is a whole MP4: its top-level boxes fill the file exactly and
    include the ``moov`` index that ffmpeg writes last (a disk that fills while ffmpeg
    writes its trailer leaves a file without it, which no player opens)."""
    seen = set()
    try:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            pos = 0
            while pos < size:
                f.seek(pos)
                head = f.read(16)
                if len(head) < 8:
                    return False
                length, kind = struct.unpack(">I4s", head[:8])
                if length == 1 and len(head) == 16:  # 64-bit size
                    length = struct.unpack(">Q", head[8:16])[0]
                elif length == 0:  # the box runs to the end of the file
                    length = size - pos
                if length < 8:
                    return False
                seen.add(kind)
                pos += length
    except OSError:
        return False
    return pos == size and b"moov" in seen and b"mdat" in seen


class VideoWriter:
    """An MP4 (H.264, yuv420p) written by ``ffmpeg`` from frames queued by the caller and
    piped by a background thread, so encoding overlaps rendering.

    The file appears under its name only when :meth:`close` succeeds (it is written to a
    temporary name beside it first).

    Args:
        path: the ``.mp4`` to write.
        width, height: frame size [px], even.
        fps: frame rate [1/s].
    """

    def __init__(self, path: str | os.PathLike, width: int, height: int, fps: float):
        import imageio_ffmpeg

        self.path = Path(path)
        self.frames = 0
        self._ctx = atomic_path(self.path, suffix=".mp4")
        self._tmp = self._ctx.__enter__()
        self._queue: queue.Queue[bytes | None] = queue.Queue(maxsize=16)
        self._error: BaseException | None = None
        self._writer = imageio_ffmpeg.write_frames(
            str(self._tmp),
            (width, height),
            fps=fps,
            codec="libx264",
            pix_fmt_out="yuv420p",
            macro_block_size=2,
            quality=7,
            ffmpeg_log_level="error",
            output_params=["-preset", "veryfast", "-threads", "1"],
        )
        self._thread = threading.Thread(target=self._pump, name="mp4-encoder", daemon=True)
        self._thread.start()

    def _pump(self) -> None:
        """The encoder thread: send queued frames to ffmpeg until ``None``; on a failure
        keep the error for the producer and drain the queue so the producer never
        blocks."""
        drained = False
        try:
            self._writer.send(None)
            while True:
                item = self._queue.get()
                if item is None:
                    drained = True
                    break
                self._writer.send(item)
            self._writer.close()
            if self.frames and not mp4_complete(self._tmp):
                raise RenderError("ffmpeg did not finish the file (is the disk full?)")
        except BaseException as exc:  # reported by close()
            self._error = exc
            while not drained and self._queue.get() is not None:  # let the producer finish
                pass

    def _failure(self) -> RenderError:
        """The encoder's error in one line (ffmpeg prints its own reason on stderr)."""
        lines = [ln.strip() for ln in str(self._error).splitlines() if ln.strip()]
        why = lines[0] if lines else repr(self._error)
        return RenderError(f"video encoding to '{self.path}' failed (ffmpeg): {why}")

    def write(self, frame: NDArray[np.uint8]) -> None:
        """Queue one ``(height, width, 3)`` uint8 frame.

        Raises:
            RenderError: the encoder has failed (e.g. ffmpeg cannot write the file).
        """
        if self._error is not None:
            raise self._failure()
        self._queue.put(np.ascontiguousarray(frame).tobytes())
        self.frames += 1

    def add_image(self, frame: FrameSamples, image: NDArray[np.uint8]) -> None:
        """Queue ``frame``'s picture (as an image sink of the film)."""
        self.write(image)

    def close(self, abort: bool = False) -> Path | None:
        """Finish the file; returns its path, or ``None`` when no frame was written or
        ``abort`` is true (the run failed: the temporary file is removed, nothing is
        renamed into place).

        Raises:
            RenderError: ffmpeg failed (not raised when aborting).
        """
        self._queue.put(None)
        self._thread.join()
        if abort or self._error is not None or self.frames == 0:
            self._ctx.__exit__(RenderError, RenderError("aborted"), None)
            if self._error is not None and not abort:
                raise self._failure() from self._error
            return None
        self._ctx.__exit__(None, None, None)
        return self.path
