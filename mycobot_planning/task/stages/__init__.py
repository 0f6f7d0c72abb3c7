"""The stages of the task constructor, under MTC's names (``from mycobot_planning.task import
stages``; ``stages.CurrentState("current")``)."""
from .compute_ik import ComputeIK
from .connect import Connect, MergeMode
from .fix_collision_objects import FixCollisionObjects
from .generate_grasp_pose import GenerateGraspPose
from .generate_place_pose import GeneratePlacePose
from .generate_pose import GeneratePose
from .generate_random_pose import GenerateRandomPose, PoseDimension
from .limit_solutions import LimitSolutions
from .modify_planning_scene import ModifyPlanningScene
from .move_relative import MoveRelative
from .move_to import MoveTo
from .pass_through import PassThrough
from .pick_place import Pick, PickPlaceBase, Place
from .predicate_filter import PredicateFilter
from .current_state import CurrentState
from .fixed_state import FixedState
from .simple_grasp import SimpleGrasp, SimpleGraspBase, SimpleUnGrasp

__all__ = [
    "ComputeIK",
    "Connect",
    "CurrentState",
    "FixCollisionObjects",
    "FixedState",
    "GenerateGraspPose",
    "GeneratePlacePose",
    "GeneratePose",
    "GenerateRandomPose",
    "LimitSolutions",
    "MergeMode",
    "ModifyPlanningScene",
    "MoveRelative",
    "MoveTo",
    "PassThrough",
    "Pick",
    "PickPlaceBase",
    "Place",
    "PoseDimension",
    "PredicateFilter",
    "SimpleGrasp",
    "SimpleGraspBase",
    "SimpleUnGrasp",
]
