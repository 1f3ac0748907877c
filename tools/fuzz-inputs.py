#!/usr/bin/env python3
"""Mutation fuzz of every input orbcal reads (docs/file-formats.md, "Safe files").

Makes seed inputs with the built orbcal (simulate, calibrate, render) and the shipped files, mutates
one file (or one command-line option) per case, runs the command that consumes it in a fresh folder
with a timeout, and classifies the outcome:

  crash            killed by a signal, exit >= 128, or a crash text (Segmentation, terminate called, what():)
  hang             no exit within --timeout seconds
  clean refusal    non-zero exit and ONE stderr line starting "orbcal:" that names the mutated file
                   (command-line options: one line naming the option; CLI11 may add its "Run with --help" line)
  unclear refusal  non-zero exit otherwise (or a refusal that left a result file that looks valid)
  silent acceptance  exit 0; each mutation generator says whether its input is clearly invalid

Exit status 1 when there is a crash, a hang, a silent acceptance of clearly invalid input or a JSON
holding a non-finite number; 0 otherwise. Standard library only (text and regex mutations).

  tools/fuzz-inputs.py [--orbcal build/tools/orbcal] [--seed 1] [--count 1300] [--jobs 2] [--csv FILE]
"""
import argparse
import concurrent.futures
import csv
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLASSES = ["crash", "hang", "clean refusal", "unclear refusal", "silent acceptance"]
# Files a run writes only when it succeeds: a refused run must not leave one behind.
RESULT_FILES = {"model.yaml", "robot_calibrated.yaml", "estimates.csv", "evaluation.json", "diagnosis.json",
                "measurements.yaml", "samples.csv"}
NUMBER = re.compile(r"(?<![\w.\-+])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w.])")
SPECIALS = [".nan", "nan", ".inf", "-.inf", "inf", "1e308", "-1e308"]
CSV_SPECIALS = ["nan", "NaN", "inf", "-inf", "1e308", "-1e308"]
# (no lone "\r": a line break in YAML and CSV alike)
JUNK = [b"\x00", b"\xff\xfe", b"\x1b[2J", b"\x07\x08", b"\xc3\x28", b"\x0a\x0a\x00\x01\x02"]


class Case:
    """One mutation: the folder's files, the command, and what was changed."""

    def __init__(self, number, surface, kind, invalid, detail, target, files, argv):
        self.number, self.surface, self.kind, self.invalid = number, surface, kind, invalid
        self.detail, self.target, self.files, self.argv = detail, target, files, argv


# ---------------------------------------------------------------------------------------------- text helpers
def code_spans(text):
    """(start, end) of every line's part before a comment: numbers and keys are mutated there only."""
    spans, pos = [], 0
    for line in text.splitlines(keepends=True):
        body = line.rstrip("\r\n")
        cut = body.find(" #")
        if body.lstrip().startswith("#"):
            cut = 0
        end = pos + (cut if cut >= 0 else len(body))
        spans.append((pos, end))
        pos += len(line)
    return spans


FREE_TEXT = re.compile(r"[ \t]*(?:-[ \t]*)?name:")


def numbers(text):
    """Numbers outside comments, and not inside a block `name:` (free text: "scene at 640 x 512")."""
    return [m for s, e in code_spans(text) if not FREE_TEXT.match(text, s, e) for m in NUMBER.finditer(text, s, e)]


def replace_span(text, start, end, new):
    return text[:start] + new + text[end:]


def key_values(text):
    """Matches of `key: scalar` outside comments (block or flow), group 1 the key, group 2 the value."""
    pat = re.compile(r"([A-Za-z_][\w]*):[ \t]+([^,{}\[\]\s#][^,{}\[\]\n#]*?)(?=\s*(?:[,}\]]|#|$|\n))")
    return [m for s, e in code_spans(text) for m in pat.finditer(text, s, e)]


def key_matches(text, key):
    pat = re.compile(r"(?<![\w-])" + re.escape(key) + r":")
    return [m for s, e in code_spans(text) for m in pat.finditer(text, s, e)]


# ---------------------------------------------------------------------------------------------- YAML mutations
# Each returns (new text or bytes, detail) or None when it does not apply; the registry below says
# whether the result is clearly invalid.
def y_duplicate_key(text, rng, ctx):
    kv = key_values(text)
    if not kv:
        return None
    m = rng.choice(kv)
    line_start = text.rfind("\n", 0, m.start()) + 1
    prefix = text[line_start:m.start()]
    if prefix.strip() in ("", "-") and "{" not in text[line_start:m.start()]:
        indent = " " * len(prefix)
        return replace_span(text, m.end(), m.end(), "\n" + indent + m.group(1) + ": " + m.group(2)), m.group(1)
    return replace_span(text, m.end(), m.end(), ", " + m.group(1) + ": " + m.group(2)), m.group(1)


def y_empty_value(text, rng, ctx):
    kv = key_values(text)
    if not kv:
        return None
    m = rng.choice(kv)
    new = rng.choice(["", "~", "null"])
    return replace_span(text, m.start(2), m.end(2), new), m.group(1) + " -> '" + new + "'"


def y_special_number(text, rng, ctx):
    nums = numbers(text)
    if not nums:
        return None
    m = rng.choice(nums)
    new = rng.choice(SPECIALS)
    return replace_span(text, m.start(), m.end(), new), m.group(0) + " -> " + new


def y_wrong_type(text, rng, ctx):
    nums = numbers(text)
    if not nums:
        return None
    m = rng.choice(nums)
    new = rng.choice(["abc", "[1, 2]", "{x: 1}", "'12 apples'", "true"])
    return replace_span(text, m.start(), m.end(), new), m.group(0) + " -> " + new


