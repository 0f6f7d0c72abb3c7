"""ComputeIK: turn the target poses of a wrapped generator into arm configurations (MTC's
stages::ComputeIK).

The full story: docs/task.md, section mycobot_planning.task.stages.compute_ik.
"""
from __future__ import annotations

import itertools
from collections import deque
from typing import Any

import numpy as np

from ...core.robot_state.robot_state import RobotState
from ...core.transforms import inverse
from ..errors import InitStageException
from ..geometry import PoseStamped, as_pose_stamped, frame_transform
from ..properties import PropertySetter
from ..stage import Stage
from ..storage import InterfaceState, SolutionBase, SubTrajectory
from ..containers import WrapperBase
from .common import default_tip, robot_tip_for_frame

#: Attempts after which a target none of them reached (not even in collision) counts as out of
#: reach: the solver's seed state and 15 nearest-pose table samples. On the seeds' pick and place
#: every reachable target converged by attempt 5 (10 targets x 10 seeds), the unreachable ones
#: from none of 2,000 attempts each. Unreachable targets are most of the grasp and place angles
#: there, so stopping early matters.
UNREACHABLE_ATTEMPTS = 16
#: Attempts in a row without a new distinct solution after which the search is saturated. On the
#: seeds' pick and place (10 reachable targets x 20 seeds) it found every solution that 1,500
#: attempts find in all 200 runs, in 13 ms (median; 150 attempts without the solver's extra
#: table restarts took 19 ms for the same result).
SATURATION_ATTEMPTS = 100


