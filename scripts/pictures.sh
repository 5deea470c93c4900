#!/usr/bin/env bash
# Regenerates the pictures of docs/pictures/ from the models (issue 22):
# the HMMWV's topology graph (--graph, Graphviz) and the patterns of L, T and
# T^T T (--sparsity), as in the paper's Figures 3 and 4.
#   scripts/pictures.sh [BUILD_DIR]     (default: build; needs its jrgen)
#   scripts/pictures.sh --report [--quick] [REPORT_BUILD_DIR]
#     runs the solver report (scripts/report.sh REPORT_BUILD_DIR, default
#     build-report: the default model set, up to ~1000 dofs, a long build;
#     --quick: the small CI set, without the time-against-size plots the
#     README links, and it says so) and copies its plots and report.md into
#     docs/pictures/report/.
#   scripts/pictures.sh --copy-report REPORT_DIR
#     copies an earlier report's plots (REPORT_DIR/plots/*.png: time against
#     model size per family, error against run time per model) and its
#     report.md into docs/pictures/report/, where the README and docs link them.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
copy_report() {  # REPORT_DIR
  local src="$1" dst="$root/docs/pictures/report"
  [ -d "$src/plots" ] || { echo "pictures.sh: $src/plots not found: run scripts/report.sh first" >&2; exit 1; }
  mkdir -p "$dst" && rm -f "$dst"/*.png
  cp "$src"/plots/*.png "$dst"/
  # The plots sit beside report.md here, not in plots/.
  sed 's|](plots/|](|g' "$src/report.md" > "$dst/report.md"
  echo "pictures.sh: copied $(ls "$dst"/*.png | wc -l) plots and report.md to $dst" >&2
  # A --quick report has no time-against-size plots: say which links broke.
  local f
  for f in $(grep -o 'docs/pictures/report/[A-Za-z0-9_]*\.png' "$root/README.md" "$root"/docs/*.md | cut -d: -f2 | sort -u); do
    [ -e "$root/$f" ] || echo "pictures.sh: warning: $f is linked from the docs but this report has no such plot" >&2
  done
}
case "${1:-}" in
  --copy-report)
    copy_report "${2:?pictures.sh --copy-report REPORT_DIR}"; exit 0 ;;
  --report)
    shift; quick=() build="$root/build-report"
    for a in "$@"; do
      case "$a" in --quick) quick=(--quick) ;; *) build="$a" ;; esac
    done
    out="$build/report-pictures"
    rm -rf "$out"
    "$root/scripts/report.sh" "$build" "${quick[@]}" -o "$out"
    copy_report "$out"; exit 0 ;;
esac
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
