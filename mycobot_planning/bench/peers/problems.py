"""Deterministic Panda pose-goal problems shared by our planner and the peer libraries.

Every planner in the `peers` benchmark must see exactly the same problems, and the peers run in
other virtual environments, so a problem is plain JSON: joint vectors, a goal pose as position +
quaternion (x, y, z, w) in the robot base frame (``panda_link0``, which is also the world frame:
the Panda is fixed at the origin), and box obstacles given the same way.

Generation uses Pinocchio + Coal directly on example-robot-data's ``panda.urdf``/``panda.srdf``
rather than our own RobotModel/PlanningScene, so the problem set does not move when our planner
changes and cannot be biased towards it. Goals come from forward kinematics of random joint
configurations that are within limits, free of self-collision (SRDF-disabled pairs excluded) and
clear of the boxes: every goal is reachable by construction, and the generating configuration is
kept (``goal_joints``) so tests can check that claim.

The goal link is ``panda_hand``: a real URDF link, so mplib (whose ``move_group`` must be a link)
and pyroboplan (which targets any Pinocchio frame) can both aim it, as can our planner.

``panda_parts_problems`` makes the ``peers`` scenario's three parts (IK poses, states to check,
joint-goal pairs) the same way, around one 0.1 m box (see docs/bench.md, peers.parts).
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ...paths import example_robot_data_dir

TIP_LINK = "panda_hand"
BASE_FRAME = "panda_link0"
GROUP = "arm"
ARM_JOINTS = [f"panda_joint{i}" for i in range(1, 8)]
FINGER_JOINTS = ["panda_finger_joint1", "panda_finger_joint2"]
START_STATE = "default"

# Two boxes in the Panda's workspace: a low block in front of the robot (like mplib's own demo
# obstacle) and a wall to its left. They make some problems need a detour without making the
# start state invalid. Sizes are full side lengths in metres; poses are in the base frame.
DEFAULT_BOXES: list[dict[str, Any]] = [
    {"id": "front_block", "size": [0.12, 0.5, 0.3], "position": [0.6, 0.0, 0.15],
     "orientation_xyzw": [0.0, 0.0, 0.0, 1.0]},
    {"id": "left_wall", "size": [0.4, 0.1, 0.5], "position": [0.35, 0.45, 0.35],
     "orientation_xyzw": [0.0, 0.0, 0.0, 1.0]},
]

# Goals whose hand sits below this height are rejected: there is no floor object (it would touch
# panda_link0 in every state and need an ACM entry in each library), but a goal under the base
# plane is not a meaningful manipulation target.
MIN_GOAL_HEIGHT = 0.05


def panda_description_dir() -> Path:
    """example-robot-data's panda_description folder (urdf/, srdf/, meshes/)."""
    return example_robot_data_dir() / "panda_description"


def panda_urdf_path() -> Path:
    return panda_description_dir() / "urdf" / "panda.urdf"


def panda_srdf_path() -> Path:
    return panda_description_dir() / "srdf" / "panda.srdf"


def absolute_mesh_urdf_text() -> str:
    """panda.urdf with every ``package://example-robot-data/...`` URI made an absolute path.

    The peers resolve package:// URIs differently (mplib substitutes a keyword, pyroboplan needs
    Pinocchio package_dirs) and neither peer venv has example-robot-data, so they get a copy with
    plain file paths that every URDF loader accepts.
    """
    text = panda_urdf_path().read_text()
    robots = example_robot_data_dir()
    return re.sub(r"package://example-robot-data/robots/", str(robots) + "/", text)


def write_absolute_urdf(directory: Path) -> Path:
    """Write :func:`absolute_mesh_urdf_text` to ``directory/panda_abs.urdf`` (only if changed)."""
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "panda_abs.urdf"
    text = absolute_mesh_urdf_text()
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)
    return path


def srdf_group_state(srdf_path: Path, name: str) -> dict[str, float]:
    """Joint values of a named SRDF group_state (a tiny parser: this module must not need ours)."""
    root = ET.parse(srdf_path).getroot()
    for state in root.iter("group_state"):
        if state.get("name") == name:
            return {j.get("name"): float(j.get("value")) for j in state.iter("joint")}
    raise ValueError(f"SRDF {srdf_path} has no group_state named '{name}'")


