#!/usr/bin/env python3
"""The documentation a newcomer reads first stays a front door, its links lead somewhere, and what
it says bake does by default is what bake does.

    tests/docs/check.py REPO_ROOT

- README.md is at most 150 lines (the depth lives in docs/) and gives the two set-up commands.
- Every relative link of the pages (README.md, docs/*.md and the other READMEs: [text](path) and
  ![alt](path)) names a file or folder that exists, relative to the page that links it; a section
  named in quotes after a page (`docs/methods.md, "The default"`, `[baking.md](baking.md), "Studio
  configs"`) is a heading or a bold paragraph lead of that page.
- No page cites an issue number or the design notes outside the repository: a reader can follow
  neither.
- The default. `spectex bake` without --method bakes the LHTSS lattice with a precision budget;
  the spectral primary decomposition (Mallett & Yuksel 2019) is `--method basis`, the default
  before. The rule reads every sentence of the pages, of the man page and of the help and
  messages (the string literals of src/, adjacent ones joined):
  - one that names the decomposition (Mallett, "primary decomposition") names the basis too (or
    its table, or the paper), and if it says how the default or each pixel is expanded, it names
    the method or command it is about (`--method basis`, `spectex basis`, `--basis`,
    `mallett2019`) or puts it in the past ("before", "former", "was", ...);
  - one that calls the basis the default ("`basis` (default)", "the default method ... basis",
    "the basis is the default", "by default ... basis", "the default basis") puts it in the past.
  Before the pages are read, the rule is run on sentences it must refuse (the text it was written
  against) and on sentences it must let through, so that a change that blunts it fails here too.
- A page whose commands (code blocks) run build/venv/bin/python also gives tests/bench/setup.sh,
  the set-up of that venv alone (minutes, where the test command takes half an hour); the script exists,
  is executable and makes the venv with the function .ci/bootstrap uses.
- A ratio README.md gives for size or time (a number followed by × within 60 characters of
  "bytes", "file", "size", "time", "faster" or "slower", or in a table whose header or row has one
  of those words) stands in a sentence or table row that
  names the kind of texture it was measured on (photograph-like, noise, flat colours, chart): a
  file's size, and so its time, depends on what the texture holds. Those sentences and rows,
  together, name all three kinds: photograph-like, noise and flat colours (one texture's ratio
  is not the method's).
- The man page renders without a warning from groff (`groff -man -Tutf8 -ww -z`): a character
  roff does not know (a raw "Δ") or a broken macro is shown wrong or dropped by `man`.
Exit 1 with one line per problem.
"""
import os
import re
import shutil
import subprocess
import sys
from bisect import bisect_right
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
pages += [p for p in (root / "python" / "README.md", root / "tests" / "bench" / "README.md",
                      root / "config" / "spectral" / "README.md") if p.exists()]
pages += sorted((root / "examples").glob("*/README.md"))


def headings(page):
    """The headings and bold paragraph leads of a Markdown page, lower case, without markup."""
    out = []
    for line in page.read_text(encoding="utf-8").splitlines():
        m = re.match(r"#+\s+(.*)", line) or re.match(r"\*\*([^*]+)\*\*", line)
        if m:
            out.append(re.sub(r"[`*]", "", m.group(1)).strip().rstrip(".").lower())
    return out


link = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
# A page then a section in quotes: `docs/methods.md, "The default"`, `[x](x.md), "Studio configs"`.
section_ref = re.compile(r"(?:\]\(([^)\s#]+\.md)\)|\b([\w./-]+\.md)\b),?\s+\"([^\"]{2,80})\"")
for page in pages:
    body = page.read_text(encoding="utf-8")
    rel = page.relative_to(root)
    for target in link.findall(body):
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue  # a URL or an anchor on the same page
        path = target.split("#", 1)[0]
        if not (page.parent / path).exists():
            problems.append(f"{rel}: link to '{target}', which does not exist")
    for m in section_ref.finditer(body):
        target = m.group(1) or m.group(2)
        # a path as the text names it: relative to the page, or to the repository's root
        found = [p for p in (page.parent / target, root / target) if p.is_file()]
        want = m.group(3).strip().rstrip(".").lower()
        if found and not any(h.startswith(want) for h in headings(found[0])):
            problems.append(f"{rel}: names the section \"{m.group(3)}\" of {target}, which has no "
                            "such heading")
    for m in re.finditer(r"\.\./shared|\bissue \d+|\bitem \d+ of", body, re.IGNORECASE):
        problems.append(f"{rel}: cites '{m.group(0)}', which a reader cannot follow")