def y_unknown_key(text, rng, ctx):
    key = rng.choice(["bogus_key", "colour", "unit_typo"])
    flows = [(s + m.start(), s + m.end()) for s, e in code_spans(text) for m in re.finditer(r"\{[^{}\n]*\}", text[s:e])]
    if flows and rng.random() < 0.5:
        a, b = rng.choice(flows)
        return replace_span(text, b - 1, b - 1, ", " + key + ": 1"), key + " (in a map)"
    return text.rstrip("\n") + "\n" + key + ": 1\n", key + " (top level)"


def y_binary_junk(data, rng, ctx):
    """Junk bytes inside a number (a value), or the whole file random bytes: clearly invalid."""
    if rng.random() < 0.3:
        return bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 400))), "the whole file random bytes"
    text = data.decode()
    spans = [(s, e) for _, s, e, _ in x_attribute_numbers(text)] if text.lstrip().startswith("<") else \
        [(m.start(), m.end()) for m in numbers(text)]
    if not spans:
        return None
    s, e = rng.choice(spans)
    pos = len(text[:rng.randint(s, e)].encode())
    junk = rng.choice(JUNK)
    return data[:pos] + junk + data[pos:], "%r inside the value at byte %d" % (junk, pos)


def y_binary_anywhere(data, rng, ctx):
    """Junk bytes anywhere (a comment, between XML elements too): not always a changed value."""
    pos = rng.randint(0, len(data))
    junk = rng.choice(JUNK)
    return data[:pos] + junk + data[pos:], "%r at byte %d" % (junk, pos)


def y_truncate(data, rng, ctx):
    if len(data) < 4:
        return None
    pos = rng.randint(1, len(data) - 1)
    return data[:pos], "cut at byte %d of %d" % (pos, len(data))


def y_delete_key(text, rng, ctx):
    keys = [k for k in ctx.get("required", []) if key_matches(text, k)]
    if not keys:
        return None
    key = rng.choice(keys)
    m = rng.choice(key_matches(text, key))
    line_start = text.rfind("\n", 0, m.start()) + 1
    line_end = text.find("\n", m.end())
    line_end = len(text) if line_end < 0 else line_end + 1
    line = text[line_start:line_end]
    if line.lstrip().startswith(key + ":") or line.lstrip().startswith("- " + key + ":"):
        # a block key: drop its line and the lines indented below it
        indent = len(line) - len(line.lstrip())
        end = line_end
        for nxt in re.finditer(r"[^\n]*\n?", text[line_end:]):
            seg = nxt.group(0)
            if not seg or (seg.strip() and len(seg) - len(seg.lstrip()) <= indent and not seg.lstrip().startswith("#")):
                break
            end += len(seg)
        return text[:line_start] + text[end:], key
    # a flow pair: drop "key: value" up to the next comma or brace at this level
    depth, i = 0, m.end()
    while i < len(text):
        c = text[i]
        if c in "[{":
            depth += 1
        elif c in "]}":
            if depth == 0:
                break
            depth -= 1
        elif c == "," and depth == 0:
            i += 1
            break
        i += 1
    return text[:m.start()] + text[i:].lstrip(" "), key


def y_path_escape(text, rng, ctx):
    keys = [k for k in ctx.get("paths", []) if key_matches(text, k)]
    if not keys:
        return None
    key = rng.choice(keys)
    m = rng.choice(key_matches(text, key))
    end = m.end()
    rest = text[end:]
    v = re.match(r"\s*(\"[^\"]*\"|\[[^\]]*\]|[^,}\n#]+)", rest)
    if not v:
        return None
    new = "\"../../../../../../etc/passwd\""
    if v.group(1).startswith("["):
        new = "[" + new + "]"
    return text[:end] + " " + new + rest[v.end():], key


def y_out_of_range(text, rng, ctx):
    options = [(k, vals) for k, vals in ctx.get("ranges", []) if key_matches(text, k)]
    if not options:
        return None
    key, values = rng.choice(options)
    m = rng.choice(key_matches(text, key))
    rest = text[m.end():]
    num = NUMBER.search(rest)
    if not num:
        return None
    new = rng.choice(values)
    return text[:m.end()] + rest[:num.start()] + new + rest[num.end():], "%s: %s -> %s" % (key, num.group(0), new)


def y_tiny_change(text, rng, ctx):
    nums = [m for m in numbers(text) if "." in m.group(0) and "e" not in m.group(0).lower()]
    if not nums:
        return None
    m = rng.choice(nums)
    v = float(m.group(0))
    new = repr(v + (abs(v) * 1e-12 if v else 1e-15))
    return replace_span(text, m.start(), m.end(), new), m.group(0) + " -> " + new


def y_comment(text, rng, ctx):
    lines = text.splitlines(keepends=True)
    i = rng.randint(0, len(lines))
    return "".join(lines[:i] + ["# a comment added by the fuzz: 1e308 nan\n"] + lines[i:]), "comment at line %d" % (i + 1)


YAML_MUTATIONS = [  # (kind, function, clearly invalid, works on bytes)
    ("duplicate key", y_duplicate_key, True, False),
    ("empty value", y_empty_value, True, False),
    ("non-finite / 1e308", y_special_number, True, False),
    ("wrong type", y_wrong_type, True, False),
    ("unknown key", y_unknown_key, True, False),
    ("binary junk", y_binary_junk, True, True),
    ("binary junk (anywhere)", y_binary_anywhere, False, True),
    ("truncated", y_truncate, False, True),
    ("deleted required key", y_delete_key, True, False),
    ("path escaping", y_path_escape, True, False),
    ("out of range", y_out_of_range, True, False),
    ("tiny change (valid)", y_tiny_change, False, False),
    ("comment (valid)", y_comment, False, False),
]


# ---------------------------------------------------------------------------------------------- CSV mutations
def parse_csv(text):
    lines = text.splitlines()
    return [line.split(",") for line in lines if line.strip()]


def join_csv(rows):
    return "\n".join(",".join(r) for r in rows) + "\n"


