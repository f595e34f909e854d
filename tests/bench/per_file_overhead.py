#!/usr/bin/env python3
"""Per-file overhead of a batch of small textures.

    build/venv/bin/python tests/bench/per_file_overhead.py --spectex build/src/spectex \\
        [--files 1000] [--size 512] [--repeat 2] [--profile 100] [--check] [--json]

Makes N distinct photograph-like 8-bit sRGB PNGs of --size² (speed_vs_error.photographic_png with
seed i: each file has its own content, so that PNG and ZIP compress as on real files) and one
large PNG holding exactly the same pixels: the N tiles laid out on a near-square W×H with
W·H = N·size² exactly (W = size·c with c the divisor of N·size closest to √N; for N = 1000,
512²: 16384×16000 = 32 columns × 31 full rows of tiles, the last 128-row band holding the 8
remaining tiles cut into 128-row strips). A 512×(512·N) strip would be the simplest layout but is
taller than some readers accept. Generating them is not timed (and runs in a child process, so
that this process's pages do not inflate the measured children's peak RSS).

Then, alternating, best wall time of --repeat runs of each (a shared machine: compare within a
run, never across runs):
  * batch  `spectex bake --from-list LIST --output-dir OUT --jobs J --threads T` over the N files
    (one process), for each J×T of --batch (default 2x1 and 1x2);
  * big    `spectex bake BIG.png -o BIG.exr --threads J·T` (one process, the same total threads).
Wall time, CPU (user + system) and peak RSS come from the child's rusage (os.wait4). Outputs are
deleted between runs (not timed).

Printed: files/s and Mpixel/s of each, batch wall / big wall, and the per-file overhead
(batch wall − big wall) / N in ms, against the per-file share of the big bake (big wall / N).
--check exits 1 when the overhead of the best batch configuration is above --target (default
0.10: a file costs at most 10 % more in a batch than its share of one large image, twice the
run-to-run noise measured on a loaded 2-core machine; see tests/bench/README.md for why). --json prints one JSON line with everything.

--profile M (default 100; 0 = off) runs the batch (first --batch configuration) once more over
the first M files under `strace -f -c` (syscall counts and times: fsync, open, mmap, clone) and
once with `--json` (per-file stage times summed: read, colour, expand, pack, waits, finish; and
the process's wall time not inside any file's `seconds`), then the same batch over M 16² PNGs
(pixel work ~0: a file's fixed cost, (wall of M files − wall of one) / (M − 1)), plain and under
`strace -f -c -w` (wall time per syscall, e.g. fsync), and reports the top costs. The timed runs
also pass `--json` (one short line per file) for each run's summed stages.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
MIB = 1024 * 1024


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def run_child(cmd, stdout_path=None):
    """Runs cmd with its own rusage: dict(wall, cpu, utime, stime, rss bytes), stderr text."""
    with tempfile.TemporaryFile() as so, tempfile.TemporaryFile() as se:
        out = open(stdout_path, "wb") if stdout_path else so
        try:
            t0 = time.monotonic()
            p = subprocess.Popen([str(c) for c in cmd], stdout=out, stderr=se)
            _, status, ru = os.wait4(p.pid, 0)
            wall = time.monotonic() - t0
        finally:
            if stdout_path:
                out.close()
        rc = os.waitstatus_to_exitcode(status)
        se.seek(0)
        err = se.read().decode(errors="replace")
        if rc != 0:
            raise RuntimeError(f"{' '.join(map(str, cmd))} failed ({rc}):\n{err[-2000:]}")
        return dict(wall=wall, cpu=ru.ru_utime + ru.ru_stime, utime=ru.ru_utime, stime=ru.ru_stime,
                    rss=ru.ru_maxrss * 1024, nvcsw=ru.ru_nvcsw, nivcsw=ru.ru_nivcsw), err


# ---------------------------------------------------------------- inputs (not timed)

def layout(n, size):
    """(W, H, columns): W = size·c, H = n·size/c, c the divisor of n·size nearest √n."""
    total_rows = n * size
    best = None
    for c in range(1, n + 1):
        if total_rows % c == 0:
            key = abs(math.log(c / math.sqrt(n)))
            if best is None or key < best[0]:
                best = (key, c)
    c = best[1]
    return size * c, total_rows // c, c


def generate(work, n, size, workers):
    """Runs in a child process: the N small PNGs and the big one, skipped when already there."""
    import numpy as np
    import OpenImageIO as oiio

    sys.path.insert(0, str(HERE))
    from speed_vs_error import photographic_png, write_png

    small = work / "small"
    small.mkdir(parents=True, exist_ok=True)
    paths = [small / f"tex{i:05d}.png" for i in range(n)]
    todo = [(str(p), i) for i, p in enumerate(paths) if not p.exists()]
    if todo:
        log(f"making {len(todo)} photograph-like {size}² PNGs in {small}")
        t0 = time.monotonic()
        if workers > 1:
            from multiprocessing import Pool
            with Pool(workers) as pool:
                pool.starmap(_make_one, [(p, size, i) for p, i in todo], chunksize=8)
        else:
            for p, i in todo:
                photographic_png(p, size, seed=1000 + i)
        log(f"  {time.monotonic() - t0:.0f} s")
    W, H, c = layout(n, size)
    big = work / f"big_{W}x{H}.png"
    if not big.exists():
        log(f"making {big.name}: the same {n} tiles on {W}x{H} ({c} columns)")
        t0 = time.monotonic()
        img = np.empty((H, W, 3), np.uint8)
        full_rows = H // size
        k = 0
        for r in range(full_rows):
            for col in range(c):
                img[r * size:(r + 1) * size, col * size:(col + 1) * size] = read_png(oiio, paths[k])
                k += 1
        rem = H - full_rows * size
        if rem:
            # The remaining tiles stacked vertically are c·rem rows of `size` columns: cut into c
            # strips of rem rows, side by side.
            stack = np.concatenate([read_png(oiio, p) for p in paths[k:]], axis=0)
            assert stack.shape[0] == c * rem
            for col in range(c):
                img[full_rows * size:, col * size:(col + 1) * size] = stack[col * rem:(col + 1) * rem]
        tmp = big.with_suffix(".tmp.png")
        write_png(tmp, img)
        tmp.rename(big)
        log(f"  {time.monotonic() - t0:.0f} s")
    (work / "list.txt").write_text("".join(f"{p}\n" for p in paths))


def make_tiny(work, m, size=16):
    """Runs in a child process: m photograph-like PNGs of size² (a fixed cost's probe)."""
    sys.path.insert(0, str(HERE))
    from speed_vs_error import photographic_png

    tiny = work / "tiny"
    tiny.mkdir(parents=True, exist_ok=True)
    paths = [tiny / f"t{i:05d}.png" for i in range(m)]
    for i, p in enumerate(paths):
        if not p.exists():
            photographic_png(str(p), size, seed=1000 + i)
    (work / "tiny_list.txt").write_text("".join(f"{p}\n" for p in paths))


def _make_one(path, size, i):
    sys.path.insert(0, str(HERE))
    from speed_vs_error import photographic_png
    photographic_png(path, size, seed=1000 + i)


def read_png(oiio, path):
    inp = oiio.ImageInput.open(str(path))
    px = inp.read_image(oiio.UINT8)
    inp.close()
    return px


# ---------------------------------------------------------------- profiling

def strace_summary(text, top=10):
    """Rows of `strace -c` output: (syscall, seconds, calls), largest time first."""
    rows = []
    for line in text.splitlines():
        f = line.split()
        if len(f) >= 5 and f[0].replace(".", "", 1).isdigit() and f[-1] not in ("total",):
            try:
                secs, calls = float(f[1]), int(f[3])
            except ValueError:
                continue
            rows.append((f[-1], secs, calls))
    rows.sort(key=lambda r: -r[1])
    return rows[:top]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spectex", default=str(ROOT / "build/src/spectex"))
    ap.add_argument("--files", type=int, default=1000, help="N small textures (default 1000)")
    ap.add_argument("--size", type=int, default=512, help="side of each small texture (default 512)")
    ap.add_argument("--batch", default="2x1,1x2", help="JOBSxTHREADS of the batch runs (default 2x1,1x2); "
                    "the big image gets JOBS·THREADS threads (the first configuration's)")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--profile", type=int, default=100, help="files for the strace / stages profile (0: none)")
    ap.add_argument("--dir", help="work folder (default a fresh one in /tmp); generated inputs in it are reused")
    ap.add_argument("--keep", action="store_true", help="keep the work folder (always kept with --dir)")
    ap.add_argument("--gen-workers", type=int, default=2)
    ap.add_argument("--target", type=float, default=0.10,
                    help="--check: per-file overhead / (big wall / N) must be <= this (default 0.10)")
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--json", action="store_true", help="also print one JSON line")
    a = ap.parse_args()

    n, size = a.files, a.size
    configs = []
    for s in a.batch.split(","):
        j, t = (int(v) for v in s.lower().split("x"))
        configs.append((j, t))
    total_threads = configs[0][0] * configs[0][1]
    if any(j * t != total_threads for j, t in configs):
        sys.exit("every --batch configuration must use the same total threads")

    work = Path(a.dir) if a.dir else Path(tempfile.mkdtemp(prefix="spectex-pfo-"))
    work.mkdir(parents=True, exist_ok=True)
    keep = a.keep or bool(a.dir)
    # Inputs, in a child process (not timed; keeps this process small).
    subprocess.run([sys.executable, "-c",
                    "import sys; sys.path.insert(0, sys.argv[1]); import per_file_overhead as m; "
                    "from pathlib import Path; m.generate(Path(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), "
                    "int(sys.argv[5]))", str(HERE), str(work), str(n), str(size), str(a.gen_workers)], check=True)
    W, H, cols = layout(n, size)
    big = work / f"big_{W}x{H}.png"
    lst = work / "list.txt"
    pixels = n * size * size
    assert W * H == pixels
    outdir, big_exr = work / "out", work / "big.exr"
    uptimes = [subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()]
    log(f"{n} × {size}² PNGs ({sum(p.stat().st_size for p in (work / 'small').glob('*.png')) / MIB:.0f} MiB) "
        f"against {big.name} ({big.stat().st_size / MIB:.0f} MiB), {pixels / 1e6:.1f} Mpixel each way; "
        f"{a.repeat} alternating runs")
    log(f"load: {uptimes[0]}")

    def clean():
        if outdir.exists():
            shutil.rmtree(outdir)
        if big_exr.exists():
            big_exr.unlink()

    jl = work / "timed.jsonl"

    def stages_of():
        """The `--json` records' stages summed over the files, and the sum of their `seconds`."""
        st = {"seconds": 0.0}
        for line in jl.read_text().splitlines():
            if line.strip():
                rec = json.loads(line)
                st["seconds"] += rec.get("seconds", 0.0)
                for sk, sv in (rec.get("stages") or {}).items():
                    if isinstance(sv, (int, float)):
                        st[sk] = st.get(sk, 0.0) + sv
        jl.unlink()
        return st

    def run_batch(j, t):
        clean()
        # --json costs one short line per file: kept in the timed runs for the stages
        r, _ = run_child([a.spectex, "bake", "--from-list", lst, "--output-dir", outdir, "--jobs", j,
                          "--threads", t, "-q", "--json", jl])
        r["bytes"] = sum(p.stat().st_size for p in outdir.iterdir())
        r["stages"] = stages_of()
        clean()
        return r

    def run_big():
        clean()
        r, _ = run_child([a.spectex, "bake", big, "-o", big_exr, "--threads", total_threads, "-q", "--json", jl])
        r["bytes"] = big_exr.stat().st_size
        r["stages"] = stages_of()
        clean()
        return r

    keys = [f"batch_j{j}t{t}" for j, t in configs] + ["big"]
    runs = {k: [] for k in keys}
    try:
        for i in range(a.repeat):
            for (j, t), k in zip(configs, keys):
                runs[k].append(run_batch(j, t))
                log(f"  run {i + 1}: batch --jobs {j} --threads {t}: {runs[k][-1]['wall']:.1f} s "
                    f"(CPU {runs[k][-1]['cpu']:.1f} s)")
                if k == keys[0]:  # the big image right after the first configuration: alternating
                    runs["big"].append(run_big())
                    log(f"  run {i + 1}: big --threads {total_threads}: {runs['big'][-1]['wall']:.1f} s "
                        f"(CPU {runs['big'][-1]['cpu']:.1f} s)")
            uptimes.append(subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())

        best = {k: dict(min(v, key=lambda r: r["wall"]), walls=[r["wall"] for r in v],
                        rss_max=max(r["rss"] for r in v)) for k, v in runs.items()}
        bg = best["big"]
        share_ms = bg["wall"] / n * 1e3
        rows = []
        for k in keys:
            r = best[k]
            row = dict(name=k, wall_s=r["wall"], cpu_s=r["cpu"], user_s=r["utime"], sys_s=r["stime"],
                       walls=r["walls"], cores_busy=r["cpu"] / r["wall"], peak_rss_mib=r["rss_max"] / MIB,
                       bytes=r["bytes"], files_per_s=n / r["wall"], mpix_per_s=pixels / 1e6 / r["wall"],
                       ratio_vs_big=r["wall"] / bg["wall"],
                       overhead_ms_per_file=(r["wall"] - bg["wall"]) / n * 1e3,
                       cpu_overhead_ms_per_file=(r["cpu"] - bg["cpu"]) / n * 1e3,
                       stages_ms_per_file={sk: sv / n * 1e3 for sk, sv in r["stages"].items()})
            rows.append(row)
        batch_rows = [r for r in rows if r["name"] != "big"]
        best_batch = min(batch_rows, key=lambda r: r["wall_s"])
        rel = best_batch["overhead_ms_per_file"] / share_ms

        # ------------------------------------------------ profile: where a file's time goes
        prof = {}
        if a.profile:
            m = min(a.profile, n)
            plist = work / "profile_list.txt"
            plist.write_text("".join(lst.read_text().splitlines(keepends=True)[:m]))
            j, t = configs[0]
            jl = work / "profile.jsonl"
            clean()
            if jl.exists():
                jl.unlink()
            r, _ = run_child([a.spectex, "bake", "--from-list", plist, "--output-dir", outdir, "--jobs", j,
                              "--threads", t, "-q", "--json", jl])
            recs = [json.loads(line) for line in jl.read_text().splitlines() if line.strip()]
            stages = {}
            for rec in recs:
                for sk, sv in (rec.get("stages") or {}).items():
                    if isinstance(sv, (int, float)):
                        stages[sk] = stages.get(sk, 0.0) + sv
            secs = sum(rec.get("seconds", 0.0) for rec in recs)
            prof.update(files=m, jobs=j, threads=t, wall_s=r["wall"], cpu_s=r["cpu"], sum_file_seconds=secs,
                        outside_files_s=r["wall"] - secs / j, stages_sum_s=stages,
                        per_file_ms={sk: sv / m * 1e3 for sk, sv in stages.items()})
            clean()
            if shutil.which("strace"):
                st = work / "strace.txt"
                try:
                    run_child(["strace", "-f", "-c", "-o", st, a.spectex, "bake", "--from-list", plist,
                               "--output-dir", outdir, "--jobs", j, "--threads", t, "-q"])
                    prof["strace_top"] = [dict(syscall=s, seconds=sec, calls=c, per_file=c / m)
                                          for s, sec, c in strace_summary(st.read_text(), 12)]
                except RuntimeError as e:
                    prof["strace_error"] = str(e)[:300]
                clean()
            # The fixed cost of a file, alone: the same batch over M 16² PNGs (pixel work ~0), and
            # where its wall time goes (strace -w: syscalls' wall time, e.g. fsync).
            subprocess.run([sys.executable, "-c",
                            "import sys; sys.path.insert(0, sys.argv[1]); import per_file_overhead as m; "
                            "from pathlib import Path; m.make_tiny(Path(sys.argv[2]), int(sys.argv[3]))",
                            str(HERE), str(work), str(m)], check=True)
            tlist = work / "tiny_list.txt"
            rt, _ = run_child([a.spectex, "bake", "--from-list", tlist, "--output-dir", outdir, "--jobs", j,
                               "--threads", t, "-q"])
            clean()
            tone = work / "tiny_one.txt"
            tone.write_text(tlist.read_text().splitlines(keepends=True)[0])
            r0, _ = run_child([a.spectex, "bake", "--from-list", tone, "--output-dir", outdir, "--jobs", j,
                               "--threads", t, "-q"])
            clean()
            prof["tiny"] = dict(files=m, wall_s=rt["wall"], cpu_s=rt["cpu"], one_file_wall_s=r0["wall"],
                                one_file_cpu_s=r0["cpu"],
                                ms_per_file=(rt["wall"] - r0["wall"]) / (m - 1) * 1e3 if m > 1 else None,
                                cpu_ms_per_file=(rt["cpu"] - r0["cpu"]) / (m - 1) * 1e3 if m > 1 else None)
            if shutil.which("strace"):
                st = work / "strace_tiny.txt"
                try:
                    run_child(["strace", "-f", "-c", "-w", "-o", st, a.spectex, "bake", "--from-list", tlist,
                               "--output-dir", outdir, "--jobs", j, "--threads", t, "-q"])
                    prof["tiny"]["strace_wall_top"] = [dict(syscall=s_, seconds=sec, calls=c, per_file=c / m)
                                                       for s_, sec, c in strace_summary(st.read_text(), 12)]
                except RuntimeError as e:
                    prof["tiny"]["strace_error"] = str(e)[:300]
                clean()
            # what a batch saves: a process's fixed cost (one file in its own process; --version)
            one = (work / "small" / "tex00000.png")
            r1, _ = run_child([a.spectex, "bake", one, "-o", work / "one.exr", "--threads", total_threads, "-q",
                               "--force"])
            rv, _ = run_child([a.spectex, "--version"])
            prof["one_file_process_s"] = r1["wall"]
            prof["version_process_s"] = rv["wall"]
            (work / "one.exr").unlink(missing_ok=True)
    finally:
        clean()
        if not keep:
            shutil.rmtree(work, ignore_errors=True)

    # ------------------------------------------------ report
    L = [f"# Per-file overhead: {n} × {size}² PNGs against one {W}×{H} PNG (same pixels)\n",
         f"spectex bake, defaults (81 bins, half, zip level 4); {total_threads} threads in all; best of "
         f"{a.repeat} alternating runs; wall, CPU and peak RSS from the child's rusage.\n",
         "| run | wall s (runs) | files/s | Mpixel/s | × big | overhead ms/file | CPU s | CPU overhead ms/file "
         "| cores busy | peak RSS MiB | bytes |",
         "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["name"] == "big":
            name = f"one {W}×{H} image, --threads {total_threads}"
        else:
            j, t = r["name"][len("batch_j"):].split("t")
            name = f"batch of {n}, --jobs {j} --threads {t}"
        L.append(f"| {name} | {r['wall_s']:.1f} ({', '.join(f'{w:.1f}' for w in r['walls'])}) | "
                 f"{r['files_per_s']:.2f} | {r['mpix_per_s']:.2f} | {r['ratio_vs_big']:.3f} | "
                 f"{r['overhead_ms_per_file']:+.1f} | {r['cpu_s']:.1f} | {r['cpu_overhead_ms_per_file']:+.1f} | "
                 f"{r['cores_busy']:.2f} | {r['peak_rss_mib']:.0f} | {r['bytes']:,} |")
    L.append(f"\nStages from `--json` (summed over the files and divided by N: ms per {size}² file; `seconds` is "
             "the files' own time, so with --jobs J it sums J files at once; waits and compress are summed "
             "wall clocks of threads, inflated by load):\n")
    skeys = [k for k in rows[-1]["stages_ms_per_file"]]
    L.append("| run | " + " | ".join(k.removesuffix("_s") for k in skeys) + " |")
    L.append("|---|" + "---|" * len(skeys))
    for r in rows:
        L.append(f"| {r['name']} | " + " | ".join(f"{r['stages_ms_per_file'].get(k, 0.0):.1f}" for k in skeys) + " |")
    L.append(f"\nA file's share of the big bake: {share_ms:.1f} ms. Best batch ({best_batch['name']}): "
             f"{best_batch['overhead_ms_per_file']:+.1f} ms per file overhead = {rel * 100:+.1f} % of that share "
             f"(target ≤ {a.target * 100:.0f} %: {'met' if rel <= a.target else 'NOT met'}).")
    if prof:
        L.append(f"\n## Profile: batch of {prof['files']} files, --jobs {prof['jobs']} --threads {prof['threads']}\n")
        L.append(f"wall {prof['wall_s']:.2f} s, CPU {prof['cpu_s']:.2f} s; sum of the files' `seconds` "
                 f"{prof['sum_file_seconds']:.2f} s (÷ jobs = {prof['sum_file_seconds'] / prof['jobs']:.2f} s); "
                 f"outside any file (start-up, set-up, tail): {prof['outside_files_s']:.2f} s. One file in its own "
                 f"process: {prof['one_file_process_s'] * 1e3:.0f} ms; `spectex --version`: "
                 f"{prof['version_process_s'] * 1e3:.0f} ms.\n")
        L.append("| stage (`--json` stages) | total s | ms per file |")
        L.append("|---|---|---|")
        for sk, sv in sorted(prof["stages_sum_s"].items(), key=lambda kv: -kv[1]):
            L.append(f"| {sk} | {sv:.2f} | {sv / prof['files'] * 1e3:.1f} |")
        if prof.get("strace_top"):
            L.append("\n`strace -f -c` (all threads; times are the syscalls' own, inflated by tracing):\n")
            L.append("| syscall | s | calls | calls per file |")
            L.append("|---|---|---|---|")
            for s in prof["strace_top"]:
                L.append(f"| {s['syscall']} | {s['seconds']:.3f} | {s['calls']} | {s['per_file']:.1f} |")
    if prof.get("tiny"):
        tq = prof["tiny"]
        L.append(f"\nFixed cost of a file: the same batch over {tq['files']} 16² PNGs took {tq['wall_s']:.2f} s "
                 f"(CPU {tq['cpu_s']:.2f} s), one such file {tq['one_file_wall_s']:.2f} s (CPU "
                 f"{tq['one_file_cpu_s']:.2f} s): {tq['ms_per_file']:.1f} ms wall and {tq['cpu_ms_per_file']:.1f} ms "
                 f"CPU a file beyond the first, = {tq['ms_per_file'] / share_ms * 100:.1f} % of a {size}² file's "
                 f"share of the big bake.")
        if tq.get("strace_wall_top"):
            L.append("\n`strace -f -c -w` of that batch (wall time in each syscall, all threads; waits included):\n")
            L.append("| syscall | wall s | calls | calls per file |")
            L.append("|---|---|---|---|")
            for s_ in tq["strace_wall_top"]:
                L.append(f"| {s_['syscall']} | {s_['seconds']:.3f} | {s_['calls']} | {s_['per_file']:.1f} |")
    L.append("\nLoad: " + " / ".join(u.split("load average:")[-1].strip() for u in uptimes) + f" ({uptimes[0]})")
    print("\n".join(L), flush=True)
    rec = dict(files=n, size=size, big=[W, H], pixels=pixels, threads=total_threads, repeat=a.repeat, rows=rows,
               share_ms=share_ms, best_batch=best_batch["name"], overhead_ms_per_file=best_batch["overhead_ms_per_file"],
               overhead_vs_share=rel, target=a.target, met=rel <= a.target, profile=prof, load=uptimes)
    if a.json:
        print(json.dumps(rec), flush=True)
    if a.check and rel > a.target:
        sys.exit(1)


if __name__ == "__main__":
    main()
