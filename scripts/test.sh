#!/usr/bin/env bash
# README command two: set up if needed, then run the whole test suite in .venv.
# With no arguments: the tests that start no ROS node run on two workers (pytest-xdist, a module
# per worker), then the ROS tests one at a time (they start processes and judge real-time
# behaviour, so they run with nothing else beside them: on two workers, fresh-clone runs failed
# tests outside the `realtime` marker too). Extra arguments go to one plain pytest run instead
# (e.g. ./scripts/test.sh -k ik -x, or -m "not ros" for the fast set).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh"
cd "$ROOT"
# Nodes started by tests talk only on localhost, on a domain of their own.
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
PYTEST=("$ROOT/.venv/bin/python" -m pytest -q)
if [[ $# -gt 0 ]]; then
  exec "${PYTEST[@]}" "$@"
fi
status=0
echo "[test] 1/2: the tests without ROS nodes, on 2 workers"
"${PYTEST[@]}" -m "not ros" -n 2 --dist loadfile || status=$?
echo "[test] 2/2: the ROS tests (the 25 slowest listed at the end: where the suite's time goes)"
# Fast DDS keeps its shared-memory ports in /dev/shm, and those of processes that died unclean
# (killed nodes, earlier runs) stay behind; one run here failed every test after a node could no
# longer open such a port ("open_and_lock_file failed"). `fastdds shm clean` removes only the
# files no live process holds.
echo "[test] Fast DDS shared memory: $("$ROOT/.venv/bin/fastdds" shm clean 2>&1 | tail -3 | tr '\n' ' ')"
"${PYTEST[@]}" -m ros --durations=25 || status=$((status > 0 ? status : $?))
exit "$status"
