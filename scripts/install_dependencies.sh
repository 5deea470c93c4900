#!/usr/bin/env bash
# Installs everything jrgen needs to build, test and benchmark, from Debian's
# packages (Debian bookworm; run as root).  The solver report (docs/report.md)
# adds LAPACKE, OpenBLAS, SuiteSparse (UMFPACK), MuJoCo, gnuplot and Python;
# the fuzz target (docs/testing.md) adds clang and its libFuzzer runtime.
#
#   scripts/install_dependencies.sh          everything (the test command, CI)
#   scripts/install_dependencies.sh --demo   only what the demo needs: the
#                                            compiler, CMake, Eigen, urdfdom,
#                                            TinyXML, fmt (the README's command 1)
#
# Another apt or dpkg process (unattended-upgrades, a second install) may hold
# apt's locks: the script then waits for them, up to JRGEN_APT_LOCK_TIMEOUT
# seconds (default 600), instead of failing at once.  apt-get install waits by
# itself (DPkg::Lock::Timeout covers dpkg's locks); apt-get update does not
# (apt 2.6 fails at once on /var/lib/apt/lists/lock), nor does the download
# cache's lock, so every apt-get call is retried while its error is a lock
# held by another process.  tests/install/lock_wait_test.sh checks this.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive LC_ALL=C

mode=full
case "${1:-}" in
  "") ;;
  --demo) mode=demo ;;
  -h|--help) sed -n '2,18p' "$0"; exit 0 ;;
  *) echo "install_dependencies.sh: unknown option '$1' (use --demo or nothing)" >&2; exit 2 ;;
esac

timeout_s=${JRGEN_APT_LOCK_TIMEOUT:-600}
deadline=$((SECONDS + timeout_s))

# apt_get ARGS...: apt-get with the lock timeout, retried while another
# process holds one of apt's locks and the deadline is not past.
apt_get() {
  local err
  err=$(mktemp)
  while true; do
    if apt-get -o DPkg::Lock::Timeout="$timeout_s" "$@" 2>"$err"; then
      cat "$err" >&2
      rm -f "$err"
      return 0
    fi
    if grep -q 'Could not get lock' "$err" && ((SECONDS < deadline)); then
      echo "install_dependencies.sh: $(grep -m1 'Could not get lock' "$err" | sed 's/^E: //'); waiting" >&2
      sleep 3
      continue
    fi
    cat "$err" >&2
    rm -f "$err"
    return 1
  done
}

demo_packages=(build-essential cmake libeigen3-dev liburdfdom-dev libtinyxml-dev libfmt-dev)
test_packages=(libgtest-dev libbenchmark-dev
               liblapacke-dev libopenblas-dev libsuitesparse-dev libmujoco-dev gnuplot-nox python3
               clang-14 libclang-rt-14-dev libomp-14-dev  # fuzzing; ThreadSanitizer with libomp (scripts/tsan.sh)
               libsundials-dev  # CVODE: the independent reference trajectories (tests/reference/trajectory_reference.cpp)
               graphviz  # jrgen --graph OUT.svg renders with dot (tests/generator/graph_test.cpp)
               openmpi-bin libopenmpi-dev)  # examples/batch_mpi and its test (optional in CMake)
packages=("${demo_packages[@]}")
[[ $mode == full ]] && packages+=("${test_packages[@]}")

apt_get update -qq
apt_get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null
echo "jrgen: dependencies installed ($mode)"
