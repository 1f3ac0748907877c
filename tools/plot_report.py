#!/usr/bin/env python3
"""Figures of orbcal's experiment reports, drawn with matplotlib from the CSV files orbcal writes.

  plot_report.py boxplot  validation_errors.csv out.png [model ...]   # Wang et al. 2023 Figs. 7 and 9 style
  plot_report.py curve    fig8.csv out.png [--x COL LABEL] [--y COL LABEL]   # Wang et al. 2023 Fig. 8 style
                                                   # (default x: n, identification configurations; y: avg_position_mm)
  plot_report.py residuals residuals.csv COLUMN LABEL out.png          # orbcal diagnose: held-out errors vs a variable
  plot_report.py components residuals.csv COLUMN LABEL out.png         # orbcal diagnose: what the selected model leaves
  plot_report.py samples samples.csv out.png          # orbcal calibrate: per-image errors before/after, outliers named
  plot_report.py parameters estimates.csv out.png     # orbcal calibrate: each parameter with its 1-sigma (and truth)
"""
import csv
import sys
from collections import OrderedDict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def boxplot(csv_path, png_path, models):
    rows = read_rows(csv_path)
    data = OrderedDict()
    for r in rows:
        data.setdefault(r["model"], []).append(r)
    names = [m for m in (models or data.keys()) if m in data]
    if not names:
        sys.exit(f"plot_report.py: {csv_path}: no rows for models {models}")
    panels = [("position_mm", "position error (mm)"), ("x_deg", "X orientation error (deg)"),
              ("y_deg", "Y orientation error (deg)"), ("z_deg", "Z orientation error (deg)")]
    fig, axes = plt.subplots(2, 2, figsize=(max(8, 1.3 * len(names) + 4), 8))
    for ax, (key, label) in zip(axes.flat, panels):
        ax.boxplot([[float(r[key]) for r in data[n]] for n in names], showfliers=True)
        ax.set_xticks(range(1, len(names) + 1))
        ax.set_xticklabels(names, rotation=35, ha="right", fontsize=8)
        ax.set_ylabel(label)
        ax.set_yscale("log")
        ax.grid(True, axis="y", alpha=0.3)
    fig.suptitle("Validation pose errors (log scale)")
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


def curve(csv_path, png_path, xcol="n", xlabel="identification configurations", ycol="avg_position_mm",
          ylabel="mean validation position error (mm)"):
    rows = read_rows(csv_path)
    series = OrderedDict()
    for r in rows:
        series.setdefault(r["method"], {}).setdefault(float(r[xcol]), []).append(float(r[ycol]))
    fig, ax = plt.subplots(figsize=(8, 5))
    for method, by_n in series.items():
        ns = sorted(by_n)
        means = [sum(by_n[n]) / len(by_n[n]) for n in ns]
        lo = [min(by_n[n]) for n in ns]
        hi = [max(by_n[n]) for n in ns]
        ax.plot(ns, means, marker="o", ms=3, label=method)
        ax.fill_between(ns, lo, hi, alpha=0.12)
    floor = [float(r["floor_mm"]) for r in rows if r.get("floor_mm")]
    if floor:
        ax.axhline(sum(floor) / len(floor), color="k", ls="--", lw=1, label="floor (control noise)")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_yscale("log")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


def residuals(csv_path, column, label, png_path):
    rows = read_rows(csv_path)
    x = [float(r[column]) for r in rows]
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.scatter(x, [float(r["base_mm"]) for r in rows], s=10, alpha=0.7, label="geometry + registration")
    ax.scatter(x, [float(r["selected_mm"]) for r in rows], s=10, alpha=0.7, label="selected model")
    ax.set_xlabel(label)
    ax.set_ylabel("held-out position error (mm)")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


def components(csv_path, column, label, png_path):
    """The selected model's held-out residual components (x, y, z, mm) against one variable."""
    rows = read_rows(csv_path)
    x = [float(r[column]) for r in rows]
    fig, ax = plt.subplots(figsize=(8, 5))
    for c in ("x", "y", "z"):
        ax.scatter(x, [float(r["selected_%s_mm" % c]) for r in rows], s=10, alpha=0.7, label=c)
    ax.axhline(0.0, color="black", linewidth=0.8)
    ax.set_xlabel(label)
    ax.set_ylabel("held-out residual of the selected model (mm)")
    ax.grid(True, alpha=0.3)
    ax.legend(title="component")
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


