#!/usr/bin/env bash
# README command one: the seeds' pick and place, planned and executed end to end.
#
#   ./scripts/demo.sh [--hardware PORT|emulated | --sim mujoco] [ROS_ARGS...]   e.g. ./scripts/demo.sh -p max_solutions:=3
#
# --hardware PORT runs the pick and place on the real myCobot 280 on serial port PORT (through
# mycobot_driver instead of the mock controllers); --hardware emulated on the emulated arm
# (mycobot_emulator on a pseudo-terminal, driven by the same driver over pymycobot). With
# --hardware the arm's readback must also end at home (within 0.02 rad per joint).
# --sim mujoco runs it in the MuJoCo twin (mujoco_sim instead of the mock controllers; the twin's
# floor goes into the planning scene and the cylinder's planning radius is padded 5 mm, see
# docs/simulation.md) and the verdict is the simulator's: the cylinder's simulated pose within 1 cm
# of the place pose, upright within 5 degrees, at most 5 mm of slip in the hand (printed).
#
# 1. sets up .venv if needed (scripts/setup.sh);
# 2. brings up the mock controllers (or the driver) and the planning_server (the bring-up robot.sh uses,
#    mycobot_planning.ros.bringup, with a log and
#    PID folder of this run's own, so a robot you started yourself is never touched);
# 3. runs mtc_node with config/mtc_node_params.yaml, execute:=true and exit_when_done:=true (extra
#    arguments go to mtc_node after those, e.g. -p place_pose:=[-0.183,0.14,0.0,0.0,0.0,0.0]),
#    showing its log: the stage tree (printState), the stage summary, the execution;
# 4. prints the stage tree again and the object's final pose, read from the planning_server's
#    monitored planning scene, next to the place pose the parameters ask for;
# 5. stops everything it started (also on Ctrl-C or an error).
# Exit code 0 only if planning and execution succeeded and the object stands within 1 cm of the
# place pose; 1 otherwise.
#
# MYCOBOT_DEMO_VIEWER=1 also starts the task viewer (port MYCOBOT_VIEWER_PORT, default 8080) and
# prints its address.
# ROS_DOMAIN_ID: yours if set, else one picked for this run (printed, so that other terminals can
# watch, e.g. `ROS_DOMAIN_ID=<n> ros2 run mycobot_planning task_viewer`). Logs stay in
# $MYCOBOT_DEMO_DIR (default /tmp/mycobot_planning/demo-<pid>).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source=scripts/demo_common.sh
source "$ROOT/scripts/demo_common.sh"
demo_prepare "${BASH_SOURCE[0]}" "${1:-}"
# The run itself (bring-up, mtc_node, the report, the clean-up) is Python:
# mycobot_planning.ros.demos.robot_demos over the bring-up module mycobot_planning.ros.bringup.
exec "$ROOT/.venv/bin/python" -m mycobot_planning.ros.demos.robot_demos demo "$@"
