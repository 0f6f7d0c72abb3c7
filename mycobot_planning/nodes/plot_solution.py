"""plot_solution: PNG pictures of a task solution or a trajectory, for reports and CI artefacts.

``ros2 run mycobot_planning plot_solution solution.json`` writes ``solution_trajectory.png``
(positions, velocities, accelerations of every moved joint over time, limits dashed) and
``solution_scene.png`` (the robot at chosen states among the scene objects) next to the input,
or into ``--out-dir``. The input is the JSON of a TaskSolution (``task.to_msg().to_json()``), a
RobotTrajectory or a JointTrajectory (interfaces_py schemas); ``-`` reads standard input.

  --at start --at "attach object" --at 4.5 --at end   states of the scene picture (stage
                                                      names, times in s); default: start,
                                                      grasp/release steps, end
  --scene-json scene.json                             objects (and start state) for a bare
                                                      trajectory
  --trajectory PATH / --scene PATH                    write only that picture, there

A tool, not a node: it does not need ROS running. The pictures come from
``mycobot_planning.visualization.plots`` (library calls ``plot_trajectory`` / ``plot_scene``).
Exit status 0 on success, 2 with a one-line reason for bad input.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="plot_solution",
        description="Write PNG pictures of a TaskSolution, RobotTrajectory or JointTrajectory JSON file.")
    parser.add_argument("input", help="JSON file (TaskSolution, RobotTrajectory or JointTrajectory); '-': stdin")
    parser.add_argument("-o", "--out-dir", type=Path, default=None,
                        help="directory of the default outputs (default: next to the input)")
    parser.add_argument("--trajectory", type=Path, default=None, metavar="PNG", help="trajectory plot path")
    parser.add_argument("--scene", type=Path, default=None, metavar="PNG", help="scene snapshot path")
    parser.add_argument("--at", action="append", default=None, metavar="STATE",
                        help="a state of the scene snapshot: start, end, a time in s or a stage name (repeatable)")
    parser.add_argument("--scene-json", type=Path, default=None, metavar="FILE",
                        help="PlanningScene JSON placing a bare trajectory among objects")
    parser.add_argument("--joints", nargs="+", default=None, help="plot only these joints")
    parser.add_argument("--title", default=None, help="picture title (default: task name and duration)")
    parser.add_argument("--dpi", type=int, default=100, help="resolution (default 100)")
    parser.add_argument("--urdf", type=Path, default=None, help="robot URDF (default: the package's myCobot 280)")
    parser.add_argument("--srdf", type=Path, default=None, help="robot SRDF (with --urdf)")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    if args.dpi < 20 or args.dpi > 600:
        parser.error(f"--dpi must be within [20, 600], got {args.dpi}")
    if (args.urdf is None) != (args.srdf is None):
        parser.error("--urdf and --srdf go together")
    try:
        text = sys.stdin.read() if args.input == "-" else Path(args.input).read_text()
    except OSError as exc:
        parser.error(f"cannot read {args.input}: {exc.strerror or exc}")
    scene_text = None
    if args.scene_json is not None:
        try:
            scene_text = args.scene_json.read_text()
        except OSError as exc:
            parser.error(f"cannot read {args.scene_json}: {exc.strerror or exc}")

    from mycobot_planning.core.robot_model.robot_model import RobotModel
    from mycobot_planning.visualization.playback import timeline_from_json
    from mycobot_planning.visualization.plots import plot_scene, plot_trajectory, snapshot_states

    try:
        model = RobotModel.mycobot() if args.urdf is None else RobotModel.from_files(args.urdf, args.srdf)
        stem = "trajectory" if args.input == "-" else Path(args.input).stem
        timeline = timeline_from_json(model, text, scene_text, label=stem)
        out_dir = args.out_dir or (Path.cwd() if args.input == "-" else Path(args.input).resolve().parent)
        wanted_traj = args.trajectory or (None if args.scene else out_dir / f"{stem}_trajectory.png")
        wanted_scene = args.scene or (None if args.trajectory else out_dir / f"{stem}_scene.png")
        written = []
        if wanted_traj is not None:
            written.append(plot_trajectory(timeline, wanted_traj, title=args.title, dpi=args.dpi, joints=args.joints))
        if wanted_scene is not None:
            states = snapshot_states(timeline, args.at)
            title = args.title or (f"{timeline.title}" if timeline.title else "scene")
            written.append(plot_scene(model, states, wanted_scene, title=title, dpi=args.dpi))
    except (ValueError, OSError) as exc:  # MessageError, SceneError, RobotModelError are ValueErrors
        print(f"plot_solution: error: {exc}", file=sys.stderr)
        return 2
    for info in written:
        print(f"wrote {info.path} ({info.width}x{info.height} px, {info.subplots} {info.kind} subplots)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