def data_cell(rows, rng, columns=None):
    header = rows[0]
    cols = [i for i, h in enumerate(header) if columns is None or any(re.fullmatch(c, h) for c in columns)]
    if not cols or len(rows) < 2:
        return None
    return rng.randint(1, len(rows) - 1), rng.choice(cols)


def c_special(text, rng, ctx):
    rows = parse_csv(text)
    cell = data_cell(rows, rng, ctx.get("numeric"))
    if not cell:
        return None
    r, c = cell
    new = rng.choice(CSV_SPECIALS)
    rows[r][c] = new
    return join_csv(rows), "row %d %s -> %s" % (r, rows[0][c], new)


def c_empty(text, rng, ctx):
    rows = parse_csv(text)
    cell = data_cell(rows, rng, [r"(?!index$).*"])  # not the index: some readers do not read it (a valid empty)
    if not cell:
        return None
    r, c = cell
    rows[r][c] = rng.choice(["", " "])
    return join_csv(rows), "row %d %s empty" % (r, rows[0][c])


def c_wrong_type(text, rng, ctx):
    rows = parse_csv(text)
    cell = data_cell(rows, rng, ctx.get("numeric"))
    if not cell:
        return None
    r, c = cell
    rows[r][c] = rng.choice(["abc", "1.2.3", "0x1g", "--1", "1,5"])
    return join_csv(rows), "row %d %s -> %s" % (r, rows[0][c], rows[r][c])


def c_out_of_range(text, rng, ctx):
    rows = parse_csv(text)
    options = [(col, vals) for col, vals in ctx.get("ranges", []) if any(re.fullmatch(col, h) for h in rows[0])]
    if not options or len(rows) < 3:
        return None
    col, values = rng.choice(options)
    cell = data_cell(rows, rng, [col])
    r, c = cell
    new = rng.choice(values)
    if new == "BACKWARDS":
        r = max(r, 2)
        new = repr(float(rows[r - 1][c]) - rng.choice([1.0, 100.0, 1e-3]))
    rows[r][c] = new
    return join_csv(rows), "row %d %s -> %s" % (r, rows[0][c], new)


def c_duplicate_column(text, rng, ctx):
    rows = parse_csv(text)
    a, b = rng.sample(range(len(rows[0])), 2)
    detail = "%s renamed %s" % (rows[0][b], rows[0][a])
    rows[0][b] = rows[0][a]
    return join_csv(rows), detail


def c_delete_column(text, rng, ctx):
    rows = parse_csv(text)
    cols = [i for i, h in enumerate(rows[0]) if any(re.fullmatch(c, h) for c in ctx.get("required", []))]
    if not cols:
        return None
    c = rng.choice(cols)
    detail = rows[0][c]
    return join_csv([r[:c] + r[c + 1:] for r in rows]), detail


def c_swap_clear(text, rng, ctx):
    rows = parse_csv(text)
    pairs = [(a, b) for a, b in ctx.get("bad_swaps", []) if a in rows[0] and b in rows[0]]
    if not pairs:
        return None
    a, b = (rows[0].index(x) for x in rng.choice(pairs))
    rows[0][a], rows[0][b] = rows[0][b], rows[0][a]
    return join_csv(rows), "%s <-> %s" % (rows[0][a], rows[0][b])


def c_swap_any(text, rng, ctx):
    rows = parse_csv(text)
    a, b = rng.sample(range(1, len(rows[0])), 2)
    rows[0][a], rows[0][b] = rows[0][b], rows[0][a]
    return join_csv(rows), "%s <-> %s" % (rows[0][a], rows[0][b])


def c_truncate_row(text, rng, ctx):
    rows = parse_csv(text)
    r = rng.randint(1, len(rows) - 1)
    keep = rng.randint(1, len(rows[r]) - 1)
    return join_csv(rows[:r] + [rows[r][:keep]]), "row %d cut after %d of %d cells" % (r, keep, len(rows[r]))


def c_extra_cell(text, rng, ctx):
    rows = parse_csv(text)
    r = rng.randint(1, len(rows) - 1)
    rows[r].append("0.5")
    return join_csv(rows), "row %d has an extra cell" % r


def c_path_escape(text, rng, ctx):
    rows = parse_csv(text)
    if "image" not in rows[0]:
        return None
    c = rows[0].index("image")
    r = rng.randint(1, len(rows) - 1)
    rows[r][c] = rng.choice(["../../../etc/passwd", "/etc/passwd", "images/../../x.png"])
    return join_csv(rows), "row %d image -> %s" % (r, rows[r][c])


def c_tiny_change(text, rng, ctx):
    rows = parse_csv(text)
    cell = data_cell(rows, rng, ctx.get("tiny"))
    if not cell:
        return None
    r, c = cell
    v = float(rows[r][c])
    rows[r][c] = repr(v + (abs(v) * 1e-12 if v else 1e-15))
    return join_csv(rows), "row %d %s + 1e-12 relative" % (r, rows[0][c])


def c_crlf_bom(text, rng, ctx):
    return "\ufeff" + text.replace("\n", "\r\n"), "BOM and CRLF"


CSV_MUTATIONS = [
    ("non-finite / 1e308", c_special, True, False),
    ("empty value", c_empty, True, False),
    ("wrong type", c_wrong_type, True, False),
    ("out of range", c_out_of_range, True, False),
    ("duplicate key", c_duplicate_column, True, False),
    ("deleted required key", c_delete_column, True, False),
    ("swapped columns", c_swap_clear, True, False),
    ("swapped columns (maybe valid)", c_swap_any, False, False),
    ("truncated", c_truncate_row, True, False),
    ("extra cell", c_extra_cell, True, False),
    ("binary junk", y_binary_junk, True, True),
    ("binary junk (anywhere)", y_binary_anywhere, False, True),
    ("path escaping", c_path_escape, True, False),
    ("tiny change (valid)", c_tiny_change, False, False),
    ("BOM + CRLF (valid)", c_crlf_bom, False, False),
]


