#!/usr/bin/env bash
# Pick and place driven by perception: simulated depth camera → perception_server → mtc_node.
#
#   ./scripts/perception_demo.sh [MTC_NODE_ROS_ARGS...]    e.g. ./scripts/perception_demo.sh -p max_solutions:=3
#
# 1. sets up .venv if needed (scripts/setup.sh);
# 2. brings up the mock controllers and the planning_server (scripts/robot.sh, with a log and
#    PID folder of this run's own, so a robot you started yourself is never touched);
# 3. starts, in the background, the camera_simulator (config/camera_scene.yaml: a table with a
#    cylinder and a box, seen from the seed's camera_head pose; clouds on
#    /camera_head/depth/color/points at 1 Hz, in base_link) and the perception_server
#    (config/perception_server.yaml), and asks the perception_server once what it sees (the
#    support surface, cylinder_0, box_0 with their poses and sizes);
# 4. runs mtc_node with config/mtc_node_params.yaml, execute:=true, exit_when_done:=true and
#    use_perception:=true: mtc_node asks the perception_server for the cylinder most similar to
#    object_dimensions, puts the detected objects into the planning scene instead of the seed's
#    table and object, plans the pick and place and executes it (extra arguments go to mtc_node);
# 5. prints the target's final pose from the planning_server's monitored scene next to the place
#    pose the parameters ask for;
# 6. stops everything it started (also on Ctrl-C or an error).
# Exit code 0 only if mtc_node took the object from perception, planning and execution succeeded
# and the object stands within 1 cm of the place pose; 1 otherwise.
#
# The simulated world has no physics: after the pick and place the camera still sees the cylinder
# where it was; the planning scene is what shows it at the place pose.
#
# ROS_DOMAIN_ID: yours if set, else one picked for this run (printed). Logs stay in
# $MYCOBOT_DEMO_DIR (default /tmp/mycobot_planning/perception-demo-<pid>).
# MYCOBOT_DEMO_VIEWER=1 also starts the task viewer and prints its address.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [[ "${1:-}" == "-h" || "${1:-}" == "--help" ]]; then
  sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d' | sed 's/^# \{0,1\}//'
  exit 0
fi
"$ROOT/scripts/setup.sh"
PY="$ROOT/.venv/bin/python"
PARAMS="$ROOT/config/mtc_node_params.yaml"
PERCEPTION_PARAMS="$ROOT/config/perception_server.yaml"
DEMO_DIR="${MYCOBOT_DEMO_DIR:-/tmp/mycobot_planning/perception-demo-$$}"
NODE_TIMEOUT="${MYCOBOT_DEMO_TIMEOUT:-600}"  # s for planning + execution
START_TIMEOUT="${MYCOBOT_START_TIMEOUT:-60}"   # s for the camera and perception to be up
mkdir -p "$DEMO_DIR"
NODE_LOG="$DEMO_DIR/mtc_node.log"

export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$((1 + $$ % 100))}"
export PYTHONUNBUFFERED=1
ROBOT=("$ROOT/scripts/robot.sh" --log-dir "$DEMO_DIR" --run-dir "$DEMO_DIR/run")

