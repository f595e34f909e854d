#!/usr/bin/env python3
"""`spectex bake` against its floor, on any texture: wall time, CPU use, peak memory, stages.

    build/venv/bin/python tests/bench/bake_vs_floor.py --spectex build/src/spectex \\
        --floor build/tests/bench/bench_exr_floor [--input TEXTURE.png] [--size 4096] [--check]

The floor is bench_exr_floor: spectex's own EXR writer fed the input's pixels expanded before the
clock starts (`--whole`), with the same grid, sample type, compression, ZIP level, chunking and
threads. Floor and bake run alternately, --repeat times each; the best wall time of each is kept
(the machines are shared: compare within one run, never across runs).

Targets, checked from child processes (os.wait4 rusage):
  * 81 bins, half, zip: bake wall <= 1.15 x floor wall; CPU time / wall close to the thread count;
    peak RSS < 2 x decoded float RGB + 64 MiB (466 MiB at 4096²);
  * 401 bins (380:780:1): peak RSS < 512 MiB.
With --methods basis,lattice every method is baked and given its own floor (the floor
writes that method's spectra, expanded by the same SpectralMethod and half rounding), alternately
in one run, and two more targets are checked: each method's bake within 1.15x its own floor (the
kernel hides under the encoder), and the lattice bake within 1.10x the basis bake (which measures
the encoder's cost of the lattice's spectra against the basis's, too: they compress differently).
Without --input, a photograph-like PNG of --size² is made (numpy + OpenImageIO from the venv).
--check exits 1 if a target is missed. Writes OUT/bake_vs_floor.md and .json.
"""
import argparse
import json
import os
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


def run_child(cmd):
    """Runs cmd with its own rusage: (wall s, CPU s, peak RSS bytes, stdout text)."""
    with tempfile.TemporaryFile() as so, tempfile.TemporaryFile() as se:
        t0 = time.monotonic()
        p = subprocess.Popen([str(c) for c in cmd], stdout=so, stderr=se)
        _, status, ru = os.wait4(p.pid, 0)
        wall = time.monotonic() - t0
        p.returncode = os.waitstatus_to_exitcode(status)
        so.seek(0)
        se.seek(0)
        if p.returncode != 0:
            raise RuntimeError(f"{' '.join(map(str, cmd))} failed ({p.returncode}):\n{se.read().decode()[-2000:]}")
        return wall, ru.ru_utime + ru.ru_stime, ru.ru_maxrss * 1024, so.read().decode()


