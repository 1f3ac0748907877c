"""Python at par with the command line, on the same files: orbcal.calibrate holds out, refuses and reports as
`orbcal calibrate DESC.yaml` (the same report.md, the same refusals and held-out numbers), orbcal.evaluate's
baseline is evaluation.json's, Robot.gravity_torques gives the torque columns `orbcal simulate` writes, and
orbcal.__version__ is the program's version."""
import json
import os
import re
import subprocess

import numpy as np
import pytest

import orbcal

PROGRAM = os.environ.get("ORBCAL_PROGRAM")
TORQUE_NOISE_NM = 0.05  # orbcal simulate's torque sensor noise, 1 sigma (SimulationSpec::torque_noise_Nm)
PAYLOADS_KG = (0.0, 1.25)

needs_program = pytest.mark.skipif(not PROGRAM or not os.path.exists(PROGRAM), reason="ORBCAL_PROGRAM (the built orbcal) not given")


def orbcal_cli(*args, cwd=None):
    return subprocess.run([PROGRAM, *args], capture_output=True, text=True, cwd=cwd, timeout=300)


@pytest.fixture(scope="module")
def compliance_data(tmp_path_factory):
    """`orbcal simulate` of the iiwa7 with a hidden compliance on joints 2 and 4, two sessions at 0 and 1.25 kg."""
    folder = tmp_path_factory.mktemp("sim") / "data"
    run = orbcal_cli("simulate", "--robot", "builtin:iiwa7.yaml", "-o", str(folder), "-n", "160", "--sessions", "2",
                     "--payload-kg", *map(str, PAYLOADS_KG), "--inject", "compliance:2,4", "--seed", "5")
    assert run.returncode == 0, run.stderr
    return folder


def refusal_lines(stderr, description):
    """The command line's refusals: `orbcal: calibrate: DESC: WHY; model.yaml not written (...)`, WHY each."""
    prefix = "orbcal: calibrate: %s: " % description
    return [re.sub(r"; model\.yaml not written \(--accept-worse writes it\)$", "", line[len(prefix):])
            for line in stderr.splitlines() if line.startswith(prefix)]


def heldout_rms_mm(stdout):
    m = re.search(r"held-out position RMS: nominal arm ([0-9.]+) mm -> calibrated ([0-9.]+) mm", stdout)
    assert m, stdout
    return float(m.group(1)), float(m.group(2))


@needs_program
def test_a_refused_calibration_is_refused_and_reported_as_the_command_line_does(compliance_data, tmp_path):
    desc = str(compliance_data / "measurements.yaml")
    cli = orbcal_cli("calibrate", desc, "-o", str(tmp_path / "cli"), "--no-plots")
    assert cli.returncode == 1, cli.stdout + cli.stderr  # the hidden compliance leaves residuals far above the noise
    with pytest.raises(orbcal.Refused) as e:
        orbcal.calibrate(orbcal.load_measurements(desc), out=str(tmp_path / "py"))
    assert isinstance(e.value, orbcal.Error) and "\n" not in str(e.value)
    c = e.value.calibration
    assert not c.accepted and c.model is None and c.model_path is None
    assert c.refusals and c.refusals == refusal_lines(cli.stderr, desc)
    before, after = heldout_rms_mm(cli.stdout)
    assert "%.4f" % (c.heldout["before"]["position_rms_m"] * 1e3) == "%.4f" % before
    assert "%.4f" % (c.heldout["after"]["position_rms_m"] * 1e3) == "%.4f" % after
    assert c.heldout["samples"] > 0 and c.fitted + c.heldout["samples"] == c.samples == 160
    # One pipeline: the same report, word for word, and no model file in either folder.
    assert c.report == (tmp_path / "cli" / "report.md").read_text() == (tmp_path / "py" / "report.md").read_text()
    assert not (tmp_path / "cli" / "model.yaml").exists() and not (tmp_path / "py" / "model.yaml").exists()
    # accept_worse returns it, marked: not accepted, with the model the command line's --accept-worse writes.
    kept = orbcal.calibrate(orbcal.load_measurements(desc), accept_worse=True)
    assert not kept.accepted and kept.refusals == c.refusals and kept.model is not None
    assert kept.report_path is None  # no out folder: nothing kept on disk


