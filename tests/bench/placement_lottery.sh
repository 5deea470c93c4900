#!/usr/bin/env bash
# Compares programs across physical page placements (docs/benchmarks.md, run 10).
#
#   tests/bench/placement_lottery.sh [-n COPIES] [-d DROPS] [-r RUNS] [-c CPU] PROGRAM...
#
# Each PROGRAM runs without arguments and prints one time on stdout (its own
# best or median).  On the machines of docs/benchmarks.md a program's speed
# depends on where the kernel puts its file's pages in physical memory, and
# byte-identical copies of one binary run up to 30% apart.  So every PROGRAM
# is copied COPIES times (default 10) into a temporary folder; then DROPS
# times (default 3) the page cache is dropped (root only: otherwise the
# copies keep their first placement, which stderr says; -d 0: one round,
# no drop) and every copy of every PROGRAM runs RUNS times (default 2),
# round-robin, pinned to CPU (default 1) with taskset when it is installed.
# Output, per PROGRAM: the median over copies and drops of each copy's
# median, the fastest and slowest copy, and how many copies ran more than
# 1.08 x the fastest.  A PROGRAM that fails or prints no number stops it.
set -euo pipefail
copies=10 drops=3 runs=2 cpu=1
while getopts "n:d:r:c:h" opt; do
  case "$opt" in
    n) copies="$OPTARG" ;;
    d) drops="$OPTARG" ;;
    r) runs="$OPTARG" ;;
    c) cpu="$OPTARG" ;;
    *) sed -n '2,17p' "$0"; [ "$opt" = h ] && exit 0 || exit 2 ;;
  esac
done
shift $((OPTIND - 1))
for v in "$copies" "$drops" "$runs" "$cpu"; do
  case "$v" in
    ''|*[!0-9]*) echo "placement_lottery.sh: -n, -d, -r and -c take a whole number, got '$v'" >&2; exit 2 ;;
  esac
done
if [ "$copies" = 0 ] || [ "$runs" = 0 ]; then
  echo "placement_lottery.sh: -n and -r must be at least 1" >&2
  exit 2
fi
if [ $# -eq 0 ]; then
  echo "placement_lottery.sh: no PROGRAM given (-h for help)" >&2
  exit 2
fi
for p in "$@"; do
  if [ ! -x "$p" ]; then
    echo "placement_lottery.sh: $p: not an executable file" >&2
    exit 2
  fi
done
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
pin=()
command -v taskset >/dev/null && pin=(taskset -c "$cpu")
can_drop=0 rounds="$drops"
[ -w /proc/sys/vm/drop_caches ] && can_drop=1
if [ "$drops" = 0 ]; then can_drop=0 rounds=1; fi
[ "$can_drop" = 1 ] || [ "$drops" = 0 ] || echo "placement_lottery.sh: cannot drop the page cache (not root): one placement per copy" >&2
i=0
for p in "$@"; do
  for c in $(seq "$copies"); do cp "$p" "$work/p${i}_c$c"; done
  i=$((i + 1))
done
for d in $(seq "$rounds"); do
  if [ "$can_drop" = 1 ]; then sync; echo 3 > /proc/sys/vm/drop_caches; fi
  for _ in $(seq "$runs"); do
    for c in $(seq "$copies"); do
      k=0
      for prog in "$@"; do
        if ! out="$("${pin[@]}" "$work/p${k}_c$c")"; then
          echo "placement_lottery.sh: $prog failed (copy $c)" >&2
          exit 1
        fi
        t="$(printf '%s\n' "$out" | tail -n 1)"
        if ! [[ "$t" =~ ^[0-9]+([.][0-9]*)?([eE][-+]?[0-9]+)?$ ]]; then
          echo "placement_lottery.sh: $prog printed '$t', not a time (copy $c)" >&2
          exit 1
        fi
        echo "$k $d.$c $t" >> "$work/times"
        k=$((k + 1))
      done
    done
  done
done
python3 - "$work/times" "$@" <<'PY'
import collections, statistics, sys
times = collections.defaultdict(list)
for line in open(sys.argv[1]):
    k, copy, t = line.split()
    times[(int(k), copy)].append(float(t))
names = sys.argv[2:]
print(f"{'program':40s} {'median':>8s} {'fastest':>8s} {'slowest':>8s}  slow copies")
for k, name in enumerate(names):
    per_copy = [statistics.median(v) for (kk, _), v in sorted(times.items()) if kk == k]
    fast = min(per_copy)
    slow = sum(x > 1.08 * fast for x in per_copy)
    print(f"{name[-40:]:40s} {statistics.median(per_copy):8.3f} {fast:8.3f} {max(per_copy):8.3f}  {slow}/{len(per_copy)}")
PY
