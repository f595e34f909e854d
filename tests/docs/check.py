#!/usr/bin/env python3
"""The documentation a newcomer reads first stays a front door, and its links lead somewhere.

    tests/docs/check.py REPO_ROOT

- README.md is at most 150 lines (the depth lives in docs/) and gives the two set-up commands.
- Every relative link in README.md and docs/*.md ([text](path) and ![alt](path)) names a file or
  folder that exists, relative to the page that links it.
- No page cites an issue number or the design notes outside the repository: a reader can follow
  neither.
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
