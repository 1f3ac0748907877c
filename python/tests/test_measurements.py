"""orbcal.load_measurements, orbcal.measurements_from_arrays and orbcal.simulate: the same samples whichever
way they arrive, and bad input refused with a one-line message naming the file (or argument) and the key."""
import numpy as np
import pytest

import orbcal


def test_simulate_returns_data_and_truth(iiwa7, tracker):
    data, truth = tracker
    assert len(data) == 200 and data.sessions == 1
    assert data.q.shape == (200, 7) and data.poses.shape == (200, 4, 4) and data.positions.shape == (200, 3)
    assert np.all(data.q >= iiwa7.lower) and np.all(data.q <= iiwa7.upper)
    np.testing.assert_allclose(data.poses[:, :3, 3], data.positions)
    assert data.temperature.shape == (200,) and data.time.shape == (200,)
    assert data.torques.shape == (200, 7)  # the iiwa7 file has masses
    assert "theta1" in truth.parameters and truth.effects == []


def test_a_saved_dataset_loads_back_to_the_same_samples(tracker, tmp_path):
    data, _ = tracker
    description = data.save(str(tmp_path / "run"), "builtin:iiwa7.yaml")
    loaded = orbcal.load_measurements(description)
    assert len(loaded) == len(data)
    np.testing.assert_array_equal(loaded.q, data.q)  # written with 17 digits: bit for bit
    np.testing.assert_array_equal(loaded.positions, data.positions)
    np.testing.assert_allclose(loaded.poses, data.poses, atol=1e-12)  # rotations through a quaternion
    np.testing.assert_array_equal(loaded.torques, data.torques)


def test_arrays_make_the_same_data(iiwa7, tracker):
    data, _ = tracker
    built = orbcal.measurements_from_arrays(iiwa7, q=data.q, poses=data.poses, torques=data.torques,
                                            temperature=data.temperature, time=data.time,
                                            noise={"position_m": 5e-5, "rotation_rad": 1.7e-4})
    assert len(built) == 200 and built.description == "(arrays)"
    np.testing.assert_array_equal(built.q, data.q)
    np.testing.assert_array_equal(built.poses, data.poses)
    assert built.noise == {"position_m": 5e-5, "rotation_rad": 1.7e-4, "joint_rad": None}
    positions = orbcal.measurements_from_arrays(iiwa7, q=data.q, positions=data.positions)
    assert positions.torques is None and positions.temperature is None
    np.testing.assert_array_equal(positions.positions, data.positions)


