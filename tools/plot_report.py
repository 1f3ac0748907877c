#!/usr/bin/env python3
"""Figures of orbcal's experiment reports, drawn with matplotlib from the CSV files orbcal writes.

  plot_report.py boxplot  validation_errors.csv out.png [model ...]   # Wang et al. 2023 Figs. 7 and 9 style
  plot_report.py curve    fig8.csv out.png [--x COL LABEL] [--y COL LABEL]   # Wang et al. 2023 Fig. 8 style
                                                   # (default x: n, identification configurations; y: avg_position_mm)
  plot_report.py residuals residuals.csv COLUMN LABEL out.png [--floor MM]   # orbcal diagnose: held-out errors vs a variable
  plot_report.py components residuals.csv COLUMN LABEL out.png [--of base|selected] [--floor MM]
                                                   # orbcal diagnose: signed residual components vs a variable
                                                   # (--floor: the noise, drawn as a dashed line; magnitudes: the
                                                   # RMS the noise alone gives, components: +- 1 sigma per axis)
  plot_report.py samples samples.csv out.png          # orbcal calibrate: per-image errors before/after, outliers named
  plot_report.py parameters estimates.csv out.png     # orbcal calibrate: each parameter with its 1-sigma (and truth)
  plot_report.py heldout heldout.csv out.png          # orbcal calibrate (measured data): held-out errors, noise floor
  plot_report.py --batch [--fds 3,4] < figures.txt   # several figures in one process (orbcal draws a command's
                                                   # figures so): one figure per line of stdin, its arguments as
                                                   # above, shell-quoted; one answer line each on stdout, at once:
                                                   # "ok", "missing: WHY" (no matplotlib) or "error: WHY";
                                                   # --fds: further sockets, each served alike by a process
                                                   # forked after matplotlib's import
"""
import csv
import io
import os
import shlex
import sys
from collections import OrderedDict


def idle_while_warming(idle):
    """--batch: importing matplotlib and the warm-up run at the idle priority (SCHED_IDLE: on a core
    orbcal's analysis, started beside this process, leaves free) where the process may return to the
    normal one for the figures, asked for once orbcal has finished (root, or RLIMIT_NICE allowing nice 0);
    elsewhere at the normal priority throughout, so that figures never wait behind other work."""
    if not hasattr(os, "SCHED_IDLE"):
        return
    try:
        import resource

        may_return = os.geteuid() == 0 or resource.getrlimit(resource.RLIMIT_NICE)[0] >= 20
        if may_return or not idle:
            os.sched_setscheduler(0, os.SCHED_IDLE if idle else os.SCHED_OTHER, os.sched_param(0))
    except (OSError, ValueError, ImportError):
        pass  # the priority is a speed-up only


if sys.argv[1:2] == ["--batch"]:
    idle_while_warming(True)

# numpy's OpenBLAS (Debian's pthread build, where installed) would start a thread per core that waits for
# work by yielding in a loop: a batch of 8 figures spent 1.7 s of system time so, on cores orbcal and the
# other figure process need. These figures use no BLAS work worth a second thread. Set before numpy loads.
for _threads in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_threads, "1")

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image  # matplotlib's own PNG writer (Pillow is one of its dependencies)
    MISSING = None
except ImportError as missing:  # one figure: the error as before; a batch answers each figure with it
    if sys.argv[1:2] != ["--batch"]:
        raise
    MISSING = "%s: %s" % (type(missing).__name__, missing)

# Single-panel figures: fixed margins (inches) with room for the usual tick and axis labels.
# tight_layout measures every tick label before the figure is drawn (a fifth of a figure's time);
# save() measures them once drawn and falls back to it only where a label would be cut.
MARGINS_IN = {"left": 0.9, "right": 0.2, "bottom": 0.65, "top": 0.25, "title": 0.3}
DPI = 110


def cut_off(fig, renderer):
    """Whether any axes' tick labels, axis labels, title or texts reach outside the drawn figure:
    what tight_layout makes room for (the data are clipped to the axes, a legend placed inside them)."""
    width, height = fig.bbox.width, fig.bbox.height
    for ax in fig.axes:
        box = ax.get_tightbbox(renderer, bbox_extra_artists=list(ax.texts), for_layout_only=True)
        if box is not None and (box.x0 < 0 or box.y0 < 0 or box.x1 > width or box.y1 > height):
            return True
    return False


