#!/usr/bin/env bash
# Launch-free bring-up of the robot: the mock ros2_control controllers (node controller_manager)
# or, with --hardware, the driver of the real myCobot 280 (node mycobot_driver, same controllers),
# the robot_state_publisher (/robot_description, /tf, /tf_static for RViz) and the planning_server
# (the move_group stand-in, with its node move_group), in the background, like the seeds' robot.sh
# but without a launch system. See usage() below.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY="$ROOT/.venv/bin/python"
LOG_DIR="${MYCOBOT_LOG_DIR:-/tmp/mycobot_planning/logs}"
RUN_DIR="${MYCOBOT_RUN_DIR:-/tmp/mycobot_planning/run}"
TIMEOUT="${MYCOBOT_START_TIMEOUT:-60}"
NODES=(mock_controllers robot_state_publisher planning_server)   # start order; stop runs in reverse
declare -A READY_TEXT=([mock_controllers]="controller_manager ready"
                       [mycobot_emulator]="mycobot_emulator ready"
                       [mycobot_driver]="mycobot_driver ready"
                       [robot_state_publisher]="robot_state_publisher ready"
                       [planning_server]="planning_server ready")
# Python module of each process (default: mycobot_planning.nodes.<name>)
declare -A MODULE=([mycobot_emulator]="mycobot_planning.hardware.emulator")
module_of() { echo "${MODULE[$1]:-mycobot_planning.nodes.$1}"; }
HARDWARE=""
DRIVER_PARAMS=()

usage() {
  cat <<EOF
Usage: scripts/robot.sh start|stop|restart|status [--log-dir DIR] [--run-dir DIR] [--timeout S]
                        [--hardware PORT|emulated [--driver-param NAME:=VALUE]...]
                        [-- PLANNING_SERVER_ROS_ARGS...]

  start    start mock_controllers, robot_state_publisher and planning_server in the background (each
           in a process group of its own), then wait until all are up: their logs say "ready" and the planning_server
           answers get_state with joint states received. Prints the PIDs and the log folder. A node
           that is already running is not started again (start is idempotent). If a node dies or
           the wait times out, whatever this start launched is stopped again and the exit code is 1.
  stop     stop them all: SIGINT to each tracked process group, SIGTERM after 10 s, SIGKILL after 3 s
           more. Only the PIDs recorded by start are signalled, never processes found by name.
  restart  stop, then start.
  status   what runs: PID, alive or dead, log file of each node. Exit code 0 when all run,
           3 when none runs, 1 otherwise (some of them only, or a node that died).

Options:
  --log-dir DIR  log folder (default \$MYCOBOT_LOG_DIR or /tmp/mycobot_planning/logs); one file
                 per node, <node>.log, the previous run's kept as <node>.log.1
  --run-dir DIR  PID files (default \$MYCOBOT_RUN_DIR or /tmp/mycobot_planning/run)
  --timeout S    seconds start waits for the nodes to be up (default \$MYCOBOT_START_TIMEOUT or 60)
  --hardware PORT|emulated
                 start/restart: drive the real myCobot 280 on serial port PORT (e.g. /dev/ttyUSB0)
                 with mycobot_driver instead of the mock controllers (same controllers and actions;
                 /joint_states from the arm's readback). "emulated" first starts mycobot_emulator,
                 an emulated arm on a pseudo-terminal (its port: RUN_DIR/mycobot_port, its fault
                 control socket: RUN_DIR/mycobot_emulator.sock), and drives that.
  --driver-param NAME:=VALUE
                 a parameter for mycobot_driver (repeatable), e.g. --driver-param model:=Pi
                 --driver-param command_rate:=20.0

Everything after "--" is handed to the planning_server as ROS arguments, after "--ros-args"
(added unless you start with it), e.g.:
  scripts/robot.sh start -- -p planning_time:=2.0 -p trajectory_execution.allowed_start_tolerance:=0.02
  scripts/robot.sh start -- --params-file config/planning_server.yaml
They are used only when the planning_server is (re)started.

Environment: ROS_DOMAIN_ID is honoured (the nodes join that domain; status shows the domain
they were started on). ROS_AUTOMATIC_DISCOVERY_RANGE is set to LOCALHOST unless already set.
The Python of .venv runs the nodes; scripts/setup.sh creates .venv first if it is missing.
EOF
}

die() { echo "robot.sh: $*" >&2; exit 1; }

# ---------------------------------------------------------------------------- arguments
COMMAND=""
SERVER_ARGS=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --log-dir) [[ $# -ge 2 ]] || die "--log-dir needs a folder"; LOG_DIR="$2"; shift 2 ;;
    --log-dir=*) LOG_DIR="${1#*=}"; shift ;;
    --run-dir) [[ $# -ge 2 ]] || die "--run-dir needs a folder"; RUN_DIR="$2"; shift 2 ;;
    --run-dir=*) RUN_DIR="${1#*=}"; shift ;;
    --timeout) [[ $# -ge 2 ]] || die "--timeout needs seconds"; TIMEOUT="$2"; shift 2 ;;
    --timeout=*) TIMEOUT="${1#*=}"; shift ;;
    --hardware) [[ $# -ge 2 && -n "$2" ]] || die "--hardware needs a serial port or 'emulated'"; HARDWARE="$2"; shift 2 ;;
    --hardware=*) HARDWARE="${1#*=}"; [[ -n "$HARDWARE" ]] || die "--hardware needs a serial port or 'emulated'"; shift ;;
    --driver-param) [[ $# -ge 2 && "$2" == *:=* ]] || die "--driver-param needs NAME:=VALUE"; DRIVER_PARAMS+=("$2"); shift 2 ;;
    --) shift; SERVER_ARGS=("$@"); break ;;
    start|stop|restart|status)
      [[ -z "$COMMAND" ]] || die "one command only (got '$COMMAND' and '$1'); see --help"
      COMMAND="$1"; shift ;;
    *) usage >&2; die "unknown argument '$1'" ;;
  esac
