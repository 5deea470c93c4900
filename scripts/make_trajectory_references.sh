#!/usr/bin/env bash
# Writes the independent reference trajectories (issue 29 item 1; docs/testing.md,
# "References"): tests/published/reference/*.tsv and tests/simulate/extreme/reference/*.tsv,
# by tests/reference/trajectory_reference.cpp (SUNDIALS CVODE on the dynamics of
# tests/reference/).  Minutes of CPU.  Usage: scripts/make_trajectory_references.sh [BUILD_DIR] [CASE...]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
shift || true
cmake --build "$build" --target trajectory_reference
prog=$build/tests/trajectory_reference
commit=$(git -C "$root" rev-parse --short HEAD)
[[ -z $(git -C "$root" status --porcelain -- tests/reference) ]] || commit="$commit + uncommitted changes to tests/reference"
cases=("$@")
[[ ${#cases[@]} -gt 0 ]] || mapfile -t cases < <("$prog" --list | cut -f1)
for c in "${cases[@]}"; do
  case $c in
    a0*) dir=$root/tests/published/reference ;;
    *) dir=$root/tests/simulate/extreme/reference ;;
  esac
  mkdir -p "$dir"
  "$prog" "$c" -o "$dir/$c.tsv" --commit "commit $commit"
done
