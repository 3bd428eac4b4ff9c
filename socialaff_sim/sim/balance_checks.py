"""The consistency checks of :class:`~.balance_config.BalanceConfig`'s settings (run when one is made): ranges,
choices from :data:`SOLVERS` and :data:`COM_REFERENCES`, and the options that need others; each failure a
:class:`~socialaff_sim.errors.ConfigError` naming the field and what was expected."""

from __future__ import annotations

import math
from typing import Any

from ..errors import ConfigError
from ..inference.compiled import KERNELS
from .shear_spread import FORMS

__all__ = ["COM_REFERENCES", "SOLVERS", "check_balance_config"]

COM_REFERENCES = ("plan", "middle")
"""Where the centre of mass is held: ``plan``, the IK's centre of mass relative to its feet, carried over to the
physical feet; ``middle``, the middle of the feet's contact points. Each is kept inside the support box. (``world``
and ``approach``, the IK's centre of mass where the plan has it in the world, were measured and removed:
docs/design.md §5.)"""

SOLVERS = ("lsq", "qp")
"""How the inverse dynamics is solved: ``lsq``, weighted least squares with non-negative contact forces
(:mod:`~socialaff_sim.sim.contact_dynamics`; the torques are clipped by MuJoCo afterwards); ``qp``, a quadratic
program with the equation of motion, the actuators' torque limits and the feet's centres of pressure as hard
constraints (:mod:`~socialaff_sim.sim.contact_qp`)."""


