#!/usr/bin/env bash
# README command one: the seeds' pick and place, planned and executed end to end.
#
#   ./scripts/demo.sh [--hardware PORT|emulated] [ROS_ARGS...]   e.g. ./scripts/demo.sh -p max_solutions:=3
#
# --hardware PORT runs the pick and place on the real myCobot 280 on serial port PORT (through
# mycobot_driver instead of the mock controllers); --hardware emulated on the emulated arm
# (mycobot_emulator on a pseudo-terminal, driven by the same driver over pymycobot). With
# --hardware the arm's readback must also end at home (within 0.02 rad per joint).
#
# 1. sets up .venv if needed (scripts/setup.sh);
# 2. brings up the mock controllers (or the driver) and the planning_server (scripts/robot.sh, with a log and
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
if [[ "${1:-}" == "-h" || "${1:-}" == "--help" ]]; then
  sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d' | sed 's/^# \{0,1\}//'
  exit 0
fi
HARDWARE=""
if [[ "${1:-}" == --hardware ]]; then
  [[ -n "${2:-}" ]] || { echo "demo.sh: --hardware needs a serial port or 'emulated'" >&2; exit 2; }
  HARDWARE="$2"; shift 2
elif [[ "${1:-}" == --hardware=* ]]; then
  HARDWARE="${1#*=}"; shift
  [[ -n "$HARDWARE" ]] || { echo "demo.sh: --hardware needs a serial port or 'emulated'" >&2; exit 2; }
fi
"$ROOT/scripts/setup.sh"
PY="$ROOT/.venv/bin/python"
PARAMS="$ROOT/config/mtc_node_params.yaml"
DEMO_DIR="${MYCOBOT_DEMO_DIR:-/tmp/mycobot_planning/demo-$$}"
NODE_TIMEOUT="${MYCOBOT_DEMO_TIMEOUT:-600}"  # s for planning + execution
mkdir -p "$DEMO_DIR"
NODE_LOG="$DEMO_DIR/mtc_node.log"

export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$((1 + $$ % 100))}"
export PYTHONUNBUFFERED=1
ROBOT=("$ROOT/scripts/robot.sh" --log-dir "$DEMO_DIR" --run-dir "$DEMO_DIR/run")
START_ARGS=()
[[ -z "$HARDWARE" ]] || START_ARGS=(--hardware "$HARDWARE")

NODE_PID=""
VIEWER_PID=""
cleanup() {
  local code=$?
  trap - EXIT INT TERM
  if [[ -n "$VIEWER_PID" ]] && kill -0 "$VIEWER_PID" 2>/dev/null; then
    kill -TERM "$VIEWER_PID" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "$VIEWER_PID" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$VIEWER_PID" 2>/dev/null || true
  fi
  if [[ -n "$NODE_PID" ]] && kill -0 "$NODE_PID" 2>/dev/null; then
    # SIGTERM: a background job of a script ignores SIGINT; the node shuts down cleanly on TERM.
    kill -TERM "$NODE_PID" 2>/dev/null || true
    for _ in $(seq 100); do kill -0 "$NODE_PID" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$NODE_PID" 2>/dev/null || true
  fi
  echo "[demo] stopping the robot"
  "${ROBOT[@]}" stop >/dev/null 2>&1 || echo "[demo] robot.sh stop reported a problem; see $DEMO_DIR" >&2
  echo "[demo] logs: $DEMO_DIR"
  exit "$code"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

echo "[demo] ROS_DOMAIN_ID=$ROS_DOMAIN_ID; logs in $DEMO_DIR"
if [[ -z "$HARDWARE" ]]; then
  echo "[demo] starting the mock controllers and the planning_server"
else
  echo "[demo] starting mycobot_driver on ${HARDWARE/#emulated/the emulated arm} and the planning_server"
fi
if ! "${ROBOT[@]}" start "${START_ARGS[@]+"${START_ARGS[@]}"}"; then
  # robot.sh stops what it started when a start fails; one more try rides out a slow machine.
  echo "[demo] the robot did not come up; trying once more" >&2
  "${ROBOT[@]}" start "${START_ARGS[@]+"${START_ARGS[@]}"}"
fi

# shellcheck source=viewer_common.sh
source "$ROOT/scripts/viewer_common.sh"
start_task_viewer "$DEMO_DIR" demo

echo "[demo] running mtc_node (plan, then execute)"
cd "$ROOT"
"$PY" -m mycobot_planning.nodes.mtc_node --ros-args --params-file "$PARAMS" \
  -p execute:=true -p exit_when_done:=true "$@" >"$NODE_LOG" 2>&1 &
NODE_PID=$!
tail -n +1 -f --pid="$NODE_PID" "$NODE_LOG" &
TAIL_PID=$!
deadline=$((SECONDS + NODE_TIMEOUT))
while kill -0 "$NODE_PID" 2>/dev/null; do
  if [[ $SECONDS -ge $deadline ]]; then
    echo "[demo] mtc_node did not finish within ${NODE_TIMEOUT} s; stopping it" >&2
    kill -TERM "$NODE_PID" 2>/dev/null || true
    break
  fi
  sleep 0.2
done
set +e
wait "$NODE_PID"
node_code=$?
set -e
NODE_PID=""
wait "$TAIL_PID" 2>/dev/null || true

echo
echo "[demo] mtc_node exited with code $node_code"
set +e
"$PY" -m mycobot_planning.demos.pick_place_report "$NODE_LOG" "$PARAMS" "$node_code" "$@"
check=$?
set -e
if [[ -n "$HARDWARE" ]]; then
  # The arm's own readback (/joint_states of mycobot_driver) must end at home.
  set +e
  "$PY" - <<'PYEOF'
import sys
import time

import rclpy
from sensor_msgs.msg import JointState

from mycobot_planning.ros.node_runtime import use_fast_discovery

use_fast_discovery()
rclpy.init()
node = rclpy.create_node("demo_home_check")
latest = []
node.create_subscription(JointState, "/joint_states", lambda m: latest.append(m), 10)
deadline = time.monotonic() + 10.0
while not latest and time.monotonic() < deadline:
    rclpy.spin_once(node, timeout_sec=0.1)
if not latest:
    print("[demo] no /joint_states from the arm: cannot check that it ended at home")
    sys.exit(1)
msg = latest[-1]
joints = dict(zip(msg.name, msg.position))
arm = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
       "link6_to_link6_flange"]  # the myCobot's arm group; home: every joint 0
error = max(abs(joints.get(j, float("inf"))) for j in arm)
print(f"[demo] arm readback at the end: {[round(joints.get(j, float('nan')), 4) for j in arm]} rad "
      f"(home: all 0; largest deviation {error:.4f} rad)")
node.destroy_node()
rclpy.try_shutdown()
sys.exit(0 if error <= 0.02 else 1)
PYEOF
  home_check=$?
  set -e
  if [[ $home_check -ne 0 ]]; then
    echo "[demo] FAILED: the arm's readback did not end at home" >&2
    [[ $check -ne 0 ]] || check=1
  else
    echo "[demo] the arm's readback ended at home"
  fi
fi
exit "$check"