done
[[ -n "$COMMAND" ]] || { usage >&2; exit 2; }
[[ "$TIMEOUT" =~ ^[0-9]+([.][0-9]+)?$ ]] || die "--timeout must be a number of seconds, got '$TIMEOUT'"
if [[ ${#SERVER_ARGS[@]} -gt 0 && "$COMMAND" != start && "$COMMAND" != restart ]]; then
  die "arguments after -- are for start/restart only"
fi
if [[ ( -n "$HARDWARE" || ${#DRIVER_PARAMS[@]} -gt 0 ) && "$COMMAND" != start && "$COMMAND" != restart ]]; then
  die "--hardware and --driver-param are for start/restart only"
fi
[[ ${#DRIVER_PARAMS[@]} -eq 0 || -n "$HARDWARE" ]] || die "--driver-param needs --hardware"
# Absolute folders: the paths printed and recorded stay valid from any working directory.
mkdir -p "$LOG_DIR" "$RUN_DIR"
LOG_DIR="$(cd "$LOG_DIR" && pwd)"
RUN_DIR="$(cd "$RUN_DIR" && pwd)"
EMULATED_PORT="$RUN_DIR/mycobot_port"
EMULATOR_SOCKET="$RUN_DIR/mycobot_emulator.sock"

# The set of processes: what this start asks for, else what the last start of this run dir
# recorded (so stop and status know a hardware bring-up), else the mock's.
nodes_for() {  # hardware -> node names, start order
  case "$1" in
    "") echo mock_controllers robot_state_publisher planning_server ;;
    emulated) echo mycobot_emulator mycobot_driver robot_state_publisher planning_server ;;
    *) echo mycobot_driver robot_state_publisher planning_server ;;
  esac
}
RECORDED_NODES=""
[[ -f "$RUN_DIR/nodes" ]] && RECORDED_NODES="$(cat "$RUN_DIR/nodes")"
if [[ "$COMMAND" == start || "$COMMAND" == restart ]]; then
  read -r -a WANTED_NODES <<< "$(nodes_for "$HARDWARE")"
fi
if [[ -n "$RECORDED_NODES" ]]; then
  read -r -a NODES <<< "$RECORDED_NODES"
elif [[ "$COMMAND" == start || "$COMMAND" == restart ]]; then
  NODES=("${WANTED_NODES[@]}")
fi

export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
export PYTHONUNBUFFERED=1

# ---------------------------------------------------------------------------- process bookkeeping
pid_file() { echo "$RUN_DIR/$1.pid"; }
log_file() { echo "$LOG_DIR/$1.log"; }
recorded_pid() { local f; f="$(pid_file "$1")"; [[ -f "$f" ]] && cat "$f" || true; }

# True when the recorded PID is a live process running that node (a reused PID is not ours).
alive() {
  local name="$1" pid state
  pid="$(recorded_pid "$name")"
  [[ -n "$pid" && -r "/proc/$pid/cmdline" ]] || return 1
  state="$(awk '{print $3}' "/proc/$pid/stat" 2>/dev/null || true)"
  [[ -n "$state" && "$state" != Z && "$state" != X ]] || return 1
  tr '\0' ' ' < "/proc/$pid/cmdline" | grep -q -- "$(module_of "$name")"
}

any_alive() {
  local name
  for name in "${NODES[@]}"; do alive "$name" && return 0; done
  return 1
}

# True while the recorded PID runs (not a zombie). Used right after start: until setsid has
# exec'd Python, /proc/PID/cmdline still shows the forking shell, so alive() would say no.
pid_running() {
  local pid state
  pid="$(recorded_pid "$1")"
  [[ -n "$pid" ]] || return 1
  state="$(awk '{print $3}' "/proc/$pid/stat" 2>/dev/null || true)"
  [[ -n "$state" && "$state" != Z && "$state" != X ]]
}

# True while any process of the group led by the node's PID remains.
group_alive() { kill -0 -- "-$1" 2>/dev/null; }

wait_group_gone() {  # pgid seconds
  local pgid="$1" deadline=$((SECONDS + $2))
  while group_alive "$pgid"; do
    [[ $SECONDS -lt $deadline ]] || return 1
    sleep 0.1
  done
}

# stop_node NAME [already_signalled]: SIGINT the node's process group (unless already done),
# escalate to SIGTERM and SIGKILL if it does not end, forget its PID.
stop_node() {
  local name="$1" signalled="${2:-}" pid
  pid="$(recorded_pid "$name")"
  if [[ -z "$pid" ]]; then
    echo "$name: not running"
    return 0
  fi
  if [[ -z "$signalled" ]] && ! alive "$name"; then
    rm -f "$(pid_file "$name")"
    echo "$name: was not running (pid $pid exited; stale pid file removed)"
    return 0
  fi
  [[ -n "$signalled" ]] || kill -INT -- "-$pid" 2>/dev/null || true
  if ! wait_group_gone "$pid" 10; then
    echo "$name: still running 10 s after SIGINT, sending SIGTERM" >&2
    kill -TERM -- "-$pid" 2>/dev/null || true
    if ! wait_group_gone "$pid" 3; then
      echo "$name: still running after SIGTERM, sending SIGKILL" >&2
      kill -KILL -- "-$pid" 2>/dev/null || true
      wait_group_gone "$pid" 3 || die "$name: process group $pid survived SIGKILL"
    fi
  fi
  rm -f "$(pid_file "$name")"
  echo "$name: stopped (pid $pid)"
}

start_node() {
  local name="$1"; shift
  local log; log="$(log_file "$name")"
  [[ -f "$log" ]] && mv -f "$log" "$log.1"
  echo "=== $name started $(date '+%Y-%m-%d %H:%M:%S') on ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-0}: $*" > "$log"
  # setsid: the node leads a process group of its own, so stop can signal it and its children
  # without touching anything else. (This shell has no job control, so the background child is
  # not a group leader and setsid runs the node in place: $! is the node's PID.)
  setsid "$PY" -m "$(module_of "$name")" "$@" >>"$log" 2>&1 </dev/null &
  local pid=$!
  echo "$pid" > "$(pid_file "$name")"
  echo "$name: started (pid $pid, log $log)"
}

server_ros_args() {
  if [[ ${#SERVER_ARGS[@]} -eq 0 ]]; then
    return 0
  fi
  if [[ "${SERVER_ARGS[0]}" != --ros-args ]]; then
    printf '%s\n' --ros-args
  fi
  printf '%s\n' "${SERVER_ARGS[@]}"
}

# The planning_server answers get_state and has joint states: it can plan from the robot's state.
server_answers() {
  "$PY" - "$1" <<'PYEOF'
import sys
import time

from mycobot_planning.ros.node_runtime import use_fast_discovery

use_fast_discovery()
from interfaces_py.clients import PlanningSceneInterface, RpcError  # noqa: E402

deadline = time.monotonic() + max(0.5, float(sys.argv[1]))
with PlanningSceneInterface(timeout=5.0) as client:
    if not client.wait_for_server(max(0.1, deadline - time.monotonic())):
        sys.exit("the planning_server does not answer requests")
    while True:
        try:
            if client.call("get_state").get("joint_state_received"):
                sys.exit(0)
        except RpcError as exc:
            problem = str(exc)
        else:
            problem = "it has received no /joint_states yet"
        if time.monotonic() > deadline:
            sys.exit(f"the planning_server is not ready: {problem}")
        time.sleep(0.1)
PYEOF
}

print_status() {
  local domain="(unknown)" running=0 dead=0 name pid
  [[ -f "$RUN_DIR/ros_domain_id" ]] && domain="$(cat "$RUN_DIR/ros_domain_id")"
  for name in "${NODES[@]}"; do
    pid="$(recorded_pid "$name")"
    if alive "$name"; then
      echo "$name: running (pid $pid, ROS_DOMAIN_ID=$domain, log $(log_file "$name"))"
      running=$((running + 1))
    elif [[ -n "$pid" ]]; then
      echo "$name: dead (pid $pid exited; see log $(log_file "$name"))"
      dead=$((dead + 1))
    else
      echo "$name: not running"
    fi
  done
  echo "logs: $LOG_DIR"
  if [[ $running -eq ${#NODES[@]} ]]; then return 0; fi
  if [[ $running -eq 0 && $dead -eq 0 ]]; then return 3; fi
  return 1
}

# ---------------------------------------------------------------------------- commands
do_stop() {
  # SIGINT every node first (the planning_server first: it stops a running execution while the
  # controllers still listen), then wait for each: their shutdowns overlap instead of adding up.
  # The emulated arm is the exception: it is stopped last, after the driver, whose shutdown sends
  # the arm its stop command (a fresh-clone run saw the emulator gone before that command).
  local i name signalled=()
  for ((i = ${#NODES[@]} - 1; i >= 0; i--)); do
    name="${NODES[$i]}"
    [[ "$name" != mycobot_emulator ]] || continue
    if alive "$name"; then
      kill -INT -- "-$(recorded_pid "$name")" 2>/dev/null || true
      signalled+=("$name")
    fi
  done
  for ((i = ${#NODES[@]} - 1; i >= 0; i--)); do
    name="${NODES[$i]}"
    if [[ " ${signalled[*]-} " == *" $name "* ]]; then
      stop_node "$name" signalled
    else
      stop_node "$name"
    fi
  done
  rm -f "$RUN_DIR/ros_domain_id" "$RUN_DIR/nodes" "$RUN_DIR/hardware"
}

do_start() {
  if [[ ! -x "$PY" ]]; then
    echo "robot.sh: $PY is missing; running scripts/setup.sh first"
    "$ROOT/scripts/setup.sh"
  fi
  local domain="${ROS_DOMAIN_ID:-0}" started=() name
  if [[ -f "$RUN_DIR/ros_domain_id" ]] && any_alive; then
    local running_domain; running_domain="$(cat "$RUN_DIR/ros_domain_id")"
    if [[ "$running_domain" != "$domain" ]]; then
      die "the robot of $RUN_DIR already runs on ROS_DOMAIN_ID=$running_domain, not $domain: stop it first or use another --run-dir"
    fi
  fi
  if [[ "${NODES[*]}" != "${WANTED_NODES[*]}" ]]; then
    if any_alive; then
      die "this run dir runs ${NODES[*]}, not ${WANTED_NODES[*]}: stop it first (scripts/robot.sh stop) or use another --run-dir"
    fi
    NODES=("${WANTED_NODES[@]}")
  fi
  if [[ -n "$HARDWARE" && -f "$RUN_DIR/hardware" && "$(cat "$RUN_DIR/hardware")" != "$HARDWARE" ]] && any_alive; then
    die "this run dir drives the arm on $(cat "$RUN_DIR/hardware"), not $HARDWARE: stop it first"
  fi
  echo "$domain" > "$RUN_DIR/ros_domain_id"
  echo "${NODES[*]}" > "$RUN_DIR/nodes"
  if [[ -n "$HARDWARE" ]]; then echo "$HARDWARE" > "$RUN_DIR/hardware"; else rm -f "$RUN_DIR/hardware"; fi
  echo "ROS_DOMAIN_ID=$domain ROS_AUTOMATIC_DISCOVERY_RANGE=$ROS_AUTOMATIC_DISCOVERY_RANGE; logs: $LOG_DIR"
  for name in "${NODES[@]}"; do
    if alive "$name"; then
      echo "$name: already running (pid $(recorded_pid "$name"))"
      if [[ "$name" == planning_server && ${#SERVER_ARGS[@]} -gt 0 ]]; then
        echo "robot.sh: planning_server already runs; arguments after -- ignored (restart to apply them)" >&2
      fi
      continue
    fi
    if [[ "$name" == planning_server ]]; then
      local args=()
      mapfile -t args < <(server_ros_args)
      start_node "$name" "${args[@]}"
    elif [[ "$name" == mycobot_emulator ]]; then
      start_node "$name" --link "$EMULATED_PORT" --control "$EMULATOR_SOCKET"
    elif [[ "$name" == mycobot_driver ]]; then
      local port="$HARDWARE" dargs=() p
      [[ "$port" == emulated ]] && port="$EMULATED_PORT"
      dargs=(--ros-args -p "port:=$port")
      for p in "${DRIVER_PARAMS[@]+"${DRIVER_PARAMS[@]}"}"; do dargs+=(-p "$p"); done
      start_node "$name" "${dargs[@]}"
    else
      start_node "$name"
    fi
    started+=("$name")
  done

  # wait until every node says it is ready (and is still alive), then until the server answers
  local deadline=$((SECONDS + ${TIMEOUT%.*} + 1)) pending=("${NODES[@]}")
  while [[ ${#pending[@]} -gt 0 ]]; do
    local still=()
    for name in "${pending[@]}"; do
      if ! pid_running "$name"; then
        echo "robot.sh: $name exited during start-up; last lines of $(log_file "$name"):" >&2
        tail -n 20 "$(log_file "$name")" >&2 || true
        abort_start "${started[@]}"
      fi
      grep -qF -- "${READY_TEXT[$name]}" "$(log_file "$name")" 2>/dev/null || still+=("$name")
    done
    pending=("${still[@]+"${still[@]}"}")
    [[ ${#pending[@]} -eq 0 ]] && break
    if [[ $SECONDS -ge $deadline ]]; then
      echo "robot.sh: ${pending[*]} not ready after ${TIMEOUT} s; see the logs in $LOG_DIR" >&2
      abort_start "${started[@]}"
    fi
    sleep 0.1
  done
  local remaining=$((deadline - SECONDS)); [[ $remaining -ge 5 ]] || remaining=5
  if ! server_answers "$remaining"; then
    if [[ " ${NODES[*]} " == *" mycobot_driver "* ]]; then
      echo "robot.sh: no joint states from the arm; last lines of $(log_file mycobot_driver):" >&2
      tail -n 5 "$(log_file mycobot_driver)" >&2 || true
    fi
    echo "robot.sh: see the logs in $LOG_DIR" >&2
    abort_start "${started[@]}"
  fi
  local summary=() n
  for n in "${NODES[@]}"; do summary+=("$n (pid $(recorded_pid "$n"))"); done
  local joined; joined="$(printf '%s, ' "${summary[@]}")"
  echo "robot up: ${joined%, }; logs in $LOG_DIR"
  if [[ -n "$HARDWARE" ]]; then
    local port="$HARDWARE"; [[ "$port" == emulated ]] && port="$EMULATED_PORT (emulated arm; faults: $EMULATOR_SOCKET)"
    echo "hardware: mycobot_driver drives the myCobot 280 on $port"
  fi
}

# Undo a failed start: stop what this start launched (never what was already running).
abort_start() {
  local name
  for ((i = $# ; i >= 1; i--)); do
    name="${!i}"
    stop_node "$name" >&2 || true
  done
  any_alive || rm -f "$RUN_DIR/ros_domain_id" "$RUN_DIR/nodes" "$RUN_DIR/hardware"
  exit 1
}

case "$COMMAND" in
  start) do_start ;;
  stop) do_stop ;;
  restart) do_stop; do_start ;;
  status) set +e; print_status; exit $? ;;
esac
