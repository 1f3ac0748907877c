"""orbcal.calibrate, orbcal.evaluate, Model.save, Model.export and orbcal.load_model on simulated tracker data, whose noise
is known: the truth predicts the data to the noise, and a calibration on half the samples predicts the
other half nearly as well."""
import math
import pathlib

import numpy as np
import pytest

import orbcal

NOISE_POSITION_M = 0.05e-3  # orbcal.simulate's default tracker noise, 1 sigma per axis


def split(robot, data, rows):
    return orbcal.measurements_from_arrays(robot, q=data.q[rows], poses=data.poses[rows], torques=data.torques[rows],
                                           temperature=data.temperature[rows], time=data.time[rows])


def test_the_truth_predicts_its_data_to_the_noise(tracker):
    data, truth = tracker
    stats = orbcal.evaluate(truth, data)
    assert stats["samples"] == 200 and stats["warnings"] == []
    # 3-D position error of pure noise: RMS sqrt(3) sigma; 200 samples put the estimate within ~5 % (1 sigma of
    # a chi-square RMS with 600 dof is 1/sqrt(2 * 600) ~ 3 %), the refitted frames take a little less.
    assert stats["position_rms_m"] == pytest.approx(math.sqrt(3) * NOISE_POSITION_M, rel=0.15)


def test_calibration_predicts_held_out_samples_near_the_noise(iiwa7, tracker, tmp_path):
    data, truth = tracker
    fit_rows, held_rows = np.arange(0, 200, 2), np.arange(1, 200, 2)
    model = orbcal.calibrate(split(iiwa7, data, fit_rows), effects=[], holdout=0).model  # held out below, by hand
    assert model.statistics["samples"] == 100
    held = split(iiwa7, data, held_rows)
    after = orbcal.evaluate(model, held)
    # ~40 parameters from 100 samples of 6 rows: the estimate adds about p / n = 7 % to the held-out mean square;
    # 1.5x the noise's RMS leaves room for the sampling scatter, while the DH errors (0.05 deg, 0.5 mm) cost mm.
    assert after["position_rms_m"] < 1.5 * math.sqrt(3) * NOISE_POSITION_M
    assert after["position_rms_m"] < 2 * orbcal.evaluate(truth, held)["position_rms_m"]
    names, values, sigmas = model.parameter_names, model.values, model.sigmas
    assert len(names) == len(values) == len(sigmas) == len(model.parameters)
    assert model.parameters["theta2"]["unit"] == "rad" and model.parameters["d1"]["unit"] == "m"
    identified = [n for n in names if model.parameters[n]["effect"] == "geometry" and not model.parameters[n]["held"]]
    assert identified
    path = model.save(str(tmp_path / "model.yaml"))
    assert (tmp_path / "robot.yaml").is_file()
    loaded = orbcal.load_model(path)
    # The file lists every fitted parameter for people; loaded, the geometry is folded into the robot file.
    assert "name: theta2," in pathlib.Path(path).read_text()
    assert set(loaded.parameter_names) < set(names) and "theta2" not in loaded.parameter_names
    assert orbcal.evaluate(loaded, held)["position_rms_m"] == pytest.approx(after["position_rms_m"], rel=1e-6)


def test_calibration_finds_a_hidden_compliance(iiwa7):
    data, truth = orbcal.simulate(iiwa7, samples=150, seed=8, effects=["compliance:2"], values=[2e-5])
    model = orbcal.calibrate(data, effects=["compliance:2"]).model
    c = model.parameters["c2"]
    assert c["unit"] == "rad/(N*m)"
    assert abs(c["value"] - 2e-5) < 4 * c["sigma"]  # within 4 sigma of the injected value


def test_export_writes_what_the_command_line_writes(iiwa7, tmp_path):
    data, _ = orbcal.simulate(iiwa7, samples=120, seed=9, effects=["compliance:2"], values=[2e-5])
    model = orbcal.calibrate(data, effects=["compliance:2"]).model
    path = model.export(str(tmp_path / "out"))
    assert path == str(tmp_path / "out" / "model.yaml")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "effects.yaml", "frames.yaml", "model.yaml", "robot.yaml", "robot_calibrated.urdf"]
    # The URDF (orbcal's DH-to-URDF writer) and robot.yaml (the calibrated DH table) are two writers of one
    # chain: the same flange pose at every configuration.
    urdf = orbcal.load_robot(str(tmp_path / "out" / "robot_calibrated.urdf"), base_link="base_link", tip_link="flange")
    dh = orbcal.load_robot(str(tmp_path / "out" / "robot.yaml"))
    rng = np.random.default_rng(4)
    for _ in range(10):
        q = rng.uniform(-1.5, 1.5, size=7)
        assert np.abs(urdf.fk(q) - dh.fk(q)).max() < 1e-9
    assert "c2" in (tmp_path / "out" / "effects.yaml").read_text()