# ---------------------------------------------------------------------------------------------- URDF mutations
def x_attribute_numbers(text):
    out = []
    for m in re.finditer(r'(xyz|rpy|lower|upper|value|mass|effort|velocity)="([^"]*)"', text):
        for n in NUMBER.finditer(m.group(2)):
            out.append((m.group(1), m.start(2) + n.start(), m.start(2) + n.end(), n.group(0)))
    return out


def x_special(text, rng, ctx):
    attr, s, e, old = rng.choice(x_attribute_numbers(text))
    new = rng.choice(["nan", "inf", "-inf", "1e308", "-1e308"])
    return replace_span(text, s, e, new), "%s %s -> %s" % (attr, old, new)


def x_out_of_range(text, rng, ctx):
    cands = [a for a in x_attribute_numbers(text) if a[0] in ("xyz", "lower", "upper", "mass")]
    attr, s, e, old = rng.choice(cands)
    new = {"xyz": "1e9", "lower": "-1e308", "upper": "1e308", "mass": "-5"}[attr]
    return replace_span(text, s, e, new), "%s %s -> %s" % (attr, old, new)


def x_wrong_type(text, rng, ctx):
    attr, s, e, old = rng.choice(x_attribute_numbers(text))
    return replace_span(text, s, e, "abc"), "%s %s -> abc" % (attr, old)


def x_empty(text, rng, ctx):
    ms = list(re.finditer(r'(xyz|lower|upper|axis|name|type|link)="([^"]*)"', text))
    m = rng.choice(ms)
    return replace_span(text, m.start(2), m.end(2), ""), m.group(1) + " empty"


def x_duplicate(text, rng, ctx):
    ms = list(re.finditer(r'<joint name="[^"]*" type="revolute">.*?</joint>\n', text, re.S))
    if not ms:
        return None
    m = rng.choice(ms)
    return text[:m.end()] + m.group(0) + text[m.end():], "joint element repeated"


def x_duplicate_attr(text, rng, ctx):
    ms = list(re.finditer(r'<limit ([^/]*)/>', text))
    m = rng.choice(ms)
    return replace_span(text, m.end(1), m.end(1), ' lower="0" '), "limit lower given twice"


def x_delete(text, rng, ctx):
    # (not <axis>: URDF's default axis is x)
    kinds = [r'<limit [^>]*/>\s*', r'<parent link="[^"]*"/>\s*', r'<child link="[^"]*"/>\s*']
    kind = rng.choice(kinds)
    ms = list(re.finditer(kind, text))
    m = rng.choice(ms)
    return text[:m.start()] + text[m.end():], m.group(0).strip()[:30] + " deleted"


def x_truncate(data, rng, ctx):
    pos = rng.randint(1, len(data) - 20)
    return data[:pos], "cut at byte %d of %d" % (pos, len(data))


def x_tiny(text, rng, ctx):
    cands = [a for a in x_attribute_numbers(text) if "." in a[3]]
    attr, s, e, old = rng.choice(cands)
    v = float(old)
    return replace_span(text, s, e, repr(v + abs(v) * 1e-12)), "%s %s + 1e-12 relative" % (attr, old)


URDF_MUTATIONS = [
    ("non-finite / 1e308", x_special, True, False),
    ("out of range", x_out_of_range, True, False),
    ("wrong type", x_wrong_type, True, False),
    ("empty value", x_empty, True, False),
    ("duplicate key", x_duplicate_attr, True, False),
    ("duplicate element", x_duplicate, True, False),
    ("deleted required key", x_delete, True, False),
    ("truncated", x_truncate, True, True),
    ("binary junk", y_binary_junk, True, True),
    ("binary junk (anywhere)", y_binary_anywhere, False, True),
    ("tiny change (valid)", x_tiny, False, False),
]


# ---------------------------------------------------------------------------------------------- surfaces
LENGTH_BIG = ["1e9", "-1e9", "1e7"]
ANGLE_BIG = ["1e6", "-1e6", "1e9"]


