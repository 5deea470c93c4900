#!/usr/bin/env bash
# ctest placement_lottery_test: tests/bench/placement_lottery.sh on two tiny
# programs whose "times" are known: the medians, the fastest and slowest copy
# and the count of slow copies must come out as computed by hand, and bad
# arguments, a failing program and one that prints no number must fail with
# one line on stderr.
set -euo pipefail
script="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/placement_lottery.sh"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
printf '#!/bin/sh\necho 1.5\n' > "$work/fast"
# The second program's copies differ by their file name's last digit: copy 1
# is slow (2.5), copies 2 and 3 take 2.0, so 1 of 3 copies is slow.
printf '#!/bin/sh\ncase "$0" in *_c1) echo 2.5 ;; *) echo 2.0 ;; esac\n' > "$work/mixed"
chmod +x "$work/fast" "$work/mixed"
out="$("$script" -n 3 -d 0 -r 2 "$work/fast" "$work/mixed")"
echo "$out"
fail() { echo "placement_lottery_test: $1" >&2; exit 1; }
echo "$out" | grep -Eq "/fast +1\.500 +1\.500 +1\.500  0/3$" || fail "wrong line for fast"
echo "$out" | grep -Eq "/mixed +2\.000 +2\.000 +2\.500  1/3$" || fail "wrong line for mixed"
if "$script" -n x "$work/fast" 2> "$work/err"; then fail "-n x accepted"; fi
[ "$(wc -l < "$work/err")" = 1 ] || fail "-n x: not one line on stderr"
if "$script" "$work/missing" 2> "$work/err"; then fail "missing program accepted"; fi
grep -q "not an executable file" "$work/err" || fail "missing program: wrong message"
printf '#!/bin/sh\nexit 3\n' > "$work/broken"
printf '#!/bin/sh\necho fast\n' > "$work/words"
chmod +x "$work/broken" "$work/words"
if "$script" -n 1 -d 0 -r 1 "$work/fast" "$work/broken" > /dev/null 2> "$work/err"; then fail "failing program accepted"; fi
grep -q "broken failed (copy 1)" "$work/err" || fail "failing program: wrong message"
if "$script" -n 1 -d 0 -r 1 "$work/words" > /dev/null 2> "$work/err"; then fail "non-number accepted"; fi
grep -q "printed 'fast', not a time" "$work/err" || fail "non-number: wrong message"
echo "placement_lottery_test: ok"
