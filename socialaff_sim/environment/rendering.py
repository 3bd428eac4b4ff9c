"""The environment's two render modes: ``rgb_array`` frames and a ``human`` window.

``rgb_array`` uses the simulator's offscreen :class:`~socialaff_sim.sim.render.SceneRenderer`
(EGL by default; a :class:`~socialaff_sim.errors.RenderingUnavailableError` says what
to install when it is missing). ``human`` opens MuJoCo's interactive viewer
(``mujoco.viewer.launch_passive``) on the simulator's model and refreshes it after
every step; it needs a display, and without one the environment's constructor
raises :class:`~socialaff_sim.errors.RenderingUnavailableError` at once.
"""

from __future__ import annotations

import os
from typing import Any

import mujoco
import numpy as np

from ..errors import RenderingUnavailableError
from ..sim.render import SceneRenderer
from ..sim.simulator import Simulator

__all__ = ["display_available", "require_display", "FrameRenderer", "HumanViewer"]


def display_available() -> bool:
    """Whether an X11 or Wayland display is set (what an on-screen window needs on Linux)."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def require_display() -> None:
    """Raise :class:`RenderingUnavailableError` when no display exists."""
    if not display_available():
        raise RenderingUnavailableError(
            "render_mode='human' opens a window and needs a display (DISPLAY and WAYLAND_DISPLAY are unset); "
            "on a headless machine use render_mode='rgb_array' and save the frames (e.g. imageio.mimsave)"
        )


class FrameRenderer:
    """``rgb_array`` frames of whichever simulator the episode uses (renderers kept per simulator)."""

    def __init__(self, width: int, height: int) -> None:
        self.width, self.height = width, height
        self._renderers: dict[int, SceneRenderer] = {}

    def render(self, sim: Simulator, caption: list[str]) -> np.ndarray:
        """(H, W, 3) uint8 image of ``sim``'s current state with ``caption`` on top."""
        r = self._renderers.get(id(sim))
        if r is None:
            r = self._renderers[id(sim)] = SceneRenderer(sim, self.width, self.height)
        return r.render(caption=caption)

    def close(self) -> None:
        for r in self._renderers.values():
            r.close()
        self._renderers.clear()


class HumanViewer:
    """MuJoCo's passive viewer on the current simulator, relaunched when the model changes."""

    def __init__(self) -> None:
        require_display()
        self._handle: Any = None
        self._model: mujoco.MjModel | None = None

    def show(self, sim: Simulator) -> None:
        model, data = sim.scene.model, sim.data
        if self._handle is not None and (self._model is not model or not self._handle.is_running()):
            self.close()
        if self._handle is None:
            try:
                import mujoco.viewer

                self._handle = mujoco.viewer.launch_passive(model, data)
            except Exception as exc:  # GLFW missing or failing: no window possible here
                raise RenderingUnavailableError(
                    f"render_mode='human': MuJoCo's viewer could not open a window ({type(exc).__name__}: {exc}); "
                    "use render_mode='rgb_array'"
                ) from None
            self._model = model
        self._handle.sync()

    def close(self) -> None:
        if self._handle is not None:
            self._handle.close()
        self._handle = None
        self._model = None
