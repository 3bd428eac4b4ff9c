"""Robot descriptions, human-to-robot scaling and mink inverse kinematics."""

from .ik import IKConfig, IKModel, IKResult, RobotIK
from .robot import RobotSpec, available_robots, load_robot
from .scaling import BodyMeasurements, KeyJointScaler, RobotFrame, ScalingConfig
from .sources import GroundTruthSource, KeyJointSource, SourceFrame, model_source

__all__ = [
    "BodyMeasurements",
    "GroundTruthSource",
    "IKConfig",
    "IKModel",
    "IKResult",
    "KeyJointScaler",
    "KeyJointSource",
    "RobotFrame",
    "RobotIK",
    "RobotSpec",
    "ScalingConfig",
    "SourceFrame",
    "available_robots",
    "load_robot",
    "model_source",
]