# --- What the pages say the default is --------------------------------------------------------

# The spectral primary decomposition, by any of its names.
DECOMPOSITION = re.compile(r"mallett(?!2019)|primary\s+decomposition|spectral\s+primar", re.I)
# Says which method or command the sentence is about ...
NAMES_METHOD = re.compile(r"--method\s+basis|method\s+basis|`basis`|\bspectex\s+basis|\bbasis\s+command"
                          r"|--basis|mallett2019", re.I)
# ... or that it is the past.
PAST = re.compile(r"\bbefore\b|\bformer|\bearlier\b|\bprevious|\bold\b|\bused\s+to\b|\buntil\b"
                  r"|\bwas\b|\bwere\b|\bthen\b", re.I)
# Speaks of what bake does without options: the default, or how every pixel is expanded.
ABOUT_DEFAULT = re.compile(r"\bdefault|\bwithout\s+--method|\b(?:each|every)\s+(?:pixel|colour|color)"
                           r"|\bexpand", re.I)
# The basis called the default method (naming it `basis` does not make that true).
BASIS_IS_DEFAULT = re.compile(
    r"\bdefault\s+(?:method|expansion|bake|upsampling)\b[^.]{0,60}\bbasis\b"
    r"|\bbasis\b[^.]{0,30}\b(?:is|as|remains|stays)\s+(?:the|bake's|spectex's)\s+default\b"
    r"|\bby\s+default\b[^.]{0,80}\b(?:basis|three\s+(?:basis\s+)?spectra|S_r)\b"
    r"|\b(?:bake|spectex)'s\s+default\b[^.]{0,40}\bbasis\b"
    r"|\bdefault\s*(?:[:=(]|is)\s*(?:the\s+)?(?:spectral\s+|fitted\s+|three-spectrum\s+)?basis\b"
    r"|\bdefault\s+(?:is|stays|remains)(?:\s+still)?\s+(?:the\s+)?`?basis\b"
    r"|\bbasis\b`?(?:,\s*[\w ]{1,20})?\s*\((?:the\s+)?default\)"
    r"|\bthe\s+default\s+basis\b", re.I)


def stale_default(sentence):
    """Why a sentence describes the basis as what bake does by default, or None."""
    if PAST.search(sentence):
        return None
    if DECOMPOSITION.search(sentence) and not NAMES_METHOD.search(sentence):
        if ABOUT_DEFAULT.search(sentence):
            return "says how the default or each pixel is expanded with the spectral primary decomposition"
        if not re.search(r"\bbasis\b|\btable\b|\bEGSR\b|\bEurographics\b", sentence, re.I):
            return "names the spectral primary decomposition without saying it is the basis"
    if BASIS_IS_DEFAULT.search(sentence):
        return "calls the basis the default"
    return None


def sentences(paragraphs):
    """(line, sentence) for paragraphs given as lists of (line number, text)."""
    out = []
    for para in paragraphs:
        starts, joined = [], ""
        for number, line in para:
            starts.append(len(joined))
            joined += line.strip() + " "
        lines_of = [number for number, _ in para]
        pos = 0
        for m in re.finditer(r"(?<=[.!?])[)\"'*_`]*\s+(?=[A-Z`*(\[\"'-])|$", joined):
            s = joined[pos:m.start()].strip()
            if s:
                out.append((lines_of[bisect_right(starts, pos) - 1], s))
            pos = m.end()
    return out


def markdown_paragraphs(body):
    paras, cur, fence = [], [], False

    def flush():
        if cur:
            paras.append(list(cur))
            cur.clear()
    for number, line in enumerate(body.splitlines(), 1):
        s = line.strip()
        if s.startswith("```"):
            flush()
            fence = not fence
            continue
        if fence or s.startswith("|") or s.startswith("#"):
            flush()  # a code line, a table row or a heading is a paragraph of its own
            if s:
                paras.append([(number, s)])
            continue
        if not s or re.match(r"([-*+]|\d+\.)\s", s):
            flush()
        if s:
            cur.append((number, s))
    flush()
    return paras


