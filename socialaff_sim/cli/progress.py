"""Progress lines of the command line on stderr: ``[elapsed] message``, silenced by ``--quiet``."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any

__all__ = ["Reporter", "FrameProgress"]


class Reporter:
    """Prints ``[  12.3 s] message`` lines on stderr unless ``quiet``; callable as a progress callback."""

    def __init__(self, quiet: bool = False) -> None:
        self.quiet = quiet
        self.start = time.perf_counter()

    def __call__(self, message: str) -> None:
        if not self.quiet:
            print(f"[{time.perf_counter() - self.start:7.1f} s] {message}", file=sys.stderr, flush=True)


class FrameProgress:
    """An ``on_frame`` callback for ``run_episode`` that reports each quarter of the episode.

    ``inner`` (e.g. a video recorder) is called first with the same arguments.
    """

    def __init__(self, say: Callable[[str], None], label: str, inner: Callable[..., None] | None = None,
                 parts: int = 4) -> None:
        self.say = say
        self.label = label
        self.inner = inner
        self.parts = parts
        self._reported = 0

    def __call__(self, sim: Any, result: Any, subevent: str | None) -> None:
        if self.inner is not None:
            self.inner(sim, result, subevent)
        n = max(int(sim.n_frames), 1)
        part = (int(sim.frame) + 1) * self.parts // n
        if result is None:
            self._reported = 0
            self.say(f"{self.label}: {n} frames to simulate")
        elif part > self._reported:
            self._reported = part
            self.say(f"{self.label}: frame {int(sim.frame) + 1}/{n} (sub-event {subevent or '-'})")