class _PandaChecker:
    """Pinocchio model + Coal collision model of the Panda and the boxes, for generation and tests."""

    def __init__(self, boxes: list[dict[str, Any]]):
        import coal
        import pinocchio as pin

        self.pin = pin
        urdf = str(panda_urdf_path())
        package_dirs = [str(example_robot_data_dir().parent.parent)]  # .../share
        self.model = pin.buildModelFromUrdf(urdf)
        self.geom = pin.buildGeomFromUrdf(self.model, urdf, pin.GeometryType.COLLISION, package_dirs=package_dirs)
        self.geom.addAllCollisionPairs()
        pin.removeCollisionPairs(self.model, self.geom, str(panda_srdf_path()))
        robot_geoms = list(range(self.geom.ngeoms))
        for box in boxes:
            quat = box["orientation_xyzw"]
            rotation = pin.Quaternion(quat[3], quat[0], quat[1], quat[2]).normalized().matrix()
            placement = pin.SE3(rotation, np.asarray(box["position"], dtype=float))
            obj = pin.GeometryObject(box["id"], 0, placement, coal.Box(*map(float, box["size"])))
            box_id = self.geom.addGeometryObject(obj)
            for robot_id in robot_geoms:
                self.geom.addCollisionPair(pin.CollisionPair(robot_id, box_id))
        self.data = self.model.createData()
        self.geom_data = self.geom.createData()
        self.tip = self.model.getFrameId(TIP_LINK)
        self.arm_q = [self.model.joints[self.model.getJointId(j)].idx_q for j in ARM_JOINTS]
        self.finger_q = [self.model.joints[self.model.getJointId(j)].idx_q for j in FINGER_JOINTS]

    def full_q(self, arm: np.ndarray, finger: float) -> np.ndarray:
        q = self.pin.neutral(self.model)
        q[self.arm_q] = arm
        q[self.finger_q] = finger
        return q

    def in_collision(self, q: np.ndarray) -> bool:
        return bool(self.pin.computeCollisions(self.model, self.data, self.geom, self.geom_data, q, True))

    def tip_pose(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(position, quaternion xyzw) of the tip link in the base frame."""
        self.pin.framesForwardKinematics(self.model, self.data, q)
        placement = self.data.oMf[self.tip]
        quat = self.pin.Quaternion(placement.rotation)
        xyzw = np.array([quat.x, quat.y, quat.z, quat.w])
        if xyzw[3] < 0:  # one canonical sign so the JSON is stable
            xyzw = -xyzw
        return placement.translation.copy(), xyzw


@lru_cache(maxsize=4)
def _checker(boxes_key: str) -> _PandaChecker:
    import json

    return _PandaChecker(json.loads(boxes_key))


def checker_for(boxes: list[dict[str, Any]]) -> _PandaChecker:
    """A cached collision/FK checker for this box set (building one parses meshes: ~0.1 s)."""
    import json

    return _checker(json.dumps(boxes, sort_keys=True))


def panda_pose_problems(count: int, seed: int, obstacles: bool = True,
                        max_draws_per_problem: int = 1000) -> list[dict[str, Any]]:
    """``count`` deterministic Panda pose-goal problems for ``seed``.

    Each problem (JSON-able dict)::

        index, group ("arm"), joint_names (7 arm joints), start (SRDF 'default' arm values),
        finger_positions ({finger joint: value}, held fixed), tip_link ("panda_hand"),
        base_frame ("panda_link0"), goal {"position": [x,y,z], "orientation_xyzw": [x,y,z,w]},
        goal_joints (the configuration the goal came from; for checks, not for planners),
        obstacles (list of boxes {id, size, position, orientation_xyzw}; same list in every problem)
    """
    if count < 0:
        raise ValueError(f"problem count must be >= 0, got {count}")
    boxes = [dict(box) for box in DEFAULT_BOXES] if obstacles else []
    checker = checker_for(boxes)
    default = srdf_group_state(panda_srdf_path(), START_STATE)
    start = np.array([default[j] for j in ARM_JOINTS])
    finger = default.get(FINGER_JOINTS[0], 0.0)
    if checker.in_collision(checker.full_q(start, finger)):
        raise ValueError("the SRDF 'default' start state collides with the benchmark boxes")

    model = checker.model
    low = np.array([model.lowerPositionLimit[i] for i in checker.arm_q])
    high = np.array([model.upperPositionLimit[i] for i in checker.arm_q])
    rng = np.random.default_rng(seed)
    problems: list[dict[str, Any]] = []
    draws = 0
    while len(problems) < count:
        draws += 1
        if draws > max_draws_per_problem * max(count, 1):
            raise RuntimeError(f"could not draw {count} valid Panda goals in {draws - 1} tries")
        arm = rng.uniform(low, high)
        q = checker.full_q(arm, finger)
        if checker.in_collision(q):
            continue
        position, quat = checker.tip_pose(q)
        if position[2] < MIN_GOAL_HEIGHT:
            continue
        problems.append({
            "index": len(problems),
            "group": GROUP,
            "joint_names": list(ARM_JOINTS),
            "start": [float(v) for v in start],
            "finger_positions": {j: float(finger) for j in FINGER_JOINTS},
            "tip_link": TIP_LINK,
            "base_frame": BASE_FRAME,
            "goal": {"position": [float(v) for v in position],
                     "orientation_xyzw": [float(v) for v in quat]},
            "goal_joints": [float(v) for v in arm],
            "obstacles": boxes,
        })
    return problems


# ---------------------------------------------------------------------------------------------
# The three-part set (IK, validity checks, joint-goal plans): issue 19's side-by-side measurement
# ---------------------------------------------------------------------------------------------

#: One 0.1 m box at (0.5, 0, 0.5) in the base frame, as in issue 19's measurement.
PARTS_BOX: dict[str, Any] = {"id": "box", "size": [0.1, 0.1, 0.1], "position": [0.5, 0.0, 0.5],
                             "orientation_xyzw": [0.0, 0.0, 0.0, 1.0]}
PARTS_IK_COUNT = 200
PARTS_CHECK_COUNT = 10_000
PARTS_PLAN_COUNT = 50


def panda_parts_problems(seed: int, ik_count: int = PARTS_IK_COUNT, check_count: int = PARTS_CHECK_COUNT,
                         plan_count: int = PARTS_PLAN_COUNT) -> dict[str, Any]:
    """Issue 19's three parts as one JSON-able dict, deterministic for ``seed``::

        joint_names, finger_positions, tip_link, base_frame, start (SRDF 'default'),
        obstacles ([PARTS_BOX]),
        ik: [{index, goal {position, orientation_xyzw}, goal_joints}]  (poses of collision-free
            random configurations; every IK starts from ``start``),
        check: [[7 arm values], ...]  (uniform in the joint limits, colliding or not),
        plan: [{index, start, goal}]  (joint goals; both ends collision-free random configurations)

    "Collision-free" means self (SRDF pairs disabled) and box, by Pinocchio + Coal on the meshes.
    """
    for what, n in (("ik_count", ik_count), ("check_count", check_count), ("plan_count", plan_count)):
        if n < 0:
            raise ValueError(f"{what} must be >= 0, got {n}")
    boxes = [dict(PARTS_BOX)]
    checker = checker_for(boxes)
    default = srdf_group_state(panda_srdf_path(), START_STATE)
    start = np.array([default[j] for j in ARM_JOINTS])
    finger = default.get(FINGER_JOINTS[0], 0.0)
    model = checker.model
    low = np.array([model.lowerPositionLimit[i] for i in checker.arm_q])
    high = np.array([model.upperPositionLimit[i] for i in checker.arm_q])
    rng = np.random.default_rng(seed)

    def free_config() -> np.ndarray:
        for _ in range(100_000):
            arm = rng.uniform(low, high)
            if not checker.in_collision(checker.full_q(arm, finger)):
                return arm
        raise RuntimeError("could not draw a collision-free Panda configuration")

    ik = []
    while len(ik) < ik_count:
        arm = free_config()
        position, quat = checker.tip_pose(checker.full_q(arm, finger))
        if position[2] < MIN_GOAL_HEIGHT:
            continue
        ik.append({"index": len(ik),
                   "goal": {"position": [float(v) for v in position],
                            "orientation_xyzw": [float(v) for v in quat]},
                   "goal_joints": [float(v) for v in arm]})
    check = [[float(v) for v in rng.uniform(low, high)] for _ in range(check_count)]
    plan = []
    for index in range(plan_count):
        a, b = free_config(), free_config()
        plan.append({"index": index, "start": [float(v) for v in a], "goal": [float(v) for v in b]})
    return {
        "joint_names": list(ARM_JOINTS),
        "finger_positions": {j: float(finger) for j in FINGER_JOINTS},
        "tip_link": TIP_LINK,
        "base_frame": BASE_FRAME,
        "start": [float(v) for v in start],
        "obstacles": boxes,
        "ik": ik,
        "check": check,
        "plan": plan,
    }