@needs_program
def test_an_accepted_calibration_matches_the_command_line(compliance_data, tmp_path):
    desc = str(compliance_data / "measurements.yaml")
    cli = orbcal_cli("calibrate", desc, "--effects", "compliance:2,4", "-o", str(tmp_path / "cli"), "--no-plots")
    assert cli.returncode == 0, cli.stderr
    c = orbcal.calibrate(orbcal.load_measurements(desc), effects=["compliance:2,4"], out=str(tmp_path / "py"))
    assert c.accepted and c.refusals == [] and c.model is not None
    before, after = heldout_rms_mm(cli.stdout)
    assert "%.4f" % (c.heldout["after"]["position_rms_m"] * 1e3) == "%.4f" % after
    assert c.heldout["after"]["position_rms_m"] < c.heldout["before"]["position_rms_m"]
    assert c.report == (tmp_path / "cli" / "report.md").read_text()
    assert (tmp_path / "py" / "model.yaml").read_text() == (tmp_path / "cli" / "model.yaml").read_text()
    assert c.model_path == str(tmp_path / "py" / "model.yaml")
    # The records: one per fitted parameter, the model's values; plain values JSON can hold.
    records = c.to_records()
    assert [r["name"] for r in records] == c.model.parameter_names
    assert np.allclose([r["value"] for r in records], c.model.values, rtol=0, atol=0)
    summary = json.loads(json.dumps(c.as_dict()))
    assert summary["accepted"] is True and summary["heldout"]["samples"] == c.heldout["samples"]


@needs_program
def test_evaluate_returns_the_baseline_evaluation_json_reports(compliance_data, tmp_path):
    desc = str(compliance_data / "measurements.yaml")
    truth = str(compliance_data / "truth" / "model.yaml")
    run = orbcal_cli("evaluate", "--model", truth, "--data", desc, "-o", str(tmp_path / "ev"))
    assert run.returncode == 0, run.stderr
    cli = json.loads((tmp_path / "ev" / "evaluation.json").read_text())
    py = orbcal.evaluate(orbcal.load_model(truth), orbcal.load_measurements(desc))
    assert py["baseline"]["samples"] == cli["baseline"]["samples"] == 160
    for key in ("position_rms", "position_max"):
        assert py["baseline"][key + "_m"] * 1e3 == pytest.approx(cli["baseline"][key + "_mm"], rel=1e-9)
        assert py[key + "_m"] * 1e3 == pytest.approx(cli[key + "_mm"], rel=1e-9)


def test_the_baseline_is_the_nominal_arm_and_sees_the_geometry_errors(iiwa7):
    """Without DH errors the nominal arm is the truth: its baseline is at the noise; with them, far above."""
    noise = 0.05e-3  # orbcal.simulate's tracker noise, 1 sigma per axis: the 3-D RMS is sqrt(3) times it
    clean, truth = orbcal.simulate(iiwa7, samples=150, seed=11, geometry="zero")
    b = orbcal.evaluate(truth, clean)["baseline"]
    assert b["position_rms_m"] == pytest.approx(np.sqrt(3) * noise, rel=0.2)
    errors, truth = orbcal.simulate(iiwa7, samples=150, seed=11)
    r = orbcal.evaluate(truth, errors)
    assert r["baseline"]["position_rms_m"] > 5 * r["position_rms_m"]


def test_array_fk_and_jacobian_match_one_configuration_at_a_time(iiwa7):
    rng = np.random.default_rng(7)
    q = rng.uniform(iiwa7.lower, iiwa7.upper, size=(25, iiwa7.dof))
    T, J = iiwa7.fk(q), iiwa7.jacobian(q)
    assert T.shape == (25, 4, 4) and J.shape == (25, 6, iiwa7.dof)
    for k in range(25):
        assert np.array_equal(T[k], iiwa7.fk(q[k]))
        assert np.array_equal(J[k], iiwa7.jacobian(q[k]))
    assert len({tuple(T[k][:3, 3]) for k in range(25)}) == 25  # not one pose repeated
    assert iiwa7.fk(list(q[3])).shape == (4, 4)  # a list is a configuration too
    with pytest.raises(ValueError):
        iiwa7.fk(q[:, :6])  # N x 6 for a 7-joint arm
    with pytest.raises(ValueError):
        iiwa7.fk(np.zeros((2, 2, 7)))


