"""Robot descriptions, human-to-robot scaling and mink inverse kinematics."""

from .ik import IKConfig, IKModel, IKResult, RobotIK
from .robot import RobotSpec, available_robots, load_robot
from .scaling import BodyMeasurements, KeyJointScaler, RobotFrame, ScalingConfig
from .model_source import ModelSource, key_joint_source, model_source
from .sources import GroundTruthSource, KeyJointSource, SourceFrame

__all__ = [
    "BodyMeasurements",
    "GroundTruthSource",
    "IKConfig",
    "IKModel",
    "IKResult",
    "KeyJointScaler",
    "KeyJointSource",
    "ModelSource",
    "RobotFrame",
    "RobotIK",
    "RobotSpec",
    "ScalingConfig",
    "SourceFrame",
    "available_robots",
    "key_joint_source",
    "load_robot",
    "model_source",
]