# PIDs of the background nodes this script started, stopped in reverse order by cleanup.
BACKGROUND=()
stop_pid() {
  local pid="$1"
  [[ -n "$pid" ]] && kill -0 "$pid" 2>/dev/null || return 0
  # SIGTERM: a background job of a script ignores SIGINT; the nodes shut down cleanly on TERM.
  kill -TERM "$pid" 2>/dev/null || true
  for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || return 0; sleep 0.1; done
  kill -KILL "$pid" 2>/dev/null || true
}
cleanup() {
  local code=$?
  trap - EXIT INT TERM
  local i
  for ((i = ${#BACKGROUND[@]} - 1; i >= 0; i--)); do stop_pid "${BACKGROUND[$i]}"; done
  echo "[perception demo] stopping the robot"
  "${ROBOT[@]}" stop >/dev/null 2>&1 || echo "[perception demo] robot.sh stop reported a problem; see $DEMO_DIR" >&2
  echo "[perception demo] logs: $DEMO_DIR"
  exit "$code"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

wait_for_log() {  # wait_for_log NAME PID LOG TEXT
  local name="$1" pid="$2" log="$3" text="$4" deadline=$((SECONDS + START_TIMEOUT))
  until grep -q "$text" "$log" 2>/dev/null; do
    if ! kill -0 "$pid" 2>/dev/null; then
      echo "[perception demo] $name exited while starting:" >&2; tail -n 20 "$log" >&2; exit 1
    fi
    if [[ $SECONDS -ge $deadline ]]; then
      echo "[perception demo] $name not ready within ${START_TIMEOUT} s:" >&2; tail -n 20 "$log" >&2; exit 1
    fi
    sleep 0.2
  done
}

echo "[perception demo] ROS_DOMAIN_ID=$ROS_DOMAIN_ID; logs in $DEMO_DIR"
echo "[perception demo] starting the mock controllers and the planning_server"
if ! "${ROBOT[@]}" start; then
  # robot.sh stops what it started when a start fails; one more try rides out a slow machine.
  echo "[perception demo] the robot did not come up; trying once more" >&2
  "${ROBOT[@]}" start
fi

cd "$ROOT"
echo "[perception demo] starting the camera_simulator and the perception_server"
"$PY" -m mycobot_planning.nodes.camera_simulator --ros-args -p rate:=1.0 >"$DEMO_DIR/camera_simulator.log" 2>&1 &
CAMERA_PID=$!
BACKGROUND+=("$CAMERA_PID")
"$PY" -m mycobot_planning.nodes.perception_server --ros-args --params-file "$PERCEPTION_PARAMS" \
  >"$DEMO_DIR/perception_server.log" 2>&1 &
PERCEPTION_PID=$!
BACKGROUND+=("$PERCEPTION_PID")
wait_for_log camera_simulator "$CAMERA_PID" "$DEMO_DIR/camera_simulator.log" "published the first cloud"
wait_for_log perception_server "$PERCEPTION_PID" "$DEMO_DIR/perception_server.log" "first point cloud received"

echo "[perception demo] what the perception_server sees:"
"$PY" - "$PARAMS" "$START_TIMEOUT" <<'PYEOF'
"""Ask the perception_server for the parameters' cylinder; print the detections."""
import sys
import time

from mycobot_planning.ros.node_runtime import use_fast_discovery

use_fast_discovery()
from interfaces_py.perception_client import PerceptionClient, RpcError  # noqa: E402
from mycobot_planning.ros.perception.perception_setup import detection_lines  # noqa: E402
from mycobot_planning.demos.pick_place import load_parameters  # noqa: E402

params = load_parameters(sys.argv[1])
deadline = time.monotonic() + float(sys.argv[2])
with PerceptionClient(timeout=30.0) as perception:
    while True:
        try:
            result = perception.get_planning_scene("cylinder", list(params.object_dimensions))
        except RpcError as exc:
            result = None
            reason = exc.message
        else:
            reason = result.message
        if result or time.monotonic() > deadline:
            break
        time.sleep(1.0)
if not result:
    print(f"  perception failed: {reason}")
    sys.exit(1)
print("\n".join("  " + line for line in detection_lines(result.response)))
PYEOF

# shellcheck source=viewer_common.sh
source "$ROOT/scripts/viewer_common.sh"
start_task_viewer "$DEMO_DIR" "perception demo"
[[ -n "$VIEWER_PID" ]] && BACKGROUND+=("$VIEWER_PID")

echo "[perception demo] running mtc_node with use_perception:=true (plan, then execute)"
"$PY" -m mycobot_planning.nodes.mtc_node --ros-args --params-file "$PARAMS" \
  -p execute:=true -p exit_when_done:=true -p use_perception:=true -p perception_server:=/perception_server \
  "$@" >"$NODE_LOG" 2>&1 &
NODE_PID=$!
BACKGROUND+=("$NODE_PID")
tail -n +1 -f --pid="$NODE_PID" "$NODE_LOG" &
TAIL_PID=$!
deadline=$((SECONDS + NODE_TIMEOUT))
while kill -0 "$NODE_PID" 2>/dev/null; do
  if [[ $SECONDS -ge $deadline ]]; then
    echo "[perception demo] mtc_node did not finish within ${NODE_TIMEOUT} s; stopping it" >&2
    kill -TERM "$NODE_PID" 2>/dev/null || true
    break
  fi
  sleep 0.2
done
set +e
wait "$NODE_PID"
node_code=$?
set -e
wait "$TAIL_PID" 2>/dev/null || true

echo
echo "[perception demo] mtc_node exited with code $node_code"
set +e
"$PY" -m mycobot_planning.demos.pick_place_report --perception "$NODE_LOG" "$PARAMS" "$node_code" "$@"
check=$?
set -e
exit "$check"