@needs_program
def test_gravity_torques_are_the_torques_orbcal_simulate_writes(compliance_data):
    data = orbcal.load_measurements(str(compliance_data / "measurements.yaml"))
    robot = data.robot
    session = np.asarray(data.session)
    for s, payload in enumerate(PAYLOADS_KG):
        rows = session == s
        tau = robot.gravity_torques(data.q[rows], payload_kg=payload)
        assert tau.shape == (rows.sum(), robot.dof)
        diff = data.torques[rows] - tau
        # What is left is the sensor noise the simulator adds (0.05 N m): its RMS, and no entry beyond 5 sigma.
        assert np.sqrt(np.mean(diff ** 2)) == pytest.approx(TORQUE_NOISE_NM, rel=0.2)
        assert np.abs(diff).max() < 5 * TORQUE_NOISE_NM
        assert np.abs(tau[:, 1]).max() > 10.0  # joint 2 carries the arm: tens of N m, far above the noise
    # One configuration gives one row of the stacked call; a payload changes the shoulder's torque.
    q0 = data.q[0]
    assert np.array_equal(robot.gravity_torques(q0), robot.gravity_torques(q0[None, :])[0])
    assert not np.allclose(robot.gravity_torques(q0, payload_kg=1.25), robot.gravity_torques(q0))


def test_gravity_torques_need_a_mass_model():
    robot = orbcal.load_robot("builtin:ssrms.yaml")
    assert not robot.has_masses
    with pytest.raises(orbcal.Error, match="no mass model"):
        robot.gravity_torques(np.zeros(robot.dof))


@needs_program
def test_version_is_the_programs():
    assert orbcal.__version__ == orbcal.version
    assert orbcal_cli("--version").stdout.strip() == "orbcal " + orbcal.__version__


@needs_program
def test_model_and_diagnosis_records(tracker, compliance_data):
    _, truth = tracker
    records = truth.to_records()
    assert [r["name"] for r in records] == truth.parameter_names
    assert set(records[0]) == {"name", "effect", "unit", "value", "sigma", "held"}
    assert [r["name"] for r in truth.as_dict()["parameters"]] == truth.parameter_names
    assert np.array_equal([r["value"] for r in records], truth.values)
    d = orbcal.diagnose(orbcal.load_measurements(str(compliance_data / "measurements.yaml")))
    flat = d.to_records()
    assert flat and sum(len(e["parameters"]) for e in d.selected) == len(flat)
    assert {r["effect"] for r in flat} == {e["effect"] for e in d.selected}
    assert set(flat[0]) == {"effect", "joints", "parameter", "value", "sigma", "unit"}
    assert d.as_dict()["verdict"] == d.verdict


@pytest.fixture(scope="module")
def diagnosed(tmp_path_factory):
    """The iiwa7 with a hidden compliance on joint 2 in one tracker set-up, three sessions at 0, 1.25 and 4 kg:
    `orbcal diagnose` of the first two (fit.yaml; compliance:2 selected, confounded with other causes of the same
    residuals, which diagnose writes as alternativeN.yaml beside model.yaml), and the third (heavy.yaml) to
    evaluate on, its joint 2 torques beyond the fitted range and its joint 1 limits 1% inside its largest reading
    (robot_limits.yaml: readings past a limit within the 2% tolerance, which evaluate accepts with a warning)."""
    folder = tmp_path_factory.mktemp("diagnosed")
    run = orbcal_cli("simulate", "-o", "data", "-n", "450", "--sessions", "3", "--payload-kg", "0", "1.25", "4",
                     "--inject", "compliance:2", "--seed", "5", "--quiet", cwd=folder)
    assert run.returncode == 0, run.stderr
    data = folder / "data"
    description = (data / "measurements.yaml").read_text()
    files = 'files: ["session_1.csv", "session_2.csv", "session_3.csv"]'
    assert files in description
    (data / "fit.yaml").write_text(description.replace(files, 'files: ["session_1.csv", "session_2.csv"]'))
    (data / "heavy.yaml").write_text(description.replace(files, 'files: ["session_3.csv"]')
                                     .replace('robot: "robot.yaml"', 'robot: "robot_limits.yaml"'))
    q = np.abs(orbcal.load_measurements(str(data / "measurements.yaml")).q[:, 0]).max()
    limit = np.degrees(q) * 0.99
    robot = (data / "robot.yaml").read_text().splitlines()
    first = next(k for k, line in enumerate(robot) if line.startswith("  - {a_m:"))
    robot[first] = re.sub(r"min_deg: [^,]+, max_deg: [^}]+", "min_deg: %.17g, max_deg: %.17g" % (-limit, limit), robot[first])
    (data / "robot_limits.yaml").write_text("\n".join(robot) + "\n")
    run = orbcal_cli("diagnose", "data/fit.yaml", "-o", "diag", "--no-plots", "--quiet", cwd=folder)
    assert run.returncode == 0, run.stderr
    return folder


