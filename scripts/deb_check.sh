#!/usr/bin/env bash
# The Debian package, as a user installs it (issue 22; CI runs this as root):
#   1. cpack -G DEB in the build folder: build/jrgen_<version>_<arch>.deb;
#   2. apt-get install ./that.deb (its dependencies from Debian);
#   3. examples/downstream configured with no prefix path (find_package(jrgen
#      0.2) finds /usr/lib/<arch>/cmake/jrgen), built and run;
#   4. the package removed again.
#   scripts/deb_check.sh [BUILD_DIR]    (default: build, already built)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"
[ "$(id -u)" = 0 ] || { echo "deb_check.sh: installs a package: run as root" >&2; exit 1; }
rm -f "$build"/jrgen_*.deb
(cd "$build" && cpack -G DEB >/dev/null)
deb="$(ls "$build"/jrgen_*.deb)"
echo "deb_check: built $(basename "$deb")"
dpkg-deb --info "$deb" | grep -E "Package|Version|Depends" || true
tmp="$(mktemp -d)"
cleanup() { rm -rf "$tmp"; dpkg -r jrgen >/dev/null 2>&1 || true; }
trap cleanup EXIT
apt-get install -y -qq "$deb" >/dev/null
dpkg -L jrgen | grep -qx /usr/bin/jrgen || { echo "deb_check: the package holds no /usr/bin/jrgen" >&2; exit 1; }
/usr/bin/jrgen --version
cmake -S "$root/examples/downstream" -B "$tmp/b" -DJRGEN_MODELS_DIR="$root/models" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF >/dev/null
grep -q "^jrgen_DIR:PATH=/usr/" "$tmp/b/CMakeCache.txt" || { echo "deb_check: find_package(jrgen) did not find the package under /usr" >&2; exit 1; }
cmake --build "$tmp/b" -j2 >/dev/null
out="$("$tmp/b/app")"
echo "$out"
grep -qx OK <<<"$out" || { echo "deb_check: examples/downstream did not print OK" >&2; exit 1; }
echo "deb_check: the package installs, and examples/downstream builds and runs against it"
