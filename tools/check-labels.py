#!/usr/bin/env python3
"""Finds internal labels where users read: in README.md and docs/, in every source, header, script,
build and scene file (comments and strings alike: strings become help text, reports and terminal
output), in every `orbcal ... --help` and `orbcal-bench ... --help` text, and in what a short
`orbcal run` prints and writes. Exit 1 with one line per hit, file:line: the label and the line.

An internal label is a name that means something only inside the project's own notes: a paper called
by the number of its extracted copy instead of by author and year, the notes that reconstructed the
papers called by their file's name, an issue number, a branch name, a claim relative to an unnamed
earlier state, or the notes' provenance tags. The patterns are in LABELS.

  tools/check-labels.py [--orbcal BIN] [--bench BIN] [--run-args ARGS] [--root DIR]

Without --orbcal / --bench only the files are searched. The patterns are checked against examples
before the search, so a pattern that no longer matches anything fails here, not silently.
"""
import argparse
import os
import re
import shlex
import subprocess
import sys
import tempfile

# (name, pattern, an example it must match, built so that this file holds no label itself)
LABELS = [
    ("a paper by its copy's number", re.compile(r"\bseeds?\s+0\d\d\b", re.I), "see" + "d 0" + "04 eq. 2"),
    ("the reconstruction notes by their file's name", re.compile(r"\bdigest\b", re.I), "the dig" + "est 2.6"),
    ("an issue number", re.compile(r"\bissues?\s+#?\d+", re.I), "(iss" + "ue 10, item 4)"),
    ("a branch name", re.compile(r"\bh\d\d-[a-z]+\b"), "the h" + "18-fuzz branch"),
    ("a claim against an unnamed earlier state",
     re.compile(r"\bbefore\s+(this|the)\s+(change|work|issue|session|commit|fix)\b", re.I), "bef" + "ore this change"),
    ("a provenance tag of the notes", re.compile(r"\[(recon|ours|external)\]"), "(\"[o" + "urs] closed form\")"),
]

SOURCE_FOLDERS = ["sim", "render", "vision", "calib", "workflow", "tools", "python", "tests", "examples",
                  "scenes", ".ci"]
SOURCE_EXTENSIONS = (".cpp", ".hpp", ".h", ".in", ".py", ".sh", ".yaml", ".yml", ".txt", ".cmake", ".md",
                     ".urdf", ".xml")
SKIP_DIRS = {"build", ".git", "__pycache__"}


def self_test():
    """Every pattern matches its example and none matches ordinary text that looks close."""
    ordinary = "seed 1, seeds 2 and 3, --seed=4; Wang et al. 2023; this issue's text; h2o-free; before this run"
    for name, pattern, example in LABELS:
        if not pattern.search(example):
            sys.exit("check-labels: the pattern for %s does not match its example %r" % (name, example))
        if pattern.search(ordinary):
            sys.exit("check-labels: the pattern for %s matches ordinary text" % name)


def scan_text(label, text, hits):
    for number, line in enumerate(text.splitlines(), 1):
        for name, pattern, _ in LABELS:
            m = pattern.search(line)
            if m:
                hits.append("%s:%d: %s (%r): %s" % (label, number, name, m.group(0), line.strip()[:160]))


def scan_file(path, shown, hits):
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            scan_text(shown, f.read(), hits)
    except OSError as e:
        hits.append("%s: cannot read: %s" % (shown, e.strerror))


def files_to_scan(root):
    yield "README.md"
    for top in ["docs"] + SOURCE_FOLDERS:
        for folder, dirs, names in os.walk(os.path.join(root, top)):
            dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS)
            for name in sorted(names):
                if name.endswith(SOURCE_EXTENSIONS) or name == "CMakeLists.txt":
                    yield os.path.relpath(os.path.join(folder, name), root)
    yield "CMakeLists.txt"


def run(cmd, cwd):
    p = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=600)
    return p.returncode, p.stdout.decode("utf-8", "replace")


def subcommands(help_text):
    """Subcommand names from a CLI11 help text's SUBCOMMANDS section."""
    names, inside = [], False
    for line in help_text.splitlines():
        if line.strip().upper().startswith("SUBCOMMANDS"):
            inside = True
            continue
        if inside:
            m = re.match(r"^\s{2}([a-z][a-z0-9-]*)\b", line)
            if m:
                names.append(m.group(1))
            elif line.strip() and not line.startswith(" "):
                inside = False
    return names


def scan_help(program, label, root, hits, prefix=(), depth=0):
    """`program [prefix] --help`, then every subcommand's, recursively (two levels: `orbcal study run`)."""
    code, text = run([program, *prefix, "--help"], root)
    shown = "`%s --help`" % " ".join([label, *prefix])
    if code != 0:
        hits.append("%s: exit %d" % (shown, code))
    scan_text(shown, text, hits)
    count = 1
    if depth < 2:
        for sub in subcommands(text):
            count += scan_help(program, label, root, hits, (*prefix, sub), depth + 1)
    return count


def scan_bench_help(bench, root, hits):
    """orbcal-bench's --help, then the --help of each section it says takes options (the others have no
    help of their own: named, they run; their printed text is in the sources searched above)."""
    code, text = run([bench, "--help"], root)
    if code != 0:
        hits.append("`orbcal-bench --help`: exit %d" % code)
    scan_text("`orbcal-bench --help`", text, hits)
    m = re.search(r"^with options[^:]*:\s*(.*)$", text, re.M)
    names = m.group(1).split() if m else []
    for name in names:
        _, sub = run([bench, name, "--help"], root)
        scan_text("`orbcal-bench %s --help`" % name, sub, hits)
    return 1 + len(names)


def scan_run(orbcal, run_args, root, hits):
    """A short `orbcal run`: what it prints and every text file it writes."""
    with tempfile.TemporaryDirectory(prefix="orbcal-labels-") as out:
        code, text = run([orbcal, "run", *shlex.split(run_args), "-o", out], root)
        if code != 0:
            hits.append("`orbcal run %s`: exit %d: %s" % (run_args, code, text.strip().splitlines()[-1:]))
        scan_text("`orbcal run` output", text, hits)
        for folder, _, names in os.walk(out):
            for name in sorted(names):
                if name.endswith((".md", ".csv", ".yaml", ".json", ".txt", ".html")):
                    path = os.path.join(folder, name)
                    scan_file(path, "`orbcal run` " + os.path.relpath(path, out), hits)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    parser.add_argument("--orbcal", help="the built orbcal: search its --help texts and a short run")
    parser.add_argument("--bench", help="the built orbcal-bench: search its --help texts")
    parser.add_argument("--run-args", default="--scene scenes/quick_scene.yaml --ident 10 --valid 20 --quiet",
                        help="options of the short `orbcal run` (default: %(default)s)")
    args = parser.parse_args()
    root = os.path.abspath(args.root)
    self_test()
    hits = []
    files = 0
    for rel in files_to_scan(root):
        scan_file(os.path.join(root, rel), rel, hits)
        files += 1
    helps = 0
    if args.orbcal:
        helps += scan_help(args.orbcal, "orbcal", root, hits)
        scan_run(args.orbcal, args.run_args, root, hits)
    if args.bench:
        helps += scan_bench_help(args.bench, root, hits)
    for h in hits:
        print(h)
    print("check-labels: %d files, %d --help texts%s: %d internal label(s)"
          % (files, helps, ", a short orbcal run" if args.orbcal else "", len(hits)))
    return 1 if hits else 0


if __name__ == "__main__":
    sys.exit(main())
