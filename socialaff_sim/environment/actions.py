"""From a policy's action to the key-frame targets the robot is sent for the end of the data frame.

The action is a (5, 3) float32 box (rows: base, left wrist, right wrist, left ankle, right ankle;
metres, robot frame) laid out by :class:`~socialaff_sim.environment.config.EnvConfig`:

* ``targets``: the targets themselves, in ``target_low … target_high`` per coordinate;
* ``residual``: offsets in [−ρ, ρ] (ρ = ``residual_bound``) added to the frame's proposal; with
  ``residual_groups`` the box is (G, 3), one offset per group of key joints, and with ``residual_tau``
  the offset sent is the action's, low-pass filtered (:mod:`~socialaff_sim.environment.residual`).

:class:`ActionDecoder` checks an action (shape (R, 3) or (3R,), R the box's rows, finite), clips it to the
box, and projects what it asks for onto the robot's envelope
(:class:`~socialaff_sim.environment.action_limits.FeasibleTargets`), keeping how far each row was
moved (``info["action_adjustment"]``). Targets unchanged within a frame's control steps are projected
once: the later steps reuse the frame's targets (and so give the frame's physics exactly).
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from .._norms import norms
from ..data.skeletons import N_KEY
from ..errors import SimulationError
from .action_limits import FeasibleTargets
from .arrays import same_array
from .config import EnvConfig
from .residual import ResidualMap

__all__ = ["action_box", "ActionDecoder"]


def action_box(config: EnvConfig) -> spaces.Box:
    """The (R, 3) float32 action space of ``config.action_mode`` (R = 5, or the residual groups' G; see the module
    docstring)."""
    if config.action_mode == "targets":
        low = np.tile(np.asarray(config.target_low, np.float32), (N_KEY, 1))
        high = np.tile(np.asarray(config.target_high, np.float32), (N_KEY, 1))
        return spaces.Box(low=low, high=high, dtype=np.float32)
    r = np.float32(config.residual_bound)
    rows = N_KEY if config.residual_groups is None else len(config.residual_groups)
    return spaces.Box(low=-r, high=r, shape=(rows, 3), dtype=np.float32)


class ActionDecoder:
    """Checks, clips and projects the actions of one environment (see the module docstring).

    ``config``: the environment's layout (its ``action_mode`` and bounds); ``feasible``: the projection onto
    the robot's envelope.
    """

    def __init__(self, config: EnvConfig, feasible: FeasibleTargets) -> None:
        self.residual = config.action_mode != "targets"
        self.feasible = feasible
        self.space = action_box(config)
        """The action space (the environment's ``action_space``)."""
        self.offsets = ResidualMap(config.residual_groups, config.residual_tau)
        """From a residual action to the offset of each control step."""
        self._rows = int(self.space.shape[0])  # type: ignore[index]
        # The box's bounds widened to float64 once (exact), so that clipping a float64 action mixes no types.
        self._low, self._high = self.space.low.astype(np.float64), self.space.high.astype(np.float64)
        self.adjustment = np.zeros(N_KEY)
        """(5,) metres each row of the latest projected action was moved by the projection."""
        self._projected: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def reset(self) -> None:
        """Forget the previous episode's projection."""
        self._projected = None
        self.adjustment = np.zeros(N_KEY)
        self.offsets.reset()

    def clip(self, action: np.ndarray) -> np.ndarray:
        """(R, 3) float64 ``action`` clipped to the box; :class:`~socialaff_sim.errors.SimulationError` on a
        wrong shape or a non-finite entry."""
        a = np.asarray(action, dtype=np.float64)
        n = self._rows
        if a.shape == (n * 3,):
            a = a.reshape(n, 3)
        if a.shape != (n, 3):
            what = "rows base, wrists, ankles" if n == N_KEY and self.offsets.n_groups == N_KEY else "a row per residual group"
            raise SimulationError(f"action: expected shape ({n}, 3) ({what}; metres), found {a.shape}")
        if not np.logical_and.reduce(np.isfinite(a), axis=None):  # ndarray.all without its wrappers
            raise SimulationError("action: expected finite numbers, found NaN or inf")
        return np.minimum(np.maximum(a, self._low), self._high)  # np.clip's value, less overhead

    def targets(self, a: np.ndarray, proposal: np.ndarray, within_frame: bool, previous_base: np.ndarray,
                fps: float, seconds: float = 0.0) -> np.ndarray:
        """(5, 3) robot-frame targets (m) for the clipped action ``a`` (:meth:`clip`).

        ``proposal`` (5, 3): the frame's proposal (what a residual adds to); ``within_frame``: a control step
        after the frame's first (an unchanged offset then keeps the frame's targets); ``previous_base`` (3,):
        the base target sent last; ``fps``: the recording's frame rate (the envelope's speed limits);
        ``seconds``: the control step's simulated time (the residual filter's Δt).
        """
        sent = self.offsets.step(a, seconds) if self.residual else a
        if within_frame and self._projected is not None and same_array(sent, self._projected[0]):
            return self._projected[1]  # the same offset within the frame: the same targets as its last step
        wanted = proposal + sent if self.residual else a
        targets = self.feasible.project(wanted, previous_base, fps)
        d = targets - wanted
        self.adjustment = norms(d, axis=1)
        self._projected = (np.array(sent), targets, self.adjustment)
        return targets
