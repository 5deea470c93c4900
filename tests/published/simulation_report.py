#!/usr/bin/env python3
"""Draws the work-precision report of the published problems (docs/simulation.md,
"Work-precision") from published_work_precision's output, with gnuplot.

    simulation_report.py --runs runs.tsv --series drift.tsv --out DIR [--log stderr.txt]

Writes DIR/wp_<problem>.png (error against CPU time and against forward-dynamics calls,
one line per integrator, points labelled by tol or dt), DIR/drift_<problem>.png (energy
and constraint drift over time, auto at tol 1e-6, with projection and without
stabilization) and DIR/work_precision.md (the tables).  Exit status 1 when gnuplot fails
or a plot is missing.
"""
import argparse
import csv
import math
import os
import shutil
import subprocess
import sys

METHODS = ["dopri5", "radau5", "sdirk4", "auto", "rk4"]
STYLE = {  # line colour, point type, dash type
    "dopri5": ("#1f77b4", 7, 1),
    "radau5": ("#d62728", 5, 1),
    "sdirk4": ("#2ca02c", 9, 1),
    "auto": ("#000000", 6, 2),
    "rk4": ("#9467bd", 13, 1),
}
ERROR_UNIT = {
    "A01": "|q - q_exact| at t_end [rad] (= error of P1 in m)",
    "A02": "max_i |q_i - q_ref,i| at t_end [rad]",
    "A02-proximal": "max_i |q_i - q_ref,i| at t_end [rad]",
    "A03": "max |q - q_ref| / max |q_ref| at t = 0.03",
    "A04": "max |q - q_ref| at t_end [rad]",
    "A05": "max |q - q_ref| at t_end [rad, m]",
}
TARGETS = [1e-3, 1e-6, 1e-9]


def read_tsv(path):
    with open(path) as f:
        return list(csv.DictReader(f, delimiter="\t"))


def num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def ok(r):
    return r["status"] == "ok" and num(r["error"]) > 0


def label(r):
    return f"dt {r['dt']}" if r["method"] == "rk4" else r["tol"]


def gnuplot(script, failures, what):
    if not shutil.which("gnuplot"):
        failures.append(f"gnuplot not found: no {what}")
        return
    p = subprocess.run(["gnuplot"], input=script, text=True, stderr=subprocess.PIPE)
    if p.returncode != 0 or not os.path.exists(what):
        failures.append(f"gnuplot failed on {what}: {p.stderr.strip()}")


def plot_wp(problem, rows, spans, out, failures):
    """Error against CPU time (left) and against forward-dynamics calls (right)."""
    png = os.path.join(out, f"wp_{problem}.png")
    present = [m for m in METHODS if any(r["method"] == m and ok(r) for r in rows)]
    dats = {}
    for m in present:  # one file per method: no empty gnuplot blocks
        dats[m] = os.path.join(out, f"wp_{problem}_{m}.dat")
        with open(dats[m], "w") as f:
            for r in rows:
                if r["method"] == m and ok(r):
                    f.write(f"{num(r['cpu_s']):.6g} {int(r['fd_calls'])} {num(r['error']):.6g} \"{label(r)}\"\n")

    def series(xcol):
        s = []
        for m in present:
            c, pt, dt = STYLE[m]
            s.append(f"'{dats[m]}' using {xcol}:3 with linespoints lc rgb '{c}' pt {pt} ps 1.3 dt {dt} "
                     f"lw 1.5 title '{m}'")
            if m != "auto":  # auto's points sit on dopri5's (or radau5's) where it does not switch
                s.append(f"'{dats[m]}' using {xcol}:3:4 with labels offset char 0.3,0.6 left font ',7' "
                         f"tc rgb '{c}' notitle")
        return ", ".join(s)

    gnuplot(f"""set terminal pngcairo size 1200,520 font 'sans,10' noenhanced
set output '{png}'
set multiplot layout 1,2 title "{problem}: work-precision over {spans.get(problem, '?')} (rtol = atol = tol; labels: tol, rk4: dt)"
set logscale xy
set format x '%.0e'
set format y '%.0e'
set grid
set ylabel '{ERROR_UNIT.get(problem, 'error')}'
set xlabel 'CPU time per run [s] (median)'
set key top right font 'sans,9'
plot {series(1)}
set xlabel 'forward-dynamics calls per run'
unset ylabel
plot {series(2)}
unset multiplot
""", failures, png)
    return png


