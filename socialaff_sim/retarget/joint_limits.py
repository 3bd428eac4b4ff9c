"""The joint range and joint velocity limits of the IK, merged into one box on Δq per data frame."""

from __future__ import annotations

import mink
import mujoco
import numpy as np

from ..errors import SimulationError

__all__ = ["JointBoxLimit"]


class JointBoxLimit(mink.Limit):
    """A mink ConfigurationLimit and VelocityLimit on the same joints, merged into one box per frame.

    Row for row it is the tighter of the two limits' bounds on Δq, computed from
    their ranges, gain and velocities: ``gain·(q_max − q)`` (and below) and
    ``v_max·dt``. The velocity bound applies to the whole data frame: across the
    IK iterations of one frame the joints may move at most ``v_max·dt`` from where
    the frame started (:meth:`begin_frame`), so a single iteration can use all of
    it. Merging halves the QP's inequality rows.

    ``free_dofs`` (6,) and ``free_speed`` (6,), optional: the floating base's dofs and
    their speed limits (m/s for the translation, rad/s for the rotation), which bound
    each QP step of the base to ``free_speed·dt`` (a floating base has no range, and
    without a bound a step that conflicting constraints make costly elsewhere could
    swing the whole robot).
    """

    def __init__(self, model: mujoco.MjModel, config_limit: mink.ConfigurationLimit,
                 velocity_limit: mink.VelocityLimit, free_dofs: np.ndarray | None = None,
                 free_speed: np.ndarray | None = None) -> None:
        if not np.array_equal(config_limit.indices, velocity_limit.indices):
            raise SimulationError("joint limits: the velocity limit must cover exactly the range-limited joints, in order")
        if len(config_limit._ball_qposadr):
            raise SimulationError("joint limits: ball joints are not supported")
        self.config_limit = config_limit
        self.velocity_limit = velocity_limit
        dofs = np.asarray(config_limit.indices, dtype=np.int64)
        self._qadr = model.jnt_qposadr[model.dof_jntid[dofs]] if dofs.size else np.zeros(0, dtype=np.int64)
        # Hinge and slide coordinates are scalars: q_max ⊖ q is a plain difference, and G never changes.
        self._lower = config_limit.lower[self._qadr]
        self._upper = config_limit.upper[self._qadr]
        self._G = (np.vstack([config_limit.projection_matrix, -config_limit.projection_matrix])
                   if config_limit.projection_matrix is not None else None)
        self._start = np.zeros(len(self._qadr))
        self._free_speed = np.zeros(0)
        if free_dofs is not None and free_speed is not None and len(free_dofs):
            rows = np.zeros((len(free_dofs), model.nv))
            rows[np.arange(len(free_dofs)), np.asarray(free_dofs, dtype=np.int64)] = 1.0
            free_G = np.vstack([rows, -rows])
            self._G = free_G if self._G is None else np.vstack([self._G, free_G])
            self._free_speed = np.asarray(free_speed, dtype=np.float64)

    def begin_frame(self, q: np.ndarray) -> None:
        """Remember the configuration (nq,) the current frame starts from."""
        self._start = np.asarray(q)[self._qadr].copy()

    def compute_qp_inequalities(self, configuration: mink.Configuration, dt: float) -> mink.Constraint:
        if self._G is None:
            return mink.Constraint()
        q = configuration.data.qpos[self._qadr]
        gain = self.config_limit.gain
        step = self.velocity_limit.limit * dt
        moved = q - self._start
        upper = np.maximum(np.minimum(gain * (self._upper - q), step - moved), 0.0)
        lower = np.maximum(np.minimum(gain * (q - self._lower), step + moved), 0.0)
        free = self._free_speed * dt
        return mink.Constraint(G=self._G, h=np.concatenate([upper, lower, free, free]))
