#!/usr/bin/env python3
"""Runs every fenced ```sh block of README.md (or of the Markdown files given) the way a newcomer would
in a fresh clone, and fails when one exits non-zero.

  run_sh_blocks.py --orbcal BIN [--source DIR] [--keep DIR] [FILE.md ...]

The blocks run in order, each with `bash -e`, in one temporary folder that holds a link to every
top-level entry of the source tree (scenes/, tests/, examples/, ...; not build/ nor .git), so that
paths relative to the repository's root resolve and what the commands write stays out of the tree;
`orbcal` is BIN (first on the PATH, and ./build/tools/orbcal), and a Python line finds the module
beside BIN's build folder (build/python). Blocks that run tools/install-deps.sh are the set-up
commands, which CI runs itself (.ci/run): they are left out, and the script checks that README.md
has exactly two of them. Exit 1 on a failing block, printing it and the end of its output.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile
import time

FENCE = re.compile(r"^( *)```(\w*)\s*$")
SETUP_MARK = "tools/install-deps.sh"


def sh_blocks(path):
    """The fenced sh blocks of a Markdown file, in order, each as (first line number, text dedented)."""
    blocks, current, indent, start, lang = [], None, 0, 0, ""
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            m = FENCE.match(line.rstrip("\n"))
            if current is None:
                if m and m.group(2):
                    current, indent, start, lang = [], len(m.group(1)), number, m.group(2)
                continue
            if m and not m.group(2):
                if lang == "sh":
                    blocks.append((start, "\n".join(current) + "\n"))
                current = None
                continue
            current.append(line.rstrip("\n")[indent:] if line[:indent].strip() == "" else line.rstrip("\n"))
    if current is not None:
        raise SystemExit("%s:%d: fenced block never closed" % (path, start))
    return blocks


def workspace(source, orbcal, work):
    """Fills work with links to the source tree's top-level entries and to the built program and module."""
    for name in sorted(os.listdir(source)):
        if name in (".git", "build") or name.startswith("build-"):
            continue
        os.symlink(os.path.join(source, name), os.path.join(work, name))
    bin_dir = os.path.join(work, ".bin")
    os.makedirs(bin_dir)
    os.symlink(orbcal, os.path.join(bin_dir, "orbcal"))
    build = os.path.join(work, "build")
    os.makedirs(os.path.join(build, "tools"))
    os.symlink(orbcal, os.path.join(build, "tools", "orbcal"))
    module = os.path.join(os.path.dirname(os.path.dirname(orbcal)), "python")  # <build>/tools/orbcal -> <build>/python
    if os.path.isdir(module):
        os.symlink(module, os.path.join(build, "python"))
    return bin_dir


def run_blocks(files, orbcal, source, work):
    bin_dir = workspace(source, orbcal, work)
    env = dict(os.environ, PATH=bin_dir + os.pathsep + os.environ.get("PATH", ""), MPLBACKEND="Agg")
    failures, ran = 0, 0
    for path in files:
        blocks = sh_blocks(path)
        setup = [b for b in blocks if SETUP_MARK in b[1]]
        if os.path.basename(path) == "README.md" and len(setup) != 2:
            print("%s: expected the two set-up commands (blocks running %s), found %d" % (path, SETUP_MARK, len(setup)))
            failures += 1
        for line, text in blocks:
            if SETUP_MARK in text:
                continue
            started = time.monotonic()
            run = subprocess.run(["bash", "-e", "-c", text], cwd=work, env=env, capture_output=True, text=True,
                                 timeout=600)
            ran += 1
            seconds = time.monotonic() - started
            where = "%s:%d" % (os.path.relpath(path, source), line)
            if run.returncode != 0:
                failures += 1
                tail = "\n".join((run.stdout + run.stderr).splitlines()[-15:])
                print("FAIL %s (exit %d, %.1f s):\n%s\n--- its output, last lines:\n%s\n" % (where, run.returncode, seconds,
                                                                                           text, tail))
            else:
                print("ok   %s (%.1f s)" % (where, seconds))
    if ran == 0:
        print("no sh block to run")
        failures += 1
    return failures


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orbcal", required=True, help="the built orbcal program")
    parser.add_argument("--source", default=os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                        help="the repository's root (default: this script's)")
    parser.add_argument("--keep", help="run in this (new or empty) folder and keep what the commands wrote")
    parser.add_argument("files", nargs="*", help="Markdown files (default: README.md)")
    args = parser.parse_args()
    source = os.path.abspath(args.source)
    orbcal = os.path.abspath(args.orbcal)
    files = [os.path.abspath(f) for f in args.files] or [os.path.join(source, "README.md")]
    if args.keep:
        os.makedirs(args.keep, exist_ok=True)
        failures = run_blocks(files, orbcal, source, os.path.abspath(args.keep))
    else:
        with tempfile.TemporaryDirectory(prefix="orbcal-readme-") as work:
            failures = run_blocks(files, orbcal, source, work)
    print("%d failing block(s)" % failures if failures else "every block ran")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
