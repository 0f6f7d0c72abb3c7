#!/usr/bin/env bash
# Reacting while moving: an object appears on the path of a running motion; the arm stops short,
# replans and arrives.
#
#   ./scripts/react_demo.sh
#
# 1. sets up .venv if needed (scripts/setup.sh);
# 2. brings up the mock controllers and the planning_server (the bring-up robot.sh uses,
#    mycobot_planning.ros.bringup, with a log and PID folder of this run's own);
# 3. moves the arm to the start of a sweep (joint 1 at -1.2 rad), then sends a MoveGroup goal on
#    /move_action to +1.2 rad at 30 % speed with planning_options.replan (3 attempts);
# 4. 0.5 s into the motion publishes a 6 cm box on /collision_object where the flange would pass at
#    mid-sweep (what perception_server does when the camera sees something new);
# 5. prints move_group's feedback (PLANNING, MONITOR, PLANNING again, MONITOR), the result, the
#    smallest clearance between the robot and the box over every recorded /joint_states state,
#    and where the arm ended;
# 6. stops everything it started (also on Ctrl-C or an error).
# Exit code 0 only if the arm arrived at the goal and never touched the box; 1 otherwise.
#
# ROS_DOMAIN_ID: yours if set, else one picked for this run (printed). Logs stay in
# $MYCOBOT_DEMO_DIR (default /tmp/mycobot_planning/react-demo-<pid>).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source=scripts/demo_common.sh
source "$ROOT/scripts/demo_common.sh"
demo_prepare "${BASH_SOURCE[0]}" "${1:-}"
exec "$ROOT/.venv/bin/python" -m mycobot_planning.ros.demos.react_demo "$@"
