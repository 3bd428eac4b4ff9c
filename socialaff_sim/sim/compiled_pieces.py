"""What ``BalanceConfig.qp_kernel = "numba"`` compiles of one balance controller, made with it (session 33–34).

Each piece is the NumPy reference's arithmetic in a no-Python loop (:func:`~socialaff_sim.inference.compiled.njit`,
fast-math off), MuJoCo's own calls kept: the QP's cost and rows (:mod:`~.qp_kernel`, DAQP then as before) and its
torque bounds; the centre-of-pressure rows (:mod:`~.cop_kernel`); the feet's contacts with the floor, their soles and
the support box (:mod:`~.support_kernel`); the feet's tasks and flat contacts (:mod:`~.feet_kernel`; not where a
foot's roll is freed, the H1's: NumPy's rows there); the self-clearance rows (:mod:`~.clearance_kernel`); the arms'
damped steps, give and compensation share (:mod:`~.arm_kernel`, made by :class:`~.hand_yield.HandYield` and
:class:`~.arm_compensation.ArmCompensation` themselves). Not bit for bit the NumPy path (sums of products written
out, not BLAS's): an alternative evaluation, judged for the standing mode by the rules of docs/design.md §5
(sessions 33 and 34). Made with the controller, so that the compilations (or numba's cache loads) are paid then.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .balance_config import BalanceConfig
from .clearance_kernel import CompiledClearance
from .contact_qp import ActuatorLimits
from .cop_kernel import cop_kernel
from .feet_kernel import CompiledFeet
from .feet_on_floor import FeetOnFloor
from .qp_kernel import CompiledLimits, kernels
from .self_clearance import SelfClearance
from .support_kernel import CompiledSupport

__all__ = ["CompiledPieces"]


class CompiledPieces:
    """The compiled pieces of a controller of ``config`` on the model ``m``: its ``feet``, the robot's coordinates
    ``vadr`` (n,), the actuators' rows ``act_rows`` among them, its actuator ``limits``, its ``clearance`` rows (or
    ``None``) and whether a foot's roll is freed (``roll_freed``)."""

    def __init__(self, m: mujoco.MjModel, config: BalanceConfig, feet: FeetOnFloor, vadr: np.ndarray,
                 act_rows: np.ndarray, limits: ActuatorLimits, clearance: SelfClearance | None,
                 roll_freed: bool) -> None:
        c = config
        kernels(), cop_kernel()  # (the QP's assembly and the centre-of-pressure rows: compiled now)
        self.support = CompiledSupport(feet)
        """The feet's contacts, soles and support box (:mod:`~.support_kernel`)."""
        self.flat = CompiledFeet(m, feet.bodies, feet.corners, vadr, c.sole_gap, c.foot_stiffness, c.foot_damping) if (
            c.flat_feet and not roll_freed and all(k is not None for k in feet.corners)) else None
        """The feet's tasks and flat contacts (:mod:`~.feet_kernel`), or ``None`` (NumPy's)."""
        self.limits = CompiledLimits(limits, act_rows, len(vadr), c.torque_fraction)
        """The QP's torque bounds (:class:`~.qp_kernel.CompiledLimits`)."""
        self.clearance_rows = None if clearance is None else CompiledClearance(m, clearance).rows
        """The self-clearance rows (:mod:`~.clearance_kernel`), or ``None`` (no ``self_clearance``)."""
