"""Assembling a :class:`~socialaff_sim.sim.stage.Stage`: one robot, one task, one skeleton layout.

A :class:`~socialaff_sim.sim.simulator.Simulator` compiles one stage per skeleton layout it meets and
reuses it; this module holds that assembly (scenes, IK, scorer, support meter, physics stepper, the
optional stance control) so the simulator keeps only the per-frame loop.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from ..data.skeletons import SkeletonLayout
from ..retarget.ik import RobotIK
from ..retarget.robot import RobotSpec
from ..retarget.scaling import BodyMeasurements, measure_robot
from .balance_control import BalanceController
from .feedforward import StandingFeedforward
from .reach import reach_model
from .scoring import SubgoalScorer
from .sim_config import SimConfig
from .stage import Stage, compile_scenes, key_frames_at
from .stance import StanceControl
from .substeps import FrameStepper
from .support import SupportMeter
from .tasks import TaskSpec

__all__ = ["leg_bandwidth", "build_stage"]


def leg_bandwidth(config: SimConfig) -> float | None:
    """The legs' standing bandwidth (rad/s): ``SimConfig.stance_bandwidth``, or the stance controller's
    when the harness may let go and that is ``None``."""
    if config.stance_bandwidth is None and config.stance is not None and config.stance.release:
        return config.stance.leg_bandwidth
    return config.stance_bandwidth


def build_stage(
    robot: RobotSpec, task: TaskSpec, config: SimConfig, layout: SkeletonLayout,
    measurements: BodyMeasurements | None,
) -> tuple[Stage, BodyMeasurements, np.ndarray | None]:
    """Compile the stage of ``layout``; returns it, the robot's body measurements and, when
    ``measurements`` was ``None`` (the first stage), the home key frames (5, 3) of the IK scene (else ``None``).

    The measurements are taken once per robot (from the first stage's IK scene at home) and completed with
    the reach model's trunk radius, height and hand offset where they lack them.
    """
    obj = task.object.spec if task.object is not None else None
    puppet = config.gravity_compensation
    scene, ik_scene, ik_model, ik_map = compile_scenes(
        robot, layout, obj, timestep=config.timestep,
        servo_bandwidth=config.servo_bandwidth, hand_force=config.hand_force,
        gravity_compensation=puppet,
        harness_time_constant=None if puppet else config.harness_time_constant,
        stance_bandwidth=None if puppet else leg_bandwidth(config),
        chair=task.chair, compliant_person=config.compliant_person, floor_time_constant=config.floor_time_constant,
    )
    home_keys = None
    if measurements is None:
        measurements = measure_robot(ik_scene.model, ik_scene.home_qpos, ik_scene.frame_kinds,
                                     ik_scene.frame_ids, ik_scene.limb_body_ids)
        home_keys = key_frames_at(ik_scene, ik_scene.home_qpos)
    meas = measurements
    reach = reach_model(scene, meas.arm, meas.leg, meas.shoulders, meas.hips, config.ik.min_distance,
                        config.trunk_vertices)
    if meas.trunk_radius == 0.0:
        meas = dataclasses.replace(meas, trunk_radius=reach.trunk_radius, height=reach.height,
                                   hand=float(np.mean(reach.hand_centre)))
    meter = SupportMeter(scene)
    data = mujoco.MjData(scene.model)
    scorer = SubgoalScorer(scene, task)
    stage = Stage(
        scene, data, ik_scene, RobotIK(ik_model, config.ik), scorer, ik_map,
        FrameStepper(scene, data, scorer, meter, None if puppet else StandingFeedforward(scene),
                     None if puppet or config.balance is None else BalanceController(scene, config.balance)),
        reach, stance=None if puppet or config.stance is None else StanceControl(scene, config.stance),
    )
    return stage, meas, home_keys