def save(fig, png_path, fixed_margins=True):
    """The figure as a PNG at DPI, drawn once: fixed margins (single panels) or tight_layout (several
    panels, and any figure whose labels the fixed margins would cut, drawn again). Written as RGB at
    zlib level 3: the figures are opaque, and on the real iiwa7's eight figures this took 0.16 s and
    566 KB against savefig's RGBA at level 6, 0.29 s and 582 KB."""
    fig.set_dpi(DPI)
    if fixed_margins:
        w, h = fig.get_size_inches()
        top = MARGINS_IN["top"] + (MARGINS_IN["title"] if any(ax.get_title() for ax in fig.axes) else 0.0)
        fig.subplots_adjust(left=MARGINS_IN["left"] / w, right=1 - MARGINS_IN["right"] / w,
                            bottom=MARGINS_IN["bottom"] / h, top=1 - top / h)
        fig.canvas.draw()
    if not fixed_margins or cut_off(fig, fig.canvas.get_renderer()):
        fig.tight_layout()
        fig.canvas.draw()
    width, height = fig.canvas.get_width_height(physical=True)
    rgba = Image.frombuffer("RGBA", (width, height), fig.canvas.buffer_rgba(), "raw", "RGBA", 0, 1)
    rgba.convert("RGB").save(png_path, format="png", compress_level=3, dpi=(DPI, DPI))


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
    save(fig, png_path, fixed_margins=False)


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
    save(fig, png_path)


def column_values(rows, csv_path, column):
    """The values of one column as numbers; a missing column is a one-line error naming the file. A
    joint's value is q<j>_deg for a revolute joint and q<j>_mm for a prismatic one (orbcal diagnose's
    residuals.csv labels each by its joint's type), its effort tau<j>_Nm or tau<j>_N."""
    if rows and column not in rows[0]:
        sys.exit(f"plot_report.py: {csv_path}: no column '{column}' (columns: {', '.join(rows[0])})")
    return [float(r[column]) for r in rows]


def residuals(csv_path, column, label, png_path, floor=None):
    rows = read_rows(csv_path)
    x = column_values(rows, csv_path, column)
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.scatter(x, [float(r["base_mm"]) for r in rows], s=10, alpha=0.7, color="C0", label="geometry + registration")
    ax.scatter(x, [float(r["selected_mm"]) for r in rows], s=10, alpha=0.7, color="C1", label="selected model")
    if floor is not None:
        ax.axhline(floor, color="k", ls="--", lw=1, label="noise floor (held-out RMS the noise alone gives)")
    ax.set_xlabel(label)
    ax.set_ylabel("held-out position error (mm)")
    ax.grid(True, alpha=0.3)
    ax.legend()
    save(fig, png_path)


def components(csv_path, column, label, png_path, of="selected", floor=None):
    """One model's held-out residual components (x, y, z, mm, signed) against one variable."""
    rows = read_rows(csv_path)
    x = column_values(rows, csv_path, column)
    fig, ax = plt.subplots(figsize=(8, 5))
    for i, c in enumerate(("x", "y", "z")):
        ax.scatter(x, [float(r["%s_%s_mm" % (of, c)]) for r in rows], s=10, alpha=0.7, color="C%d" % (i + 2), label=c)
    ax.axhline(0.0, color="black", linewidth=0.8)
    if floor is not None:
        ax.axhline(floor, color="k", ls="--", lw=1, label="noise, +- 1 sigma per axis")
        ax.axhline(-floor, color="k", ls="--", lw=1)
    ax.set_xlabel(label)
    model = "geometry + registration" if of == "base" else "the selected model"
    ax.set_ylabel("held-out residual of %s (mm)" % model)
    ax.grid(True, alpha=0.3)
    ax.legend(title="component")
    save(fig, png_path)


def samples(csv_path, png_path):
    """Blue: the nominal arm, green: calibrated; circles identification, squares held out. Red means one
    thing only: an image the consistency check flags (ringed and named)."""
    rows = read_rows(csv_path)
    fig, ax = plt.subplots(figsize=(10, 5))
    for which, marker in (("identification", "o"), ("held-out", "s")):
        sel = [(i, r) for i, r in enumerate(rows) if r["set"] == which]
        if not sel:
            continue
        xs = [i for i, _ in sel]
        ax.scatter(xs, [float(r["before_mm"]) for _, r in sel], marker=marker, s=14, alpha=0.6, color="C0",
                   label=which + ": nominal arm")
        ax.scatter(xs, [float(r["after_mm"]) for _, r in sel], marker=marker, s=14, alpha=0.8, color="C2",
                   label=which + ": calibrated")
    flagged = [(i, r) for i, r in enumerate(rows) if r["outlier"] == "1"]
    if flagged:
        ax.scatter([i for i, _ in flagged], [float(r["after_mm"]) for _, r in flagged], s=60, facecolors="none",
                   edgecolors="red", linewidths=1.2, label="inconsistent (calibrated)")
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
    ax.set_title("Per-image errors before (blue) and after (green) calibration; inconsistent images in red")
    save(fig, png_path)


