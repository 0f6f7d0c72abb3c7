#!/usr/bin/env bash
# Launch-free bring-up of the robot: the mock ros2_control controllers (node controller_manager)
# or, with --hardware, the driver of the real myCobot 280 (node mycobot_driver, same controllers),
# or, with --sim mujoco, the MuJoCo physics twin (node mujoco_sim, same controllers),
# the robot_state_publisher (/robot_description, /tf, /tf_static for RViz) and the planning_server
# (the move_group stand-in, with its node move_group), in the background, like the seeds' robot.sh
# but without a launch system. A thin wrapper: the bring-up is mycobot_planning.ros.bringup
# (Python; `scripts/robot.sh --help` lists the commands and options).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY="$ROOT/.venv/bin/python"
if [[ ! -x "$PY" ]]; then
  echo "robot.sh: $PY is missing; running scripts/setup.sh first"
  "$ROOT/scripts/setup.sh"
fi
exec "$PY" -m mycobot_planning.ros.bringup "$@"