def plot_drift(problem, srows, conserves, has_constraints, out, failures):
    """Energy drift (top) and constraint drift (bottom) against time."""
    panels = []
    dat = os.path.join(out, f"drift_{problem}.dat")
    stabs = ["projection", "none"]
    with open(dat, "w") as f:
        for st in stabs:
            for r in srows:
                if r["stabilization"] == st:
                    f.write(f"{r['t']} {r['energy_drift']} {r['phi']} {r['phiqv']}\n")
            f.write("\n\n")
    present = [st for st in stabs if any(r["stabilization"] == st for r in srows)]
    t_last = {st: max(num(r["t"]) for r in srows if r["stabilization"] == st) for st in present}
    t_end = max(t_last.values())
    title = {st: st if t_last[st] >= t_end else f"{st} (failed at t = {t_last[st]:.3g} s)" for st in present}
    if not has_constraints:  # a tree: nothing to stabilize
        title = {st: "auto, tol 1e-6" for st in present}
    if conserves:
        lines = [f"'{dat}' index {stabs.index(st)} using 1:($2>0?$2:1/0) with lines lw 1.5 "
                 f"lc rgb '{'#1f77b4' if st == 'projection' else '#d62728'}' title '{title[st]}'" for st in present]
        ylabel = {"A03": "|E - W_motor - E0| / max kinetic energy",
                  "A05": "|E + W_dampers - E0| / max kinetic energy"}.get(problem, "|E - E0| / max kinetic energy")
        panels.append(f"set ylabel '{ylabel}'\nplot {', '.join(lines)}")
    if has_constraints:
        lines = []
        for st in present:
            c = '#1f77b4' if st == 'projection' else '#d62728'
            i = stabs.index(st)
            lines.append(f"'{dat}' index {i} using 1:($3>0?$3:1/0) with lines lw 1.5 lc rgb '{c}' title 'max |Phi|, {title[st]}'")
            lines.append(f"'{dat}' index {i} using 1:($4>0?$4:1/0) with lines lw 1.5 dt 2 lc rgb '{c}' "
                         f"title 'max |Phiq v|, {title[st]}'")
        panels.append(f"set ylabel 'constraint drift [m], [m/s]'\nplot {', '.join(lines)}")
    if not panels:
        return None
    png = os.path.join(out, f"drift_{problem}.png")
    body = "\n".join(panels)
    subtitle = "projection vs no stabilization" if has_constraints else "a tree: no constraints"
    gnuplot(f"""set terminal pngcairo size 900,{300 * len(panels) + 80} font 'sans,10' noenhanced
set output '{png}'
set multiplot layout {len(panels)},1 title "{problem}: drift over the run (auto, tol 1e-6; {subtitle})"
set logscale y
set format y '%.0e'
set grid
set xlabel 't [s]'
set key outside right font 'sans,9'
set lmargin at screen 0.1
set rmargin at screen 0.68
{body}
unset multiplot
""", failures, png)
    return png


def fmt(x, spec):
    return "—" if math.isnan(x) else format(x, spec)


def cheapest(rows, method, target):
    """The run of `method` of least CPU time whose error is at most `target`."""
    c = [r for r in rows if r["method"] == method and ok(r) and num(r["error"]) <= target]
    return min(c, key=lambda r: num(r["cpu_s"])) if c else None


