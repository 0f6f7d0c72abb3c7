#!/usr/bin/env bash
# README command two: set up if needed, then run the whole test suite in .venv.
# Extra arguments go to pytest (e.g. ./scripts/test.sh -k ik -x).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh"
cd "$ROOT"
# Nodes started by tests talk only on localhost, on a domain of their own.
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
exec "$ROOT/.venv/bin/python" -m pytest -q "$@"