def image_size(path):
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    if not inp:
        raise RuntimeError(f"{path}: {oiio.geterror()}")
    spec = inp.spec()
    inp.close()
    return spec.width, spec.height


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spectex", default=str(ROOT / "build/src/spectex"))
    ap.add_argument("--floor", default=str(ROOT / "build/tests/bench/bench_exr_floor"))
    ap.add_argument("--input", help="texture to bake (default: a photograph-like PNG of --size²)")
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--zip-level", type=int, default=4)
    ap.add_argument("--no-401", action="store_true", help="skip the 401-bin memory run")
    ap.add_argument("--methods", default="basis", help="comma-separated --method values to bake (first: basis)")
    ap.add_argument("--no-nearest", action="store_true", help="skip the --half-rounding nearest runs")
    ap.add_argument("--out", default="bench-report")
    ap.add_argument("--check", action="store_true", help="exit 1 if a target is missed")
    a = ap.parse_args()

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="spectex-bvf-", dir=out))
    try:
        src = Path(a.input) if a.input else work / f"photo{a.size}.png"
        if not a.input:
            log(f"making {src} ({a.size}²)")
            # In a child process: a forked child starts with this process's resident pages, so a
            # parent that held the generated image would inflate every measured peak RSS after it.
            subprocess.run([sys.executable, "-c", "import sys; sys.path.insert(0, sys.argv[1]); "
                            "from speed_vs_error import photographic_png; photographic_png(sys.argv[2], int(sys.argv[3]))",
                            str(HERE), str(src), str(a.size)], check=True)
        w, h = image_size(src)
        budget81 = 2 * w * h * 3 * 4 + 64 * MIB
        T = a.threads
        common = ["--threads", T, "--zip-level", a.zip_level]
        bake_exr, floor_exr, jl = work / "bake.exr", work / "floor.exr", work / "bake.jsonl"

        def bake(extra=()):
            if jl.exists():
                jl.unlink()
            wall, cpu, rss, _ = run_child([a.spectex, "bake", src, "-o", bake_exr, "--force", "-q", "--json", jl,
                                           *common, *extra])
            rec = json.loads(jl.read_text().splitlines()[-1])
            return dict(wall=wall, cpu=cpu, rss=rss, bytes=rec["bytes"], stages=rec.get("stages", {}))

        def floor(grid, method=None):
            extra = ["--method", method] if method else []
            wall, cpu, rss, text = run_child([a.floor, "--source", src, "--whole", "--wavelengths", grid,
                                              "--out", floor_exr, *common, *extra])
            rec = json.loads(text.strip().splitlines()[-1])
            return dict(wall=rec["wall_s"], cpu=rec["cpu_s"], rss=rss, bytes=rec["bytes"], writer=rec.get("writer"))

        methods = [m for m in a.methods.split(",") if m]
        if methods[0] != "basis":
            methods.insert(0, "basis")
        multi = len(methods) > 1
        rows, names, floor_of = {}, {}, {}
        log(f"{src}: {w}x{h}, threads {T}, zip level {a.zip_level}, {a.repeat} alternating runs, methods {methods}")
        runs = {}
        for m in methods:
            fk, bk_ = ("floor", "bake") if m == "basis" else (f"floor_{m}", f"bake_{m}")
            runs[fk], runs[bk_] = [], []
            names[fk] = f"floor (writer only, 81 bins{', ' + m + ' spectra' if multi else ''})"
            names[bk_] = f"bake, 81 bins{' --method ' + m if multi else ''} (default colour rounding)"
            floor_of[bk_] = fk
        if not a.no_nearest:
            runs["bake_nearest"] = []
            names["bake_nearest"] = "bake, 81 bins, --half-rounding nearest"
            floor_of["bake_nearest"] = "floor"
        for i in range(a.repeat):
            for m in methods:
                fk, bk_ = ("floor", "bake") if m == "basis" else (f"floor_{m}", f"bake_{m}")
                runs[fk].append(floor("380:780:5", m if multi else None))
                runs[bk_].append(bake(["--method", m]))  # named: the floor writes that method's spectra
                log(f"  run {i + 1}, {m}: floor {runs[fk][-1]['wall']:.2f} s, bake {runs[bk_][-1]['wall']:.2f} s")
            if not a.no_nearest:
                runs["bake_nearest"].append(bake(["--method", "basis", "--half-rounding", "nearest"]))
                log(f"  run {i + 1}: bake nearest {runs['bake_nearest'][-1]['wall']:.2f} s")
        for k, v in runs.items():
            best = min(v, key=lambda r: r["wall"])
            best["rss_max"] = max(r["rss"] for r in v)
            rows[k] = best
        if not a.no_401:
            log("  401 bins (380:780:1), one run for memory")
            rows["bake_401"] = bake(["--method", "basis", "--wavelengths", "380:780:1"])
            rows["bake_401"]["rss_max"] = rows["bake_401"]["rss"]
            names["bake_401"] = "bake, 401 bins (380:780:1)"
            floor_of["bake_401"] = None  # no 401-bin floor is run: memory only

        fl, bk = rows["floor"], rows["bake"]
        ratio = bk["wall"] / fl["wall"]
        checks = [
            ("81 bins: bake wall / floor wall <= 1.15", ratio <= 1.15, f"{ratio:.3f}"),
            ("81 bins: cores busy (CPU s / wall s) >= 0.9 x threads", bk["cpu"] / bk["wall"] >= 0.9 * T,
             f"{bk['cpu'] / bk['wall']:.2f} of {T}"),
            (f"81 bins: peak RSS < 2 x float RGB + 64 MiB ({budget81 / MIB:.0f} MiB)", bk["rss_max"] < budget81,
             f"{bk['rss_max'] / MIB:.0f} MiB"),
        ]
        for m in methods[1:]:
            r, f = rows[f"bake_{m}"], rows[f"floor_{m}"]
            checks.append((f"--method {m}: bake wall / its own floor wall <= 1.15", r["wall"] / f["wall"] <= 1.15,
                           f"{r['wall'] / f['wall']:.3f}"))
            checks.append((f"--method {m}: bake wall / basis bake wall <= 1.10", r["wall"] / bk["wall"] <= 1.10,
                           f"{r['wall'] / bk['wall']:.3f} (bytes {r['bytes'] / bk['bytes']:.2f}x)"))
            checks.append((f"--method {m}: peak RSS < {budget81 / MIB:.0f} MiB", r["rss_max"] < budget81,
                           f"{r['rss_max'] / MIB:.0f} MiB"))
        if "bake_401" in rows:
            r4 = rows["bake_401"]
            checks.append(("401 bins: peak RSS < 512 MiB", r4["rss_max"] < 512 * MIB, f"{r4['rss_max'] / MIB:.0f} MiB"))

        L = [f"# spectex bake against its floor\n",
             f"Input `{src.name}` {w}×{h}; {T} threads; ZIP level {a.zip_level}; best of {a.repeat} alternating "
             f"runs (peak RSS: the largest). Floor: `bench_exr_floor --whole` ({fl['writer']} writer); "
             f"× floor: against the floor of the same spectra.\n",
             "| run | wall s | × floor | CPU s | cores busy | peak RSS MiB | bytes |",
             "|---|---|---|---|---|---|---|"]
        for k, r in rows.items():
            ref = rows.get(floor_of.get(k, k)) if floor_of.get(k, k) else None
            ratio_text = f"{r['wall'] / ref['wall']:.3f}" if ref else "—"
            L.append(f"| {names[k]} | {r['wall']:.2f} | {ratio_text} | {r['cpu']:.2f} | "
                     f"{r['cpu'] / r['wall']:.2f} | {r['rss_max'] / MIB:.0f} | {r['bytes']} |")
        L.append("\nStages of the bake (seconds; producer thread: read, colour, expand; writer thread: pack, waits; "
                 "compress: CPU seconds over the workers):\n")
        L.append("| run | read | colour | expand | pack | waiting for encoder | waiting for producer | compress CPU |")
        L.append("|---|---|---|---|---|---|---|---|")
        for k, r in rows.items():
            st = r.get("stages")
            if st:
                L.append(f"| {names[k]} | {st['read_s']:.2f} | {st['colour_s']:.2f} | {st['expand_s']:.2f} | "
                         f"{st['pack_s']:.2f} | {st['encoder_wait_s']:.2f} | {st['producer_wait_s']:.2f} | "
                         f"{st['compress_cpu_s']:.2f} |")
        L.append("\n| target | met | measured |")
        L.append("|---|---|---|")
        for name, ok, val in checks:
            L.append(f"| {name} | {'yes' if ok else '**no**'} | {val} |")
        text = "\n".join(L) + "\n"
        (out / "bake_vs_floor.md").write_text(text)
        (out / "bake_vs_floor.json").write_text(json.dumps(dict(input=str(src), width=w, height=h, threads=T,
                                                                 rows=rows, checks=checks), indent=1))
        print(text)
        return 1 if a.check and not all(ok for _, ok, _ in checks) else 0
    finally:
        for p in sorted(work.glob("*"), reverse=True):
            p.unlink()
        work.rmdir()


if __name__ == "__main__":
    sys.exit(main())
