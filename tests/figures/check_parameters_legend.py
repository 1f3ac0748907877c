#!/usr/bin/env python3
"""parameters.png (tools/plot_report.py parameters) names only the colours it draws: its legends and its
title mention held (grey) and relative (orange) parameters only where estimates.csv has such rows.

  check_parameters_legend.py [WORK_DIR]     exit 1 on a failure, one line per failure
"""
import csv
import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "tools"))
import plot_report  # noqa: E402

COLUMNS = ["parameter", "unit", "estimate", "sigma", "held", "class", "truth"]


def write_estimates(path, kinds):
    """An estimates.csv with one mm parameter per kind in `kinds` (free, relative, held)."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(COLUMNS)
        for i, kind in enumerate(kinds):
            w.writerow(["d%d" % (i + 1), "mm", "%.2f" % (0.1 * (i + 1)), "0.05", "1" if kind == "held" else "0",
                        "relative" if kind == "relative" else "independent", ""])


def drawn(work, name, kinds):
    """(legend texts, title) of parameters.png drawn from such a file."""
    csv_path = os.path.join(work, name + ".csv")
    write_estimates(csv_path, kinds)
    fig = plot_report.parameters(csv_path, os.path.join(work, name + ".png"))
    ax = fig.axes[0]
    return [t.get_text() for t in ax.get_legend().get_texts()], ax.get_title()


def main():
    work = sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp(prefix="orbcal-legend-")
    os.makedirs(work, exist_ok=True)
    failures = []
    cases = {"free only": ["free", "free"], "free and held": ["free", "held"],
             "all three": ["free", "relative", "held"]}
    for name, kinds in cases.items():
        legend, title = drawn(work, name.replace(" ", "_"), kinds)
        expect_held, expect_relative = "held" in kinds, "relative" in kinds
        checks = [("held in the legend", any("held" in t for t in legend), expect_held),
                  ("combination in the legend", any("combination" in t for t in legend), expect_relative),
                  ("grey in the title", "grey" in title, expect_held),
                  ("orange in the title", "orange" in title, expect_relative),
                  ("estimates in the legend", any("estimate" in t for t in legend), True)]
        for what, found, expected in checks:
            if found != expected:
                failures.append("%s: %s is %s, expected %s (legend %s, title %r)" % (name, what, found, expected, legend, title))
    for f in failures:
        print(f)
    print("%d failure(s)" % len(failures) if failures else "parameters.png names only the colours it draws")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