def test_array_errors(iiwa7, tracker):
    data, _ = tracker
    with pytest.raises(ValueError, match="exactly one of positions= and poses="):
        orbcal.measurements_from_arrays(iiwa7, q=data.q)
    with pytest.raises(ValueError, match="positions: expected 200 rows of 3"):
        orbcal.measurements_from_arrays(iiwa7, q=data.q, positions=data.positions[:10])
    q = data.q.copy()
    q[7, 3] = 4.0  # beyond the iiwa7's +-120 deg on joint 4
    with pytest.raises(orbcal.Error, match=r"^q\[7\]: joint 4: 4 rad \(229.183 deg\) is outside the joint limits \[-120, 120\] deg "
                       r"of builtin:iiwa7.yaml by more than 2% of the joint's range \(4.8 deg\)$"):
        orbcal.measurements_from_arrays(iiwa7, q=q, positions=data.positions)
    # Within 2% of the joint's 240 deg range past the limit (an encoder past a soft limit): accepted, with a warning.
    q[7, 3] = np.radians(120.0 + 4.0)
    with pytest.warns(UserWarning, match=r"joint 4: 1 reading past its upper limit 120 deg of builtin:iiwa7.yaml, by up to 4 deg"):
        orbcal.measurements_from_arrays(iiwa7, q=q, positions=data.positions)
    poses = data.poses.copy()
    poses[3, 0, 0] += 0.01
    with pytest.raises(orbcal.Error, match=r"^poses\[3\]: not a rigid transform"):
        orbcal.measurements_from_arrays(iiwa7, q=data.q, poses=poses)
    torques = data.torques.copy()
    torques[9, 0] = np.nan  # a NaN would read as "not measured"
    with pytest.raises(orbcal.Error, match=r"^torques\[9\]: not a finite number$"):
        orbcal.measurements_from_arrays(iiwa7, q=data.q, positions=data.positions, torques=torques)
    hot = data.temperature.copy()
    hot[0] = 250.0  # above a motor winding's insulation limit
    with pytest.raises(orbcal.Error, match=r"^temperature\[0\]: 250 degC is outside -150 to 200 degC"):
        orbcal.measurements_from_arrays(iiwa7, q=data.q, positions=data.positions, temperature=hot)
    with pytest.raises(orbcal.Error, match="^world_T_base: given exactly when base is 'known' \\(base: 'shared'\\)$"):
        orbcal.measurements_from_arrays(iiwa7, q=data.q, positions=data.positions, world_T_base=np.eye(4))
    with pytest.raises(orbcal.Error, match="^flange_T_marker: given exactly when marker is 'known'"):
        orbcal.measurements_from_arrays(iiwa7, q=data.q, positions=data.positions, marker="known")
    known = orbcal.measurements_from_arrays(iiwa7, q=data.q, positions=data.positions, base="known", world_T_base=np.eye(4))
    assert known.registration == {"base": "known", "marker": "shared"}
    with pytest.raises(orbcal.Error, match="noise: position_m: 1 is outside 1e-9 m to 0.1 m"):
        orbcal.measurements_from_arrays(iiwa7, q=data.q, positions=data.positions, noise={"position_m": 1.0})


def test_bad_csv_cell_names_the_file_line_and_column(tracker, tmp_path):
    data, _ = tracker
    description = data.save(str(tmp_path / "run"), "builtin:iiwa7.yaml")
    csv = tmp_path / "run" / "session_1.csv"
    lines = csv.read_text().splitlines()
    cells = lines[5].split(",")
    cells[2] = "nan?"  # q2_rad of the fifth sample
    lines[5] = ",".join(cells)
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(orbcal.Error) as e:
        orbcal.load_measurements(description)
    message = str(e.value)
    assert "\n" not in message
    assert str(csv) in message and "line 6" in message and "q2_rad" in message


def test_bad_description_key(tmp_path):
    (tmp_path / "m.yaml").write_text("format: orbcal-measurements-1\nrobot: builtin:iiwa7.yaml\nfiles: [a.csv]\n"
                                     "joints: {columns: [a, b, c, d, e, f, g], unit: grad}\n"
                                     "pose: {position: [x, y, z], length_unit: m}\nregistration: {base: shared, marker: shared}\n")
    with pytest.raises(orbcal.Error, match=r"m\.yaml: joints\.unit: .*grad"):
        orbcal.load_measurements(str(tmp_path / "m.yaml"))


def test_simulate_payload_per_session_loads_the_joints(iiwa7):
    data, _ = orbcal.simulate(iiwa7, samples=40, sessions=2, seed=5, payload_kg=[0.0, 3.0], noise={"position_m": 1e-5})
    assert data.sessions == 2 and data.session == [0] * 20 + [1] * 20
    one, _ = orbcal.simulate(iiwa7, samples=40, sessions=2, seed=5, payload_kg=3.0, noise={"position_m": 1e-5})
    # A payload adds torque on the shoulder (joint 2) at the same configurations: a heavier arm on session 0.
    assert np.abs(one.torques[:20, 1]).mean() > np.abs(data.torques[:20, 1]).mean()
    np.testing.assert_allclose(one.torques[20:], data.torques[20:])


def test_simulate_refuses_an_unknown_effect(iiwa7):
    with pytest.raises(orbcal.Error, match="effects: .*wobble"):
        orbcal.simulate(iiwa7, samples=50, effects=["wobble:2"])
