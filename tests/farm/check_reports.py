#!/usr/bin/env python3
"""Checks the JSON Lines reports of one run of examples/farm/slurm_bake.sbatch (tests/farm/run_slurm.sh).

    check_reports.py OUTDIR BASEDIR JOBID NTASKS LIST EXPECT [FAILING_INPUT]

Task K of the array wrote OUTDIR/spectex-JOBID-K.jsonl. Every input of LIST must appear exactly once
over the NTASKS reports, in the report of its shard (index i in the byte-sorted list goes to task
(i mod NTASKS) + 1), with status EXPECT (ok or skipped), except FAILING_INPUT, which must have
failed with an error. A baked file's output must be OUTDIR/<its folder below BASEDIR>/<stem>.exr:
the asset tree mirrored.
"""
import json
import os
import sys

outdir, basedir, jobid, ntasks, listfile, expect = sys.argv[1:7]
failing = sys.argv[7] if len(sys.argv) > 7 else None
ntasks = int(ntasks)
with open(listfile, "rb") as f:
    inputs = sorted(line.rstrip(b"\n") for line in f if line.strip())
shard_of = {os.fsdecode(p): i % ntasks + 1 for i, p in enumerate(inputs)}
problems = []
seen = {}
for task in range(1, ntasks + 1):
    report = os.path.join(outdir, f"spectex-{jobid}-{task}.jsonl")
    if not os.path.isfile(report):
        problems.append(f"task {task}: no report {report}")
        continue
    with open(report, encoding="utf-8") as f:
        lines = f.read().splitlines()
    for n, line in enumerate(lines, 1):
        where = f"{os.path.basename(report)}:{n}"
        try:
            rec = json.loads(line)
        except ValueError as e:
            problems.append(f"{where}: not JSON ({e})")
            continue
        src = rec.get("input")
        if rec.get("schema_version") != 2:  # the bake report's schema (docs/pipelines.md, "Reports")
            problems.append(f"{where}: schema_version {rec.get('schema_version')!r}")
        if src not in shard_of:
            problems.append(f"{where}: {src!r} is not in the list")
            continue
        seen.setdefault(src, []).append(task)
        if shard_of[src] != task:
            problems.append(f"{where}: {src} belongs to shard {shard_of[src]}, baked by task {task}")
        want = "failed" if src == failing else expect
        if rec.get("status") != want:
            problems.append(f"{where}: {src}: status {rec.get('status')!r}, expected {want!r} "
                            f"(error {rec.get('error')!r})")
        if want == "failed" and not rec.get("error"):
            problems.append(f"{where}: {src} failed without an error message")
        if want == "ok":
            rel = os.path.splitext(os.path.relpath(src, basedir))[0]
            if rec.get("output") != os.path.join(outdir, rel + ".exr"):
                problems.append(f"{where}: {src} written to {rec.get('output')!r}")
            if rec.get("error") is not None:
                problems.append(f"{where}: {src}: error {rec.get('error')!r} with status ok")
        if want == "skipped" and not rec.get("reason"):
            problems.append(f"{where}: {src} skipped without a reason")
for src in shard_of:
    if len(seen.get(src, [])) != 1:
        problems.append(f"{src}: reported by tasks {seen.get(src, [])}, expected exactly once")
for p in problems:
    print(f"  {p}")
print(f"  {len(seen)} inputs in {ntasks} reports, {len(problems)} problems")
sys.exit(1 if problems else 0)
