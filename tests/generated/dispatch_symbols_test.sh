#!/usr/bin/env bash
# dispatch_symbols_test.sh DISPATCHED.a SINGLE.a: the solver library built
# as add_jr_solver() builds it holds both copies of forward_dynamics and of
# the steps (GCC's target_clones: NAME.arch_x86_64_v3 and NAME.default), and
# the one built with JRGEN_NO_DISPATCH holds one (docs/specialization.md).
set -euo pipefail
dispatched=$1 single=$2
fail() { echo "dispatch_symbols_test: $*" >&2; exit 1; }
syms=$(nm -C "$dispatched")
for fn in forward_dynamics solve_augmented mass_matrix step1_factor step31_solve_T; do
  grep -q "${fn}(.*\.arch_x86_64_v3\|${fn}\.arch_x86_64_v3" <<<"$syms" ||
    fail "$dispatched: no x86-64-v3 copy of $fn (JRGEN_DISPATCH lost?)"
  grep -q "${fn}(.*\.default\|${fn}\.default" <<<"$syms" || fail "$dispatched: no baseline copy of $fn"
done
if nm "$single" | grep -q "arch_x86_64_v3"; then
  fail "$single: built with JRGEN_NO_DISPATCH but holds x86-64-v3 copies"
fi
echo "dispatch_symbols_test: both copies in $(basename "$dispatched"), one in $(basename "$single")"