def check_balance_config(c: Any) -> None:  # (a BalanceConfig; typed loosely: balance_config imports this module)
    """Raise :class:`~socialaff_sim.errors.ConfigError` for the first inconsistent setting of ``c``."""
    if not (isinstance(c.qp_every, int) and c.qp_every >= 1):
        raise ConfigError(f"BalanceConfig.qp_every: expected an integer ≥ 1, found {c.qp_every!r}")
    if not (c.hold_gain >= 0.0 and c.hold_near >= 0.0):
        raise ConfigError(f"BalanceConfig: expected hold_gain ≥ 0 and hold_near ≥ 0 m, found {c.hold_gain}, "
                          f"{c.hold_near}")
    for name in ("joint_bandwidth", "torso_bandwidth", "com_bandwidth", "torso_bandwidth_roll_free"):
        if getattr(c, name) is not None and not getattr(c, name) > 0.0:
            raise ConfigError(f"BalanceConfig.{name}: expected a frequency > 0 rad/s, found {getattr(c, name)}")
    for name in ("foot_damping", "foot_stiffness", "com_damping", "support_margin", "release_delay", "release_margin",
                 "catch_margin", "catch_blend", "external_filter", "w_feet", "w_com", "w_torso", "w_joint",
                 "upper_weight", "cop_margin", "sole_gap", "shift_weight"):
        if not getattr(c, name) >= 0.0:
            raise ConfigError(f"BalanceConfig.{name}: expected a value ≥ 0, found {getattr(c, name)}")
    if not (c.w_dynamics > 0.0 and c.w_force > 0.0):
        raise ConfigError(f"BalanceConfig: expected w_dynamics > 0 and w_force > 0, found {c.w_dynamics}, "
                          f"{c.w_force}")
    latch = c.arm_compensation is not None and c.compensation_gate is not None  # the arms' touch latch (ArmCompensation)
    if not c.friction > 0.0:
        raise ConfigError(f"BalanceConfig.friction: expected μ > 0, found {c.friction}")
    if c.touch_friction is not None and not (c.touch_friction > 0.0 and latch):
        raise ConfigError(f"BalanceConfig.touch_friction: expected None or μ_t > 0 with arm_compensation and "
                          f"compensation_gate (the touch latch), found {c.touch_friction}")
    if c.shear_spread is not None and not (c.shear_spread > 0.0 and c.solver == "qp"):
        raise ConfigError(f"BalanceConfig.shear_spread: expected None or w_s > 0 with solver='qp', found "
                          f"{c.shear_spread} with solver {c.solver!r}")
    if c.shear_spread_touched and (c.shear_spread is None or not latch):
        raise ConfigError("BalanceConfig.shear_spread_touched: needs shear_spread and the touch latch (arm_compensation "
                          "and compensation_gate)")
    if c.shear_couple is not None and not (c.shear_couple > 0.0 and c.solver == "qp"):
        raise ConfigError(f"BalanceConfig.shear_couple: expected None or w_c > 0 with solver='qp', found "
                          f"{c.shear_couple} with solver {c.solver!r}")
    if c.shear_couple_form not in FORMS:
        raise ConfigError(f"BalanceConfig.shear_couple_form: expected one of {', '.join(FORMS)}, found "
                          f"{c.shear_couple_form!r}")
    if c.shear_couple_touched and (c.shear_couple is None or not latch):
        raise ConfigError("BalanceConfig.shear_couple_touched: needs shear_couple and the touch latch (arm_compensation "
                          "and compensation_gate)")
    if c.qp_kernel not in KERNELS or (c.qp_kernel != "numpy" and c.solver != "qp"):
        raise ConfigError(f"BalanceConfig.qp_kernel: expected one of {', '.join(KERNELS)} (numba with solver='qp'), "
                          f"found {c.qp_kernel!r} with solver {c.solver!r}")
    if c.solver not in SOLVERS:
        raise ConfigError(f"BalanceConfig.solver: expected one of {', '.join(SOLVERS)}, found {c.solver!r}")
    if c.self_clearance is not None and (c.solver != "qp" or not c.self_clearance >= 0.0):
        raise ConfigError(f"BalanceConfig.self_clearance: needs solver='qp' and a distance ≥ 0 m, found "
                          f"{c.self_clearance!r} with solver {c.solver!r}")
    if not (c.clearance_detection > 0.0 and c.clearance_bandwidth > 0.0):
        raise ConfigError(f"BalanceConfig: expected clearance_detection > 0 m and clearance_bandwidth > 0 rad/s, "
                          f"found {c.clearance_detection}, {c.clearance_bandwidth}")
    if c.hand_yield is not None and not c.hand_yield >= 0.0:
        raise ConfigError(f"BalanceConfig.hand_yield: expected None or a fraction ≥ 0, found {c.hand_yield}")
    if c.yield_twist is not None and (c.hand_yield is None or not c.yield_twist > 0.0):
        raise ConfigError(f"BalanceConfig.yield_twist: needs hand_yield and a length > 0 m, found "
                          f"{c.yield_twist!r} with hand_yield {c.hand_yield!r}")
    if c.yield_carried and c.hand_yield is None:
        raise ConfigError("BalanceConfig.yield_carried: needs hand_yield (the carried object's forces are counted "
                          "by the hands' give)")
    if c.arm_compensation is not None and not c.arm_compensation >= 0.0:
        raise ConfigError(f"BalanceConfig.arm_compensation: expected None or a fraction ≥ 0, found "
                          f"{c.arm_compensation}")
    if not c.compensation_release > 0.0:
        raise ConfigError(f"BalanceConfig.compensation_release: expected a force > 0 N, found "
                          f"{c.compensation_release}")
    if c.compensation_gate is not None and not c.compensation_gate > 0.0:
        raise ConfigError(f"BalanceConfig.compensation_gate: expected None or a distance > 0 m, found "
                          f"{c.compensation_gate}")
    if not (c.yield_damping > 0.0 and c.yield_return >= 0.0):
        raise ConfigError(f"BalanceConfig: expected yield_damping > 0 N·s/m and yield_return ≥ 0 s, found "
                          f"{c.yield_damping}, {c.yield_return}")
    if c.cop_corner_share is not None and not (c.solver == "qp" and 0.0 <= c.cop_corner_share < 0.25):
        raise ConfigError(f"BalanceConfig.cop_corner_share: needs solver='qp' and a share in [0, 0.25), found "
                          f"{c.solver!r}, {c.cop_corner_share!r}")
    if c.flat_roll_free and not c.flat_feet:
        raise ConfigError("BalanceConfig.flat_roll_free: needs flat_feet (the feet's hard rows)")
    if c.yaw_first and not c.flat_feet:
        raise ConfigError("BalanceConfig.yaw_first: needs flat_feet (the feet's hard rows)")
    if c.flat_feet and c.solver != "qp":
        raise ConfigError(f"BalanceConfig.flat_feet: needs solver='qp' (hard constraints), found {c.solver!r}")
    if not 0.0 <= c.min_foot_load < 0.5:
        raise ConfigError(f"BalanceConfig.min_foot_load: expected a fraction in [0, 0.5), found "
                          f"{c.min_foot_load}")
    if not 0.0 < c.torque_fraction <= 1.0:
        raise ConfigError(f"BalanceConfig.torque_fraction: expected a fraction in (0, 1], found "
                          f"{c.torque_fraction}")
    if c.com_reference not in COM_REFERENCES:
        raise ConfigError(f"BalanceConfig.com_reference: expected one of {', '.join(COM_REFERENCES)}, found "
                          f"{c.com_reference!r}")
    if c.com_shift is not None and (c.com_reference != "plan" or not c.com_shift > 0.0):
        raise ConfigError(f"BalanceConfig.com_shift: needs com_reference='plan' and a distance > 0 m, found "
                          f"{c.com_shift!r} with com_reference {c.com_reference!r}")
    if c.catch_follow_feet is not None and not c.catch_follow_feet >= 0.0:
        raise ConfigError(f"BalanceConfig.catch_follow_feet: expected None or a distance ≥ 0 m, found "
                          f"{c.catch_follow_feet!r}")
    if c.catch_follow_chair and c.catch_follow_feet is None:
        raise ConfigError("BalanceConfig.catch_follow_chair: needs catch_follow_feet")
    if c.release_settled is not None and not c.release_settled > 0.0:
        raise ConfigError(f"BalanceConfig.release_settled: expected None or a distance > 0 m, found "
                          f"{c.release_settled!r}")
    if (c.release_settled_above or c.release_settled_causal_only) and c.release_settled is None:
        raise ConfigError("BalanceConfig.release_settled_above/_causal_only: needs release_settled")
    if c.release_settled_raised is not None and (c.release_settled is None or not math.isfinite(c.release_settled_raised)):
        raise ConfigError(f"BalanceConfig.release_settled_raised: needs release_settled and a finite height (m), found "
                          f"{c.release_settled_raised!r}")
    if c.release_settled_until_touch and c.release_settled is None:
        raise ConfigError("BalanceConfig.release_settled_until_touch: needs release_settled")
    if c.release_settled_latch and c.release_settled_raised is None:
        raise ConfigError("BalanceConfig.release_settled_latch: needs release_settled_raised")
    if c.hand_task is not None and not (c.hand_task > 0.0 and c.hand_task_bandwidth > 0.0):
        raise ConfigError(f"BalanceConfig: expected hand_task None or > 0 and hand_task_bandwidth > 0 rad/s, found "
                          f"{c.hand_task!r}, {c.hand_task_bandwidth}")
    if c.hand_task_touched and (c.hand_task is None or not latch):
        raise ConfigError("BalanceConfig.hand_task_touched: needs hand_task, arm_compensation and compensation_gate "
                          "(their touch latch)")
    if c.release_front_catch is not None and not (c.flat_roll_free and c.release_front_catch > 0.0):
        raise ConfigError(f"BalanceConfig.release_front_catch: needs flat_roll_free (the robots it picks) and a "
                          f"distance > 0 m, found {c.release_front_catch!r}")
    if c.release_front_long != 0.0 and not (c.release_front_catch is not None and c.release_front_long > 0.0):
        raise ConfigError(f"BalanceConfig.release_front_long: needs release_front_catch and a length > 0 m (0: off), "
                          f"found {c.release_front_long!r}")
    if c.release_ahead_catch is not None and not (c.flat_roll_free and c.release_ahead_catch >= 0.0):
        raise ConfigError(f"BalanceConfig.release_ahead_catch: needs flat_roll_free (the robots it picks) and a "
                          f"distance ≥ 0 m, found {c.release_ahead_catch!r}")
    if c.release_tilt_touched is not None and not (
            c.flat_roll_free and latch and c.release_tilt <= c.release_tilt_touched < c.catch_tilt):
        raise ConfigError(f"BalanceConfig.release_tilt_touched: needs flat_roll_free (the robots it picks), "
                          f"arm_compensation and compensation_gate (their touch latch) and a tilt in [release_tilt, "
                          f"catch_tilt) degrees, found {c.release_tilt_touched!r}")
    if c.release_tilt_touched_above and c.release_tilt_touched is None:
        raise ConfigError("BalanceConfig.release_tilt_touched_above: needs release_tilt_touched")
    if c.hand_task_roll_free and (c.hand_task is None or not c.flat_roll_free):
        raise ConfigError("BalanceConfig.hand_task_roll_free: needs hand_task and flat_roll_free (the robots it "
                          "picks)")
    if c.hand_task_arm_weight is not None and (c.hand_task is None or c.hand_task_touched
                                                  or not 0.0 < c.hand_task_arm_weight <= 1.0):
        raise ConfigError(f"BalanceConfig.hand_task_arm_weight: needs hand_task (not hand_task_touched) and a "
                          f"factor in (0, 1], found {c.hand_task_arm_weight!r}")
    if c.hand_task_plan_velocity and c.hand_task is None:
        raise ConfigError("BalanceConfig.hand_task_plan_velocity: needs hand_task (the rows it moves)")
    if c.hand_task_velocity_until_touch and (not c.hand_task_plan_velocity or not latch):
        raise ConfigError("BalanceConfig.hand_task_velocity_until_touch: needs hand_task_plan_velocity, "
                          "arm_compensation and compensation_gate (their touch latch)")
    if c.shift_until_touch and (c.com_shift is None or not latch):
        raise ConfigError("BalanceConfig.shift_until_touch: needs com_shift, arm_compensation and compensation_gate "
                          "(their touch latch ends the approach)")
    if c.plan_velocity_until_touch and (not (c.com_plan_velocity or c.torso_plan_velocity) or not latch):
        raise ConfigError("BalanceConfig.plan_velocity_until_touch: needs com_plan_velocity or torso_plan_velocity, "
                          "and arm_compensation and compensation_gate (their touch latch)")
    if c.plan_velocity_raised is not None and (not (c.com_plan_velocity or c.torso_plan_velocity)
                                                  or not math.isfinite(c.plan_velocity_raised)):
        raise ConfigError(f"BalanceConfig.plan_velocity_raised: needs com_plan_velocity or torso_plan_velocity and "
                          f"a finite height (m), found {c.plan_velocity_raised!r}")
    if c.plan_velocity_tilt is not None and (not (c.com_plan_velocity or c.torso_plan_velocity)
                                                or not 0.0 < c.plan_velocity_tilt < 90.0):
        raise ConfigError(f"BalanceConfig.plan_velocity_tilt: needs com_plan_velocity or torso_plan_velocity and "
                          f"an angle in (0, 90) degrees, found {c.plan_velocity_tilt!r}")
    if c.angmom_weight is not None and not (c.angmom_weight > 0.0 and c.angmom_bandwidth >= 0.0):
        raise ConfigError(f"BalanceConfig: expected angmom_weight None or > 0 and angmom_bandwidth ≥ 0 1/s, found "
                          f"{c.angmom_weight!r}, {c.angmom_bandwidth}")
    if (c.angmom_root_still or c.angmom_about_feet) and c.angmom_weight is None:
        raise ConfigError("BalanceConfig.angmom_root_still / angmom_about_feet: need angmom_weight (the rows)")
    if c.catch_tilt_lean_roll_free is not None and not (c.flat_roll_free and c.tilt_from_plan
                                                        and 0.0 < c.catch_tilt_lean_roll_free <= 5.0):
        raise ConfigError(f"BalanceConfig.catch_tilt_lean_roll_free: needs flat_roll_free (the robots it picks), "
                          f"tilt_from_plan and a gain in (0, 5], found {c.catch_tilt_lean_roll_free!r}")
    if c.catch_tilt_lean_touched and (c.catch_tilt_lean_roll_free is None or not latch):
        raise ConfigError("BalanceConfig.catch_tilt_lean_touched: needs catch_tilt_lean_roll_free, arm_compensation "
                          "and compensation_gate (their touch latch)")
    if not 0.0 <= c.release_tilt <= c.catch_tilt < 90.0:
        raise ConfigError(f"BalanceConfig: expected 0 ≤ release_tilt ≤ catch_tilt < 90 degrees, found "
                          f"{c.release_tilt}, {c.catch_tilt}")
