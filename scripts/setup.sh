#!/usr/bin/env bash
# Creates .venv at the repository root (if missing) with the pinned dependencies and the package
# in editable mode. Idempotent: a stamp records the hash of what was installed, so a second run
# returns at once. Used by scripts/demo.sh and scripts/test.sh (the README's two commands).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
STAMP="$VENV/.mycobot_planning_setup"
PYTHON="${PYTHON:-python3}"

want="$(cat "$ROOT/scripts/requirements.txt" "$ROOT/scripts/constraints.txt" "$ROOT/setup.py" "$ROOT/setup.cfg" "$ROOT/package.xml" | sha256sum | cut -d' ' -f1)"
if [[ -x "$VENV/bin/python" && -f "$STAMP" && "$(cat "$STAMP")" == "$want" ]]; then
  exit 0
fi

echo "[setup] preparing $VENV (one-time; later runs skip this)"
if [[ ! -x "$VENV/bin/python" ]]; then
  "$PYTHON" -m venv "$VENV"
fi
"$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --upgrade "pip==26.3"
"$VENV/bin/python" -m pip install --quiet --disable-pip-version-check \
  -r "$ROOT/scripts/requirements.txt" -c "$ROOT/scripts/constraints.txt"
# setuptools' own deprecation chatter goes to a log; it is shown only if the install fails.
if ! "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation \
    -e "$ROOT" >"$VENV/editable-install.log" 2>&1; then
  cat "$VENV/editable-install.log" >&2
  exit 1
fi
# Prove the stack loads together before declaring success.
"$VENV/bin/python" -c "import rclpy, pinocchio, coal, ompl, ruckig, numpy, scipy, yaml, mycobot_planning, interfaces_py"
echo "$want" > "$STAMP"
echo "[setup] done: activate with 'source .venv/bin/activate'"
