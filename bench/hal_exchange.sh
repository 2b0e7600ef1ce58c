#!/usr/bin/env bash
# The HAL exchange's timing on this machine: runs the nested sheet on the HAL-simulated thermal
# gantry (scripts/hal-sim, position mode) for SECONDS of wall-clock time (default 60), stops it
# with SIGINT (a controlled stop, exit 3, the report written), and writes the backend's note
# (exchange jitter p50, p99, p99.9, max; late exchanges; the real-time setting) with the
# command, the machine and its load before and after.
#
#   bench/hal_exchange.sh [MACHPLAN_BINARY] > bench/results/hal_exchange.txt
#
# MACHPLAN_BINARY defaults to build/release/cli/machplan, then build/dev/cli/machplan. Needs
# HAL (scripts/setup); brings it up and down itself.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-}
if [[ -z "$bin" ]]; then
  for b in build/release/cli/machplan build/dev/cli/machplan; do [[ -x "$b" ]] && bin=$b && break; done
fi
[[ -x "$bin" ]] || { echo "no machplan binary (give its path)" >&2; exit 2; }
seconds=${SECONDS_RUN:-60}
out=$(mktemp -d)
trap 'scripts/hal-sim down >/dev/null 2>&1 || true; rm -rf "$out"' EXIT
scripts/hal-sim up >/dev/null
# One run as this user (real time when allowed), and, when this user is root, one as the uid HAL
# runs as (65534), which may not lock memory or use SCHED_FIFO: ordinary scheduling.
run() {  # $1: label, rest: command prefix
  local label=$1
  shift
  scripts/hal-sim home 0 0 >/dev/null
  local load_before load_after rc
  load_before=$(uptime)
  set +e
  "$@" timeout --preserve-status -s INT "$seconds" $cmd >"$out/run.json" 2>"$out/run.err"
  rc=$?
  set -e
  load_after=$(uptime)
  echo
  echo "## $label"
  echo "# command: scripts/hal-sim up && $* timeout -s INT $seconds $cmd && scripts/hal-sim down"
  echo "# load before: ${load_before# }"
  echo "# load after:  ${load_after# }"
  echo "# exit: $rc (3: stopped by SIGINT after $seconds s, as intended)"
  grep -v '^$' "$out/run.err" | sed 's/^/# stderr: /' || true
  python3 - "$out/run.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(f"# machine time run: {d['cycle_time_s']:.3f} s, status {d['status']}, cuts completed {sum(1 for c in d['cuts'] if c.get('complete'))}, max contour error {d['max_contour_error_mm']:.4f} mm")
for n in d["backend_notes"]:
    print(n)
PY
}
cmd="$bin run datasets/parts/nested_sheet.ngc --machine thermal_gantry --backend hal --json"
echo "# bench/hal_exchange.sh, $(date -u +%Y-%m-%d)"
echo "# machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(uname -sr), $(. /etc/os-release && echo "$PRETTY_NAME"); shared with other jobs"
echo "# HAL: scripts/hal-sim (thermal_gantry, position mode), servo thread 1 ms, SCHED_FIFO 80 when root"
echo "# jitter: |interval between two exchanges - 1 ms|; late: commands written after their period began"
run "as $(id -un)"
if [ "$(id -u)" -eq 0 ] && command -v setpriv >/dev/null; then
  chmod -R o+rX "$out"
  run "as uid 65534 (no real-time privileges)" setpriv --reuid=65534 --regid=65534 --clear-groups
fi