def test_unknown_method_and_effect_are_refused(tracker):
    data, _ = tracker
    with pytest.raises(orbcal.Error, match="method: 'GN': expected LM, LSE or EKF"):
        orbcal.calibrate(data, method="GN")
    with pytest.raises(orbcal.Error, match="effects: "):
        orbcal.calibrate(data, effects=["compliance:9"])


def test_a_model_that_cannot_be_written_leaves_nothing(iiwa7, tracker, tmp_path):
    data, truth = tracker
    (tmp_path / "file").write_text("not a folder")
    with pytest.raises(orbcal.Error) as e:
        truth.save(str(tmp_path / "file" / "model.yaml"))
    assert "\n" not in str(e.value) and str(tmp_path / "file") in str(e.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_calibration_levels_free_the_geometry_they_name(tracker):
    data, _ = tracker
    geometry = lambda model: {n: p for n, p in model.parameters.items() if p["effect"] == "geometry"}
    # The frames alone leave the DH errors (mm) against a 0.05 mm tracker: refused, as the command line refuses it.
    with pytest.raises(orbcal.Refused) as refused:
        orbcal.calibrate(data, level="frames")
    assert refused.value.calibration.level == "frames" and refused.value.calibration.model is None
    frames = orbcal.calibrate(data, level="frames", accept_worse=True).model
    assert frames.statistics["level"] == "frames"
    assert all(p["held"] and p["value"] == 0.0 for p in geometry(frames).values())
    listed = orbcal.calibrate(data, level="theta2,d3", accept_worse=True).model
    free = sorted(n for n, p in geometry(listed).items() if not p["held"])
    assert free == ["d3", "theta2"]
    # The default: chosen by cross-validation, which says what each level predicts. The DH errors (0.05 deg,
    # 0.5 mm) cost mm against a 0.05 mm tracker, so a level that frees every DH error wins here: the
    # prior-regularized map (kept unless another level predicts significantly better) or full.
    chosen = orbcal.calibrate(data)
    assert chosen.accepted and "cross-validation" in chosen.level_reason
    assert chosen.level in ("map", "full") and chosen.model.statistics["level"] == chosen.level
    with pytest.raises(orbcal.Error, match="level: 'bogus1' is not a parameter of this model"):
        orbcal.calibrate(data, level="theta1,bogus1")


def test_evaluate_says_which_samples_leave_the_fitted_torque_range(iiwa7):
    # A compliance of joint 2 fitted on the samples with the smaller |torque| of joint 2, evaluated on the rest:
    # every one of those leaves the fitted range, by up to the difference of the largest torques.
    data, _ = orbcal.simulate(iiwa7, samples=200, seed=5, effects=["compliance:2"], payload_kg=1.25)
    tau = np.abs(data.torques[:, 1])
    low, high = np.flatnonzero(tau <= np.median(tau)), np.flatnonzero(tau > np.median(tau))
    model = orbcal.calibrate(split(iiwa7, data, low), effects=["compliance:2"], level="full", accept_worse=True).model
    inside = orbcal.evaluate(model, split(iiwa7, data, low))
    assert [r["samples_outside"] for r in inside["beyond_range"]] == [0] and inside["warnings"] == []
    outside = orbcal.evaluate(model, split(iiwa7, data, high))
    (r,) = outside["beyond_range"]
    assert r["effect"] == "compliance:2" and r["variable"] == "tau2_Nm" and r["unit"] == "N m"
    assert r["hi"] > r["lo"]
    excess = np.array(r["excess"])
    expected = np.maximum(0.0, np.maximum(r["lo"] - data.torques[high, 1], data.torques[high, 1] - r["hi"]))
    assert len(excess) == len(high) and np.allclose(excess, expected, atol=1e-9)
    assert r["samples_outside"] == np.count_nonzero(expected > 0) > 0
    assert r["max_excess"] == pytest.approx(expected.max())
    assert any("compliance:2" in w and "joint 2 torque" in w for w in outside["warnings"])