def write_tables(problems, runs, w):
    w("### Work to reach an accuracy\n")
    w("The cheapest run (median CPU time) of each integrator whose error at t_end is at most the target; "
      "in brackets the tol (rk4: dt) and the forward-dynamics calls.  '—': no run of the sweep got there.\n")
    w("| problem | error <= | " + " | ".join(METHODS) + " |")
    w("|---|---|" + "---|" * len(METHODS))
    for p in problems:
        rows = [r for r in runs if r["problem"] == p]
        for t in TARGETS:
            cells = []
            for m in METHODS:
                r = cheapest(rows, m, t)
                cells.append("—" if r is None else
                             f"{num(r['cpu_s']) * 1e3:.3g} ms ({label(r)}, {int(r['fd_calls'])})")
            w(f"| {p} | {t:.0e} | " + " | ".join(cells) + " |")
    w("")
    w("### Drift and failures\n")
    w("Over the run, at every accepted step of the default integrator (auto) with projection: energy drift "
      "max |E - W - E0| / max kinetic energy (W: the motor's work on A03, minus the dampers' dissipated work on A05, "
      "integrated as one more state in that run), max |Phi|, max |Phiq v|.\n")
    w("| problem | tol | error | energy drift | max abs Phi | max abs Phiq v | auto switched |")
    w("|---|---|---:|---:|---:|---:|---|")
    for p in problems:
        for r in runs:
            if r["problem"] == p and r["method"] == "auto" and r["tol"] in ("1e-04", "1e-06", "1e-08", "1e-10"):
                w(f"| {p} | {r['tol']} | {fmt(num(r['error']), '.1e')} | {r['energy_drift']} | {r['phi_max']} | "
                  f"{r['phiqv_max']} | {'yes' if r['switched'] == '1' else 'no'} |")
    fails = [r for r in runs if r["status"] != "ok"]
    if fails:
        w("\nFailed runs (the integrator's Failure, one line each):\n")
        for r in fails:
            w(f"* {r['problem']} {r['method']} {label(r)}: {r['status'][len('failed: '):]}")
    w("")


def write_full_table(problems, runs, w):
    w("### All runs\n")
    w("| problem | method | tol / dt | error | CPU [ms] | reps | fd calls | steps | rejected | switched | "
      "energy drift | max abs Phi | max abs Phiq v |")
    w("|---|---|---|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|")
    for p in problems:
        for r in runs:
            if r["problem"] != p:
                continue
            if r["status"] != "ok":
                w(f"| {p} | {r['method']} | {label(r)} | failed | | | | | | | | | |")
                continue
            w(f"| {p} | {r['method']} | {label(r)} | {fmt(num(r['error']), '.2e')} | {num(r['cpu_s']) * 1e3:.3g} | "
              f"{r['reps']} | {r['fd_calls']} | {r['steps']} | {r['rejected']} | {r['switched']} | "
              f"{r['energy_drift']} | {r['phi_max']} | {r['phiqv_max']} |")
    w("")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", required=True)
    ap.add_argument("--series", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--log", help="the program's stderr (spans, references), quoted in the report")
    ap.add_argument("--header", default="", help="a line for the report's top (machine, date, commit)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    runs, series = read_tsv(a.runs), read_tsv(a.series)
    problems = list(dict.fromkeys(r["problem"] for r in runs))
    notes = open(a.log).read().strip().splitlines() if a.log else []
    spans = {}
    for line in notes:
        if ": t_end = " in line:
            name, rest = line.split(": t_end = ", 1)
            spans[name] = rest.split(" ", 1)[0] + " s"
    failures, pngs = [], []
    for p in problems:
        rows = [r for r in runs if r["problem"] == p]
        pngs.append(plot_wp(p, rows, spans, a.out, failures))
        srows = [r for r in series if r["problem"] == p]
        conserves = any(r["energy_drift"] not in ("n/a", "nan", "-nan") for r in rows)
        has_c = any(r["phi_max"] != "n/a" for r in rows)
        d = plot_drift(p, srows, conserves, has_c, a.out, failures) if srows else None
        if d:
            pngs.append(d)
    lines = []
    w = lines.append
    w("# Work-precision of the published problems\n")
    if a.header:
        w(a.header + "\n")
    if notes:
        w("Spans and references (the program's notes):\n")
        w("```")
        lines.extend(notes)
        w("```\n")
    write_tables(problems, runs, w)
    for p in pngs:
        w(f"![{os.path.basename(p)}]({os.path.basename(p)})\n")
    write_full_table(problems, runs, w)
    with open(os.path.join(a.out, "work_precision.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    for msg in failures:
        print("simulation_report.py: " + msg, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