def parameters(csv_path, png_path):
    """Each parameter's estimate +- 1 sigma: blue where determined on its own, orange where it lies in an
    unidentifiable combination (class relative: only the combination is determined, the value alone may
    sit several sigma from the truth), grey where held as unidentifiable (kept at its nominal value)."""
    rows = read_rows(csv_path)
    units = list(OrderedDict.fromkeys(r["unit"] for r in rows))
    fig, axes = plt.subplots(len(units), 1, figsize=(11, 3.2 * len(units)), squeeze=False)
    for ax, unit in zip(axes[:, 0], units):
        sel = [r for r in rows if r["unit"] == unit]
        xs = range(len(sel))
        kinds = (("free", "C0", "estimate +- 1 sigma"),
                 ("relative", "C1", "in an unidentifiable combination"),
                 ("held", "grey", "held as unidentifiable (nominal)"))
        for kind, colour, text in kinds:
            idx = [i for i, r in enumerate(sel) if parameter_kind(r) == kind]
            if not idx:
                continue
            est = [float(sel[i]["estimate"]) for i in idx]
            sig = [float(sel[i]["sigma"]) if sel[i]["sigma"] else 0.0 for i in idx]
            ax.errorbar(idx, est, yerr=sig, fmt="o", ms=3, capsize=2, color=colour, label=text)
        truth = [(i, float(r["truth"])) for i, r in enumerate(sel) if r.get("truth")]
        if truth:
            ax.scatter([i for i, _ in truth], [t for _, t in truth], marker="x", color="k", s=18, label="injected")
        for i, r in enumerate(sel):
            if parameter_kind(r) == "held":
                ax.axvspan(i - 0.4, i + 0.4, color="grey", alpha=0.2)
        ax.set_xticks(list(xs))
        ax.set_xticklabels([r["parameter"] for r in sel], rotation=90, fontsize=7)
        ax.set_ylabel(unit)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    axes[0, 0].set_title(parameters_title({parameter_kind(r) for r in rows}))
    save(fig, png_path, fixed_margins=False)
    return fig


def parameters_title(kinds):
    """The figure's title, naming only the colours its panels use (`kinds`: parameter_kind's values)."""
    notes = [text for kind, text in (("held", "grey: held as unidentifiable"),
                                     ("relative", "orange: only a combination is determined")) if kind in kinds]
    return "Identified parameter errors" + (" (%s)" % "; ".join(notes) if notes else "")


def parameter_kind(row):
    """held, relative (in an unidentifiable combination) or free, from estimates.csv's held and class."""
    if row["held"] == "1":
        return "held"
    return "relative" if row.get("class") == "relative" else "free"


def split_options(args, names, arity):
    """`args` as (positional arguments, {NAME: [values]}): each --NAME (NAME in `names`) anywhere takes
    the `arity` arguments after it; exits with the usage on an unknown or incomplete option."""
    positional, found = [], {}
    while args:
        if args[0].startswith("--"):
            if args[0][2:] not in names or len(args) < 1 + arity:
                sys.exit(__doc__)
            found[args[0][2:]] = args[1:1 + arity]
            args = args[1 + arity:]
        else:
            positional.append(args[0])
            args = args[1:]
    return positional, found


def heldout(csv_path, png_path):
    """Per held-out sample: position error (and rotation, where measured), nominal and calibrated, with
    the noise floor (the RMS the measurement noise alone gives)."""
    rows = read_rows(csv_path)
    panels = [("mm", "position error (mm)")]
    if any(r["after_deg"] for r in rows):
        panels.append(("deg", "rotation error (deg)"))
    fig, axes = plt.subplots(len(panels), 1, figsize=(10, 3.6 * len(panels)), squeeze=False)
    for ax, (unit, label) in zip(axes[:, 0], panels):
        sel = [r for r in rows if r["after_" + unit]]
        xs = [int(r["sample"]) for r in sel]
        ax.scatter(xs, [float(r["before_" + unit]) for r in sel], s=14, alpha=0.7, label="nominal arm, registration fitted")
        ax.scatter(xs, [float(r["after_" + unit]) for r in sel], s=14, alpha=0.8, label="calibrated")
        ax.axhline(float(sel[0]["floor_" + unit]), color="k", ls="--", lw=1, label="noise floor (RMS of the noise alone)")
        ax.set_ylabel(label)
        ax.set_yscale("log")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    axes[-1, 0].set_xlabel("held-out sample")
    axes[0, 0].set_title("Held-out errors before and after calibration")
    save(fig, png_path, fixed_margins=len(panels) == 1)


def one_line(text):
    return " ".join(str(text).split())


