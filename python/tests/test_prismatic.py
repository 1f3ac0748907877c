"""Prismatic joints in the Python module: joint types, fk(q) with q in SI (m for the torso lift) against the
chain of scenes/mobile_manipulator.urdf read here with xml.etree (not orbcal), and the Jacobian's prismatic
column against central differences of fk."""
import math
import xml.etree.ElementTree as ET

import numpy as np

import orbcal
from conftest import SOURCE_DIR

URDF = SOURCE_DIR / "scenes" / "mobile_manipulator.urdf"


def rot(axis, angle):
    """Rotation matrix about a unit axis (Rodrigues)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def origin(joint):
    """A URDF <origin>: T(xyz) Rz(yaw) Ry(pitch) Rx(roll)."""
    o = joint.find("origin")
    xyz = [float(v) for v in o.get("xyz", "0 0 0").split()]
    r, p, y = (float(v) for v in o.get("rpy", "0 0 0").split())
    T = np.eye(4)
    T[:3, :3] = rot([0, 0, 1], y) @ rot([0, 1, 0], p) @ rot([1, 0, 0], r)
    T[:3, 3] = xyz
    return T


def fk_by_hand(q):
    """base_link_T_iiwa_link_ee: the file's joints in order (each listed after its parent here), movable
    ones followed by Rot(axis, q) or Trans(axis q)."""
    joints = {j.find("child").get("link"): j for j in ET.parse(URDF).getroot().iter("joint")}
    chain, link = [], "iiwa_link_ee"
    while link in joints:
        chain.append(joints[link])
        link = joints[link].find("parent").get("link")
    T, k = np.eye(4), 0
    for j in reversed(chain):
        T = T @ origin(j)
        if j.get("type") == "fixed":
            continue
        axis = [float(v) for v in j.find("axis").get("xyz").split()]
        M = np.eye(4)
        if j.get("type") == "prismatic":
            M[:3, 3] = q[k] * np.asarray(axis)
        else:
            M[:3, :3] = rot(axis, q[k])
        T, k = T @ M, k + 1
    return T


def test_joint_types_and_limits_in_si():
    robot = orbcal.load_robot(str(URDF))
    assert robot.dof == 8
    assert robot.joint_types == ["prismatic"] + ["revolute"] * 7
    assert robot.joint_names[0] == "torso_lift_joint"
    assert robot.lower[0] == 0.0 and robot.upper[0] == 0.4  # metres, as the URDF's <limit>


def test_fk_takes_metres_for_the_torso_and_matches_the_chain_written_here():
    robot = orbcal.load_robot(str(URDF))
    rng = np.random.default_rng(21)
    for _ in range(5):
        q = robot.lower + rng.random(robot.dof) * (robot.upper - robot.lower)
        np.testing.assert_allclose(robot.fk(q), fk_by_hand(q), atol=1e-12)
    # 0.25 m of lift raises the flange by 0.25 m, whatever the arm does.
    q = np.zeros(robot.dof)
    q2 = q.copy()
    q2[0] = 0.25
    np.testing.assert_allclose(robot.fk(q2)[:3, 3] - robot.fk(q)[:3, 3], [0, 0, 0.25], atol=1e-12)


def test_prismatic_jacobian_column_is_the_derivative_of_fk():
    robot = orbcal.load_robot(str(URDF))
    q = np.array([0.2, 0.3, -0.5, 0.4, 1.1, -0.2, 0.6, 0.1])
    h = 1e-6  # central differences: truncation ~h^2, round-off ~1e-16 / h, both far below 1e-7
    dp = (robot.fk(q + h * np.eye(8)[0])[:3, 3] - robot.fk(q - h * np.eye(8)[0])[:3, 3]) / (2 * h)
    J = robot.jacobian(q)
    np.testing.assert_allclose(J[:3, 0], dp, atol=1e-7)
    np.testing.assert_allclose(J[3:, 0], 0, atol=1e-12)  # a slide turns nothing
    assert np.linalg.norm(J[:3, 0]) > 0.99