class ComputeIK(WrapperBase):
    def __init__(self, name: str = "IK", child: Stage | None = None) -> None:
        super().__init__(name, child)
        p = self._properties
        p.declare("eef", type=str, description="name of end-effector")
        p.declare("group", type=str, description="name of active group (derived from eef if not provided)")
        p.declare("default_pose", "", "default joint pose of active group (defines cost of IK)", type=str)
        p.declare("max_ik_solutions", 1, "maximum number of IK solutions per target", type=int)
        p.declare("ignore_collisions", False, "spawn colliding solutions too", type=bool)
        p.declare("min_solution_distance", 0.1, "minimum distance between separate IK solutions for the same target",
                  type=float)
        p.declare("ik_frame", type=PoseStamped, coerce=as_pose_stamped, description="frame to be moved towards goal pose")
        p.declare("target_pose", type=PoseStamped, coerce=as_pose_stamped, description="goal pose for ik frame")
        self._arrived: list[SolutionBase] = []  # upstream solutions not yet ordered
        self._upstream: deque[SolutionBase] = deque()  # in the order they will be solved

    # MTC's setters
    setEndEffector = PropertySetter("eef", str)
    setGroup = PropertySetter("group", str)

    def setIKFrame(self, pose_or_link: Any, link: str | None = None) -> None:
        self._properties.set("ik_frame", pose_or_link if link is None else PoseStamped(link, pose_or_link))

    def setTargetPose(self, pose: Any, frame: str = "") -> None:
        if isinstance(pose, PoseStamped):
            self._properties.set("target_pose", pose)
        else:
            self._properties.set("target_pose", PoseStamped(frame, pose))

    setMaxIKSolutions = PropertySetter("max_ik_solutions", int)
    setMinSolutionDistance = PropertySetter("min_solution_distance", float)
    setIgnoreCollisions = PropertySetter("ignore_collisions", bool)

    def reset(self) -> None:
        super().reset()
        self._arrived.clear()
        self._upstream.clear()

    def init(self, robot_model) -> None:
        errors = InitStageException().collect(super().init, robot_model)
        p = self._properties
        eef, group = p["eef"], p["group"]
        self._check_eef(eef, robot_model, errors)
        if group is not None:
            self._check_group("group", group, robot_model, errors)
        if eef is None and group is None and not (p.property("eef").initsFrom(self.INTERFACE)
                                                  or p.property("group").initsFrom(self.INTERFACE)):
            errors.push_back(self, "neither property 'eef' nor property 'group' is defined: "
                                   + self._describe_undefined("group"))
        if p["max_ik_solutions"] is not None and p["max_ik_solutions"] < 1:
            errors.push_back(self, f"property 'max_ik_solutions' must be >= 1, got {p['max_ik_solutions']}")
        if p["min_solution_distance"] is not None and p["min_solution_distance"] < 0:
            errors.push_back(self, f"property 'min_solution_distance' must be >= 0, got {p['min_solution_distance']}")
        if p["target_pose"] is None and not p.property("target_pose").initsFrom(self.INTERFACE):
            errors.push_back(self, "property 'target_pose' is undefined; set it (setTargetPose) or read it from the "
                                   "interface (configureInitFrom(Stage.INTERFACE, ['target_pose']))")
        if errors:
            raise errors

    def _on_new_solution(self, solution: SolutionBase) -> None:
        self._arrived.append(solution)

    def _can_compute(self) -> bool:
        return bool(self._upstream or self._arrived) or self._children[0]._can_compute()

    def _schedule_key(self) -> tuple | None:
        keys = [solution.start.schedule_key() for solution in itertools.chain(self._upstream, self._arrived)
                if solution.start is not None]
        child = self._children[0]._schedule_key()
        if child is not None:
            keys.append(child)
        return min(keys) if keys else None

    def _compute(self) -> None:
        child = self._children[0]
        if child._can_compute():
            child._run_compute()
        if not self._upstream and self._arrived:
            # A generator spawns its targets in sweep order (grasp angle 0, 15, 30... degrees)
            # and neighbouring targets are reachable or not together: on the seeds' pick and
            # place the first reachable grasp angle is the 18th of 24. Spreading the tries over
            # the batch finds a reachable target after a few, and still solves every target.
            self._upstream.extend(self._arrived[i] for i in spread_order(len(self._arrived)))
            self._arrived.clear()
        if self._upstream:
            self._solve(self._upstream.popleft())

    def _spawn_failure(self, scene, comment: str) -> None:
        self.spawn(InterfaceState(scene.diff()), SubTrajectory.failure(comment))

    def _solve(self, upstream: SolutionBase) -> None:
        p = self._properties
        p.performInitFrom(self.INTERFACE, upstream.start.properties)  # type: ignore[union-attr]
        scene = upstream.start.scene  # type: ignore[union-attr]
        model = scene.robot_model
        eef, group = p["eef"], p["group"]
        if eef is not None and eef not in model.end_effectors:
            self._spawn_failure(scene, f"unknown end effector '{eef}'")
            return
        if group is None and eef is not None:
            group = model.end_effectors[eef].parent_group
        if group is None or not model.has_group(group):
            self._spawn_failure(scene, f"neither eef nor group are well defined (group: {group})")
            return
        jmg = model.group(group)
        timeout = p["timeout"]
        if timeout is None:
            timeout = float(model.kinematics(group)["kinematics_solver_timeout"])
        target_msg = p["target_pose"]
        if target_msg is None:
            self._spawn_failure(scene, "target pose undefined")
            return
        try:
            target = frame_transform(scene, target_msg.frame_id) @ target_msg.pose
            ik_frame = p["ik_frame"]
            if ik_frame is None:
                link = model.end_effectors[eef].parent_link if eef is not None else default_tip(model, group)
                ik_pose = scene.current_state.frame_pose(link)
            else:
                link, ik_pose = robot_tip_for_frame(ik_frame, scene, group)
        except ValueError as exc:
            self._spawn_failure(scene, f"{upstream.comment} {exc}".strip())
            return
        offset = inverse(scene.current_state.frame_pose(link)) @ ik_pose
        default_pose = p["default_pose"]
        if default_pose:
            compare = np.array([model.named_state(default_pose, group)[j] for j in jmg.joint_names])
        else:
            compare = scene.current_state.group_positions(group)
        solutions = self._search(scene, group, link, offset, target, float(timeout))
        indices = jmg.variable_indices
        for positions, valid, contact in solutions:
            solution_scene = scene.diff()
            state = solution_scene.current_state.copy()
            values = state.positions.copy()
            values[indices] = positions
            state.set_positions(values)
            solution_scene.set_current_state(state)
            sub = SubTrajectory(comment=upstream.comment)
            if valid:
                sub.cost = upstream.cost + float(np.sum(np.abs(positions - compare)))
            else:
                sub.markAsFailure(f"Collision between '{contact[0]}' and '{contact[1]}'" if contact
                                  else "outside joint limits")
            new_state = InterfaceState(solution_scene, lineage_depth=upstream.start.lineage_depth)  # type: ignore[union-attr]
            self.forwardProperties(upstream.start, new_state)  # type: ignore[arg-type]
            self.spawn(new_state, sub)
        if not solutions:
            self._spawn_failure(scene, f"{upstream.comment} no IK found".strip())

    def _search(self, scene, group: str, link: str, offset: np.ndarray, target: np.ndarray,
                timeout: float) -> list[tuple[np.ndarray, bool, tuple[str, str] | None]]:
        """Distinct IK solutions (valid or colliding) for the ik frame at ``target``."""
        p = self._properties
        model = scene.robot_model
        max_solutions = int(p["max_ik_solutions"])
        min_distance = float(p["min_solution_distance"])
        ignore_collisions = bool(p["ignore_collisions"])
        indices = model.group(group).variable_indices
        solver = self._context.ik_solver(group, link, offset)  # type: ignore[union-attr]
        found: list[tuple[np.ndarray, bool, tuple[str, str] | None]] = []

        def record(state: RobotState) -> bool:
            x = state.positions[indices]
            for other, _, _ in found:
                if float(np.sum(np.abs(x - other))) < min_distance:
                    return False
            if ignore_collisions:
                valid = state.satisfies_bounds()
                contact = None
            else:
                valid = scene.is_state_valid(state)
                contact = None
                if not valid:
                    report = scene.check_collision(state, max_contacts=1)
                    if report.contacts:
                        contact = (report.contacts[0].body_a, report.contacts[0].body_b)
            found.append((x.copy(), valid, contact))
            # Several wanted: every distinct solution, colliding ones too, counts towards
            # max_ik_solutions (MTC spawns those as failures). One wanted: look on for a valid one.
            return valid or max_solutions > 1

        rng = np.random.default_rng(self._context.next_seed())  # type: ignore[union-attr]
        solver.solve(target, seed=scene.current_state, timeout=timeout, max_solutions=max_solutions,
                     min_solution_distance=min_distance, validity=record, rng=rng,
                     give_up_after=UNREACHABLE_ATTEMPTS, saturation=SATURATION_ATTEMPTS)
        return found[:max_solutions] if max_solutions > 1 else _first_valid(found)


def spread_order(n: int) -> list[int]:
    """0..n-1 in van der Corput order (0, n/2, n/4, 3n/4, ...): each next index falls in the
    largest gap left, so the first few cover the whole range."""
    bits = max(1, (n - 1).bit_length())
    return [i for i in sorted(range(1 << bits), key=lambda k: int(format(k, f"0{bits}b")[::-1], 2)) if i < n]


def _first_valid(found):
    valid = [item for item in found if item[1]]
    return valid[:1] + [item for item in found if not item[1]] if valid else found