def roff_text(line):
    """A man(7) line as the reader sees it (font macros, escapes); None for a break."""
    if line.startswith(".\\\"") or line.startswith("'\\\""):
        return ""
    if line.startswith("."):
        m = re.match(r"\.(\w+)\s*(.*)", line)
        if not m:
            return ""
        macro, args = m.groups()
        if macro in ("B", "I", "SM", "SB"):
            line = args.replace('"', "")
        elif macro in ("BR", "RB", "BI", "IB", "IR", "RI"):
            line = "".join(a.strip('"') for a in re.findall(r'"[^"]*"|\S+', args))
        elif macro in ("SH", "SS"):
            return None
        else:
            return None  # .PP, .TP, .RS, .SY, ...: a new paragraph
    line = re.sub(r"\\f(?:\[[^\]]*\]|\(..|.)", "", line)
    line = re.sub(r"\\\((?:mu)", "x", line)
    line = re.sub(r"\\\((?:lq|rq)", '"', line)
    line = re.sub(r"\\\(..", "-", line)
    line = line.replace("\\-", "-").replace("\\%", "").replace("\\&", "").replace("\\|", "")
    return line.replace("\\ ", " ").replace("\\e", "\\")


def roff_paragraphs(body):
    paras, cur = [], []
    for number, line in enumerate(body.splitlines(), 1):
        t = roff_text(line)
        if t is None:
            if cur:
                paras.append(cur)
            cur = []
        elif t.strip():
            cur.append((number, t))
    if cur:
        paras.append(cur)
    return paras


def cpp_paragraphs(body):
    """The string literals of a C++ file, adjacent ones joined as the compiler joins them."""
    paras, cur, i, line = [], [], 0, 1
    token = re.compile(r'//[^\n]*|/\*.*?\*/|R"([^(\s]*)\((.*?)\)\1"|"((?:[^"\\\n]|\\.)*)"'
                       r"|'(?:[^'\\\n]|\\.)*'|\s+|[^\s\"'/]+|/", re.S)
    while i < len(body):
        m = token.match(body, i)
        t = m.group(0)
        if m.group(2) is not None or m.group(3) is not None:
            s = m.group(2) if m.group(2) is not None else m.group(3)
            s = re.sub(r"\\n", " ", s).replace('\\"', '"').replace("\\\\", "\\")
            cur.append((line, s))
        elif not (t.isspace() or t.startswith("//") or t.startswith("/*")):
            if cur:
                paras.append([(cur[0][0], "".join(s for _, s in cur))])
            cur = []
        line += t.count("\n")
        i = m.end()
    if cur:
        paras.append([(cur[0][0], "".join(s for _, s in cur))])
    return paras


def stale_defaults(rel, paragraphs):
    return [f"{rel}:{n}: {why}: \"{s if len(s) < 160 else s[:157] + '...'}\""
            for n, s in sentences(paragraphs) if (why := stale_default(s))]


# The rule first, on what it was written against: the help and the man page when the default had
# become the lattice but they still named the decomposition, and a page calling the basis the
# default. And on what it must let through: the basis named as an option, a command, the past.
MUST_REFUSE = [
    "Spectral reflectance OpenEXR textures from sRGB (and other) textures, with the spectral "
    "primary decomposition of Mallett & Yuksel (2019).",
    "Turns textures into spectral reflectance OpenEXRs (Fichet 2021 layout, channels "
    "T.<wavelength>nm): read with OpenImageIO, linearise with OpenColorIO, expand each pixel with "
    "the spectral primary decomposition (Mallett & Yuksel 2019).",
    "By default each pixel is expanded with the basis of Mallett and Yuksel.",
    "The default is the spectral primary decomposition basis.",
    "spectex bake uses the basis by default: three spectra fitted on the grid.",
    "The default method, the basis, is exact under D65.",
    "The basis is the default and the fastest.",
    "| `basis` (default) | yes | 1.41 | 6.42 | daylight scenes; smallest files, fastest bake |",
    "| basis, fitted smooth (default) | 1.89 / 6.42 |",
    "The default stays `basis`.",
    "Why the default is still `basis`, measured two ways:",
    "on these measured reflectances it lands about where the lattice does, and closer than the "
    "default basis under A and FL11.",
]
MUST_PASS = [
    "--method basis uses the spectral primary decomposition of Mallett and Yuksel (2019) instead:",
    "Fits a spectral primary decomposition basis (Mallett & Yuksel 2019): three reflectance spectra.",
    "| basis, fitted smooth (the default before) | 1.89 / 6.42 |",
    "The basis is the spectral primary decomposition of Mallett & Yuksel (EGSR 2019).",
    "`--method basis` bakes the default before, byte for byte.",
    "the default smooth basis has the smallest files",
    "The basis (`--basis`) is by default fitted on the output grid.",
    "Which colours decide for the basis: auto (default) every grid on the sample.",
    "Objective of the fitted basis (default smooth; see spectex basis).",
    "--observer NAME|FILE Observer of the fitted basis: cie1931-2 (default), cie1964-10, or a CSV.",
    "The plugin's speed was measured when bake's default was the basis, a 178 MB file.",
    "By default the spectrum is interpolated between exact, bounded spectra at the vertices of a "
    "9x9x9 lattice.",
]
for s in MUST_REFUSE:
    if not stale_default(s):
        problems.append(f"tests/docs/check.py: the default rule lets through \"{s}\"")
