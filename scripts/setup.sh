#!/usr/bin/env bash
# Creates .venv at the repository root (if missing) with the pinned dependencies and the package
# in editable mode. Idempotent: a stamp records the hash of what was installed, so a second run
# returns at once. Used by scripts/demo.sh and scripts/test.sh (the README's two commands).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
STAMP="$VENV/.mycobot_planning_setup"
PYTHON="${PYTHON:-python3}"

# Debian packages: Chromium for the task viewer's browser test. Pinned; if the mirror no longer
# carries that build (security updates replace it), the current one is installed and we say so.
CHROMIUM_VERSION="156.0.8078.79-1~deb12u1"
if ! command -v chromium >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1 && [[ "$(id -u)" == 0 ]]; then
  echo "[setup] installing Debian package chromium=$CHROMIUM_VERSION (headless browser tests)"
  apt-get update -qq >/dev/null
  if ! DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "chromium=$CHROMIUM_VERSION" >/dev/null; then
    echo "[setup] chromium $CHROMIUM_VERSION is no longer available; installing the current build"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null || echo "[setup] chromium could not be installed; browser tests will be skipped"
  fi
fi

# Debian packages: headless OpenGL for MuJoCo's depth camera (MUJOCO_GL=egl): the GL vendor-neutral
# dispatch (libegl1, libopengl0: PyOpenGL loads libEGL.so.1 and libOpenGL.so.0) and Mesa's EGL
# and DRI drivers, whose software rasteriser (llvmpipe) renders on machines without a GPU.
# Pinned; installed only when missing (an installed Mesa is left as it is); if the mirror no
# longer carries these builds, the current ones are installed and we say so.
EGL_PACKAGES=("libegl1=1.6.0-1" "libopengl0=1.6.0-1" "libegl-mesa0=22.3.6-1+deb12u2" "libgl1-mesa-dri=22.3.6-1+deb12u2")
egl_missing=()
if command -v dpkg-query >/dev/null 2>&1; then
  for pkg in "${EGL_PACKAGES[@]}"; do
    if [[ "$(dpkg-query -W -f='${Status}' "${pkg%%=*}" 2>/dev/null)" != "install ok installed" ]]; then
      egl_missing+=("$pkg")
    fi
  done
fi
if (( ${#egl_missing[@]} )); then
  if command -v apt-get >/dev/null 2>&1 && [[ "$(id -u)" == 0 ]]; then
    echo "[setup] installing Debian packages ${egl_missing[*]} (headless EGL rendering for the MuJoCo depth camera)"
    apt-get update -qq >/dev/null
    if ! DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${egl_missing[@]}" >/dev/null; then
      echo "[setup] these builds are no longer available; installing the current ${egl_missing[*]%%=*}"
      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${egl_missing[@]%%=*}" >/dev/null \
        || echo "[setup] EGL packages could not be installed; the simulated depth camera will not render"
    fi
  else
    echo "[setup] missing Debian packages ${egl_missing[*]%%=*} (not root: not installed); the simulated depth camera needs them"
  fi
fi

want="$(cat "$ROOT/scripts/requirements.txt" "$ROOT/scripts/constraints.txt" "$ROOT/setup.py" "$ROOT/setup.cfg" "$ROOT/package.xml" | sha256sum | cut -d' ' -f1)"
if [[ -x "$VENV/bin/python" && -f "$STAMP" && "$(cat "$STAMP")" == "$want" ]]; then
  # MoveIt's, ros2_control's and MTC's interface packages (a no-op when its own stamp is current).
  "$ROOT/scripts/build_interfaces.sh" "$VENV"
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
# MoveIt's, ros2_control's and MTC's interface packages, built from interfaces_py/ros_packages.
"$ROOT/scripts/build_interfaces.sh" "$VENV"
# Prove the stack loads together before declaring success.
"$VENV/bin/python" -c "import rclpy, pinocchio, coal, ompl, ruckig, numpy, scipy, yaml, viser, matplotlib, mujoco, mycobot_planning, interfaces_py, moveit_msgs.action, control_msgs.action, pymoveit2"
# numba compiles the core's kernels on first use and caches them beside the sources: do it now,
# not in the first plan of a node or of two test workers at once (mycobot_planning/core/jit_warm_up.py)
"$VENV/bin/python" -m mycobot_planning.core.jit_warm_up
echo "$want" > "$STAMP"
echo "[setup] done: activate with 'source .venv/bin/activate'"
