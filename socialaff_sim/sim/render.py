"""Offscreen rendering of the simulator: a side view, the five targets, a caption.

The OpenGL context is made here rather than through ``mujoco.Renderer`` so that
the backend does not depend on ``MUJOCO_GL`` having been set before MuJoCo was
first imported: ``MUJOCO_GL`` (``egl``, ``osmesa`` or ``glfw``) is honoured when
set, EGL is used otherwise. When the libraries are missing,
:class:`~socialaff_sim.errors.RenderingUnavailableError` says what to install.
The human is drawn red, the robot green, the object yellow and the targets as
small blue spheres; :meth:`SceneRenderer.close` frees the GL context.
"""

from __future__ import annotations

import os
from typing import Any

import mujoco
import numpy as np

from ..errors import RenderingUnavailableError
from .framing import fit_camera
from .simulator import Simulator

__all__ = ["SceneRenderer", "gl_context", "INSTALL_HINT", "draw_caption", "caption_band", "pillow"]

INSTALL_HINT = (
    "install the EGL libraries (Debian/Ubuntu: apt-get install libegl1 libegl-mesa0 libgl1) "
    "and set MUJOCO_GL=egl, or set MUJOCO_GL=osmesa with libosmesa6 installed"
)
TARGET_RGBA = np.array([0.15, 0.35, 0.95, 0.9], dtype=np.float32)
TARGET_RADIUS = 0.035


def gl_context(width: int, height: int) -> Any:
    """A current offscreen OpenGL context of the configured backend (EGL by default)."""
    backend = os.environ.get("MUJOCO_GL", "").strip().lower() or "egl"
    try:
        if backend == "egl":
            from mujoco.egl import GLContext
        elif backend == "osmesa":
            from mujoco.osmesa import GLContext  # type: ignore[no-redef]
        elif backend in ("glfw", "glx", "1", "true", "on", "enable", "enabled"):
            if not os.environ.get("DISPLAY"):
                raise RenderingUnavailableError(f"MUJOCO_GL={backend} needs a display (DISPLAY is unset); {INSTALL_HINT}")
            from mujoco.glfw import GLContext  # type: ignore[no-redef]
        else:
            raise RenderingUnavailableError(f"rendering is disabled or unknown (MUJOCO_GL={backend!r}); {INSTALL_HINT}")
        ctx = GLContext(width, height)
        ctx.make_current()
    except RenderingUnavailableError:
        raise
    except Exception as exc:  # ImportError, OSError, EGL/GL errors: all mean "no offscreen GL here"
        raise RenderingUnavailableError(
            f"offscreen rendering with MUJOCO_GL={backend} is unavailable ({type(exc).__name__}: {exc}); {INSTALL_HINT}"
        ) from None
    return ctx


def pillow() -> Any:
    """The PIL package, or :class:`RenderingUnavailableError` saying how to install it."""
    try:
        import PIL.Image
        import PIL.ImageDraw
        import PIL.ImageFont
    except ImportError:
        raise RenderingUnavailableError("captions and contact sheets need Pillow: pip install socialaff-sim[render]") from None
    return PIL


def _font(size: int) -> Any:
    ImageFont = pillow().ImageFont

    try:
        return ImageFont.load_default(size=size)
    except (TypeError, OSError):  # Pillow < 10.1 or no FreeType
        return ImageFont.load_default()


def caption_band(n_lines: int, size: int) -> int:
    """Height (px) of the dark band :func:`draw_caption` draws for ``n_lines`` lines of ``size`` px text."""
    return size // 3 + n_lines * (size + size // 3) if n_lines else 0


def draw_caption(rgb: np.ndarray, lines: list[str], size: int = 18) -> np.ndarray:
    """``rgb`` (H, W, 3) uint8 with ``lines`` of text on a dark band at the top."""
    pil = pillow()
    Image, ImageDraw = pil.Image, pil.ImageDraw

    img = Image.fromarray(rgb)
    draw = ImageDraw.Draw(img, "RGBA")
    font = _font(size)
    pad = size // 3
    band = caption_band(len(lines), size)
    draw.rectangle((0, 0, img.width, band), fill=(0, 0, 0, 150))
    for i, text in enumerate(lines):
        draw.text((pad * 2, pad + i * (size + pad)), text, fill=(255, 255, 255, 255), font=font)
    return np.asarray(img)


