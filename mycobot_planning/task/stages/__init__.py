"""The stages of the task constructor, under MTC's names (``from mycobot_planning.task import
stages``; ``stages.CurrentState("current")``)."""
from .compute_ik import ComputeIK
from .connect import Connect
from .generate_pose import GenerateGraspPose, GeneratePlacePose, GeneratePose
from .modify_planning_scene import ModifyPlanningScene
from .move_relative import MoveRelative
from .move_to import MoveTo
from .predicate_filter import PredicateFilter
from .states import CurrentState, FixedState

__all__ = [
    "ComputeIK",
    "Connect",
    "CurrentState",
    "FixedState",
    "GenerateGraspPose",
    "GeneratePlacePose",
    "GeneratePose",
    "ModifyPlanningScene",
    "MoveRelative",
    "MoveTo",
    "PredicateFilter",
]
