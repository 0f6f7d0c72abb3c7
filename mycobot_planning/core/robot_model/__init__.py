"""The robot model (moveit_core/robot_model): a URDF + SRDF read into groups, chains, end
effectors, named states and limits. robot_config finds the files of a configuration directory,
srdf parses the SRDF and srdf_check reconciles it with the URDF."""
from .robot_config import RobotConfig
from .robot_model import EndEffector, JointInfo, JointModelGroup, RobotModel
from .srdf import Srdf, parse_srdf

__all__ = ["EndEffector", "JointInfo", "JointModelGroup", "RobotConfig", "RobotModel", "Srdf", "parse_srdf"]