def samples(csv_path, png_path):
    rows = read_rows(csv_path)
    fig, ax = plt.subplots(figsize=(10, 5))
    for which, marker in (("identification", "o"), ("held-out", "s")):
        sel = [(i, r) for i, r in enumerate(rows) if r["set"] == which]
        if not sel:
            continue
        xs = [i for i, _ in sel]
        ax.scatter(xs, [float(r["before_mm"]) for _, r in sel], marker=marker, s=14, alpha=0.6,
                   label=which + ": nominal arm")
        ax.scatter(xs, [float(r["after_mm"]) for _, r in sel], marker=marker, s=14, alpha=0.8,
                   label=which + ": calibrated")
    flagged = [(i, r) for i, r in enumerate(rows) if r["outlier"] == "1"]
    if len(flagged) <= 10:  # a few named; many: the fit as a whole is off, the report says why
        for i, r in flagged:
            ax.annotate(r["image"], (i, float(r["after_mm"])), fontsize=7, color="red", rotation=30)
    else:
        ax.text(0.01, 0.02, "%d of %d images inconsistent: see the report" % (len(flagged), len(rows)),
                transform=ax.transAxes, color="red", fontsize=9)
    ax.set_xlabel("image (dataset order)")
    ax.set_ylabel("position error against the measured pose (mm)")
    ax.set_yscale("log")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Per-image errors before and after calibration (inconsistent images named in red)")
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


def parameters(csv_path, png_path):
    rows = read_rows(csv_path)
    units = list(OrderedDict.fromkeys(r["unit"] for r in rows))
    fig, axes = plt.subplots(len(units), 1, figsize=(11, 3.2 * len(units)), squeeze=False)
    for ax, unit in zip(axes[:, 0], units):
        sel = [r for r in rows if r["unit"] == unit]
        xs = range(len(sel))
        est = [float(r["estimate"]) for r in sel]
        sig = [float(r["sigma"]) if r["sigma"] else 0.0 for r in sel]
        ax.errorbar(xs, est, yerr=sig, fmt="o", ms=3, capsize=2, label="estimate +- 1 sigma")
        truth = [(i, float(r["truth"])) for i, r in enumerate(sel) if r.get("truth")]
        if truth:
            ax.scatter([i for i, _ in truth], [t for _, t in truth], marker="x", color="k", s=18, label="injected")
        held = [i for i, r in enumerate(sel) if r["held"] == "1"]
        for i in held:
            ax.axvspan(i - 0.4, i + 0.4, color="grey", alpha=0.2)
        ax.set_xticks(list(xs))
        ax.set_xticklabels([r["parameter"] for r in sel], rotation=90, fontsize=7)
        ax.set_ylabel(unit)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    axes[0, 0].set_title("Identified parameter errors (grey: held as unidentifiable)")
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


def main(argv):
    if len(argv) >= 4 and argv[1] in ("samples", "parameters"):
        (samples if argv[1] == "samples" else parameters)(argv[2], argv[3])
        return
    if len(argv) >= 6 and argv[1] in ("residuals", "components"):
        (residuals if argv[1] == "residuals" else components)(argv[2], argv[3], argv[4], argv[5])
        return
    if len(argv) < 4 or argv[1] not in ("boxplot", "curve"):
        sys.exit(__doc__)
    if argv[1] == "boxplot":
        boxplot(argv[2], argv[3], argv[4:])
    else:
        axes, positional, rest = {}, [], argv[2:]
        while rest:  # --x/--y COL LABEL anywhere among CSV and PNG
            if rest[0] in ("--x", "--y") and len(rest) >= 3:
                axes[rest[0]] = (rest[1], rest[2])
                rest = rest[3:]
            else:
                positional.append(rest[0])
                rest = rest[1:]
        if len(positional) != 2:
            sys.exit(__doc__)
        x = axes.get("--x", ("n", "identification configurations"))
        y = axes.get("--y", ("avg_position_mm", "mean validation position error (mm)"))
        curve(positional[0], positional[1], x[0], x[1], y[0], y[1])


if __name__ == "__main__":
    main(sys.argv)