def surfaces(seeds):
    """Every input surface: the files of its case folder, the file mutated, its mutations and context,
    and the command that consumes it (argv after the orbcal program, run in the case folder)."""
    sim = {"sim/" + f: os.path.join(seeds, "sim", f) for f in os.listdir(os.path.join(seeds, "sim"))
           if os.path.isfile(os.path.join(seeds, "sim", f))}
    ds = {}
    for base, _, files in os.walk(os.path.join(seeds, "ds")):
        for f in files:
            full = os.path.join(base, f)
            ds[os.path.relpath(full, seeds)] = full
    cal = {"cal/" + f: os.path.join(seeds, "cal", f) for f in ("model.yaml", "robot.yaml")}
    scene = os.path.join(ROOT, "scenes", "quick_scene.yaml")
    calibrate_desc = ["calibrate", "sim/measurements.yaml", "--effects", "compliance:2", "-o", "out", "--quiet", "--no-plots"]
    evaluate = ["evaluate", "--model", "cal/model.yaml", "--data", "sim/measurements.yaml", "-o", "out"]
    diagnose = ["diagnose", "sim/measurements.yaml", "-o", "out", "--quiet", "--no-plots", "--folds", "3",
                "--max-effects", "1", "--no-empirical"]
    render = ["render", "-o", "out", "--count", "2", "--seed", "1"]
    return [
        dict(name="robot YAML", files={"robot.yaml": os.path.join(ROOT, "scenes", "iiwa7.yaml")},
             target="robot.yaml", kinds=YAML_MUTATIONS,
             ctx=dict(required=["joints", "convention", "d_m", "min_deg", "max_deg"],
                      ranges=[("d_m", LENGTH_BIG), ("a_m", LENGTH_BIG), ("alpha_deg", ANGLE_BIG),
                              ("min_deg", ["-1e6", "-1e9"]), ("max_deg", ["1e6", "1e9"]),
                              ("mass_kg", ["-1", "1e9"]), ("com_m", LENGTH_BIG), ("gravity_m_s2", ["1e9", "-1e9"])]),
             commands=[["simulate", "--robot", "robot.yaml", "-o", "out", "-n", "20", "--quiet"]]),
        dict(name="URDF", files={"arm.urdf": os.path.join(ROOT, "tests", "data", "iiwa7_inertial.urdf")},
             target="arm.urdf", kinds=URDF_MUTATIONS, ctx={},
             commands=[["simulate", "--robot", "arm.urdf", "-o", "out", "-n", "20", "--quiet"]]),
        dict(name="scene YAML", files={"scene.yaml": scene}, target="scene.yaml", kinds=YAML_MUTATIONS,
             ctx=dict(required=["camera", "board", "base_T_board", "flange_T_camera", "fx_px", "square_m"],
                      ranges=[("fx_px", ["-700", "1e9"]), ("cx_px", ["-1e6", "1e6"]), ("square_m", ["-0.08", "1e9"]),
                              ("xyz_m", LENGTH_BIG), ("rpy_deg", ANGLE_BIG), ("inner_corners_x", ["-9", "1000000"]),
                              ("distance_m", ["-1", "1e9"]), ("max_tilt_deg", ["-5", "1e6"]),
                              ("width_px", ["-640", "1e9"])]),
             commands=[render + ["--scene", "scene.yaml"]]),
        dict(name="camera file", files={"cam.yaml": os.path.join(seeds, "cam.yaml"),
                                        "scene.yaml": os.path.join(seeds, "scene_cam.yaml")},
             target="cam.yaml", kinds=YAML_MUTATIONS,
             ctx=dict(required=["camera_matrix", "image_width", "image_height", "distortion_coefficients", "data"],
                      ranges=[("image_width", ["-640", "1e9"]), ("image_height", ["0", "1e9"]), ("data", ["1e9", "-700"])]),
             commands=[render + ["--scene", "scene.yaml"]]),
        dict(name="error-set YAML", files={"errors.yaml": os.path.join(ROOT, "scenes", "errors_cyclic.yaml")},
             target="errors.yaml", kinds=YAML_MUTATIONS,
             ctx=dict(required=["spec", "format"],
                      ranges=[("cyclic2_sin1", ["1e308", "1e9", "-1e9"]), ("cyclic2_cos2", ["1e9", "-1e308"])]),
             commands=[render + ["--scene", scene, "--errors", "errors.yaml"]]),
        dict(name="error-set YAML (effects)", files={"errors.yaml": os.path.join(seeds, "errors_effects.yaml")},
             target="errors.yaml", kinds=YAML_MUTATIONS,
             ctx=dict(required=["spec", "format", "parameters", "temperature"],
                      ranges=[("c2", ["1e308", "-5", "1e3"]), ("start_C", ["1e6", "-1e6"]), ("rise_C", ["1e6"]),
                              ("payload_kg", ["-1", "1e9"]), ("tau_s", ["-5", "0"]), ("angle_sigma_deg", ANGLE_BIG),
                              ("length_sigma_mm", ["1e9", "-1"]), ("sample_period_s", ["-15", "0", "1e308"])]),
             commands=[render + ["--scene", scene, "--errors", "errors.yaml"]]),
        dict(name="measurement description", files=dict(sim), target="sim/measurements.yaml", kinds=YAML_MUTATIONS,
             ctx=dict(required=["files", "joints", "pose", "robot", "format", "columns", "unit"],
                      paths=["robot", "files"],
                      ranges=[("position_mm", ["1e9", "-1", "0"]), ("rotation_deg", ["1e9", "-1"]),
                              ("joint_deg", ["1e9", "-0.5"])]),
             commands=[calibrate_desc, diagnose]),
        dict(name="measured CSV", files=dict(sim, **cal), target="sim/session_1.csv", kinds=CSV_MUTATIONS,
             ctx=dict(numeric=[r"(?!index).*"], tiny=[r"q\d_rad", r"[xyz]_m", r"tau\d_Nm"],  # the description names no index
                      required=[r"q\d_rad", r"[xyz]_m", r"q[wxyz]", r"tau\d_Nm", "temperature_C", "time_s"],
                      ranges=[(r"tau\d_Nm", ["1e12", "-1e12"]), ("temperature_C", ["1e6", "-1e6", "-300"]),
                              ("time_s", ["BACKWARDS", "1e12", "-1e12"]), (r"[xyz]_m", ["1e9", "-1e9", "1e5"]),
                              (r"q\d_rad", ["1e6", "-100"]), (r"q[wxyz]", ["5", "-3"])],
                      bad_swaps=[("x_m", "qw"), ("y_m", "qx"), ("q1_rad", "time_s")]),
             commands=[calibrate_desc, diagnose, evaluate]),
        dict(name="model.yaml", files=dict(sim, **cal),
             target="cal/model.yaml", kinds=YAML_MUTATIONS,
             ctx=dict(required=["format", "robot", "registration", "effects", "parameters", "world_T_base",
                                "flange_T_marker", "sessions"],
                      paths=["robot"],
                      ranges=[("c2", ["-5", "1e308", "1e3"]), ("xyz_m", LENGTH_BIG), ("rpy_deg", ANGLE_BIG),
                              ("value", ["1e9", "-1e9"]), ("sessions", ["0", "-1", "1000000"])]),
             commands=[evaluate]),
        dict(name="dataset manifest", files=dict(ds), target="ds/manifest.yaml", kinds=YAML_MUTATIONS,
             ctx=dict(required=["format", "robot", "scene", "samples", "num_samples"],
                      paths=["robot", "scene", "samples", "file"],
                      ranges=[("joint_noise_deg", ["-1", "1e6", "11"]), ("num_samples", ["-1", "0", "1000000"]),
                              ("theta_deg", ANGLE_BIG), ("a_mm", ["1e9", "-1e9"]), ("configurations", ["-1", "0.5"])]),
             commands=[["calibrate", "ds", "-o", "out", "--holdout", "0", "--quiet", "--no-plots"]]),
        dict(name="samples.csv", files=dict(ds), target="ds/samples.csv", kinds=CSV_MUTATIONS,
             ctx=dict(numeric=[r"index", r"q\d_(true_)?rad", r"cam_board_.*"], tiny=[r"q\d_rad"],
                      required=["index", "image", r"q\d_rad"],
                      ranges=[(r"q\d_rad", ["1e6", "-100"]), (r"q\d_true_rad", ["1e6", "-100"]),
                              (r"cam_board_[xyz]_m", ["1e9", "-1e9"]), (r"cam_board_r[xyz]_rad", ["1e6", "100"]),
                              ("index", ["-1", "1000000"])],
                      bad_swaps=[("index", "image"), ("image", "q1_rad")]),
             commands=[["calibrate", "ds", "-o", "out", "--holdout", "0", "--quiet", "--no-plots"]]),
        dict(name="configurations CSV", files={"configs.csv": os.path.join(seeds, "configs.csv")},
             target="configs.csv", kinds=CSV_MUTATIONS,
             ctx=dict(numeric=[r".*"], tiny=[r".*"], required=[r"q\d.*"],
                      ranges=[(r"q\d.*", ["1e6", "-1e9"])], bad_swaps=[]),
             commands=[["identifiability", "--configs", "configs.csv"]]),
        dict(name="study YAML", files={"study.yaml": os.path.join(seeds, "study.yaml")}, target="study.yaml",
             kinds=YAML_MUTATIONS,
             ctx=dict(required=["format", "job", "seeds"],
                      ranges=[("count", ["-5", "0", "1e308"]), ("first", ["-1", "1e308"]), ("shards", ["0", "-2"]),
                              ("throttle", ["-1", "0"]), ("joint-noise-deg", ["-1", "1e6"])]),
             commands=[["study", "run", "study.yaml", "-o", "out", "-j", "1"]]),
        dict(name="command-line options", files=dict(sim), target=None, kinds=None, ctx={}, commands=None),
    ]