class SceneRenderer:
    """Renders a :class:`Simulator`'s current state to RGB arrays; one GL context per instance."""

    def __init__(self, sim: Simulator, width: int = 640, height: int = 480) -> None:
        self.sim = sim
        self.width, self.height = width, height
        self._ctx = gl_context(width, height)
        self._model: mujoco.MjModel | None = None
        self._con: Any = None
        self._opt = mujoco.MjvOption()
        self._pert = mujoco.MjvPerturb()
        self._cam = mujoco.MjvCamera()
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._buf = np.empty((height, width, 3), dtype=np.uint8)

    def _bind(self, model: mujoco.MjModel) -> None:
        """(Re)create the MuJoCo render context for ``model`` (scenes differ per skeleton layout)."""
        if model is self._model:
            return
        if self.width > model.vis.global_.offwidth or self.height > model.vis.global_.offheight:
            raise RenderingUnavailableError(
                f"image size {self.width}x{self.height} exceeds the scene's offscreen buffer "
                f"{model.vis.global_.offwidth}x{model.vis.global_.offheight}"
            )
        self._ctx.make_current()
        if self._con is not None:
            self._con.free()
        self._con = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._con)
        self._scn = mujoco.MjvScene(model, maxgeom=2000)
        self._model = model

    def __enter__(self) -> SceneRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Free the MuJoCo render context and the GL context (idempotent)."""
        if getattr(self, "_ctx", None) is None:
            return
        if self._con is not None:
            self._ctx.make_current()
            self._con.free()
            self._con = None
        self._ctx.free()
        self._ctx = None

    def _aim(self, band: float, targets: np.ndarray) -> None:
        """Side camera: looking across the robot-human axis at both of them, where they are now (the robot's
        root as simulated, not where it was placed: it walks in), from at least the distance that fits both
        standing; nearer the look-at height and farther than that as needed to keep every visible body, the
        object and the targets ``targets`` (K, 3) world inside the image below the caption band (the top
        ``band`` fraction of its height)."""
        sim = self.sim
        robot = np.array(sim.data.qpos[sim.scene.robot_qadr[:3]])
        human = sim.pose.joints[min(sim.frame, sim.n_frames - 1)]
        human_xy = np.nanmean(human, axis=0)[:2] if np.isfinite(human).any() else robot[:2] + sim.frame_R.rotation[:2, 0]
        mid = 0.5 * (robot[:2] + human_xy)
        sep = float(np.linalg.norm(human_xy - robot[:2]))
        model, data = sim.scene.model, sim.data
        # Every body's geoms as their bounding spheres: the static world (floor, chair) is left to fall where it may.
        shown = ((model.geom_bodyid != 0) & (model.geom_rgba[:, 3] > 0)
                 & (np.asarray(self._opt.geomgroup)[np.clip(model.geom_group, 0, 5)] != 0)
                 & (model.geom_rbound > 0) & (model.geom_rbound < 1.0))
        targets = np.asarray(targets, dtype=np.float64).reshape(-1, 3)
        targets = targets[np.isfinite(targets).all(axis=1)]
        centres = np.concatenate([data.geom_xpos[shown], targets])
        radii = np.concatenate([model.geom_rbound[shown], np.full(len(targets), TARGET_RADIUS)])
        cam = self._cam
        cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        cam.azimuth = float(np.degrees(sim.frame_R.yaw)) + 90.0
        cam.elevation = -12.0
        # Far enough that both, 2 m tall, fit (45° vertical field of view); farther when a raised arm needs it.
        lookat, cam.distance = fit_camera(centres, radii, mid, cam.azimuth, cam.elevation, float(model.vis.global_.fovy),
                                          self.width / self.height, band, max(3.4, 1.3 * sep + 1.5))
        cam.lookat[:] = lookat

    def render(self, caption: list[str] | None = None, targets: np.ndarray | None = None) -> np.ndarray:
        """(H, W, 3) uint8 image of the current state; ``targets`` (5, 3) robot frame (default: the last ones)."""
        if self._ctx is None:
            raise RenderingUnavailableError("this renderer has been closed")
        sim = self.sim
        self._bind(sim.scene.model)
        tg = sim.last_targets if targets is None else targets
        world = sim.frame_R.to_world(np.asarray(tg))
        size = max(12, self.height // 26)
        self._aim(caption_band(len(caption or []), size) / self.height, world)
        self._ctx.make_current()
        mujoco.mjv_updateScene(self._model, sim.data, self._opt, self._pert, self._cam,
                               mujoco.mjtCatBit.mjCAT_ALL, self._scn)
        scn = self._scn
        for p in world:
            if scn.ngeom >= scn.maxgeom or not np.isfinite(p).all():
                continue
            mujoco.mjv_initGeom(scn.geoms[scn.ngeom], mujoco.mjtGeom.mjGEOM_SPHERE,
                                np.array([TARGET_RADIUS, 0.0, 0.0]), p, np.eye(3).ravel(), TARGET_RGBA)
            scn.ngeom += 1
        mujoco.mjr_render(self._rect, scn, self._con)
        mujoco.mjr_readPixels(self._buf, None, self._rect, self._con)
        rgb = np.flipud(self._buf).copy()
        if caption:
            rgb = draw_caption(rgb, caption, size=size)
        return rgb
