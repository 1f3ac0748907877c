"""orbcal.load_robot: forward kinematics against products written here from the robot files' own tables,
the Jacobian against central differences of fk, and errors that name the file and the key."""
import math

import numpy as np
import pytest
import yaml

import orbcal
from conftest import SOURCE_DIR


def rot(axis, angle):
    """Rotation matrix about a unit axis (Rodrigues)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def homogeneous(R=np.eye(3), t=(0, 0, 0)):
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


def modified_dh(a, alpha, d, theta):
    """Craig's modified DH: Rx(alpha) Tx(a) Rz(theta) Tz(d)."""
    return (homogeneous(rot([1, 0, 0], alpha)) @ homogeneous(t=[a, 0, 0]) @ homogeneous(rot([0, 0, 1], theta))
            @ homogeneous(t=[0, 0, d]))


def ssrms_fk(q):
    """The SSRMS's flange pose from scenes/ssrms.yaml's table, read with PyYAML (not orbcal)."""
    spec = yaml.safe_load((SOURCE_DIR / "scenes" / "ssrms.yaml").read_text())
    row = lambda r, theta: modified_dh(r["a_m"], math.radians(r["alpha_deg"]), r["d_m"], theta)  # noqa: E731
    T = row(spec["base"]["dh"], math.radians(spec["base"]["dh"]["theta_deg"]))
    for j, qj in zip(spec["joints"], q):
        T = T @ row(j, math.radians(j["theta_offset_deg"]) + qj)
    return T @ row(spec["tool"]["dh"], math.radians(spec["tool"]["dh"]["theta_deg"]))


URDF = """<?xml version="1.0"?>
<robot name="three">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tip"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.1 0 0.4" rpy="0.2 0 0.1"/><axis xyz="0 1 0"/><limit lower="-1.5" upper="1.5" effort="1" velocity="1"/></joint>
  <joint name="wrist" type="revolute"><parent link="l2"/><child link="tip"/>
    <origin xyz="0 0.05 0.35" rpy="0 -0.3 0"/><axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>
"""

# Each joint: its origin (xyz, rpy) in the parent link and its axis, as URDF = T(xyz) Rz(yaw) Ry(pitch) Rx(roll) Rot(axis, q).
URDF_JOINTS = [((0, 0, 0.3), (0, 0, 0), (0, 0, 1)), ((0.1, 0, 0.4), (0.2, 0, 0.1), (0, 1, 0)),
               ((0, 0.05, 0.35), (0, -0.3, 0), (1, 0, 0))]


def urdf_fk(q):
    T = np.eye(4)
    for (xyz, (r, p, y), axis), qj in zip(URDF_JOINTS, q):
        R = rot([0, 0, 1], y) @ rot([0, 1, 0], p) @ rot([1, 0, 0], r)
        T = T @ homogeneous(R, xyz) @ homogeneous(rot(axis, qj))
    return T


def test_ssrms_fk_matches_the_dh_product_of_its_table():
    arm = orbcal.load_robot("builtin:ssrms.yaml")
    assert arm.dof == 7 and arm.convention == "modified"
    rng = np.random.default_rng(11)
    for _ in range(5):
        q = rng.uniform(arm.lower, arm.upper)
        T = arm.fk(q)
        assert T.shape == (4, 4)
        # 1e-9 m on a 20 m arm: double rounding over nine transforms, nothing a formula could hide in.
        np.testing.assert_allclose(T, ssrms_fk(q), atol=1e-9)


def test_urdf_fk_matches_the_chain_written_here(tmp_path):
    path = tmp_path / "three.urdf"
    path.write_text(URDF)
    arm = orbcal.load_robot(str(path), base_link="base", tip_link="tip")
    assert arm.joint_names == ["shoulder", "elbow", "wrist"]
    np.testing.assert_allclose(arm.lower, [-2, -1.5, -3])
    np.testing.assert_allclose(arm.upper, [2, 1.5, 3])
    for q in ([0, 0, 0], [0.5, -1.0, 2.0], [-1.9, 1.4, -2.5]):
        np.testing.assert_allclose(arm.fk(np.array(q)), urdf_fk(q), atol=1e-12)


def test_jacobian_is_the_derivative_of_fk():
    arm = orbcal.load_robot("builtin:iiwa7.yaml")
    q = np.random.default_rng(5).uniform(arm.lower, arm.upper) * 0.8
    J = arm.jacobian(q)
    assert J.shape == (6, arm.dof)
    h = 1e-6  # central differences: truncation error ~h^2 = 1e-12, rounding ~1e-16 / h = 1e-10
    for j in range(arm.dof):
        dq = np.zeros(arm.dof)
        dq[j] = h
        Tp, Tm = arm.fk(q + dq), arm.fk(q - dq)
        v = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        W = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ arm.fk(q)[:3, :3].T  # skew(w) in the base frame
        np.testing.assert_allclose(J[:3, j], v, atol=1e-7)
        np.testing.assert_allclose(J[3:, j], [W[2, 1], W[0, 2], W[1, 0]], atol=1e-7)


def test_wrong_joint_count_is_a_value_error():
    arm = orbcal.load_robot("builtin:iiwa7.yaml")
    with pytest.raises(ValueError, match="expected 7 joint angles, got 3"):
        arm.fk(np.zeros(3))


def test_bad_robot_file_raises_orbcal_error_naming_file_and_key(tmp_path):
    text = (SOURCE_DIR / "scenes" / "ssrms.yaml").read_text().replace("d_m: 0.7026, theta_offset_deg: 0.0,",
                                                                       "d_m: abc, theta_offset_deg: 0.0,", 1)
    path = tmp_path / "bent.yaml"
    path.write_text(text)
    with pytest.raises(orbcal.Error) as e:
        orbcal.load_robot(str(path))
    message = str(e.value)
    assert isinstance(e.value, RuntimeError)
    assert "\n" not in message
    assert str(path) in message and "joints[1].d_m" in message and "'abc'" in message


def test_missing_robot_file_names_it(tmp_path):
    with pytest.raises(orbcal.Error, match="nothing.yaml: cannot read"):
        orbcal.load_robot(str(tmp_path / "nothing.yaml"))
