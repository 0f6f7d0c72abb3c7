# Sourced by the demo scripts: start the task viewer when MYCOBOT_DEMO_VIEWER=1 and print its
# address, so a user can watch the demo in a browser. Sets VIEWER_PID ("" when not started);
# the caller stops it on exit. Needs PY (the venv's python) to be set.
start_task_viewer() {  # LOG_DIR TAG
  local log_dir="$1" tag="$2" log url
  VIEWER_PID=""
  if [[ "${MYCOBOT_DEMO_VIEWER:-0}" != 1 ]]; then
    echo "[$tag] to watch in a browser, run with MYCOBOT_DEMO_VIEWER=1 (serves http://127.0.0.1:${MYCOBOT_VIEWER_PORT:-8080}/)"
    return 0
  fi
  log="$log_dir/task_viewer.log"
  "$PY" -m mycobot_planning.nodes.task_viewer --ros-args -p port:="${MYCOBOT_VIEWER_PORT:-8080}" >"$log" 2>&1 &
  VIEWER_PID=$!
  for _ in $(seq 200); do
    grep -q "in a browser" "$log" 2>/dev/null && break
    kill -0 "$VIEWER_PID" 2>/dev/null || break
    sleep 0.1
  done
  url="$(grep -o 'http://[^ ]*' "$log" 2>/dev/null | head -n 1 || true)"
  if [[ -n "$url" ]]; then
    echo "[$tag] task viewer running: open $url in a browser"
  else
    echo "[$tag] the task viewer did not start; see $log" >&2
  fi
}
