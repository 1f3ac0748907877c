#!/usr/bin/env python3
"""Joint-angle corrections of an orbcal effects file: the reference implementation of docs/export.md.

orbcal calibrate writes effects.yaml (format orbcal-effects-1) beside the calibrated model. Joint N of
the arm stands at q[N] + dq[N], q the joint readings; joint_corrections() below computes dq from the
file's joint_angle entries, compensate() the command that puts the joints where they are wanted.

Run as a program it reads a CSV of configurations and writes their corrections:

    apply_effects.py EFFECTS.yaml SAMPLES.csv > corrections.csv

SAMPLES.csv: a header, then one row per configuration with the columns q1..qN (rad; m for a prismatic
joint) and, where the effects read them, tau1..tauN (the actuators' torques, N m; a prismatic joint's
force, N) and dir1..dirN (the approach directions, +1, -1 or 0). The output has the columns dq1..dqN
(rad; m for a prismatic joint), every number with 17 significant digits.
Needs PyYAML (Debian: python3-yaml).
"""
import csv
import math
import sys

import yaml

# A prismatic joint's cyclic error repeats with the lead of its screw, as the formula states it:
# sin(k * 2 * pi * qN / 0.005).
LEAD_SCREW_M = 0.005


def legendre(x, order):
    """[P1(x), ..., P_order(x)], the Legendre polynomials (Bonnet's recursion)."""
    values, p0, p1 = [], 1.0, x
    for k in range(1, order + 1):
        values.append(p1)
        p0, p1 = p1, ((2 * k + 1) * x * p1 - k * p0) / (k + 1)
    return values


def spec_joints(spec):
    """The joints (from 0) and the range (lo, hi) or None of a spec such as "empirical:7,6/3@-1.5..2"."""
    body = spec.split(":", 1)[1]
    rng = None
    if "@" in body:
        body, text = body.split("@", 1)
        lo, hi = text.split("..")
        rng = (float(lo), float(hi))
    joints = [int(j) - 1 for j in body.split("/", 1)[0].split(",")]
    return joints, rng


def joint_corrections(effects, q, tau=None, direction=None, arm_joints=None):
    """dq (rad, one per joint) of the joint_angle entries of effects.yaml's `effects` list.

    q: the joint readings (rad); tau: the torques the actuators apply (N m, about each joint's axis;
    only compliance and empirical_torque read them); direction: the direction each joint approached
    from, +1, -1 or 0 (only backlash reads it); arm_joints: the file's `joints` list (a prismatic joint's
    cyclic error is periodic in its screw's lead). Entries that apply to the chain are skipped.
    """
    dq = [0.0] * len(q)
    for e in effects:
        if e["applies_to"] != "joint_angle":
            continue
        kind, j = e["effect"], e["joint"] - 1
        p = [float(x["value"]) for x in e["parameters"]]
        joints, rng = spec_joints(e["spec"])
        if kind == "compliance":  # the joint yields to its load: -(c tau + c3 tau^3)
            t = tau[j]
            dq[j] -= p[0] * t + (p[1] * t ** 3 if len(p) > 1 else 0.0)
        elif kind == "cyclic":  # pairs (sin k, cos k), k = 1, 2, ...; a lead screw's travel: 2 pi q / lead
            phase = 2 * math.pi * q[j] / LEAD_SCREW_M if arm_joints and arm_joints[j]["type"] == "prismatic" else q[j]
            for k in range(1, len(p) // 2 + 1):
                dq[j] += p[2 * k - 2] * math.sin(k * phase) + p[2 * k - 1] * math.cos(k * phase)
        elif kind == "scale":
            dq[j] += p[0] * q[j]
        elif kind == "backlash":
            dq[j] += p[0] * direction[j]
        elif kind == "coupling":  # joint j off in proportion to the other joint's angle
            dq[j] += p[0] * q[joints[1]]
        elif kind in ("empirical", "empirical_torque"):  # Legendre series on the fitted range
            x = (tau if kind == "empirical_torque" else q)[joints[1]]
            lo, hi = rng
            s = (2.0 * x - lo - hi) / (hi - lo)
            dq[j] += sum(c * pk for c, pk in zip(p, legendre(s, len(p))))
        else:
            raise ValueError(f"effect {kind!r} ({e['spec']}): no formula known to this implementation")
    return dq


def compensate(effects, q_wanted, tau=None, direction=None, iterations=10, arm_joints=None):
    """The command c with c + dq(c) = q_wanted (fixed-point iteration; dq changes slowly with q)."""
    c = list(q_wanted)
    for _ in range(iterations):
        dq = joint_corrections(effects, c, tau, direction, arm_joints)
        c = [w - d for w, d in zip(q_wanted, dq)]
    return c


def main(argv):
    if len(argv) != 3:
        sys.stderr.write(__doc__)
        return 2
    with open(argv[1], encoding="utf-8") as f:
        model = yaml.safe_load(f)
    if model.get("format") != "orbcal-effects-1":
        sys.stderr.write(f"{argv[1]}: format: expected orbcal-effects-1\n")
        return 1
    n = len(model["joints"])
    out = csv.writer(sys.stdout, lineterminator="\n")
    out.writerow([f"dq{j + 1}" for j in range(n)])
    with open(argv[2], encoding="utf-8", newline="") as f:
        for row in csv.DictReader(f):
            def column(name):
                return [float(row[f"{name}{j + 1}"]) for j in range(n)] if f"{name}1" in row else None
            dq = joint_corrections(model["effects"], column("q"), column("tau"), column("dir"), model["joints"])
            out.writerow([repr(v) for v in dq])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