# Command-line options: (argv before the option, option, bad values, good values)
CLI_OPTIONS = [
    (["simulate", "-o", "out", "--quiet"], "-n", ["0", "-5", "1e308", "nan", "abc", "2.5"], ["15"]),
    (["simulate", "-o", "out", "-n", "20", "--quiet"], "--noise-position-mm", ["0", "-1", "nan", "inf", "1e9"], ["0.1"]),
    (["simulate", "-o", "out", "-n", "20", "--quiet"], "--noise-rotation-deg", ["-1", "nan", "1e9"], ["0.02"]),
    (["simulate", "-o", "out", "-n", "20", "--quiet"], "--joint-noise-deg", ["-1", "nan", "1e6"], ["0.01"]),
    (["simulate", "-o", "out", "-n", "20", "--quiet"], "--payload-kg", ["-1", "nan", "1e308", "inf"], ["2"]),
    (["simulate", "-o", "out", "-n", "20", "--quiet"], "--error-length-mm", ["-1", "nan", "1e9", "inf"], ["1"]),
    (["simulate", "-o", "out", "-n", "20", "--quiet"], "--error-angle-deg", ["-1", "nan", "1e9", "inf"], ["0.1"]),
    (["simulate", "-o", "out", "-n", "20", "--quiet"], "--sessions", ["0", "-1", "1e9", "x"], ["2"]),
    (["simulate", "-o", "out", "-n", "20", "--quiet"], "--seed", ["-1", "abc", "1e308", "nan"], ["7"]),
    (["simulate", "-o", "out", "-n", "20", "--quiet", "--inject", "compliance:2"], "--values",
     ["nan", "1e308", "-5", "inf"], ["1e-5"]),
    (["calibrate", "sim/measurements.yaml", "--effects", "compliance:2", "-o", "out", "--quiet", "--no-plots"], "--holdout",
     ["nan", "-0.1", "1.5", "inf"], ["0.25"]),
    (["calibrate", "sim/measurements.yaml", "--effects", "compliance:2", "-o", "out", "--quiet", "--no-plots"],
     "--noise-position-mm", ["-1", "nan", "0", "1e9"], []),
    (["calibrate", "sim/measurements.yaml", "--effects", "compliance:2", "-o", "out", "--quiet", "--no-plots"], "--seed",
     ["-1", "nan", "1e308"], ["3"]),
    (["calibrate", "sim/measurements.yaml", "-o", "out", "--quiet", "--no-plots"], "--effects",
     ["compliance:0", "compliance:99", "cyclic:2/0", "cyclic:2/1e308", "compliance:nan", "bogus:1"], []),
    (["render", "-o", "out", "--seed", "1"], "--count", ["0", "-1", "nan", "1e308"], ["2"]),
    (["render", "-o", "out", "--count", "2"], "--joint-noise-deg", ["-1", "nan", "1e6"], ["0.02"]),
    (["render", "-o", "out", "--count", "2"], "--shard", ["5/2", "-1/2", "0/0", "nan/2", "1e308/2"], ["0/1"]),
    (["diagnose", "sim/measurements.yaml", "-o", "out", "--quiet", "--no-plots"], "--folds", ["1", "0", "nan", "1e9"], []),
    (["diagnose", "sim/measurements.yaml", "-o", "out", "--quiet", "--no-plots"], "--alpha", ["nan", "0", "2", "inf"], []),
    (["diagnose", "sim/measurements.yaml", "-o", "out", "--quiet", "--no-plots"], "--penalty", ["nan", "-1", "inf"], []),
    (["fk", "0", "0", "0", "0", "0", "0"], "", ["nan", "inf", "1e308", "abc", "1e6"], ["10"]),
]


# ---------------------------------------------------------------------------------------------- seed inputs
def run(orbcal, argv, cwd, timeout=300):
    return subprocess.run([orbcal] + argv, cwd=cwd, capture_output=True, timeout=timeout)


