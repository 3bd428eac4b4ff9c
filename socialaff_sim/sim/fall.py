"""When the robot has fallen: its base too low or its trunk tilted too far from its upright posture at home.

The same test ends a Gymnasium episode (``termination_reason == "fell"``,
:class:`socialaff_sim.environment.episode_end.EpisodeEnd`, thresholds from ``EnvConfig``) and gives an
episode of :func:`socialaff_sim.sim.episode.run_episode` its ``fell`` outcome (:class:`FallWatch`, with the
defaults below).
"""

from __future__ import annotations

import mujoco
import numpy as np

from .simulator import Simulator

__all__ = ["FALL_HEIGHT", "FALL_TILT", "body_up", "tilt_cosine", "tilt_angle", "FallWatch"]

FALL_HEIGHT = 0.5
"""[—]: the robot has fallen when its base is lower than this fraction of its height at home."""
FALL_TILT = 60.0
"""[deg]: the robot has also fallen when its trunk tilts more than this from its upright posture at home."""


def body_up(home_quat: np.ndarray) -> np.ndarray:
    """(3,) the world vertical in the body's own axes at its home orientation ``home_quat`` (w, x, y, z)."""
    h = np.empty(9)
    mujoco.mju_quat2Mat(h, np.asarray(home_quat, dtype=np.float64))
    return h.reshape(3, 3).T @ np.array([0.0, 0.0, 1.0])


def tilt_cosine(quat: np.ndarray, up: np.ndarray) -> float:
    """cos of the angle between the vertical and the body's axis ``up`` (:func:`body_up`) carried by the body's
    orientation ``quat`` (4,) (w, x, y, z): the z row of the rotation matrix of a unit quaternion, times ``up``."""
    w, x, y, z = np.asarray(quat, dtype=np.float64).tolist()  # Python floats: scalar arithmetic without NumPy's
    ux, uy, uz = np.asarray(up, dtype=np.float64).tolist()
    n = w * w + x * x + y * y + z * z
    row = (2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z)
    return (row[0] * ux + row[1] * uy + row[2] * uz) / max(n, 1e-12)


def tilt_angle(quat: np.ndarray, home_quat: np.ndarray) -> float:
    """Angle (rad) between the vertical and the body's home vertical carried by its rotation now.

    ``quat`` / ``home_quat`` (4,) (w, x, y, z): the body's orientation now and at home; a turn
    about the vertical axis alone gives 0.
    """
    return float(np.arccos(min(1.0, max(-1.0, tilt_cosine(quat, body_up(home_quat))))))


class FallWatch:
    """Watches one episode of a :class:`~socialaff_sim.sim.simulator.Simulator` for a fall, frame by frame.

    ``fall_height`` [—] and ``fall_tilt`` [deg]: as :data:`FALL_HEIGHT` and :data:`FALL_TILT`. Call
    :meth:`reset` after the simulator's reset, :meth:`update` after every step; :attr:`time` is then the
    simulated time (s) of the first frame that ended fallen (``None``: never).
    """

    def __init__(self, fall_height: float = FALL_HEIGHT, fall_tilt: float = FALL_TILT) -> None:
        self.fall_height, self.fall_tilt = float(fall_height), float(fall_tilt)
        self.time: float | None = None
        self._low, self._cos, self._up = 0.0, 1.0, np.array([0.0, 0.0, 1.0])
        self._quat = np.arange(3, 7)

    def reset(self, sim: Simulator) -> None:
        """Take the thresholds of ``sim``'s robot (its base height and orientation at home) and forget any fall."""
        self.time = None
        self._low = self.fall_height * float(sim.home_key_frames[0, 2])
        self._cos = float(np.cos(np.deg2rad(self.fall_tilt)))
        self._up = body_up(sim.scene.home_qpos[3:7])
        self._quat = np.asarray(sim.scene.robot_qadr[3:7], dtype=np.int64)

    def fallen(self, sim: Simulator) -> bool:
        """Whether ``sim``'s robot is fallen now (base below the height, or trunk past the tilt)."""
        base = float(sim.robot_key_frames()[0, 2])
        return base < self._low or tilt_cosine(sim.data.qpos[self._quat], self._up) < self._cos

    def update(self, sim: Simulator, t: float) -> bool:
        """Record a fall at simulated time ``t`` (s) if the robot is fallen now and had not fallen before;
        returns whether it has fallen by now."""
        if self.time is None and self.fallen(sim):
            self.time = float(t)
        return self.time is not None
