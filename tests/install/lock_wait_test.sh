#!/usr/bin/env bash
# scripts/install_dependencies.sh waits for apt's locks (issue 19, item 10).
# Holds the lock of apt-get update (/var/lib/apt/lists/lock) and dpkg's
# frontend lock with fcntl locks, as apt and dpkg take them, for HOLD seconds
# from another process, and checks that
#   1. with JRGEN_APT_LOCK_TIMEOUT=0 the script fails on the lock (so the
#      locks are really held and the check below can fail), and
#   2. by default it waits, then succeeds, after the locks are released.
# Runs apt-get update and an install of packages already present (--demo):
# needs root and the network; run by .ci/run after the test suite.
set -euo pipefail
cd "$(dirname "$0")/../.."
hold=${HOLD:-8}
log=$(mktemp)
ready=$(mktemp -u)
trap 'rm -f "$log" "$ready"' EXIT

hold_locks() {  # hold_locks SECONDS: returns once the locks are held
  rm -f "$ready"
  python3 - "$1" "$ready" <<'PY' &
import fcntl, sys, time
files = [open(p, "a") for p in ("/var/lib/apt/lists/lock", "/var/lib/dpkg/lock-frontend")]
for f in files:
    fcntl.lockf(f, fcntl.LOCK_EX)
open(sys.argv[2], "w").close()
time.sleep(float(sys.argv[1]))
PY
  holder=$!
  until [[ -e $ready ]]; do sleep 0.1; done
}

# 1. No waiting allowed: a lock error, non-zero exit.
hold_locks "$hold"
if JRGEN_APT_LOCK_TIMEOUT=0 scripts/install_dependencies.sh --demo >"$log" 2>&1; then
  echo "FAIL: the script succeeded while apt's locks were held"; cat "$log"; exit 1
fi
grep -q 'Could not get lock' "$log" || { echo "FAIL: no lock error"; cat "$log"; exit 1; }
wait "$holder"

# 2. Default: waits for the holder, then succeeds.
hold_locks "$hold"
start=$SECONDS
scripts/install_dependencies.sh --demo >"$log" 2>&1 || { echo "FAIL: the script did not wait"; cat "$log"; exit 1; }
took=$((SECONDS - start))
wait "$holder"
grep -q 'waiting' "$log" || { echo "FAIL: the script never saw the lock"; cat "$log"; exit 1; }
if ((took < hold - 2)); then echo "FAIL: finished in ${took}s, before the ${hold}s lock was released"; exit 1; fi
echo "lock_wait_test: failed fast with timeout 0; waited and succeeded in ${took}s (locks held ${hold}s)"
