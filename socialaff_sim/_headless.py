"""Offscreen rendering by default: choose MuJoCo's OpenGL backend before MuJoCo is imported.

MuJoCo (and dm_control) read ``MUJOCO_GL`` once, when they are first imported, and fall back to
GLFW, which needs a display and warns on every machine without one. ``import socialaff_sim``
therefore picks a backend first: the user's ``MUJOCO_GL`` if set; nothing (GLFW) when a display is
present; otherwise EGL, or OSMesa when only OSMesa's library is installed.
"""

from __future__ import annotations

import ctypes.util
import os
import sys
from collections.abc import Callable, MutableMapping
from dataclasses import dataclass

__all__ = ["GLChoice", "choose_gl_backend", "GL_CHOICE"]


@dataclass(frozen=True)
class GLChoice:
    """The OpenGL backend MuJoCo will use and why."""

    backend: str | None
    """Value of ``MUJOCO_GL`` (``"egl"``, ``"osmesa"``, ``"glfw"``, …); ``None``: unset, MuJoCo's default (GLFW)."""
    reason: str
    """One sentence for ``--verbose``."""


def choose_gl_backend(
    environ: MutableMapping[str, str] | None = None,
    find_library: Callable[[str], str | None] = ctypes.util.find_library,
    mujoco_imported: bool | None = None,
) -> GLChoice:
    """Set ``MUJOCO_GL`` in ``environ`` (default ``os.environ``) when no display is present; returns the choice."""
    env = os.environ if environ is None else environ
    imported = ("mujoco" in sys.modules) if mujoco_imported is None else mujoco_imported
    late = " (MuJoCo was imported earlier, so its own choice stands)" if imported else ""
    user = env.get("MUJOCO_GL", "").strip()
    if user:
        return GLChoice(user.lower(), f"MUJOCO_GL={user} set by the user")
    if env.get("DISPLAY") or env.get("WAYLAND_DISPLAY"):
        return GLChoice(None, "a display is present: MuJoCo's default (GLFW) renders through it")
    if find_library("EGL"):
        backend, why = "egl", "no display; EGL found"
    elif find_library("OSMesa"):
        backend, why = "osmesa", "no display; no EGL, OSMesa found"
    else:
        # Still EGL: it avoids GLFW's warning, and rendering raises a clear error naming the packages.
        backend, why = "egl", "no display and neither EGL nor OSMesa found (install libegl1 libegl-mesa0 libgl1 to render)"
    env["MUJOCO_GL"] = backend
    return GLChoice(backend, f"MUJOCO_GL={backend} chosen: {why}{late}")


GL_CHOICE: GLChoice = choose_gl_backend()
"""The choice made when ``socialaff_sim`` was imported."""
