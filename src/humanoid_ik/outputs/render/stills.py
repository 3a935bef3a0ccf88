"""Still pictures of a render: PNG snapshots of chosen frames, a contact sheet of frames
spread over the run, and an animated GIF, each written atomically. :class:`Stills` and
:class:`GifFrames` collect the frames they need as image sinks of the film."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.outputs.atomic import atomic_path
from humanoid_ik.outputs.render.drawing import COLORS, TRAIL_COLORS
from humanoid_ik.run.metrics import FrameSamples

__all__ = [
    "GIF_MAX_FPS",
    "GifFrames",
    "Stills",
    "sheet_indices",
    "snapshot_indices",
    "snapshot_plan",
    "write_contact_sheet",
    "write_gif",
    "write_png",
]

GIF_MAX_FPS = 25.0
"""The GIF keeps every k-th frame, the smallest k that plays at most this fast [1/s]."""


def write_png(path: Path, image: NDArray[np.uint8]) -> Path:
    """Write ``image`` ``(height, width, 3)`` to ``path`` as PNG, atomically."""
    from PIL import Image

    with atomic_path(path) as tmp:
        Image.fromarray(image).save(tmp, format="PNG")
    return path


def write_contact_sheet(
    path: Path, tiles: Sequence[tuple[int, float, NDArray[np.uint8]]], max_tile_width: int = 320
) -> Path:
    """A grid of frames, at most 4 per row, each labelled with its index and time.

    Args:
        path: the PNG to write (atomically).
        tiles: ``(frame index, time [s], image (height, width, 3))`` in order.
        max_tile_width: wider frames are scaled down to this width [px].
    """
    from PIL import Image, ImageDraw

    n = len(tiles)
    cols = min(4, n)
    rows = math.ceil(n / cols)
    h0, w0 = tiles[0][2].shape[:2]
    scale = min(1.0, max_tile_width / w0)
    tw, th = max(1, round(w0 * scale)), max(1, round(h0 * scale))
    pad = 4
    sheet = Image.new("RGB", (cols * (tw + pad) + pad, rows * (th + pad) + pad), (20, 20, 24))
    draw = ImageDraw.Draw(sheet)
    for k, (idx, t, img) in enumerate(tiles):
        tile = Image.fromarray(img)
        if scale != 1.0:
            tile = tile.resize((tw, th), Image.Resampling.BILINEAR)
        x = pad + (k % cols) * (tw + pad)
        y = pad + (k // cols) * (th + pad)
        sheet.paste(tile, (x, y))
        draw.text((x + 3, y + 2), f"#{idx}  {t:.2f} s", fill=(255, 255, 255))
    with atomic_path(path) as tmp:
        sheet.save(tmp, format="PNG")
    return path


def write_gif(path: Path, frames: Sequence[NDArray[np.uint8]], frame_ms: int) -> Path:
    """An animated GIF with one palette for every frame (taken from a few frames spread
    over the run, no dithering), so that Pillow stores only what changed between frames.

    Args:
        path: the GIF to write (atomically).
        frames: the images ``(height, width, 3)``, in order.
        frame_ms: how long each frame shows [ms].
    """
    from PIL import Image

    picks = [frames[k] for k in np.linspace(0, len(frames) - 1, min(6, len(frames))).astype(int)]
    # the marker and trail colours get palette entries of their own
    swatch = np.array(
        [[255 * np.array(c[:3]) for c in (*COLORS.values(), *TRAIL_COLORS)]], dtype=np.uint8
    )
    width = picks[0].shape[1]
    swatch = np.repeat(np.repeat(swatch, 8, axis=0), -(-width // swatch.shape[1]), axis=1)
    picks.append(swatch[:, :width])
    palette = Image.fromarray(np.concatenate(picks, axis=0)).quantize(
        colors=255, method=Image.Quantize.MEDIANCUT
    )
    imgs = [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
    with atomic_path(path) as tmp:
        imgs[0].save(
            tmp,
            format="GIF",
            save_all=True,
            append_images=imgs[1:],
            duration=frame_ms,
            loop=0,
            optimize=False,
        )
    return path


def snapshot_indices(times: Sequence[float], fps: float, n: int) -> list[int]:
    """The frames saved as PNG: those nearest ``times`` [s] at ``fps`` [1/s] (clipped to the
    last of ``n`` frames), or without ``times`` four frames spread over the run."""
    return snapshot_plan(times, fps, n)[0]


def snapshot_plan(times: Sequence[float], fps: float, n: int) -> tuple[list[int], list[str]]:
    """:func:`snapshot_indices` and a note for every snapshot time that does not get a
    frame of its own, so none is dropped silently: a time after the last rendered frame
    (the last frame is saved for it) and times that fall on the same frame.

    Returns:
        The frame indices, and the notes (one line each).
    """
    if not times:
        return (sorted({round(k * (n - 1) / 3) for k in range(4)}) if n > 1 else [0]), []
    notes: list[str] = []
    by_frame: dict[int, list[float]] = {}
    late = [t for t in times if round(t * fps) > n - 1]
    for t in times:
        if t not in late:
            by_frame.setdefault(round(t * fps), []).append(t)
    for i, ts in sorted(by_frame.items()):
        if len(ts) > 1:
            shown = ", ".join(f"{t:g} s" for t in ts)
            notes.append(
                f"snapshots at {shown} fall on the same frame #{i} ({i / fps:.2f} s at "
                f"{fps:g} frames/s); one PNG"
            )
    if late:
        shown = ", ".join(f"{t:g} s" for t in late)
        notes.append(
            f"snapshot(s) at {shown} after the last rendered frame #{n - 1} "
            f"({(n - 1) / fps:.2f} s); that frame is saved for them"
        )
        by_frame.setdefault(n - 1, [])
    return sorted(by_frame), notes


def sheet_indices(count: int, n: int) -> list[int]:
    """The ``count`` frames of the contact sheet, spread evenly over ``n`` frames."""
    if count <= 0:
        return []
    if count >= n:
        return list(range(n))
    return sorted({round(k * (n - 1) / (count - 1)) for k in range(count)} if count > 1 else {0})


class Stills:
    """Keeps the frames of the PNG snapshots and of the contact sheet (an image sink).

    Args:
        snapshots: indices of the frames saved as PNG.
        sheet: indices of the frames on the contact sheet.
    """

    def __init__(self, snapshots: Sequence[int], sheet: Sequence[int]):
        self.snapshots = sorted(set(snapshots))
        self.sheet = sorted(set(sheet))
        self._wanted = set(self.snapshots) | set(self.sheet)
        self.kept: dict[int, tuple[float, NDArray[np.uint8]]] = {}

    def add_image(self, frame: FrameSamples, image: NDArray[np.uint8]) -> None:
        """Keep ``image`` when its frame is a snapshot or on the sheet."""
        if frame.index in self._wanted:
            self.kept[frame.index] = (frame.time, image)

    def write(self, folder: Path) -> tuple[tuple[Path, ...], Path | None]:
        """Write ``frame_NNNN.png`` for each snapshot rendered and ``contact_sheet.png``.

        Returns:
            The PNG snapshots, and the contact sheet (``None`` when none of its frames
            was rendered).
        """
        kept = self.kept
        snaps = tuple(
            write_png(folder / f"frame_{i:04d}.png", kept[i][1])
            for i in self.snapshots
            if i in kept
        )
        tiles = [(i, kept[i][0], kept[i][1]) for i in self.sheet if i in kept]
        sheet = write_contact_sheet(folder / "contact_sheet.png", tiles) if tiles else None
        return snaps, sheet


class GifFrames:
    """Keeps every ``step``-th frame for the GIF (an image sink).

    Args:
        fps: the scene's frame rate [1/s]; the GIF plays at most :data:`GIF_MAX_FPS`.

    Attributes:
        step: the GIF keeps frames ``0, step, 2 step...``.
        frame_ms: how long each GIF frame shows [ms], so it plays in real time.
    """

    def __init__(self, fps: float):
        self.step = max(1, math.ceil(fps / GIF_MAX_FPS))
        self.frame_ms = round(1000 * self.step / fps)
        self.frames: list[NDArray[np.uint8]] = []

    def add_image(self, frame: FrameSamples, image: NDArray[np.uint8]) -> None:
        """Keep ``image`` on every ``step``-th frame."""
        if frame.index % self.step == 0:
            self.frames.append(image)

    def write(self, path: Path) -> Path | None:
        """Write the GIF; ``None`` (nothing written) when no frame was kept."""
        return write_gif(path, self.frames, self.frame_ms) if self.frames else None
