"""Recording an episode: an MP4 (imageio-ffmpeg) and a PNG contact sheet of evenly spaced frames."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

import numpy as np

from .._atomic import atomic_path
from ..errors import RenderingUnavailableError
from .episode import support_caption
from .render import SceneRenderer, pillow
from .simulator import Simulator, StepResult

__all__ = ["EpisodeRecorder", "contact_sheet", "caption_lines"]


def caption_lines(sim: Simulator, subevent: str | None) -> list[str]:
    """Caption lines: time and sub-event; per sub-goal its contact now and whether it was ever achieved; the
    physics mode with the frame's outside support, the feet's sliding so far and the servos' effort."""
    inter = sim.interaction
    assert inter is not None
    head = (f"{inter.label}  {sim.robot.name}  frame {sim.frame}/{sim.n_frames - 1}  "
            f"t = {sim.time:.2f} s  sub-event: {subevent or '-'}")
    marks = [s.state_text() for s in sim.scorer.subgoals]
    fails = [f.kind for f in sim.scorer.failures if f.triggered]
    tail = "  ".join(marks) + ("   FAILED: " + ", ".join(fails) if fails else "")
    return [head, tail, support_caption(sim)]


def contact_sheet(frames: list[np.ndarray], cols: int = 4) -> np.ndarray:
    """Tile equally sized (H, W, 3) frames into one image, ``cols`` per row (blank cells are white)."""
    if not frames:
        raise ValueError("contact_sheet needs at least one frame")
    h, w, _ = frames[0].shape
    rows = -(-len(frames) // cols)
    cols = min(cols, len(frames))
    sheet = np.full((rows * h, cols * w, 3), 255, dtype=np.uint8)
    for i, f in enumerate(frames):
        r, c = divmod(i, cols)
        sheet[r * h:(r + 1) * h, c * w:(c + 1) * w] = f
    return sheet


class EpisodeRecorder:
    """An ``on_frame`` callback for :func:`~socialaff_sim.sim.episode.run_episode` that writes the video.

    Frames stream into ``video`` (MP4 at the data's frame rate); ``n_sheet`` evenly
    spaced frames are kept for the contact sheet written by :meth:`close`.
    Both files are written atomically.
    """

    def __init__(self, sim: Simulator, video: str | Path | None, sheet: str | Path | None, *,
                 width: int = 640, height: int = 480, n_sheet: int = 8) -> None:
        self.renderer = SceneRenderer(sim, width, height)
        self.video_path = None if video is None else Path(video)
        self.sheet_path = None if sheet is None else Path(sheet)
        self.n_sheet = n_sheet
        self._stack = contextlib.ExitStack()
        self._writer: Any = None
        self._keep: set[int] = set()
        self.sheet_frames: list[np.ndarray] = []
        self.n_written = 0

    def _open(self, sim: Simulator) -> None:
        n = sim.n_frames
        self._keep = set(np.linspace(0, n - 1, min(self.n_sheet, n)).round().astype(int).tolist())
        if self.video_path is not None:
            try:
                import imageio.v2 as imageio
            except ImportError:
                raise RenderingUnavailableError("writing MP4 needs imageio and imageio-ffmpeg (pip install socialaff-sim[render])") from None
            tmp = self._stack.enter_context(atomic_path(self.video_path, suffix=".mp4"))
            self._writer = imageio.get_writer(tmp, fps=float(sim.interaction.fps), codec="libx264",  # type: ignore[union-attr]
                                              quality=7, macro_block_size=16, ffmpeg_log_level="error")

    def __call__(self, sim: Simulator, result: StepResult | None, subevent: str | None) -> None:
        if result is None:
            self._open(sim)
        rgb = self.renderer.render(caption_lines(sim, subevent))
        if self._writer is not None:
            self._writer.append_data(rgb)
            self.n_written += 1
        if sim.frame in self._keep:
            self.sheet_frames.append(rgb)

    def __enter__(self) -> EpisodeRecorder:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is None:
            self.close()
            return
        try:  # drop the half-written video
            if self._writer is not None:
                self._writer.close()
                self._writer = None
            self._stack.__exit__(exc_type, exc, tb)
        finally:
            self.renderer.close()

    def close(self) -> None:
        """Finish the video, write the contact sheet and free the renderer."""
        try:
            if self._writer is not None:
                self._writer.close()
                self._writer = None
            self._stack.close()
            if self.sheet_path is not None and self.sheet_frames:
                with atomic_path(self.sheet_path, suffix=".png") as tmp:
                    pillow().Image.fromarray(contact_sheet(self.sheet_frames)).save(tmp, format="PNG")
        finally:
            self.renderer.close()