@needs_program
def test_evaluate_is_the_command_lines_with_the_alternatives_and_the_warnings(diagnosed, tmp_path):
    model_file, description = "diag/model.yaml", "data/heavy.yaml"
    cli = orbcal_cli("evaluate", "--model", model_file, "--data", description, "-o", str(tmp_path / "cli"), cwd=diagnosed)
    assert cli.returncode == 0, cli.stderr
    cwd = os.getcwd()
    os.chdir(diagnosed)  # the same relative paths: the report names the model file and the description as given
    try:
        model = orbcal.load_model(model_file)
        py = orbcal.evaluate(model, orbcal.load_measurements(description), out=str(tmp_path / "py"))
        quiet = orbcal.evaluate(model, orbcal.load_measurements(description))
    finally:
        os.chdir(cwd)
    # One pipeline: evaluation.md byte for byte (the CLI has no figures to leave out here), and every other file.
    for name in ("evaluation.md", "evaluation.json", "residuals.csv"):
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    assert py["report"] == quiet["report"] == (tmp_path / "cli" / "evaluation.md").read_text()
    # The confounded alternatives diagnose wrote beside model.yaml, each predicting the new data, as the CLI's JSON has them.
    assert model.source == model_file and [os.path.basename(a) for a in model.alternatives][:1] == ["alternative1.yaml"]
    cli_json = json.loads((tmp_path / "cli" / "evaluation.json").read_text())
    assert len(py["alternatives"]) == len(model.alternatives) == len(cli_json["alternatives"]) >= 1
    for a, c in zip(py["alternatives"], cli_json["alternatives"]):
        assert a["model"] == c["model"] and a["effects"] == c["effects"] and a["effects"] != "compliance:2"
        assert a["position_rms_m"] * 1e3 == pytest.approx(c["position_rms_mm"], rel=1e-12)
        assert len(a["divergence_m"]) == py["samples"] == 150
        # 4 kg against the 0 and 1.25 kg of the fit: samples beyond the fitted torque range, where the predictions part.
        assert a["samples_beyond"] > 0 and a["apart_beyond_max_m"] == pytest.approx(
            max(d for d, x in zip(a["divergence_m"], py["beyond_range"][0]["excess"]) if x > 0))
    assert "## Where the model extrapolates" in py["report"] and "`" + py["alternatives"][0]["effects"] + "`" in py["report"]
    # The warnings: the readings past joint 1's narrowed limit, then the torques beyond the fitted range, as the CLI prints them.
    printed = [line[len("warning: "):] for line in cli.stderr.splitlines() if line.startswith("warning: ")]
    assert py["warnings"] == printed and len(printed) >= 2
    assert py["warnings"][0].startswith("joint 1") and "past its" in py["warnings"][0]
    assert any("compliance:2" in w for w in py["warnings"][1:])


@needs_program
def test_a_model_in_memory_is_named_so_and_the_calibrated_model_is_carried(compliance_data, tmp_path):
    data = orbcal.load_measurements(str(compliance_data / "measurements.yaml"))
    c = orbcal.calibrate(data, effects=["compliance:2,4"], out=str(tmp_path / "cal"))
    # The model carried from the calibration is the one written: the same model file, its fitted ranges included.
    assert c.model.source == c.model_path
    c.model.save(str(tmp_path / "again" / "model.yaml"))
    body = lambda p: [line for line in p.read_text().splitlines() if not line.startswith("#")]
    assert body(tmp_path / "again" / "model.yaml") == body(tmp_path / "cal" / "model.yaml")
    assert "range: {tau2_Nm: [" in (tmp_path / "cal" / "model.yaml").read_text()
    kept = orbcal.calibrate(data, effects=["compliance:2,4"])
    assert kept.model.source is None and kept.model.alternatives == []
    r = orbcal.evaluate(kept.model, data)
    assert r["report"].startswith("# Evaluation of `(model in memory)` on `%s`" % data.description)
    assert [x["samples_outside"] for x in r["beyond_range"]] == [0, 0]  # its own data lies within its fitted ranges
    assert r["alternatives"] == []
