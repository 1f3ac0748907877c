"""The report figures (tools/plot_report.py) say what their legends say: one meaning per colour in
samples.png, held and combination-only parameters drawn as such in parameters.png, a noise floor on
the residual figures, signed components of the model asked for; and --batch, which draws several figures
in one process, answering each."""
import importlib.util
import os
import pathlib
import subprocess
import sys

import matplotlib
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import to_rgba  # noqa: E402

RED = to_rgba("red")
SOURCE_DIR = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def plot_report():
    spec = importlib.util.spec_from_file_location("plot_report", SOURCE_DIR / "tools" / "plot_report.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def write_csv(path, header, rows):
    path.write_text(",".join(header) + "\n" + "".join(",".join(str(c) for c in r) + "\n" for r in rows))
    return str(path)


def colours(collection):
    return {tuple(c) for c in collection.get_facecolors()} | {tuple(c) for c in collection.get_edgecolors()}


def test_samples_red_marks_only_the_inconsistent_images(plot_report, tmp_path):
    rows = [("img%02d.png" % i, "identification" if i < 8 else "held-out", 2.0 + i, 0.1 + 0.01 * i, 1 if i == 3 else 0)
            for i in range(12)]
    csv = write_csv(tmp_path / "samples.csv", ["image", "set", "before_mm", "after_mm", "outlier"], rows)
    plt.close("all")
    plot_report.samples(csv, str(tmp_path / "samples.png"))
    ax = plt.gcf().axes[0]
    red = [c for c in ax.collections if RED in colours(c)]
    assert len(ax.collections) == 5  # nominal and calibrated of both sets, and the ring
    assert len(red) == 1
    assert [tuple(p) for p in red[0].get_offsets()] == [(3.0, 0.13)]
    assert [t.get_text() for t in ax.texts if to_rgba(t.get_color()) == RED] == ["img03.png"]


def test_parameters_draw_held_grey_and_combination_members_apart(plot_report, tmp_path):
    header = ["method", "parameter", "unit", "estimate", "sigma", "truth", "held", "class"]
    rows = [("EKF", "theta1", "deg", 0.0, 0.0, "", 1, "relative"),
            ("EKF", "theta2", "deg", 0.02, 0.001, "", 0, "independent"),
            ("EKF", "d3", "mm", 0.5, 0.1, "", 0, "relative"),
            ("EKF", "d4", "mm", -0.4, 0.1, "", 0, "relative"),
            ("EKF", "a2", "mm", 0.1, 0.01, "", 0, "independent")]
    csv = write_csv(tmp_path / "estimates.csv", header, rows)
    plt.close("all")
    plot_report.parameters(csv, str(tmp_path / "parameters.png"))
    deg, mm = plt.gcf().axes
    assert [t.get_text() for t in deg.get_legend().get_texts()] == ["estimate +- 1 sigma", "held as unidentifiable (nominal)"]
    assert [t.get_text() for t in mm.get_legend().get_texts()] == ["estimate +- 1 sigma", "in an unidentifiable combination"]
    held_line = deg.get_legend().legend_handles[1] if hasattr(deg.get_legend(), "legend_handles") else deg.get_legend().legendHandles[1]
    assert to_rgba(held_line.get_color()) == to_rgba("grey")
    assert len(deg.patches) == 1  # the grey band of the one held parameter


def test_residual_figures_draw_the_noise_floor_and_signed_components(plot_report, tmp_path):
    header = ["index", "base_mm", "selected_mm", "q2_deg", "base_x_mm", "base_y_mm", "base_z_mm",
              "selected_x_mm", "selected_y_mm", "selected_z_mm"]
    rows = [(i, 0.3, 0.08, 10.0 * i, 0.2, -0.1 * (i % 2), 0.05, 0.01, -0.02, 0.03) for i in range(10)]
    csv = write_csv(tmp_path / "residuals.csv", header, rows)
    plt.close("all")
    plot_report.residuals(csv, "q2_deg", "q2 (deg)", str(tmp_path / "r.png"), floor=0.087)
    ax = plt.gcf().axes[0]
    assert [tuple(l.get_ydata()) for l in ax.get_lines()] == [(0.087, 0.087)]
    plt.close("all")
    plot_report.components(csv, "q2_deg", "q2 (deg)", str(tmp_path / "c.png"), of="base", floor=0.05)
    ax = plt.gcf().axes[0]
    assert sorted(l.get_ydata()[0] for l in ax.get_lines()) == [-0.05, 0.0, 0.05]
    x_component = ax.collections[0].get_offsets()
    assert [p[1] for p in x_component] == [0.2] * 10  # base_x_mm, signed, not selected_x_mm
    assert "geometry + registration" in ax.get_ylabel()


def test_residual_figures_take_a_prismatic_joint_in_mm_and_name_a_missing_column(plot_report, tmp_path):
    # diagnose's residuals.csv on an arm with a prismatic torso: q1_mm beside q2_deg.
    header = ["index", "base_mm", "selected_mm", "q1_mm", "q2_deg", "base_x_mm", "base_y_mm", "base_z_mm"]
    rows = [(i, 0.3, 0.08, 25.0 * i, 10.0 * i, 0.2, -0.1, 0.05) for i in range(10)]
    csv = write_csv(tmp_path / "residuals.csv", header, rows)
    plt.close("all")
    plot_report.residuals(csv, "q1_mm", "joint 1 position (mm)", str(tmp_path / "r.png"))
    ax = plt.gcf().axes[0]
    assert ax.get_xlabel() == "joint 1 position (mm)"
    assert [p[0] for p in ax.collections[0].get_offsets()] == [25.0 * i for i in range(10)]
    plt.close("all")
    plot_report.components(csv, "q1_mm", "joint 1 position (mm)", str(tmp_path / "c.png"), of="base")
    assert [p[0] for p in plt.gcf().axes[0].collections[0].get_offsets()] == [25.0 * i for i in range(10)]
    with pytest.raises(SystemExit) as e:
        plot_report.residuals(csv, "q1_deg", "joint 1 angle (deg)", str(tmp_path / "r.png"))
    assert str(e.value).startswith("plot_report.py: %s: no column 'q1_deg' (columns: index, " % csv)
    assert "\n" not in str(e.value)


def run_batch(lines, cwd, env=None):
    """plot_report.py --batch fed `lines`; its answer lines."""
    out = subprocess.run([sys.executable, str(SOURCE_DIR / "tools" / "plot_report.py"), "--batch"], input="".join(lines),
                         capture_output=True, text=True, cwd=cwd, env=env, timeout=120, check=True)
    return out.stdout.splitlines()


def test_batch_draws_each_figure_of_its_input_and_answers_each_on_one_line(tmp_path):
    header = ["parameter", "effect", "unit", "estimate", "sigma", "truth", "held", "class"]
    write_csv(tmp_path / "estimates.csv", header, [("d1", "geometry", "mm", 0.1, 0.01, "", 0, "")])
    write_csv(tmp_path / "residuals.csv", ["index", "q2_deg", "base_mm", "selected_mm"], [(0, 10.0, 0.2, 0.1), (1, 20.0, 0.3, 0.1)])
    lines = ["parameters estimates.csv 'a b.png'\n",
             "residuals residuals.csv q9_deg 'joint 9 (deg)' r.png\n",   # a column that is not there: named, the next drawn
             "\n",                                                       # blank lines are skipped
             "bogus\n",
             "residuals residuals.csv q2_deg 'joint 2 (deg)' r.png --floor 0.05\n"]
    answers = run_batch(lines, tmp_path)
    assert answers[0] == "ok" and answers[3] == "ok"
    assert answers[1].startswith("error: plot_report.py: residuals.csv: no column 'q9_deg' (columns: index, ")
    assert answers[2] == "error: plot_report.py: bad arguments: bogus"
    assert len(answers) == 4
    assert (tmp_path / "a b.png").stat().st_size > 1000 and (tmp_path / "r.png").stat().st_size > 1000


def test_batch_without_matplotlib_answers_missing_for_each_figure(tmp_path):
    fake = tmp_path / "fake" / "matplotlib"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("raise ImportError(\"No module named 'matplotlib'\")\n")
    env = dict(os.environ, PYTHONPATH=str(tmp_path / "fake"))
    answers = run_batch(["parameters e.csv a.png\n", "heldout h.csv b.png\n"], tmp_path, env)
    assert answers == ["missing: ImportError: No module named 'matplotlib'"] * 2
    # One figure alone still fails with Python's own error, as before.
    single = subprocess.run([sys.executable, str(SOURCE_DIR / "tools" / "plot_report.py"), "parameters", "e.csv", "a.png"],
                            capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120)
    assert single.returncode != 0 and single.stderr.strip().splitlines()[-1] == "ImportError: No module named 'matplotlib'"


@pytest.mark.skipif(not hasattr(os, "SCHED_IDLE"), reason="no SCHED_IDLE on this system")
def test_batch_warms_up_at_idle_priority_and_draws_at_the_normal_one(plot_report, tmp_path):
    # --batch imports and warms up at SCHED_IDLE where it may return to the normal policy: the figures,
    # asked for once orbcal has finished, are drawn at the normal one (never behind other work).
    import resource

    may_return = os.geteuid() == 0 or resource.getrlimit(resource.RLIMIT_NICE)[0] >= 20
    write_csv(tmp_path / "residuals.csv", ["index", "q2_deg", "base_mm", "selected_mm"], [(0, 10.0, 0.2, 0.1), (1, 20.0, 0.3, 0.1)])
    policies = []

    def answer(text):
        policies.append((text, os.sched_getscheduler(0)))

    before = os.sched_getscheduler(0)
    try:
        plot_report.idle_while_warming(True)
        assert os.sched_getscheduler(0) == (os.SCHED_IDLE if may_return else before)
        plot_report.batch(["residuals %s q2_deg 'joint 2 (deg)' %s\n" % (tmp_path / "residuals.csv", tmp_path / "r.png")], answer)
    finally:
        if may_return:
            os.sched_setscheduler(0, before, os.sched_param(0))
    assert policies == [("ok", os.SCHED_OTHER if may_return else before)]


def test_batch_serves_further_sockets_from_forked_drawers(tmp_path):
    # --batch --fds N: the socket at descriptor N is served by a process forked after the import, side by
    # side with the one reading stdin; each drawer's figures are its own, and both end when their input does.
    import socket

    write_csv(tmp_path / "residuals.csv", ["index", "q2_deg", "base_mm", "selected_mm"], [(0, 10.0, 0.2, 0.1), (1, 20.0, 0.3, 0.1)])
    ours, theirs = socket.socketpair()
    script = str(SOURCE_DIR / "tools" / "plot_report.py")
    batch = subprocess.Popen([sys.executable, script, "--batch", "--fds", str(theirs.fileno())], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True, cwd=tmp_path, pass_fds=(theirs.fileno(),))
    theirs.close()
    with ours.makefile("rw") as second:
        second.write("residuals residuals.csv q2_deg 'joint 2 (deg)' second.png\nbogus\n")
        second.flush()
        assert [second.readline(), second.readline()] == ["ok\n", "error: plot_report.py: bad arguments: bogus\n"]
    ours.close()
    out, _ = batch.communicate("residuals residuals.csv index sample first.png\n", timeout=120)
    assert out.splitlines() == ["ok"]
    assert batch.returncode == 0
    assert (tmp_path / "first.png").stat().st_size > 1000 and (tmp_path / "second.png").stat().st_size > 1000


@pytest.mark.parametrize("label, fits", [("q2 (deg)", True), ("joint 2\nangle\nas logged\n(deg)", False)])
def test_single_panel_figures_keep_fixed_margins_unless_a_label_would_be_cut(plot_report, tmp_path, label, fits):
    # The fixed margins hold where the labels fit; an axis label of four lines would be cut at the bottom,
    # and tight_layout makes room for it. Either way nothing reaches outside the drawn figure.
    rows = [(i, 0.3 * (1 + i), 0.08, 10.0 * i) for i in range(10)]
    csv = write_csv(tmp_path / "residuals.csv", ["index", "base_mm", "selected_mm", "q2_deg"], rows)
    plt.close("all")
    plot_report.residuals(csv, "q2_deg", label, str(tmp_path / "r.png"))
    fig = plt.gcf()
    fixed_bottom = plot_report.MARGINS_IN["bottom"] / fig.get_size_inches()[1]
    assert (fig.subplotpars.bottom == pytest.approx(fixed_bottom)) == fits
    assert not plot_report.cut_off(fig, fig.canvas.get_renderer())
    assert (tmp_path / "r.png").stat().st_size > 1000
