#!/usr/bin/env bash
# Builds the interface packages in interfaces_py/ros_packages (moveit_msgs, control_msgs,
# moveit_task_constructor_msgs, tf2_msgs, octomap_msgs, object_recognition_msgs, and the objective
# server's own mycobot_objective_msgs) into real ROS
# types installed in the venv, so rclpy imports them with no environment set. Called by
# scripts/setup.sh. PyPI has no wheels of these packages; the pip ROS toolchain
# (rosidl generators, ament_cmake) plus Debian's compiler and cmake build them here.
#
# Skips the build when a stamp says this exact source tree is installed, or when a sourced
# ROS 2 Jazzy install (AMENT_PREFIX_PATH) already provides every package.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${1:-$ROOT/.venv}"
SRC="$ROOT/interfaces_py/ros_packages"
STAMP="$VENV/.mycobot_planning_interfaces"
# Dependency order: moveit_msgs needs octomap_msgs and object_recognition_msgs; the MTC
# messages and the objective server's need moveit_msgs.
PACKAGES=(octomap_msgs object_recognition_msgs tf2_msgs control_msgs moveit_msgs moveit_task_constructor_msgs
          mycobot_objective_msgs)

want="$( (cd "$SRC" && find . -type f | LC_ALL=C sort | xargs sha256sum; sha256sum "$ROOT/scripts/build_interfaces.sh") | sha256sum | cut -d' ' -f1)"
if [[ -f "$STAMP" && "$(cat "$STAMP")" == "$want" ]]; then
  exit 0
fi

# A sourced ROS 2 install that has them all: use it, build nothing.
if [[ -n "${AMENT_PREFIX_PATH:-}" ]]; then
  missing=0
  for pkg in "${PACKAGES[@]}"; do
    found=0
    IFS=: read -ra prefixes <<<"$AMENT_PREFIX_PATH"
    for prefix in "${prefixes[@]}"; do
      [[ "$prefix" == "$VENV" ]] && continue
      [[ -f "$prefix/share/ament_index/resource_index/packages/$pkg" ]] && found=1
    done
    [[ $found == 1 ]] || missing=1
  done
  if [[ $missing == 0 ]] && "$VENV/bin/python" -c "import moveit_msgs.msg, control_msgs.action, moveit_task_constructor_msgs.msg, tf2_msgs.msg, mycobot_objective_msgs.action" 2>/dev/null; then
    echo "[setup] using the interface packages of the sourced ROS 2 install ($AMENT_PREFIX_PATH)"
    exit 0
  fi
fi

# Debian's compiler and cmake (pinned to the versions Debian 12 ships; any build would do).
need=()
command -v cmake >/dev/null 2>&1 || need+=("cmake=3.25.1-1")
command -v g++ >/dev/null 2>&1 || need+=("g++=4:12.2.0-3")
command -v make >/dev/null 2>&1 || need+=("make=4.3-4.1")
if (( ${#need[@]} )); then
  if command -v apt-get >/dev/null 2>&1 && [[ "$(id -u)" == 0 ]]; then
    echo "[setup] installing Debian packages ${need[*]} (interface build)"
    apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
  else
    echo "[setup] the interface build needs ${need[*]}; install them (e.g. sudo apt-get install cmake g++ make)" >&2
    exit 1
  fi
fi

PY="$VENV/bin/python"
# The toolchain wheels were built on a machine whose Python lived in /opt/python/cp311-cp311;
# their exported CMake targets still name its include directories. Point them at ours.
PYINC="$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
NPINC="$("$PY" -c 'import numpy; print(numpy.get_include())')"
for f in $(grep -rl "/opt/python/cp311-cp311" "$VENV"/share/*/cmake/ 2>/dev/null || true); do
  sed -i "s#/opt/python/cp311-cp311/include/python3.11#$PYINC#g; s#/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include#$NPINC#g" "$f"
done

BUILD="$VENV/build/interfaces"
JOBS="$(nproc 2>/dev/null || echo 2)"
export AMENT_PREFIX_PATH="$VENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
start=$SECONDS
echo "[setup] building interface packages (${PACKAGES[*]}) into $VENV; one-time, a few minutes"
for pkg in "${PACKAGES[@]}"; do
  t0=$SECONDS
  rm -rf "$BUILD/$pkg"
  mkdir -p "$BUILD/$pkg"
  log="$BUILD/$pkg.log"
  if ! (cd "$BUILD/$pkg" \
        && cmake "$SRC/$pkg" -DCMAKE_PREFIX_PATH="$VENV" -DCMAKE_INSTALL_PREFIX="$VENV" \
             -DPython3_EXECUTABLE="$PY" -DBUILD_TESTING=OFF \
        && make -j"$JOBS" install) >"$log" 2>&1; then
    tail -40 "$log" >&2
    echo "[setup] building $pkg failed; full log: $log" >&2
    exit 1
  fi
  echo "[setup]   $pkg built in $((SECONDS - t0)) s"
done
"$PY" -c "import moveit_msgs.action, control_msgs.action, moveit_task_constructor_msgs.action, tf2_msgs.msg, octomap_msgs.msg, object_recognition_msgs.msg, mycobot_objective_msgs.action"
rm -rf "$BUILD"
echo "$want" >"$STAMP"
echo "[setup] interface packages built in $((SECONDS - start)) s"
