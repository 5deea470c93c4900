#!/usr/bin/env python3
"""Runs the report programs (tests/report/report_<model>) and writes
OUT/report.md with its plots (docs/report.md).

    run_report.py --programs report_programs.tsv --out DIR [--set NAME] [--quick]

Each program times every method on its model (Google Benchmark, the median of
repeated runs) and checks every method's qdd error against its bound; this
script gathers the JSON results into tables, draws error-vs-time and
time-vs-size plots with gnuplot, fits the slope of log t against log n per
method and model family, and lays the HMMWV beside the paper's Tables 4 and 5.
Exit status 1 when a program failed its checks or a method or plot is missing.
"""
import argparse
import json
import math
import os
import platform
import re
import shutil
import subprocess
import sys
import time

METHODS = ["gauss", "symmetric", "sparse", "alg_d", "alg_s", "gen_llt", "gen_ldlt", "mujoco"]
LABELS = {
    "gauss": "Gauss (PartialPivLU)",
    "symmetric": "Symmetric (dsysv)",
    "sparse": "Sparse (UMFPACK)",
    "alg_d": "Alg-D (dense Cholesky)",
    "alg_s": "Alg-S interpreted",
    "gen_llt": "generated LLT",
    "gen_ldlt": "generated LDLT",
    "mujoco": "MuJoCo mj_factorM+solveM",
}
# One colour per method in every plot (gnuplot's default yellow is hard to see).
COLORS = {
    "gauss": "#9400d3", "symmetric": "#009e73", "sparse": "#56b4e9", "alg_d": "#e69f00",
    "alg_s": "#8b4513", "gen_llt": "#0072b2", "gen_ldlt": "#d62728", "mujoco": "#000000",
}
STEPS = ["1", "2", "3.1", "3.2", "3.3", "3.4", "3.5", "4"]
# The paper's Table 4 and 5 (HMMWV, microseconds, 1997 hardware).
PAPER_T4 = {"gauss": 2336, "symmetric": 2022, "sparse": 3532, "alg_s": 1201, "alg_d": 1179}
PAPER_T5 = {
    "alg_s": [300, 59, 246, 50, 276, 159, 57, 54],
    "alg_d": [289, 31, 347, 27, 276, 147, 31, 31],
}


def fmt_t(x):
    if x is None:
        return "—"
    if x >= 100:
        return f"{x:.0f}"
    if x >= 10:
        return f"{x:.1f}"
    if x >= 1:
        return f"{x:.2f}"
    return f"{x:.3f}"


def fmt_e(x):
    return "—" if x is None else f"{x:.1e}"


