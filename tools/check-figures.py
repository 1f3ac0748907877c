#!/usr/bin/env python3
"""Re-runs the seeded commands that README.md and docs/ name for their figures, and reports each figure
that no longer matches what the command prints (or writes).

A figure is marked in the Markdown by an HTML comment right before it (invisible on the rendered page):

    <!-- figure: NAME [fast] [needs=PATH]
    cmd: orbcal configs --select O3 -n 50 --pool 1000 --seed 1 -o {out}/configs.csv
    expect: 2.897 | 2.150 | 9.59
    -->

`cmd` is a shell-free command line (split like a shell would, no pipes), run from the repository's
root; a leading `orbcal` or `orbcal-bench` is the built program, `{out}` a fresh temporary folder
shared by the figure's commands. Several `cmd` lines run in order (a calibration, then an evaluation of
its model); each must exit 0, or non-zero where it starts with `!` (a refused calibration). Each
`expect` value (separated by `|`) must appear in the figure itself, i.e. the text after the comment up
to the first blank line outside a fenced block (a paragraph, a table or a code block), and in what the
command printed or wrote into `{out}` (its text files), as a whole number: 0.408 does not match 10.408 or
0.4081. `fast` marks the figures CTest checks (a few seconds each); `needs` a path (relative to the
root) without which the figure is skipped with a message, such as the real iiwa7 data.

  tools/check-figures.py --orbcal BIN [--bench BIN] [--all] [--list] [--only NAME]... [--root DIR]

Without --all only the `fast` figures run. Exit 1 when a figure does not match, a command fails, or a
mark is malformed; each problem is one line, FILE:LINE: NAME: what.
"""
import argparse
import glob
import os
import re
import shlex
import subprocess
import sys
import tempfile
import time

MARK = re.compile(r"<!--\s*figure:\s*(?P<head>[^\n]*)\n(?P<body>.*?)-->", re.S)


class Figure:
    def __init__(self, path, line, name, fast, needs, cmd, expects, block):
        self.path, self.line, self.name, self.fast, self.needs = path, line, name, fast, needs
        self.cmd, self.expects, self.block = cmd, expects, block

    def where(self):
        return "%s:%d: %s" % (self.path, self.line, self.name)


def figure_block(text, start):
    """The text after a mark up to the first blank line outside a fenced block, without the marks of
    other figures that share it (a table several commands produce)."""
    lines, fence = [], False
    for line in re.sub(r"<!--\s*figure:.*?-->\n?", "", text[start:], flags=re.S).lstrip("\n").split("\n"):
        if line.startswith("```"):
            fence = not fence
        if not fence and not line.strip() and lines:
            break
        lines.append(line)
    return "\n".join(lines)


def parse(root, rel, problems):
    text = open(os.path.join(root, rel), encoding="utf-8").read()
    figures = []
    for m in MARK.finditer(text):
        if len(re.findall(r"^```", text[:m.start()], re.M)) % 2:
            continue  # an example inside a fenced block, not a mark
        line = text.count("\n", 0, m.start()) + 1
        words = m.group("head").split()
        name = words[0] if words else "?"
        fast = "fast" in words[1:]
        needs = [w[len("needs="):] for w in words[1:] if w.startswith("needs=")]
        fields = {}
        for body_line in m.group("body").strip().split("\n"):
            key, _, value = body_line.partition(":")
            fields.setdefault(key.strip(), []).append(value.strip())
        cmd = fields.get("cmd", [])
        expects = [e.strip() for v in fields.get("expect", []) for e in v.split("|") if e.strip()]
        if not cmd or not expects:
            problems.append("%s:%d: %s: a figure mark needs `cmd:` and `expect:`" % (rel, line, name))
            continue
        figures.append(Figure(rel, line, name, fast, needs, cmd, expects, figure_block(text, m.end())))
    return figures


