#!/usr/bin/env python3
"""Which configuration should `spectex bake` use by default? Every figure the decision needs, for
each candidate, from one run on one machine.

    build/venv/bin/python tests/bench/default_decision.py --spectex build/src/spectex \\
        [--budget-args "--precision auto"] [--size 4096] [--repeat 2] [--out bench-report/]

Candidates (each a set of bake options; --config NAME=OPTIONS adds more, --only keeps those given):
the basis (the default before), the lattice with the Jakob-Hanika vertex prior, the lattice with the
LHTSS prior, and spectex bake's default (no options); with --budget-args, each but the default again
with those options added (a precision budget; the default has its own).

Measured for each:
  * exact under D65: all 16,777,216 8-bit colours (a 4096² PNG holding each once) baked in half and
    checked by `spectex verify --source --report-only`: codes that re-encode, linear RGB error; and
    in float (without the budget options): the largest linear RGB error (the target is 1e-6);
  * natural under other light: tests/bench/method_accuracy.py with this binary, the spectra as the
    file stores them (half, with the candidate's options): the mean ΔE00 averaged over A, FL2, FL11,
    D50 and LED-B3 and the worst sample under each light, on the TUNING sets (CES, TCS, VS pooled;
    reported, not a target: the priors were chosen there) and on the two held-out ColorCheckers
    (Ohta, BabelColor Average), against Jakob-Hanika and the default before (the basis at full precision);
  * the budget's own cost: the worst ΔE00 between the budgeted spectra and the same candidate's
    spectra in float, over the dense sample of the cube (every 4th code and 255 per axis, 274,625
    colours) under D65, A, FL2, FL11, D50 and LED-B3 (CIE 1931 2°, 380:780:5, L*a*b* relative to each
    light's own white: both spectra are under the same light, so no adaptation is involved);
  * cost: a --size² photograph-like PNG baked --repeat times per candidate, alternating; best wall
    time, file bytes and peak RSS (os.wait4), each as a ratio to the first candidate's.

The targets (printed with each figure): D65 all codes in half, float within 1e-6; mean over the five
lights at most 0.8× Jakob-Hanika's; the worst under each light at most 1.0 above Jakob-Hanika's and
never above the basis'; the budget at most 0.5 ΔE00; bytes and time at most 1.25× the basis
at full precision; peak memory within 1.1× (unchanged up to noise). Writes OUT/default_decision.md
and .json. A benchmark, not a test: it takes about 20-40 minutes on 2 cores.
"""
import argparse
import json
import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import method_accuracy as ma  # noqa: E402
import speed_vs_error as sve  # noqa: E402

