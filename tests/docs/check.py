#!/usr/bin/env python3
"""The documentation a newcomer reads first stays a front door, and its links lead somewhere.

    tests/docs/check.py REPO_ROOT

- README.md is at most 150 lines (the depth lives in docs/) and gives the two set-up commands.
- Every relative link in README.md and docs/*.md ([text](path) and ![alt](path)) names a file or
  folder that exists, relative to the page that links it.
- No page cites an issue number or the design notes outside the repository: a reader can follow
  neither.
- A ratio README.md gives for size or time (a number followed by × within 60 characters of
  "bytes", "file", "size", "time", "faster" or "slower", or in a table whose header or row has one
  of those words) stands in a sentence or table row that
  names the kind of texture it was measured on (photograph-like, noise, flat colours, chart): a
  file's size, and so its time, depends on what the texture holds. Those sentences and rows,
  together, name all three kinds: photograph-like, noise and flat colours (one texture's ratio
  is not the method's).
Exit 1 with one line per problem.
"""
import re
import sys
from pathlib import Path

root = Path(sys.argv[1] if len(sys.argv) > 1 else ".").resolve()
problems = []
readme = root / "README.md"
text = readme.read_text(encoding="utf-8")
lines = text.count("\n")
if lines > 150:
    problems.append(f"README.md: {lines} lines; the front door stays under 150 (move depth into docs/)")
for cmd in (".ci/bootstrap example", ".ci/bootstrap test"):
    if cmd not in text:
        problems.append(f"README.md: the set-up command '{cmd}' is missing")


def units(body):
    """Table rows (each with its header) and sentences of a page's prose (code blocks left out)."""
    body = re.sub(r"```.*?```", "", body, flags=re.DOTALL)
    for para in re.split(r"\n\s*\n", body):
        if para.lstrip().startswith("|"):
            head, *rows = para.strip().splitlines()
            yield from ((head + " " + row, True) for row in rows)  # a row, read with its column names
        else:
            yield from ((u, False) for u in re.split(r"(?<=[.!?])\s+(?=[A-Z*`(])", " ".join(para.split())))


ratio = re.compile(r"\d+(?:\.\d+)?\s*×")
about = re.compile(r"bytes|\bfiles?\b|\bsize\b|\btimes?\b|faster|slower", re.IGNORECASE)
texture = re.compile(r"photograph-like|\bnoise|\bnoisy|flat colou?rs|\bchart\b", re.IGNORECASE)
kinds = {"photograph-like": r"photograph-like", "noise": r"\bnois", "flat colours": r"flat colou?rs"}
named = set()
for unit, row in units(text):
    for m in ratio.finditer(unit):
        near = unit if row else unit[max(0, m.start() - 60):m.end() + 60]
        if not about.search(near):
            continue
        if not texture.search(unit):
            problems.append(f"README.md: '{m.group(0)}' gives a size or time ratio without naming the "
                            f"texture it was measured on: {unit.strip()[:120]}")
        named |= {k for k, rx in kinds.items() if re.search(rx, unit, re.IGNORECASE)}
for k in kinds:
    if k not in named:
        problems.append(f"README.md: no size or time ratio is given for a {k} texture (give the "
                        f"photograph-like, noise and flat colours figures)")

pages = [readme] + sorted((root / "docs").glob("*.md"))
link = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
for page in pages:
    body = page.read_text(encoding="utf-8")
    rel = page.relative_to(root)
    for target in link.findall(body):
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue  # a URL or an anchor on the same page
        path = target.split("#", 1)[0]
        if not (page.parent / path).exists():
            problems.append(f"{rel}: link to '{target}', which does not exist")
    for m in re.finditer(r"\.\./shared|\bissue \d+|\bitem \d+ of", body, re.IGNORECASE):
        problems.append(f"{rel}: cites '{m.group(0)}', which a reader cannot follow")

for p in problems:
    print(p)
sys.exit(1 if problems else 0)
