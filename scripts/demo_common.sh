# Sourced (not run) by the demo wrappers demo.sh, perception_demo.sh and react_demo.sh: the steps
# each of them takes before running its demo.
#
#   demo_prepare SCRIPT [FIRST_ARG]
#
# With FIRST_ARG -h or --help: prints SCRIPT's header comment (its line 2 up to its
# `set -euo pipefail` line, without the leading '# ') and exits 0. Otherwise sets up .venv if
# needed (scripts/setup.sh) and changes to the repository root ($ROOT, set by the wrapper).
demo_prepare() {
  local script="$1" first="${2:-}"
  if [[ "$first" == "-h" || "$first" == "--help" ]]; then
    sed -n '2,/^set -euo/p' "$script" | sed '$d' | sed 's/^# \{0,1\}//'
    exit 0
  fi
  "$ROOT/scripts/setup.sh"
  cd "$ROOT"
}
