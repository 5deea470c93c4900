#!/usr/bin/env python3
"""The table of scripts/peers_fd.sh from the Google Benchmark JSON files of the
peers programs (tests/peers): per model the median CPU time per call in
microseconds of jrgen's forward_dynamics, MuJoCo's mj_forward, Pinocchio's aba
and crba+nle+cholesky, and jrgen's parts; then the accuracy of every qdd
against the reference (tests/peers/fd_reference.hpp).

usage: format_peers.py FILE.json...   (in the order of the rows)"""
import json
import sys

COLUMNS = [("jrgen forward_dynamics", "jrgen/forward_dynamics"),
           ("MuJoCo mj_forward", "mujoco/mj_forward"),
           ("Pinocchio aba", "pinocchio/aba"),
           ("Pinocchio crba+nle+chol", "pinocchio/crba+nle+cholesky")]


def load(path):
    with open(path) as f:
        data = json.load(f)
    ctx = data["context"]
    rows = {}
    for b in data["benchmarks"]:
        if b.get("aggregate_name") != "median":
            continue
        rows[b["run_name"]] = b
    return ctx, rows


def us(rows, name):
    b = rows.get(name)
    if b is None:
        return None
    scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}[b.get("time_unit", "ns")]
    return b["cpu_time"] * scale


def fmt(x):
    if x is None:
        return ""
    return f"{x:#.3g}" if x < 100 else f"{x:.0f}"


def model_cell(ctx, rows):
    nv, nc = (int(x) for x in ctx["nv_nc"].split())
    extra = ", floating" if ctx.get("base") == "floating" else ""
    if nc:
        extra += f", {nc} rows"
    return f"{ctx['model']} ({nv}{extra})"


def parts_cell(rows):
    p = [us(rows, "jrgen/mass_matrix"), us(rows, "jrgen/bias_forces"), us(rows, "jrgen/solve_augmented")]
    cell = "M / h / solve: " + " / ".join(fmt(x) for x in p)
    cg = us(rows, "jrgen/constraint_jacobian+gamma")
    if cg is not None:
        cell += f", Phiq + gamma {fmt(cg)}"
    return cell


def main(paths):
    models = [load(p) for p in paths]
    print("Median CPU time per call, microseconds (ratio: peer / jrgen forward_dynamics).\n")
    print("| model (nv) | " + " | ".join(c for c, _ in COLUMNS) + " | jrgen parts |")
    print("|---" * (len(COLUMNS) + 2) + "|")
    for ctx, rows in models:
        jr = us(rows, COLUMNS[0][1])
        cells = [fmt(jr)]
        for _, name in COLUMNS[1:]:
            t = us(rows, name)
            cells.append("" if t is None or jr is None else f"{fmt(t)} ({t / jr:.2f}x)")
        print(f"| {model_cell(ctx, rows)} | " + " | ".join(cells) + f" | {parts_cell(rows)} |")
    print("\nqdd against the reference (|x - ref| / |ref|) and against jrgen's forward_dynamics:\n")
    print("| model | jrgen vs reference | MuJoCo vs reference | MuJoCo vs jrgen | Pinocchio aba vs jrgen | not run |")
    print("|---|---|---|---|---|---|")
    for ctx, rows in models:
        def err(name, key):
            b = rows.get(name)
            return "" if b is None or b.get(key, -1) < 0 else f"{b[key]:.1e}"
        notes = []
        for peer in ("mujoco", "pinocchio"):
            note = ctx.get(peer, "")
            if note and "passive" not in note and note != "ok":
                notes.append(f"{peer}: {note}")
        print(f"| {ctx['model']} | {err('jrgen/forward_dynamics', 'err_ref')} | "
              f"{err('mujoco/mj_forward', 'err_ref')} | {err('mujoco/mj_forward', 'err_jrgen')} | "
              f"{err('pinocchio/aba', 'err_jrgen')} | {'; '.join(notes)} |")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
