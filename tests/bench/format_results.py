#!/usr/bin/env python3
"""format_results.py RESULTS_DIR OPS_DIR: Markdown tables from the JSON output
of the bench_<model> programs (run with --benchmark_repetitions and
--benchmark_report_aggregates_only=true) and the jrgen --report files."""
import json
import re
import sys
from pathlib import Path

ORDER = ["arm7", "legged30", "hmmwv14", "hmmwv14_ldlt", "tree100", "tree1000", "tree3000", "tree10000", "chain50", "chain100", "chain200"]
METHODS = [
    ("generated_solve_augmented", "gen solve"),
    ("eigen_dense_llt", "dense LLT"),
    ("eigen_dense_partial_lu", "dense LU"),
    ("eigen_sparse_llt", "sparse LLT"),
    ("generated_forward_dynamics", "gen forward_dynamics"),
]


def load(path):
    data = json.loads(path.read_text())
    runs = {}
    for b in data["benchmarks"]:
        if b.get("run_type") != "aggregate":
            continue
        runs.setdefault(b["run_name"], {})[b["aggregate_name"]] = b
    return data["context"], runs


def to_us(b, key):
    scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}[b["time_unit"]]
    return b[key] * scale


def fmt_time(us):
    if us is None:
        return "skipped"
    if us >= 1000:
        return f"{us / 1000:.2f} ms"
    if us >= 100:
        return f"{us:.0f} µs"
    if us >= 10:
        return f"{us:.1f} µs"
    return f"{us:.2f} µs"


def fmt_e(x):
    return "—" if x is None else f"{x:.1e}"


def ops_total(ops_dir, name):
    path = ops_dir / f"{name}.md"
    if not path.exists():
        return None, None
    text = path.read_text()
    total = 0
    for row in ("A", "M", "D", "SQ"):
        m = re.search(rf"^\| {row} \|.*\| (\d+) \|$", text, re.M)
        if m:
            total += int(m.group(1))
    m = re.search(r"stored entries of L = (\d+)", text)
    return total, (int(m.group(1)) if m else None)


def main():
    results = Path(sys.argv[1])
    ops_dir = Path(sys.argv[2])
    key = "cpu_time" if len(sys.argv) < 4 else sys.argv[3]
    models = {}
    for p in results.glob("*.json"):
        models[p.stem] = load(p)
    names = [n for n in ORDER if n in models] + sorted(n for n in models if n not in ORDER)

    print(f"Median {key.replace('_', ' ')} per call over 5 repetitions (cv = coefficient of variation"
          " of the 5 repetition means); ratios are dense time / generated solve time.\n")
    print("| model | nv | L entries | gen solve ops | " + " | ".join(m[1] for m in METHODS)
          + " | LLT / gen | LU / gen | sparse LLT / gen |")
    print("|---|---:|---:|---:|" + "---:|" * (len(METHODS) + 3))
    for n in names:
        ctx, runs = models[n]
        ops, nnz = ops_total(ops_dir, n)
        t = {}
        cells = []
        for m, _ in METHODS:
            r = runs.get(m)
            if r is None:
                t[m] = None
                cells.append("skipped")
                continue
            t[m] = to_us(r["median"], key)
            cv = r.get("cv", {}).get(key)
            cells.append(fmt_time(t[m]) + (f" ±{100 * cv:.0f}%" if cv is not None else ""))
        g = t["generated_solve_augmented"]

        def ratio(m):
            return "—" if t[m] is None or not g else f"{t[m] / g:.1f}x"
        print(f"| {n} | {ctx.get('nv')} | {nnz if nnz is not None else ctx.get('nnz_lower_M')} | "
              f"{ops if ops is not None else '—'} | " + " | ".join(cells)
              + f" | {ratio('eigen_dense_llt')} | {ratio('eigen_dense_partial_lu')} | {ratio('eigen_sparse_llt')} |")

    print("\nAccuracy on the same M and Q (state 0): err = ||qdd - qdd_ref|| / ||qdd_ref|| against the"
          " reference named in the last column; bwd = ||Q - M qdd|| / (||M||_F ||qdd|| + ||Q||) in long"
          " double; cond1 = Eigen's LLT estimate of the 1-norm condition number of M;"
          " gen-vs-LLT, gen-vs-LU = ||qdd_gen - qdd_other|| / ||qdd_other||.\n")
    print("| model | cond1(M) | " + " | ".join(f"err {m[1]}" for m in METHODS)
          + " | bwd gen | bwd LLT | bwd LU | gen-vs-LLT | gen-vs-LU | reference |")
    print("|---|---:|" + "---:|" * (len(METHODS) + 5) + "---|")
    for n in names:
        ctx, runs = models[n]

        def counter(m, c):
            r = runs.get(m)
            return None if r is None else r["median"].get(c)
        gen = "generated_solve_augmented"
        print(f"| {n} | {fmt_e(counter('eigen_dense_llt', 'cond1'))} | "
              + " | ".join(fmt_e(counter(m, "err")) for m, _ in METHODS)
              + f" | {fmt_e(counter(gen, 'bwd'))} | {fmt_e(counter('eigen_dense_llt', 'bwd'))}"
              f" | {fmt_e(counter('eigen_dense_partial_lu', 'bwd'))}"
              f" | {fmt_e(counter(gen, 'd_llt'))} | {fmt_e(counter(gen, 'd_lu'))} | {ctx.get('reference')} |")


if __name__ == "__main__":
    main()