def warm_up():
    """A small figure drawn into memory: the fonts, the text layout and the PNG writer are loaded
    before the first figure is asked for (orbcal starts the batch while it computes)."""
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.scatter([0.0, 1.0], [0.0, 1.0], s=10, alpha=0.7, label="x")
    ax.axhline(0.5, color="k", ls="--", lw=1)
    ax.set_xlabel("x (mm)")
    ax.set_yscale("log")
    ax.grid(True, alpha=0.3)
    ax.legend(title="t", fontsize=8)
    save(fig, io.BytesIO())
    plt.close(fig)


def batch(lines, answer, more_fds=()):
    """Draws the figure of each line (plot_report.py's arguments, shell-quoted) and answers each with
    one line: ok, missing: WHY or error: WHY (the message a single run would end with). Each descriptor
    of `more_fds` is a further socket with its own requests, served by a process forked once matplotlib
    is imported and warmed up (the import's time is paid once, the figures drawn side by side)."""
    if not MISSING:
        warm_up()
    for fd in more_fds:
        if os.fork() == 0:
            # The caller sees a drawer gone only when no process holds its socket: this one lets go of
            # the others' (stdin and stdout become /dev/null).
            devnull = os.open(os.devnull, os.O_RDWR)
            for std in (0, 1):
                os.dup2(devnull, std)
            for other in [devnull] + [f for f in more_fds if f != fd]:
                os.close(other)
            try:
                with os.fdopen(fd, "r") as requests, os.fdopen(os.dup(fd), "w") as answers:
                    answer_each(requests, lambda text: (answers.write(text + "\n"), answers.flush()))
            finally:
                os._exit(0)
    for fd in more_fds:
        os.close(fd)
    answer_each(lines, answer)


def answer_each(lines, answer):
    first = True
    for line in lines:
        if first:
            idle_while_warming(False)  # a figure is asked for: orbcal has finished
            first = False
        if not line.strip():
            continue
        if MISSING:
            answer("missing: " + MISSING)
            continue
        try:
            main(["plot_report.py"] + shlex.split(line))
            answer("ok")
        except SystemExit as e:  # a usage error or a named one (a missing column)
            answer("error: " + ("plot_report.py: bad arguments: " + one_line(line) if e.code == __doc__ else one_line(e.code)))
        except Exception as e:  # noqa: BLE001 - any error of one figure is its answer, the next figure is drawn
            answer("error: %s: %s" % (type(e).__name__, one_line(e)))
        finally:
            plt.close("all")  # a figure's memory goes with it


def answer_on_stdout(text):
    sys.stdout.write(text + "\n")
    sys.stdout.flush()


def batch_fds(args):
    """--batch's further sockets: [] or ["--fds", "3,4"] -> (3, 4); None for anything else."""
    if not args:
        return ()
    if len(args) == 2 and args[0] == "--fds" and all(f.isdigit() and int(f) > 2 for f in args[1].split(",")):
        return tuple(int(f) for f in args[1].split(","))
    return None


def main(argv):
    if argv[1:2] == ["--batch"] and batch_fds(argv[2:]) is not None:
        batch(sys.stdin, answer_on_stdout, batch_fds(argv[2:]))
        return
    if len(argv) >= 4 and argv[1] in ("samples", "parameters", "heldout"):
        {"samples": samples, "parameters": parameters, "heldout": heldout}[argv[1]](argv[2], argv[3])
        return
    if len(argv) >= 6 and argv[1] in ("residuals", "components"):
        # Options may come before the PNG (orbcal appends the PNG last).
        positional, opts = split_options(argv[2:], ("floor", "of") if argv[1] == "components" else ("floor",), 1)
        if len(positional) != 4:  # CSV COLUMN LABEL PNG
            sys.exit(__doc__)
        floor = float(opts["floor"][0]) if "floor" in opts else None
        if argv[1] == "residuals":
            residuals(*positional, floor)
        else:
            components(*positional, opts.get("of", ["selected"])[0], floor)
        return
    if len(argv) < 4 or argv[1] not in ("boxplot", "curve"):
        sys.exit(__doc__)
    if argv[1] == "boxplot":
        boxplot(argv[2], argv[3], argv[4:])
    else:
        positional, axes = split_options(argv[2:], ("x", "y"), 2)  # --x/--y COL LABEL anywhere among CSV and PNG
        if len(positional) != 2:
            sys.exit(__doc__)
        x = axes.get("x", ("n", "identification configurations"))
        y = axes.get("y", ("avg_position_mm", "mean validation position error (mm)"))
        curve(positional[0], positional[1], x[0], x[1], y[0], y[1])


if __name__ == "__main__":
    main(sys.argv)
