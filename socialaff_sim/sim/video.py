"""Recording an episode: an MP4 (imageio-ffmpeg) and a PNG contact sheet of evenly spaced frames and of the
moments the sub-goals' flags change."""

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

__all__ = ["EpisodeRecorder", "contact_sheet", "caption_lines", "sheet_frames"]


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


def sheet_frames(n_frames: int, n_sheet: int, moments: list[int]) -> list[int]:
    """Frame indices of a contact sheet: ``n_sheet`` evenly spaced over ``n_frames``, each frame of ``moments``
    (the moments a sub-goal's flag changes) in place of the nearest evenly spaced one that is neither the first
    nor the last frame nor another moment (added when none is left); sorted."""
    chosen = set(np.linspace(0, n_frames - 1, min(n_sheet, n_frames)).round().astype(int).tolist())
    fixed = {0, n_frames - 1}
    for m in sorted(set(moments)):
        if m in chosen:
            fixed.add(m)
            continue
        free = [f for f in chosen if f not in fixed]
        if free:
            chosen.discard(min(free, key=lambda f: (abs(f - m), f)))
        chosen.add(m)
        fixed.add(m)
    return sorted(chosen)


class EpisodeRecorder:
    """An ``on_frame`` callback for :func:`~socialaff_sim.sim.episode.run_episode` that writes the video.

    Frames stream into ``video`` (MP4 at the data's frame rate); the contact sheet written by :meth:`close`
    holds ``n_sheet`` evenly spaced frames, with the first frame at which each sub-goal shows "now touching" and
    the first at which it shows as achieved in place of the nearest (:func:`sheet_frames`), so that the moment a
    flag claims is on the sheet. Both files are written atomically.
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
        self._kept: dict[int, np.ndarray] = {}
        self._seen: set[tuple[str, str]] = set()
        self.moments: list[int] = []
        """Frames at which a sub-goal first showed "now touching" or first showed as achieved."""
        self.sheet_frames: list[np.ndarray] = []
        self.n_written = 0
        self._n = 0

    def _open(self, sim: Simulator) -> None:
        n = self._n = sim.n_frames
        self._keep = set(sheet_frames(n, self.n_sheet, []))  # the evenly spaced frames; the moments come as seen
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
        moment = False
        for goal in sim.scorer.subgoals:
            for flag, on in (("now", goal.current), ("achieved", goal.success)):
                if on and (goal.name, flag) not in self._seen:
                    self._seen.add((goal.name, flag))
                    moment = True
        if moment and sim.frame not in self.moments:
            self.moments.append(sim.frame)
        if sim.frame in self._keep or moment:
            self._kept[sim.frame] = rgb

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
            self.sheet_frames = [self._kept[f] for f in sheet_frames(self._n, self.n_sheet, self.moments)
                                 if f in self._kept]
            if self.sheet_path is not None and self.sheet_frames:
                with atomic_path(self.sheet_path, suffix=".png") as tmp:
                    pillow().Image.fromarray(contact_sheet(self.sheet_frames)).save(tmp, format="PNG")
        finally:
            self.renderer.close()
