"""The end of scripts/demo.sh and scripts/perception_demo.sh: what mtc_node did, and whether the
object stands at the place pose.

    python -m mycobot_planning.demos.pick_place_report [--perception] NODE_LOG PARAMS EXIT_CODE [ROS_ARGS...]

Prints the stage tree mtc_node logged (plain demo) and the object's final pose read from the
planning_server, next to the place pose the parameters ask for (the file, then any
`-p name:=value` given to the demo). Exits 0 only if mtc_node succeeded and the object is within
1 cm of the place pose and no longer attached. One module for both demos, so they judge alike.
"""
from __future__ import annotations

import re
import sys

import numpy as np
import yaml

from mycobot_planning.paths import use_fast_discovery

#: How far from the place pose the object may stand (m).
PLACE_TOLERANCE = 0.01

_PERCEPTION_LINE = re.compile(r"Perception target '([^']+)': height ([0-9.]+) m, radius ([0-9.]+) m")


def stage_tree(log: str) -> list[str] | None:
    """The printState block mtc_node logged after "Task state:", or None if it never planned."""
    if "Task state:\n" not in log:
        return None
    lines = []
    for line in log.split("Task state:\n", 1)[1].splitlines():
        if line.startswith("["):
            break
        lines.append(line)
    return lines


def parameters_with_overrides(params_path: str, ros_args: list[str]):
    """The parameter file's PickPlaceParameters with the demo's `-p name:=value` applied."""
    from mycobot_planning.demos.pick_place import load_parameters

    params = load_parameters(params_path)
    overrides = {}
    for flag, item in zip(ros_args, ros_args[1:]):
        if flag == "-p" and ":=" in item:
            name, value = item.split(":=", 1)
            overrides[name] = yaml.safe_load(value)
    known = set(params.as_dict())
    return params.with_changes(**{k: v for k, v in overrides.items() if k in known})


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    perception = bool(args) and args[0] == "--perception"
    if perception:
        args = args[1:]
    if len(args) < 3:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    log_path, params_path, node_code, ros_args = args[0], args[1], int(args[2]), args[3:]
    log = open(log_path, encoding="utf-8", errors="replace").read()
    params = parameters_with_overrides(params_path, ros_args)

    if perception:
        # The line PerceptionObjectSource logs once it put the detected objects into the scene.
        found = _PERCEPTION_LINE.search(log)
        if found is None:
            print('FAILED: mtc_node did not take the object from perception (no "Perception target" line '
                  "in its log); see its log above.")
            return 1
        target, height, radius = found.group(1), float(found.group(2)), float(found.group(3))
        params = params.with_changes(object_dimensions=[height, radius])
    else:
        target = params.object_name
        tree = stage_tree(log)
        if tree is None:
            print("No stage tree: mtc_node did not get to planning (see its log above).")
        else:
            print("Stage tree (printState of the planned task):")
            print("\n".join(tree))

    from mycobot_planning.demos.pick_place import expected_place_pose

    expected = expected_place_pose(params)[:3, 3]
    use_fast_discovery()
    from interfaces_py.clients import PlanningSceneInterface, RpcError

    try:
        with PlanningSceneInterface(timeout=10.0) as scene:
            poses = scene.get_object_poses([target])
            attached = scene.get_attached_objects([target])
            names = scene.get_known_object_names()
            state = scene.call("get_state").get("robot_state", {})
    except RpcError as exc:
        print(f"Cannot read the planning scene from the planning_server: {exc}")
        return 1
    if perception:
        print(f"Planning scene objects: {', '.join(names)}")
    if target not in poses:
        print(f"FAILED: the planning scene has no object '{target}'.")
        return 1
    pose = poses[target]
    position = np.asarray(pose.position, dtype=float)
    error = float(np.linalg.norm(position - expected))
    still = " (still attached to the robot)" if attached else ""
    where = f"position [{position[0]:.4f}, {position[1]:.4f}, {position[2]:.4f}]"
    if perception:
        print(f"Perceived target '{target}' (height {height:.4f} m, radius {radius:.4f} m) final pose: {where}{still}")
    else:
        quat = ", ".join(f"{q:.4f}" for q in pose.orientation)
        print(f"Object '{target}' final pose (monitored planning scene): {where}, orientation (x, y, z, w) [{quat}]{still}")
    print(f"Place pose asked for: position [{expected[0]:.4f}, {expected[1]:.4f}, {expected[2]:.4f}]; "
          f"distance {error * 1000:.1f} mm")
    joints = dict(zip(state.get("joint_names", []), state.get("positions", [])))
    if joints and not perception:
        print("Joints now: " + ", ".join(f"{k} {v:+.3f}" for k, v in joints.items()))

    ok = node_code == 0 and not attached
    if error > PLACE_TOLERANCE:
        print("FAILED: the object is not within 1 cm of the place pose.")
        ok = False
    elif not ok:
        print("FAILED: mtc_node reported a failure (see its log above).")
    elif perception:
        print("SUCCESS: perception found the cylinder, mtc_node picked it and placed it at the place pose.")
    else:
        print("SUCCESS: the object stands at the place pose (within 1 cm).")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