def make_seeds(orbcal, seeds, seed):
    """The seed inputs, each consumed once unmutated first (its command must exit 0)."""
    def need(argv):
        r = run(orbcal, argv, seeds)
        if r.returncode != 0:
            sys.exit("fuzz-inputs: seed input: orbcal %s failed (%d): %s" % (" ".join(argv), r.returncode,
                                                                          r.stderr.decode(errors="replace")))
    need(["simulate", "-o", "sim", "-n", "60", "--sessions", "2", "--payload-kg", "0", "1.25", "--inject",
          "compliance:2", "--values", "5e-5", "--seed", str(seed), "--joint-noise-deg", "0.002", "--quiet"])
    need(["calibrate", "sim/measurements.yaml", "--effects", "compliance:2", "-o", "cal", "--quiet", "--no-plots"])
    need(["render", "-o", "ds", "--scene", os.path.join(ROOT, "scenes", "quick_scene.yaml"), "--errors",
          os.path.join(ROOT, "scenes", "errors_cyclic.yaml"), "--count", "12", "--seed", str(seed)])
    need(["configs", "-n", "12", "--seed", str(seed), "-o", "configs.csv"])
    text = open(os.path.join(ROOT, "scenes", "quick_scene.yaml")).read()
    cam = re.search(r"camera:\n(?:  .*\n)+", text)
    with open(os.path.join(seeds, "scene_cam.yaml"), "w") as f:
        f.write(text[:cam.start()] + "camera: {file: cam.yaml}\n" + text[cam.end():])
    with open(os.path.join(seeds, "cam.yaml"), "w") as f:
        f.write("image_width: 640\nimage_height: 512\ncamera_name: quick\n"
                "camera_matrix: {rows: 3, cols: 3, data: [700.0, 0, 321.4, 0, 700.0, 254.2, 0, 0, 1]}\n"
                "distortion_model: plumb_bob\n"
                "distortion_coefficients: {rows: 1, cols: 5, data: [0.01, -0.02, 0, 0, 0]}\n"
                "rectification_matrix: {rows: 3, cols: 3, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}\n"
                "projection_matrix: {rows: 3, cols: 4, data: [700.0, 0, 321.4, 0, 0, 700.0, 254.2, 0, 0, 0, 1, 0]}\n")
    with open(os.path.join(seeds, "errors_effects.yaml"), "w") as f:
        f.write("format: orbcal-errors-1\n"
                "geometry: {random: {angle_sigma_deg: 0.3, length_sigma_mm: 1, seed: 1}}\n"
                "effects:\n"
                "  - {spec: \"compliance:2\", parameters: {c2: 5.0e-5}}\n"
                "  - {spec: \"thermal\", parameters: {alpha_thermal: 1.2e-5}}\n"
                "covariates:\n  payload_kg: 1.5\n"
                "  temperature: {start_C: 20.0, rise_C: 8.5, tau_s: 600.0}\n  sample_period_s: 15\n")
    with open(os.path.join(seeds, "study.yaml"), "w") as f:
        f.write("format: orbcal-study-1\nname: fuzz\njob: render\n"
                "options: {count: 2, scene: \"%s\", joint-noise-deg: 0.01}\n"
                "grid:\n  png-compression: [1]\n"
                "seeds: {first: 1, count: 1}\nshards: 1\n"
                "slurm: {throttle: 2, time: \"00:10:00\", mem: 1G, cpus_per_task: 1}\n"
                % os.path.join(ROOT, "scenes", "quick_scene.yaml"))


def check_seed_surfaces(orbcal, seeds, table, timeout):
    """Each surface's commands on its unmutated inputs: they must all exit 0, or the fuzz measures nothing."""
    bad = []
    for s in table:
        for argv in s["commands"] or []:
            folder = tempfile.mkdtemp(prefix="seedcheck-", dir=seeds)
            lay_out(folder, s["files"])
            r = run(orbcal, argv, folder, timeout)
            if r.returncode != 0:
                bad.append("%s: orbcal %s -> %d: %s" % (s["name"], " ".join(argv), r.returncode,
                                                       r.stderr.decode(errors="replace").strip()[:300]))
            shutil.rmtree(folder, ignore_errors=True)
    return bad


# ---------------------------------------------------------------------------------------------- cases
def lay_out(folder, files):
    for rel, src in files.items():
        dst = os.path.join(folder, rel)
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        shutil.copyfile(src, dst)


def make_case(number, surface, rng):
    """One mutation of the surface; None when the drawn generator does not apply."""
    if surface["target"] is None:
        prefix, opt, bad, good = rng.choice(CLI_OPTIONS)
        invalid = not good or rng.random() < 0.85
        value = rng.choice(bad if invalid else good)
        argv = prefix + ([opt, value] if opt else [value])
        kind = "option value" if invalid else "option value (valid)"
        case = Case(number, surface["name"], kind, invalid, "%s %s" % (opt or "joints_deg", value), None,
                    surface["files"], argv)
        case.option = opt or "joints_deg"
        return case
    kind, fn, invalid, binary = rng.choice(surface["kinds"])
    data = open(surface["files"][surface["target"]], "rb").read()
    out = fn(data if binary else data.decode(), rng, surface["ctx"])
    if out is None:
        return None
    new, detail = out
    if not binary:
        new = new.encode()
    if new == data:
        return None
    return Case(number, surface["name"], kind, invalid, detail, surface["target"], surface["files"],
                rng.choice(surface["commands"])), new


CRASH_TEXT = re.compile(rb"Segmentation|terminate called|what\(\):|Assertion|AddressSanitizer|core dumped|std::")
NONFINITE_JSON = re.compile(rb"\b(NaN|-?Infinity|-?inf|nan)\b")


