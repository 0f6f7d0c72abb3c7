#!/usr/bin/env bash
# README command two: set up if needed, then run the whole test suite in .venv.
# With no arguments: the tests that start no ROS node run on two workers (pytest-xdist, a module
# per worker), then the ROS tests whose verdicts do not hang on timing, also on two workers (each
# worker's nodes on a ROS domain of its own), then the `realtime` ROS tests (motions stopped in
# time, servoing, physics in real time: test/conftest.py REALTIME_MODULES) one at a time with
# nothing else beside them. Extra arguments go to one plain pytest run instead (e.g.
# ./scripts/test.sh -k ik -x, or -m "not ros" for the fast set).
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
echo "[test] 1/3: the tests without ROS nodes, on 2 workers"
"${PYTEST[@]}" -m "not ros" -n 2 --dist loadfile || status=$?
echo "[test] 2/3: the ROS tests that judge no timing, on 2 workers (the 15 slowest listed at the end)"
"${PYTEST[@]}" -m "ros and not realtime" -n 2 --dist loadfile --durations=15 || status=$((status > 0 ? status : $?))
echo "[test] 3/3: the realtime ROS tests, one at a time (the 15 slowest listed at the end)"
"${PYTEST[@]}" -m "ros and realtime" --durations=15 || status=$((status > 0 ? status : $?))
exit "$status"