BUDGET_LIGHTS = ["D65", "A", "FL2", "FL11", "D50", "LED-B3"]


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def run(cmd, ok=(0,)):
    p = subprocess.run([str(c) for c in cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if p.returncode not in ok:
        raise RuntimeError(f"{shlex.join(map(str, cmd))} exited {p.returncode}:\n{p.stderr[-2000:]}")
    return p


# Runs the bake and reports its wall time and peak RSS from a small interpreter of its own: a child
# forked straight from this process would count the pages it shares with it (gigabytes once the
# 4096² test images are made) in its peak RSS.
_SPAWN = (
    "import os, sys, time\n"
    "t = time.perf_counter()\n"
    "pid = os.posix_spawn(sys.argv[2], sys.argv[2:], os.environ)\n"
    "_, status, ru = os.wait4(pid, 0)\n"
    "open(sys.argv[1], 'w').write(f'{time.perf_counter() - t} {ru.ru_maxrss} {os.waitstatus_to_exitcode(status)}')\n"
)


def timed_bake(spectex, src, out, opts):
    """(wall s, peak RSS MiB) of one bake, measured from the child's rusage."""
    cmd = [spectex, "bake", src, "-o", out, "-q", *opts]
    with tempfile.NamedTemporaryFile(suffix=".txt") as res:
        p = subprocess.run([sys.executable, "-S", "-c", _SPAWN, res.name, *map(str, cmd)],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        fields = Path(res.name).read_text().split()
    if p.returncode != 0 or len(fields) != 3 or fields[2] != "0":
        raise RuntimeError(f"{shlex.join(map(str, cmd))} failed:\n{p.stderr[-2000:]}")
    return float(fields[0]), int(fields[1]) / 1024.0


def verify_json(spectex, exr, src):
    p = run([spectex, "verify", exr, "--source", src, "--report-only", "--json", "-"], ok=(0, 1))
    return json.loads(p.stdout)


def lab_under(light, S, W):
    """L*a*b* of spectra S (pixels × bins on 380:780:5) under a light, relative to its own white."""
    xyz = S @ W.T
    white = W.sum(1)
    import colour

    return colour.XYZ_to_Lab(xyz, colour.XYZ_to_xy(white))


def on_grid_rows(wl, S):
    if len(wl) == len(ma.GRID) and np.abs(wl - ma.GRID).max() < 1e-6:
        return S
    return np.stack([np.interp(ma.GRID, wl, r) for r in S])


def budget_cost(spectex, work, sample_png, opts, budget_opts):
    """Worst ΔE00 per light between the candidate with and without the budget options (float)."""
    import colour

    exact, rounded = work / "budget_ref.exr", work / "budget.exr"
    run([spectex, "bake", sample_png, "-o", exact, "-q", *opts, "--type", "float"])
    run([spectex, "bake", sample_png, "-o", rounded, "-q", *opts, *budget_opts])
    wl0, S0 = sve.read_spectra(exact)
    wl1, S1 = sve.read_spectra(rounded)
    S0, S1 = on_grid_rows(wl0, S0), on_grid_rows(wl1, S1)
    worst = {}
    for light in BUDGET_LIGHTS:
        W = ma.weights(light)
        de = colour.delta_E(lab_under(light, S0, W), lab_under(light, S1, W), method="CIE 2000")
        worst[light] = float(np.max(de))
    return worst


def accuracy(a, configs, work):
    """method_accuracy.py's tables for every candidate and Jakob-Hanika, spectra stored in half."""
    out = work / "accuracy.json"
    specs = [" ".join(o) if o else "default" for o in configs.values()]
    specs.append("--method jakob-hanika")
    run([sys.executable, HERE / "method_accuracy.py", "--spectex", a.spectex, "--methods", *specs,
         "--extra=--type half", "--json", out])
    data = json.loads(out.read_text())
    res = {}
    for name, o in list(configs.items()) + [("jakob-hanika", None)]:
        spec = "--method jakob-hanika" if o is None else (" ".join(o) if o else "default")
        res[name] = dict(tuning=data["tuning_pooled"][spec],
                         ohta=data["per_set"][spec]["ColorChecker (Ohta, 24)"],
                         babel=data["per_set"][spec]["ColorChecker (BabelColor Average, 24)"])
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spectex", default=str(HERE.parent.parent / "build/src/spectex"))
    ap.add_argument("--budget-args", default="", help="bake options of the precision budget, e.g. '--precision auto'")
    ap.add_argument("--config", action="append", default=[], metavar="NAME=OPTIONS",
                    help="another candidate (bake options)")
    ap.add_argument("--only", action="store_true", help="only the --config candidates (the first is the baseline)")
    ap.add_argument("--size", type=int, default=4096, help="side of the photograph-like PNG (default 4096)")
    ap.add_argument("--repeat", type=int, default=2, help="timed bakes per candidate, best kept")
    ap.add_argument("--skip-cube", action="store_true", help="skip the 16.7M-colour D65 check")
    ap.add_argument("--cold-cache", action="store_true",
                    help="time the budgeted bakes with the cache empty (each chooses its bits); by default the "
                         "cache is warmed first, as on a user's machine after the first bake")
    ap.add_argument("--out", default="bench-report")
    a = ap.parse_args()
    t_start = time.time()

    base = {} if a.only else {
        "basis (the default before)": ["--method", "basis"],
        "lattice, JH prior": ["--method", "lattice"],
        "lattice, LHTSS prior": ["--method", "lattice", "--vertex-prior", "lhtss"],
        "spectex bake's default (no options)": [],
    }
    for c in a.config:
        name, _, opts = c.partition("=")
        base[name] = shlex.split(opts)
    budget = shlex.split(a.budget_args)
    configs = dict(base)
    if budget:
        for name, o in base.items():
            if o:  # the default (no options) has its budget already
                configs[f"{name} + {a.budget_args}"] = o + budget
    first = next(iter(configs))

    work = Path(tempfile.mkdtemp(prefix="spectex-default-"))
    rows = {n: {"options": shlex.join(o)} for n, o in configs.items()}
    try:
        photo = work / "photo.png"
        log(f"making a {a.size}² photograph-like PNG")
        sve.photographic_png(photo, a.size)
        # The run's own cache of --precision auto's bits (and plans): never the user's.
        os.environ["SPECTEX_CACHE_DIR"] = str(work / "cache")
        if budget and not a.cold_cache:
            log("warming the cache of the precision's bits")
            tiny = work / "tiny.png"
            sve.photographic_png(tiny, 16)
            for name, o in configs.items():
                if name not in base:
                    run([a.spectex, "bake", tiny, "-o", work / "tiny.exr", "-q", *o])
        log("cost: alternating bakes")
        for r in range(a.repeat):
            for name, o in configs.items():
                out = work / "photo.exr"
                wall, rss = timed_bake(a.spectex, photo, out, o)
                row = rows[name]
                row["wall_s"] = min(row.get("wall_s", 1e30), wall)
                row["peak_mib"] = max(row.get("peak_mib", 0), rss)
                row["bytes"] = out.stat().st_size
                log(f"  {name}: {wall:.2f} s, {row['bytes'] / 1e6:.1f} MB, {rss:.0f} MiB")
        for name in configs:
            for k in ("wall_s", "bytes", "peak_mib"):
                rows[name][k + "_ratio"] = rows[name][k] / rows[first][k]

        if not a.skip_cube:
            cube = work / "cube.png"
            log("D65: all 16,777,216 colours")
            sve.cube_full_png(cube)
            for name, o in configs.items():
                out = work / "cube.exr"
                run([a.spectex, "bake", cube, "-o", out, "-q", *o])
                v = verify_json(a.spectex, out, cube)
                s = v["source"]
                rows[name]["d65_half"] = dict(matched=s["code_match"]["matched"], checked=s["code_match"]["checked"],
                                              rgb_max=s["rgb_error"]["max"], de_max=s["ciede2000"]["max"])
                if name in base:
                    run([a.spectex, "bake", cube, "-o", out, "-q", *o, "--type", "float"])
                    v = verify_json(a.spectex, out, cube)
                    rows[name]["d65_float_rgb_max"] = v["source"]["rgb_error"]["max"]
                log(f"  {name}: {rows[name]['d65_half']}")
                out.unlink()

        if budget:
            sample = work / "sample.png"
            sve.dense_sample_png(sample)
            log("the budget's cost against the same spectra in float")
            for name, o in base.items():
                key = f"{name} + {a.budget_args}" if o else name
                rows[key]["budget_worst"] = budget_cost(a.spectex, work, sample, o, budget if o else [])

        log("accuracy under other light (method_accuracy.py)")
        acc = accuracy(a, configs, work)
    finally:
        import shutil

        shutil.rmtree(work, ignore_errors=True)

    jh = acc.pop("jakob-hanika")
    today = acc[first]
    cache = "cold cache (each budgeted bake chooses its bits)" if a.cold_cache else "warm cache (bits chosen before)"
    report = ["# Default decision\n", f"`{a.spectex}`, {a.size}² photograph-like PNG, best of {a.repeat}; "
              f"baseline: {first}; {cache if budget else 'no budget'}.\n"]
    report.append("| candidate | bytes × | time × | peak MiB | D65 half codes | float max err | "
                  "TUNING mean (× JH) | Ohta mean (× JH) | budget worst |")
    report.append("|---|---|---|---|---|---|---|---|---|")
    checks = []
    for name, row in rows.items():
        t, o = acc[name]["tuning"], acc[name]["ohta"]
        row["accuracy"] = acc[name]
        d = row.get("d65_half")
        codes = f"{d['matched']:,}/{d['checked']:,}" if d else "—"
        fl = f"{row['d65_float_rgb_max']:.1e}" if "d65_float_rgb_max" in row else "—"
        bw = row.get("budget_worst")
        report.append(
            f"| {name} | {row['bytes_ratio']:.2f} | {row['wall_s_ratio']:.2f} | {row['peak_mib']:.0f} | {codes} | {fl} | "
            f"{t['avg_mean']:.3f} ({t['avg_mean'] / jh['tuning']['avg_mean']:.2f}) | "
            f"{o['avg_mean']:.3f} ({o['avg_mean'] / jh['ohta']['avg_mean']:.2f}) | "
            f"{max(bw.values()):.3f} |" if bw else
            f"| {name} | {row['bytes_ratio']:.2f} | {row['wall_s_ratio']:.2f} | {row['peak_mib']:.0f} | {codes} | {fl} | "
            f"{t['avg_mean']:.3f} ({t['avg_mean'] / jh['tuning']['avg_mean']:.2f}) | "
            f"{o['avg_mean']:.3f} ({o['avg_mean'] / jh['ohta']['avg_mean']:.2f}) | — |")
        # The targets, each with its figure.
        c = {}
        if d:
            c["D65 half: every code"] = (d["matched"] == d["checked"], f"{d['matched']:,}/{d['checked']:,}")
        if "d65_float_rgb_max" in row:
            c["D65 float ≤ 1e-6"] = (row["d65_float_rgb_max"] <= 1e-6, f"{row['d65_float_rgb_max']:.2e}")
        # The targets hold on measured reflectances not used for tuning: the two held-out charts.
        for set_name, key in (("Ohta", "ohta"), ("BabelColor", "babel")):
            mine, theirs, dflt = acc[name][key], jh[key], today[key]
            c[f"{set_name} mean ≤ 0.8× JH"] = (mine["avg_mean"] <= 0.8 * theirs["avg_mean"],
                                              f"{mine['avg_mean'] / theirs['avg_mean']:.3f}×")
            for L in ma.LIGHTS:
                w, wj, wd = mine[L]["max"], theirs[L]["max"], dflt[L]["max"]
                c[f"{set_name} worst {L} ≤ JH + 1 and ≤ the basis'"] = (
                    w <= wj + 1.0 and w <= wd + 1e-9, f"{w:.2f} (JH {wj:.2f}, basis {wd:.2f})")
        if bw:
            c["budget ≤ 0.5"] = (max(bw.values()) <= 0.5, ", ".join(f"{L} {v:.3f}" for L, v in bw.items()))
        c["bytes ≤ 1.25× basis"] = (row["bytes_ratio"] <= 1.25, f"{row['bytes_ratio']:.2f}×")
        c["time ≤ 1.25× basis"] = (row["wall_s_ratio"] <= 1.25, f"{row['wall_s_ratio']:.2f}×")
        c["peak memory ≤ 1.1× basis"] = (row["peak_mib_ratio"] <= 1.1, f"{row['peak_mib_ratio']:.2f}×")
        row["targets"] = {k: dict(met=bool(v[0]), figure=v[1]) for k, v in c.items()}
        missed = [f"{k}: {v[1]}" for k, v in c.items() if not v[0]]
        checks.append(f"- **{name}**: " + ("every target met" if not missed else "missed — " + "; ".join(missed)))
    report.append("\nPer light, worst ΔE00 (TUNING / Ohta / BabelColor; the targets use the two held-out charts):\n")
    report.append("| candidate | " + " | ".join(ma.LIGHTS) + " |")
    report.append("|---|" + "---|" * len(ma.LIGHTS))
    for name, r in list(acc.items()) + [("jakob-hanika", jh)]:
        report.append(f"| {name} | " + " | ".join(
            f"{r['tuning'][L]['max']:.2f} / {r['ohta'][L]['max']:.2f} / {r['babel'][L]['max']:.2f}"
            for L in ma.LIGHTS) + " |")
    report.append("\nTargets:\n")
    report += checks
    report.append(f"\nRuntime {time.time() - t_start:.0f} s.")
    text = "\n".join(report)
    print(text)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "default_decision.md").write_text(text + "\n")
    (out / "default_decision.json").write_text(json.dumps(dict(rows=rows, jakob_hanika=jh), indent=1))


if __name__ == "__main__":
    main()