def classify(case, code, stderr, folder):
    lines = [l for l in stderr.decode(errors="replace").splitlines() if l.strip()]
    notes = []
    for base, _, files in os.walk(folder):
        for f in files:
            if f.endswith(".json") and NONFINITE_JSON.search(open(os.path.join(base, f), "rb").read()):
                notes.append("non-finite number in " + os.path.relpath(os.path.join(base, f), folder))
    if code is None:
        return "hang", notes
    if code < 0 or code >= 128 or CRASH_TEXT.search(stderr):
        return "crash", notes
    if code == 0:
        return "silent acceptance", notes
    out = os.path.join(folder, "out")
    left = sorted(f for f in (os.listdir(out) if os.path.isdir(out) else []) if f in RESULT_FILES)
    if left:
        notes.append("refused but left " + ", ".join(left))
        return "unclear refusal", notes
    if case.target is None:  # an option: CLI11 adds "Run with --help for more information."
        core = [l for l in lines if not l.startswith("Run with --help")]
        return ("clean refusal" if len(core) == 1 and case.option.lstrip("-") in core[0]
                else "unclear refusal"), notes
    name = os.path.basename(case.target)
    clean = len(lines) == 1 and lines[0].startswith("orbcal:") and name in lines[0]
    return ("clean refusal" if clean else "unclear refusal"), notes


def run_case(orbcal, work, timeout, case, content):
    folder = os.path.join(work, "case-%05d" % case.number)
    os.makedirs(folder)
    lay_out(folder, case.files)
    if case.target is not None:
        with open(os.path.join(folder, case.target), "wb") as f:
            f.write(content)
    start = time.monotonic()
    try:
        p = subprocess.Popen([orbcal] + case.argv, cwd=folder, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             start_new_session=True)
        try:
            _, err = p.communicate(timeout=timeout)
            code = p.returncode
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, 9)
            _, err = p.communicate()
            code = None
    finally:
        seconds = time.monotonic() - start
    cls, notes = classify(case, code, err, folder)
    first = err.decode(errors="replace").strip().splitlines()
    shutil.rmtree(folder, ignore_errors=True)
    return dict(case=case.number, surface=case.surface, kind=case.kind, clearly_invalid=case.invalid,
                detail=case.detail, command="orbcal " + " ".join(case.argv), exit=code, seconds=round(seconds, 2),
                outcome=cls, notes="; ".join(notes), stderr_lines=len(first), stderr=(first[0] if first else "")[:300])


def summary(rows, table):
    names = [s["name"] for s in table]
    head = "| surface | cases | " + " | ".join(CLASSES) + " | of which clearly invalid |"
    out = [head, "|" + "---|" * (len(CLASSES) + 3)]
    for name in names + ["all"]:
        rs = [r for r in rows if name in ("all", r["surface"])]
        counts = [sum(r["outcome"] == c for r in rs) for c in CLASSES]
        invalid = sum(r["outcome"] == "silent acceptance" and r["clearly_invalid"] for r in rs)
        label = "**all**" if name == "all" else name
        out.append("| %s | %d | %s | %d |" % (label, len(rs), " | ".join(str(c) for c in counts), invalid))
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--orbcal", default=os.path.join(ROOT, "build", "tools", "orbcal"))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--count", type=int, default=1300)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds before a case counts as a hang")
    ap.add_argument("--csv", default="fuzz-inputs.csv", help="every case, one row")
    ap.add_argument("--keep", action="store_true", help="keep the work folder")
    a = ap.parse_args()
    orbcal = os.path.abspath(a.orbcal)
    if not os.access(orbcal, os.X_OK):
        sys.exit("fuzz-inputs: %s: not an executable (build orbcal first, or give --orbcal)" % orbcal)
    work = tempfile.mkdtemp(prefix="orbcal-fuzz-")
    seeds = os.path.join(work, "seeds")
    os.makedirs(seeds)
    try:
        make_seeds(orbcal, seeds, a.seed)
        table = surfaces(seeds)
        for s in table:
            s["files"] = dict(s["files"])
        bad = check_seed_surfaces(orbcal, seeds, table, a.timeout)
        if bad:
            sys.exit("fuzz-inputs: the unmutated inputs are refused, so the fuzz would measure nothing:\n  "
                     + "\n  ".join(bad))
        rng = random.Random(a.seed)
        cases = []
        while len(cases) < a.count:
            surface = table[len(cases) % len(table)]  # round robin: every surface gets its share
            made = make_case(len(cases), surface, rng)
            if made is None:
                continue
            case, content = (made, None) if isinstance(made, Case) else made
            cases.append((case, content))
        rows, start = [], time.monotonic()
        with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
            futures = [pool.submit(run_case, orbcal, work, a.timeout, c, content) for c, content in cases]
            for n, f in enumerate(concurrent.futures.as_completed(futures), 1):
                rows.append(f.result())
                bad_now = [r for r in rows if r["outcome"] in ("crash", "hang") or r["notes"].startswith("non-finite")
                           or (r["outcome"] == "silent acceptance" and r["clearly_invalid"])]
                if n % 20 == 0 or n == len(futures):
                    print("fuzz-inputs: %d/%d cases, %.0f s, %d findings" % (n, len(futures), time.monotonic() - start,
                                                                            len(bad_now)), flush=True)
        rows.sort(key=lambda r: r["case"])
        with open(a.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            w.writeheader()
            w.writerows(rows)
        print("\n" + summary(rows, table) + "\n")
        findings = [r for r in rows if r["outcome"] in ("crash", "hang") or "non-finite" in r["notes"]
                    or (r["outcome"] == "silent acceptance" and r["clearly_invalid"])]
        for r in findings:
            print("FINDING case %d (%s, %s: %s): %s, exit %s: %s" % (r["case"], r["surface"], r["kind"], r["detail"],
                                                                   r["outcome"], r["exit"], r["stderr"]))
        print("fuzz-inputs: %d cases (seed %d) against %s; every case in %s; %d findings"
              % (len(rows), a.seed, orbcal, a.csv, len(findings)))
        return 1 if findings else 0
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