def occurs(value, text):
    """value in text as a whole token: no digit, letter or decimal part glued to either side."""
    pattern = r"(?<![\w.])" + re.escape(value) + r"(?![\w]|\.\d)"
    return re.search(pattern, text) is not None


def run(fig, root, programs):
    """Runs the figure's commands in order in one {out}; (problem or None, everything printed or written,
    seconds)."""
    with tempfile.TemporaryDirectory(prefix="orbcal-figure-") as out:
        texts, start = [], time.monotonic()
        for cmd in fig.cmd:
            refused = cmd.startswith("!")
            argv = [a.replace("{out}", out) for a in shlex.split(cmd.lstrip("! "))]
            if argv[0] in programs:
                argv[0] = programs[argv[0]]
            p = subprocess.run(argv, cwd=root, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=3600)
            texts.append(p.stdout.decode("utf-8", "replace"))
            if (p.returncode != 0) != refused:
                last = texts[-1].strip().splitlines()[-1:]
                return "`%s` exited %d: %s" % (cmd, p.returncode, last), "", time.monotonic() - start
        seconds = time.monotonic() - start
        for path in sorted(glob.glob(os.path.join(out, "**", "*"), recursive=True)):
            if path.endswith((".md", ".csv", ".yaml", ".json", ".txt")) and os.path.isfile(path):
                texts.append(open(path, encoding="utf-8", errors="replace").read())
        return None, "\n".join(texts), seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    parser.add_argument("--orbcal", help="the built orbcal")
    parser.add_argument("--bench", help="the built orbcal-bench")
    parser.add_argument("--all", action="store_true", help="every figure, not only the fast ones")
    parser.add_argument("--only", action="append", default=[], help="the figure of this name (repeatable)")
    parser.add_argument("--list", action="store_true", help="list the figures and exit")
    args = parser.parse_args()
    root = os.path.abspath(args.root)
    problems = []
    sources = ["README.md"] + sorted(os.path.relpath(p, root) for p in glob.glob(os.path.join(root, "docs", "*.md")))
    figures = [f for rel in sources for f in parse(root, rel, problems)]
    names = [f.name for f in figures]
    problems += ["%s: the name is used twice" % f.where() for f in figures if names.count(f.name) > 1]
    for f in figures:  # the marks must agree with the visible figure, whether or not it runs now
        problems += ["%s: %r is not in the figure below the mark" % (f.where(), e) for e in f.expects
                     if not occurs(e, f.block)]
    if args.list:
        for f in figures:
            print("%s%s: %s" % (f.where(), " (fast)" if f.fast else "", " && ".join(f.cmd)))
        return 0
    if args.only:
        chosen = [f for f in figures if f.name in args.only]
    else:
        chosen = [f for f in figures if args.all or f.fast]
    if args.only and not chosen:
        problems.append("no figure named %s" % ", ".join(args.only))
    programs = {k: v for k, v in (("orbcal", args.orbcal), ("orbcal-bench", args.bench)) if v}
    checked = skipped = 0
    for f in chosen:
        missing = [n for n in f.needs if not os.path.exists(os.path.join(root, n))]
        absent = sorted({shlex.split(c.lstrip("! "))[0] for c in f.cmd} - set(programs) & {"orbcal", "orbcal-bench"})
        if missing or absent:
            print("%s: skipped: %s absent" % (f.where(), ", ".join(missing + absent)))
            skipped += 1
            continue
        failure, output, seconds = run(f, root, programs)
        checked += 1
        if failure:
            problems.append("%s: %s" % (f.where(), failure))
            continue
        stale = [e for e in f.expects if not occurs(e, output)]
        print("%s: %s (%.1f s)" % (f.where(), "stale: " + ", ".join(stale) if stale else "matches", seconds))
        problems += ["%s: %r no longer printed by `%s`" % (f.where(), e, " && ".join(f.cmd)) for e in stale]
    for p in problems:
        print(p)
    print("check-figures: %d figure marks, %d checked, %d skipped, %d problem(s)" %
          (len(figures), checked, skipped, len(problems)))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
