#!/usr/bin/env bash
# README command one: set up if needed, then run the main demo.
# Today: load the myCobot, solve IK for a pose over the seeds' table and print the solutions.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh"
exec "$ROOT/.venv/bin/python" -m mycobot_planning.demos.ik_over_table "$@"
