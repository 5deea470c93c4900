#!/usr/bin/env bash
# Regenerates the pictures of docs/pictures/ from the models (issue 22):
# the HMMWV's topology graph (--graph, Graphviz) and the patterns of L, T and
# T^T T (--sparsity), as in the paper's Figures 3 and 4.
#   scripts/pictures.sh [BUILD_DIR]     (default: build; needs its jrgen)
#   scripts/pictures.sh --report REPORT_DIR
#     copies the solver report's plots (scripts/report.sh: time against model
#     size, error against run time; REPORT_DIR/plots/*.png) and its report.md
#     into docs/pictures/report/, where the README and docs link them.
set -euo pipefail
if [ "${1:-}" = "--report" ]; then
  src="${2:?pictures.sh --report REPORT_DIR}"
  dst="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/docs/pictures/report"
  [ -d "$src/plots" ] || { echo "pictures.sh: $src/plots not found: run scripts/report.sh first" >&2; exit 1; }
  mkdir -p "$dst" && rm -f "$dst"/*.png
  cp "$src"/plots/*.png "$dst"/ && cp "$src/report.md" "$dst/report.md"
  echo "pictures.sh: copied $(ls "$dst"/*.png | wc -l) plots to $dst" >&2
  exit 0
fi
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
jrgen="$build/generator/jrgen"
[ -x "$jrgen" ] || { echo "pictures.sh: $jrgen not found; build it first (cmake --build $build --target jrgen)" >&2; exit 1; }
out="$root/docs/pictures"
mkdir -p "$out"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
draw() {  # name urdf [cuts]
  local name="$1" urdf="$2" cuts=()
  [ $# -ge 3 ] && cuts=(--cuts "$3")
  "$jrgen" "$urdf" "${cuts[@]}" -o "$tmp/$name.cpp" --graph "$out/${name}_graph.svg" --sparsity "$out/${name}_sparsity.svg"
}
draw hmmwv14 "$root/models/hmmwv14.urdf" "$root/models/hmmwv14.cuts.xml"
draw stewart "$root/models/stewart.urdf" "$root/models/stewart.cuts.xml"
draw fourbar "$root/models/fourbar.urdf"
echo "pictures.sh: wrote $(ls "$out" | wc -l) files to $out" >&2