def run_programs(programs, out, quick, reuse=False):
    jdir = os.path.join(out, "json")
    wdir = os.path.join(out, "work")
    os.makedirs(jdir, exist_ok=True)
    os.makedirs(wdir, exist_ok=True)
    results, failures = [], []
    cpu = os.environ.get("REPORT_CPU")
    for name, path, flags in programs:
        jfile = os.path.join(jdir, name + ".json")
        if reuse:
            with open(jfile) as f:
                results.append((name, json.load(f)))
            continue
        cmd = [path, "--json", jfile] + flags + (["--quick"] if quick else [])
        if cpu and shutil.which("taskset"):
            cmd = ["taskset", "-c", cpu] + cmd
        t0 = time.time()
        p = subprocess.run(cmd, cwd=wdir, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        with open(os.path.join(wdir, name + ".log"), "w") as f:
            f.write(p.stderr)
            f.write(p.stdout)
        print(f"report: {name}: exit {p.returncode} ({time.time() - t0:.1f} s)", flush=True)
        sys.stderr.write(p.stderr)
        if p.returncode != 0:
            failures.append(f"{name}: program exited with {p.returncode}")
        if not os.path.exists(jfile):
            failures.append(f"{name}: no JSON output")
            continue
        with open(jfile) as f:
            results.append((name, json.load(f)))
    return results, failures


def parse(name, data):
    ctx = data["context"]
    nq, nv, nc, K = (int(x) for x in ctx["sizes_nq_nv_nc_K"].split())
    m = {"name": name, "nv": nv, "nc": nc, "K": K, "cond_A": float(ctx["cond1_A"]),
         "cond_M": float(ctx["cond1_M"]), "cond_W": float(ctx["cond1_W"]), "state": ctx.get("state", ""),
         "mujoco_check": ctx.get("mujoco_check", ""), "checks": ctx.get("checks", ""),
         "compile_flags": ctx.get("compile_flags", "unknown"),
         "date": ctx.get("date", ""), "load": (ctx.get("load_avg") or [None])[0],
         "methods": {}, "steps": {}, "prefix": {}, "fd": {}}
    for b in data["benchmarks"]:
        if b.get("aggregate_name") != "median":
            continue
        bname = b["run_name"]
        # CPU time of the process, microseconds (Unit(us)): robust to other
        # processes sharing the machine, equal to real_time on a quiet one.
        t = b["cpu_time"]
        if bname.startswith("fd/"):
            m["fd"][bname[3:]] = dict(time=t, err_ref=b.get("err_ref"), err_jrgen=b.get("err_jrgen"))
        elif bname.startswith("step/"):
            _, meth, step = bname.split("/")
            m["steps"].setdefault(meth, {})[step] = t
        elif bname.startswith("prefix/"):
            _, meth, last = bname.split("/")
            m["prefix"].setdefault(meth, {})[int(last)] = t
        else:
            m["methods"][bname] = dict(time=t, err_qdd=b.get("err_qdd"), err_lambda=b.get("err_lambda"),
                                       err_f=b.get("err_f"), res17=b.get("res17"), bound=b.get("bound"),
                                       passed=b.get("pass") == 1)
    # Generated code per step: differences of consecutive prefixes.
    for meth, pre in m["prefix"].items():
        order = [k for k in range(9) if k in pre]
        steps = {}
        for a, b in zip(order, order[1:]):
            steps[STEPS[b - 1] if b <= 7 else "4"] = max(pre[b] - pre[a], 0.0)
        steps["gather"] = pre[0]
        m["steps"][meth] = steps
    return m


def family(name):
    return re.sub(r"_\d+$", "", name)


def fit_slope(points):
    """Least squares slope of log t against log n."""
    if len(points) < 2:
        return None
    xs = [math.log(n) for n, _ in points]
    ys = [math.log(t) for _, t in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    if sxx == 0:
        return None
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx


def log_range(lo, hi, pad=1.5):
    """A log axis a factor pad beyond the data, its ends rounded out to 1, 2
    or 5 times a power of ten: no point on the border, little empty space."""
    def nice(x, up):
        e = math.floor(math.log10(x))
        steps = [1, 2, 5, 10]
        m = x / 10.0 ** e
        f = min(s for s in steps if s >= m * (1 - 1e-12)) if up else max(s for s in steps if s <= m * (1 + 1e-12))
        return f * 10.0 ** e
    # 1e-3 wider than the round ends: gnuplot drops a tic a rounding error
    # beyond the range (tree_1000's "1e-14" on the border).
    return nice(lo / pad, False) * (1 - 1e-3), nice(hi * pad, True) * (1 + 1e-3)


def log_tics(axis, lo, hi):
    """Labels at 1, 2 and 5 times each power of ten when the axis spans less
    than two decades (gnuplot labels only whole decades, maybe just one)."""
    if hi / lo >= 100:
        return ""
    vals = [f * 10.0 ** e for e in range(math.floor(math.log10(lo)), math.ceil(math.log10(hi)) + 1)
            for f in (1, 2, 5)]
    def label(v):
        return f"{v:g}" if 1e-3 <= v < 1e6 else f"{v:.0e}".replace("e-0", "e-").replace("e+0", "e")
    return f"set {axis}tics (" + ", ".join(f'"{label(v)}" {v:.6g}' for v in vals
                                           if lo * (1 - 1e-9) <= v <= hi * (1 + 1e-9)) + ")"


def gnuplot(script, failures, what):
    if not shutil.which("gnuplot"):
        failures.append(f"gnuplot not found: no {what}")
        return
    p = subprocess.run(["gnuplot"], input=script, text=True, stderr=subprocess.PIPE)
    if p.returncode != 0:
        failures.append(f"gnuplot failed on {what}: {p.stderr.strip()}")


def plot_error_vs_time(models, out, failures):
    """One point per method and model: qdd error against run time."""
    pdir = os.path.join(out, "plots")
    os.makedirs(pdir, exist_ok=True)
    files = []
    for m in models:
        dat = os.path.join(pdir, f"err_time_{m['name']}.dat")
        with open(dat, "w") as f:
            for i, meth in enumerate(METHODS):
                r = m["methods"].get(meth)
                if r and r["err_qdd"] is not None:
                    err = max(r["err_qdd"], 1e-18)  # exact results on a log axis
                    f.write(f"{r['time']:.6g} {err:.6g} {i} \"{meth}\"\n")
        svg = os.path.join(pdir, f"err_time_{m['name']}.png")
        pts = [(r["time"], max(r["err_qdd"], 1e-18)) for r in m["methods"].values() if r["err_qdd"] is not None]
        x0, x1 = log_range(min(t for t, _ in pts), max(t for t, _ in pts))
        y0, y1 = log_range(min(e for _, e in pts), max(e for _, e in pts))
        series = [f"'{dat}' using 1:(($3=={i})?$2:1/0) with points pt {i + 4} ps 1.6 lw 2 lc rgb '{COLORS[meth]}' title '{LABELS[meth]}'"
                  for i, meth in enumerate(METHODS) if meth in m["methods"]]
        # The hollow markers (even gnuplot point types) again on top, so that a
        # point under a filled one stays visible (on the 1000-dof trees the
        # generated solver is table-driven: Alg-S's time and error exactly).
        series += [f"'{dat}' using 1:(($3=={i})?$2:1/0) with points pt {i + 4} ps 1.6 lw 2 lc rgb '{COLORS[meth]}' notitle"
                   for i, meth in enumerate(METHODS) if meth in m["methods"] and (i + 4) % 2 == 0]
        gnuplot(f"""set terminal pngcairo size 800,500 font 'sans,10' noenhanced
set output '{svg}'
set title "{m['name']} (nv {m['nv']}, nc {m['nc']}): error of qdd against time of one solve (lower left is better)"
set logscale xy
set xrange [{x0:g}:{x1:g}]
set yrange [{y0:g}:{y1:g}]
{log_tics('x', x0, x1)}
{log_tics('y', y0, y1)}
set xlabel 'median CPU time per solve [µs]'
set ylabel 'error of qdd, relative to an extended-precision solve'
set key outside right top Left reverse font 'sans,9' title 'method'
set grid
plot {', '.join(series)}
""", failures, svg)
        files.append(svg)
    return files


def plot_scaling(models, out, failures):
    """Time against K = nv + nc per model family, log-log, with fitted slopes."""
    pdir = os.path.join(out, "plots")
    fams = {}
    for m in models:
        fams.setdefault(family(m["name"]), []).append(m)
    slopes, files = {}, []
    for fam, ms in sorted(fams.items()):
        if len(ms) < 2:
            continue
        ms.sort(key=lambda m: m["K"])
        plots = []
        for i, meth in enumerate(METHODS):
            pts = [(m["K"], m["methods"][meth]["time"]) for m in ms if meth in m["methods"]]
            s = fit_slope(pts)
            if s is None:
                continue
            slopes[(fam, meth)] = s
            dat = os.path.join(pdir, f"scaling_{fam}_{meth}.dat")
            with open(dat, "w") as f:
                for n, t in pts:
                    f.write(f"{n} {t:.6g}\n")
            # A method that ran on part of the family only (MuJoCo on long
            # chains): its slope is over that part, and the legend says so.
            part = f" (K {pts[0][0]}-{pts[-1][0]})" if len(pts) < len(ms) else ""
            plots.append(f"'{dat}' using 1:2 with linespoints lw 1.5 pt {i + 4} lc rgb '{COLORS[meth]}' "
                         f"title '{LABELS[meth]}: slope {s:.2f}{part}'")
        svg = os.path.join(pdir, f"scaling_{fam}.png")
        times = [r["time"] for m in ms for r in m["methods"].values()]
        y0, y1 = log_range(min(times), max(times))
        ks = [m["K"] for m in ms]
        gnuplot(f"""set terminal pngcairo size 900,600 font 'sans,10' noenhanced
set output '{svg}'
set title "{fam} ({', '.join(m['name'] for m in ms)}): time of one solve against size\\nslope: least-squares fit of log t against log K (time grows as K^slope)"
set logscale xy
set xrange [{ks[0] / 1.25:g}:{ks[-1] * 1.25:g}]
set yrange [{y0:g}:{y1:g}]
set xtics ({', '.join(str(k) for k in ks)})
{log_tics('y', y0, y1)}
set xlabel 'K = nv + nc (unknowns of eq. 17: velocities + constraint rows)'
set ylabel 'median CPU time per solve [µs]'
set key below Left reverse font 'sans,9' maxcols 3 samplen 3 width -3 height 1.5
set grid
plot {', '.join(plots)}
""", failures, svg)
        files.append((fam, svg, [m["name"] for m in ms]))
    return slopes, files


def write_fd_table(models, w):
    """The full forward-dynamics table: the generated forward_dynamics against
    MuJoCo's mj_forward on the same q, v, tau (report_core.cpp, fd/...)."""
    rows = [m for m in models if m["fd"]]
    if not rows:
        return
    w("\n## Full forward dynamics: forward_dynamics against MuJoCo's mj_forward\n")
    w("The whole call on the same q, v, tau: jrgen's generated `forward_dynamics` (kinematics, M, h, Phiq, "
      "gamma and the solve) and MuJoCo's `mj_forward` (contacts, limits, constraint solver, actuation and "
      "sensors off, passive forces on for damping; trees only) on the MJCF written from jrgen's topology. "
      "Median CPU time per call; errors of qdd relative to the independent reference (the repository's "
      "world-frame M, h, Phiq and gamma, eq. (17) solved in long double; its own error is about eps cond(M)).\n")
    w("| model | nv | nc | jrgen forward_dynamics [µs] | MuJoCo mj_forward [µs] | MuJoCo / jrgen | "
      "jrgen error | MuJoCo error | MuJoCo vs jrgen |")
    w("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m in rows:
        jr, mj = m["fd"].get("jrgen"), m["fd"].get("mujoco")
        ratio = f"{mj['time'] / jr['time']:.2f}" if jr and mj and jr["time"] else "—"
        w(f"| {m['name']} | {m['nv']} | {m['nc']} | {fmt_t(jr and jr['time'])} | {fmt_t(mj and mj['time'])} | "
          f"{ratio} | {fmt_e(jr and jr['err_ref'])} | {fmt_e(mj and mj['err_ref'])} | "
          f"{fmt_e(mj and mj['err_jrgen'])} |")


def write_report(models, out, args, failures, notes, elapsed):
    lines = []
    w = lines.append
    w("# jrgen solver report\n")
    commit = subprocess.run(["git", "-C", os.path.dirname(os.path.abspath(__file__)), "rev-parse", "--short", "HEAD"],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout.strip()
    cpu = ""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    w(f"Set `{args.set}`{' (quick timings)' if args.quick else ''}; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; "
      f"commit {commit or 'unknown'}; {cpu}, {os.cpu_count()} logical CPUs, {platform.platform()}; "
      f"load average {os.getloadavg()[0]:.2f}; "
      + ("formatted again from an earlier run's JSON.\n" if args.reuse else f"total run time {elapsed:.0f} s.\n"))
    # When the programs ran and how loaded the machine was, from each
    # program's Google Benchmark context (also right for --reuse).
    dates = sorted(m["date"][:16].replace("T", " ") for m in models if m["date"])
    loads = [m["load"] for m in models if m["load"] is not None]
    if dates and loads:
        w(f"Programs run {dates[0]} to {dates[-1][11:]} UTC; 1-minute load average as each program started "
          f"{min(loads):.2f} to {max(loads):.2f} on {os.cpu_count()} CPUs (above {os.cpu_count()}: other "
          "processes competed for the CPUs; the times are CPU times, medians of repetitions, less affected "
          "than wall time but not immune).\n")
    flags = sorted({m["compile_flags"] for m in models})
    w(f"Compiled with {'; '.join(f'`{f}`' for f in flags) or 'unknown flags'} (every timed method but the "
      "prebuilt libraries: LAPACKE/OpenBLAS, UMFPACK, MuJoCo).\n")
    w("Every method solves eq. (17) on the same M, Q = tau - h, Phiq, gamma of one assembled state; "
      "times are medians of repeated Google Benchmark runs in microseconds; errors are relative to an "
      "extended-precision solve of the same system (docs/report.md).\n")
    w("## Models\n")
    w("| model | nv | nc | K = nv+nc | cond1(A) | cond1(M) | cond1(TᵀT) | checks | MuJoCo M check |")
    w("|---|---:|---:|---:|---:|---:|---:|---|---|")
    for m in models:
        w(f"| {m['name']} | {m['nv']} | {m['nc']} | {m['K']} | {m['cond_A']:.1e} | {m['cond_M']:.1e} | "
          f"{m['cond_W']:.1e} | {m['checks']} | {m['mujoco_check']} |")
    w("")
    present = [meth for meth in METHODS if any(meth in m["methods"] for m in models)]
    w("## Time per solve [µs] (median)\n")
    w("| model | K | " + " | ".join(present) + " |")
    w("|---|---:|" + "---:|" * len(present))
    for m in models:
        w(f"| {m['name']} | {m['K']} | " + " | ".join(fmt_t(m["methods"].get(meth, {}).get("time")) for meth in present) + " |")
    w("\n## Time relative to the generated LLT solver (method / gen_llt)\n")
    w("| model | " + " | ".join(present) + " |")
    w("|---|" + "---:|" * len(present))
    for m in models:
        g = m["methods"].get("gen_llt", {}).get("time")
        w(f"| {m['name']} | " + " | ".join(
            f"{m['methods'][meth]['time'] / g:.2f}" if g and meth in m["methods"] else "—" for meth in present) + " |")
    for key, title in [("err_qdd", "Relative error of qdd"), ("err_lambda", "Relative error of λ (closed loops)"),
                       ("err_f", "Relative error of Φqᵀλ (closed loops)"), ("res17", "Normwise backward error of eq. (17)"),
                       ("bound", "Bound checked on the qdd error: 10 K eps max(cond(A), cond(M) cond(TᵀT))")]:
        rows = [m for m in models if key not in ("err_lambda", "err_f") or m["nc"] > 0]
        if not rows:
            continue
        w(f"\n## {title}\n")
        w("| model | " + " | ".join(present) + " |")
        w("|---|" + "---:|" * len(present))
        for m in rows:
            cells = []
            for meth in present:
                r = m["methods"].get(meth)
                if r is None:
                    cells.append("—")
                    continue
                mark = "" if key != "err_qdd" or r["passed"] else " **FAIL**"
                cells.append(fmt_e(r.get(key)) + mark)
            w(f"| {m['name']} | " + " | ".join(cells) + " |")
    w("\nFor MuJoCo the error is measured against the extended-precision solve of MuJoCo's own M "
      "(its free-joint linear velocity is in the world frame, jrgen's in the joint frame), and "
      "λ does not apply.\n")
    write_fd_table(models, w)
    w("")

    # The paper's Tables 4 and 5.
    h = next((m for m in models if m["name"] == "hmmwv14"), None)
    if h:
        w("## The paper's Tables 4 and 5 on this machine (HMMWV, nv 27, nc 16)\n")
        gen = h["methods"].get("gen_llt", {}).get("time")
        algd = h["methods"].get("alg_d", {}).get("time")
        w("| method | here [µs] | here / generated LLT | here / Alg-D | paper 1997 [µs] | paper / Alg-D | paper / Alg-S |")
        w("|---|---:|---:|---:|---:|---:|---:|")
        for meth in ["gauss", "symmetric", "sparse", "alg_s", "alg_d", "gen_llt", "gen_ldlt"]:
            r = h["methods"].get(meth)
            if not r:
                continue
            pp = PAPER_T4.get(meth)
            w(f"| {LABELS[meth]} | {fmt_t(r['time'])} | {r['time'] / gen:.2f} | {r['time'] / algd:.2f} | "
              f"{pp if pp else '—'} | {pp / PAPER_T4['alg_d']:.2f} | {pp / PAPER_T4['alg_s']:.2f} |"
              if pp else
              f"| {LABELS[meth]} | {fmt_t(r['time'])} | {r['time'] / gen:.2f} | {r['time'] / algd:.2f} | — | — | — |")
        w("\n(The paper's \"Harwell\" column, MA28, is matched with UMFPACK here; the paper has no generated code.)\n")
        if h["steps"]:
            w("Table 5, per step [µs] (Alg-D and Alg-S interpreted: each step alone on the data of a full solve; "
              "generated: differences of consecutive prefixes `solve_augmented_steps(..., k)`, whose gather of "
              "M, Q, Phiq, gamma is listed apart):\n")
            w("| | gather | " + " | ".join(STEPS) + " | sum of steps |")
            w("|---|---:|" + "---:|" * (len(STEPS) + 1))
            for meth in ["alg_s", "alg_d", "gen_llt", "gen_ldlt"]:
                st = h["steps"].get(meth)
                if not st:
                    continue
                vals = [st.get(s) for s in STEPS]
                total = sum(v for v in vals if v is not None)
                w(f"| {LABELS[meth]} | {fmt_t(st.get('gather')) if 'gather' in st else '—'} | "
                  + " | ".join(fmt_t(v) for v in vals) + f" | {fmt_t(total)} |")
            for meth in ["alg_s", "alg_d"]:
                w(f"| paper 1997 {'Alg-S' if meth == 'alg_s' else 'Alg-D'} | — | " + " | ".join(str(v) for v in PAPER_T5[meth])
                  + f" | {sum(PAPER_T5[meth])} |")
            g = h["steps"].get("gen_llt")
            if g:
                w("\nPer-step ratio (method / generated LLT):\n")
                w("| | " + " | ".join(STEPS) + " |")
                w("|---|" + "---:|" * len(STEPS))
                for meth in ["alg_s", "alg_d"]:
                    st = h["steps"].get(meth, {})
                    w(f"| {LABELS[meth]} | " + " | ".join(
                        f"{st[s] / g[s]:.1f}" if s in st and g.get(s) else "—" for s in STEPS) + " |")
                w("| paper Alg-S / Alg-D | " + " | ".join(
                    f"{a / d:.2f}" for a, d in zip(PAPER_T5["alg_s"], PAPER_T5["alg_d"])) + " |")
            w("")

    # Plots.
    err_files = plot_error_vs_time(models, out, failures)
    slopes, scaling_files = plot_scaling(models, out, failures)
    if scaling_files:
        w("## Scaling: time against K on log-log axes\n")
        w("One picture per family of models (the same kind of mechanism at growing size): the median CPU time "
          "of one solve of eq. (17) in µs against K = nv + nc, the number of unknowns (velocities plus "
          "constraint rows), both axes logarithmic, one line per method. A straight line of slope s means a "
          "time growing as K^s (dense LU: up to 3; a sparse tree solve: about 1); the slope in the legend is "
          "the least-squares fit over the family's models. A method missing from a picture did not run on those "
          "models (MuJoCo: closed loops, or chains of more than ~98 bodies, which its XML reader rejects); its "
          "legend then gives the range of K its slope is fitted over.\n")
        w("Least-squares slope of log t against log K per method and model family:\n")
        w("| family | models | " + " | ".join(present) + " |")
        w("|---|---|" + "---:|" * len(present))
        for fam, svg, names in scaling_files:
            w(f"| {fam} | {', '.join(names)} | " + " | ".join(
                f"{slopes[(fam, meth)]:.2f}" if (fam, meth) in slopes else "—" for meth in present) + " |")
        w("")
        for fam, svg, _ in scaling_files:
            w(f"![{fam}]({os.path.relpath(svg, out)})\n")
    w("## Error against time, per model\n")
    w("One picture per model, one point per method: the median CPU time of one solve in µs (x) against the "
      "relative error of qdd (y, the norm of the difference from an extended-precision solve of the same "
      "system divided by the norm of that solution), both axes logarithmic; lower and further left is better. "
      "An exact result (error 0) is drawn at 1e-18. Hollow markers are drawn again on top, so that two methods "
      "with the same time and error (Alg-S and the table-driven generated solver on the 1000-dof trees) both "
      "show.\n")
    for svg in err_files:
        w(f"![{os.path.basename(svg)}]({os.path.relpath(svg, out)})\n")
    if notes:
        w("## Notes\n")
        for n in notes:
            w(f"- {n}")
        w("")
    if failures:
        w("## Failures\n")
        for f in failures:
            w(f"- {f}")
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    return err_files, scaling_files


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--programs", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--set", default="default")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--reuse", action="store_true", help="format the JSON of an earlier run again, run nothing")
    args = ap.parse_args()
    # The programs run in OUT/work: a relative OUT would name the wrong place.
    args.out = os.path.abspath(args.out)
    programs = []
    with open(args.programs) as f:
        for line in f:
            if line.strip():
                parts = line.rstrip("\n").split("\t")
                programs.append((parts[0], parts[1], [x for x in parts[2:] if x]))
    os.makedirs(args.out, exist_ok=True)
    t0 = time.time()
    results, failures = run_programs(programs, args.out, args.quick, args.reuse)
    models = [parse(n, d) for n, d in results]
    # Every method must be present, MuJoCo on every tree; outside --quick a
    # model MuJoCo itself rejects (its XML reader stops at 100 nested
    # elements: chains of more than ~98 bodies) is a note, not a failure.
    notes = []
    for m in models:
        rejected = m["mujoco_check"].startswith("MuJoCo rejected")
        if rejected and not args.quick:
            notes.append(f"{m['name']}: no MuJoCo timing: {m['mujoco_check']}")
        need = METHODS[:-1] + (["mujoco"] if m["nc"] == 0 and (args.quick or not rejected) else [])
        for meth in need:
            if meth not in m["methods"]:
                failures.append(f"{m['name']}: no result for {meth}"
                                + (f" ({m['mujoco_check']})" if meth == "mujoco" else ""))
        for meth, r in m["methods"].items():
            if not r["passed"]:
                failures.append(f"{m['name']}: {meth}: qdd error {r['err_qdd']:.2e} above its bound {r['bound']:.2e}")
        if "jrgen" not in m["fd"]:
            failures.append(f"{m['name']}: no full forward-dynamics timing")
        elif not m["fd"]["jrgen"]["err_ref"] < 1e-6:
            failures.append(f"{m['name']}: forward_dynamics qdd error {m['fd']['jrgen']['err_ref']:.2e} "
                            "against the reference")
        mjfd = m["fd"].get("mujoco")
        if mjfd and not mjfd["err_jrgen"] < 1e-6:
            notes.append(f"{m['name']}: MuJoCo's mj_forward differs from jrgen's forward_dynamics by "
                         f"{mjfd['err_jrgen']:.1e}")
        if m["mujoco_check"].endswith("(FAIL)"):
            failures.append(f"{m['name']}: MuJoCo mass matrix differs: {m['mujoco_check']}")
    err_files, scaling_files = write_report(models, args.out, args, failures, notes, time.time() - t0)
    for svg in err_files + [s for _, s, _ in scaling_files]:
        if not os.path.exists(svg) or os.path.getsize(svg) == 0:
            failures.append(f"plot missing: {svg}")
    print(f"report: wrote {os.path.join(args.out, 'report.md')}")
    for f in failures:
        print(f"report: FAILED: {f}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