for s in MUST_PASS:
    if stale_default(s):
        problems.append(f"tests/docs/check.py: the default rule refuses \"{s}\"")
# ... and on whole paragraphs as each reader splits them (a sentence over lines, in literals).
for rel, paras, want in (
        ("a page", markdown_paragraphs("Intro.\n\nEvery pixel is expanded\nwith the spectral "
                                       "primary\ndecomposition. Done.\n"), 3),
        ("a man page", roff_paragraphs(".PP\nexpand each pixel\n.BR with \" the\"\nspectral primary "
                                       "decomposition.\n"), 2),
        ("a help string", cpp_paragraphs('p("x",\n    "expand each pixel with the spectral "\n'
                                         '    "primary decomposition.");\n'), 2)):
    found = stale_defaults(rel, paras)
    if len(found) != 1 or not found[0].startswith(f"{rel}:{want}:"):
        problems.append(f"tests/docs/check.py: the default rule on {rel} found {found}, "
                        f"not one sentence at line {want}")

for page in pages:
    problems += stale_defaults(page.relative_to(root), markdown_paragraphs(page.read_text(encoding="utf-8")))
man = root / "man" / "spectex.1"
problems += stale_defaults(man.relative_to(root), roff_paragraphs(man.read_text(encoding="utf-8")))
for src in sorted(root.glob("src/**/*.cpp")) + sorted(root.glob("src/**/*.h")):
    problems += stale_defaults(src.relative_to(root), cpp_paragraphs(src.read_text(encoding="utf-8")))


# --- The benchmarks' own set-up ---------------------------------------------------------------

setup = root / "tests" / "bench" / "setup.sh"
if not (setup.is_file() and os.access(setup, os.X_OK)):
    problems.append("tests/bench/setup.sh: missing or not executable (the benchmarks' venv set-up)")
elif "spectex_venv" not in setup.read_text() or "spectex_venv" not in (root / ".ci" / "bootstrap").read_text():
    problems.append("tests/bench/setup.sh: does not make the venv with spectex_venv (.ci/lib.sh), as "
                    ".ci/bootstrap does: two recipes for one venv drift apart")
for page in pages:
    body, fence = page.read_text(encoding="utf-8"), False
    for line in body.splitlines():
        if line.strip().startswith("```"):
            fence = not fence
        elif fence and re.match(r"\s*(?:\w+=\S+\s+)*build/venv/bin/python\b", line):
            if "tests/bench/setup.sh" not in body:
                problems.append(f"{page.relative_to(root)}: a command runs build/venv/bin/python, but the "
                                "page does not give tests/bench/setup.sh, which makes that venv alone")
            break

# --- The man page as groff reads it --------------------------------------------------------------

if shutil.which("groff") is None:
    problems.append("man/spectex.1: groff is not installed (groff-base), so the man page cannot be checked")
else:
    r = subprocess.run(["groff", "-man", "-Tutf8", "-ww", "-z", str(man)], capture_output=True, text=True)
    for line in (r.stderr.strip().splitlines() or ([f"groff exited {r.returncode}"] if r.returncode else [])):
        problems.append(f"man/spectex.1: groff: {line}")

for p in problems:
    print(p)
sys.exit(1 if problems else 0)
