"""orbcal.calibrate_images: a description of images goes through `orbcal calibrate DESC.yaml`'s own pipeline
(workflow::runImageCalibrate): a rendered eye-in-hand set with joint readings and hidden joint offsets is
calibrated at the offsets level; a level naming no parameter of the robot is refused."""
import math

import pytest

import orbcal

from conftest import SOURCE_DIR

OFFSETS_DEG = [0.0, -0.3, 0.25, -0.2, 0.35, -0.25, 0.0]  # joints 1 and 7 turn with the frames: not identifiable


def _description(folder):
    path = folder / "images.yaml"
    path.write_text(
        "format: orbcal-measurements-1\nfiles: [samples.csv]\nrobot: robot.yaml\n"
        "joints: {columns: [q1_rad, q2_rad, q3_rad, q4_rad, q5_rad, q6_rad, q7_rad], unit: rad}\nimages: {column: image}\n"
        "camera: {width_px: 640, height_px: 512, fx_px: 700.0, fy_px: 700.0, cx_px: 321.4, cy_px: 254.2, distortion: [0, 0, 0, 0, 0]}\n"
        "board: {chessboard: {squares: [10, 7], square_mm: 80}}\nsetup: eye_in_hand\n")
    return str(path)


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    folder = tmp_path_factory.mktemp("image-levels")
    errors = folder / "errors.yaml"
    errors.write_text("format: orbcal-errors-1\ngeometry:\n" + "".join(
        f"  - {{theta_deg: {o}, alpha_deg: 0, a_mm: 0, d_mm: 0}}\n" for o in OFFSETS_DEG))
    out = folder / "ds"
    orbcal.render_dataset(str(SOURCE_DIR / "scenes" / "quick_scene.yaml"), 20, str(out), errors=str(errors), joint_noise_rad=0.0)
    return out


def test_calibrate_images_finds_joint_offsets_at_the_offsets_level(rendered):
    r = orbcal.calibrate_images(_description(rendered), level="offsets")
    assert r["accepted"], r["refusals"]
    assert r["level"] == "offsets"
    assert r["levels_tried"][0]["accepted"] and r["levels_tried"][0]["p_value"] < 0.01
    assert r["heldout_rms_m"] < 0.05 * r["frames_heldout_rms_m"]
    by_name = {p["name"]: p for p in r["parameters"]}
    for j in range(2, 7):
        p = by_name[f"theta{j}"]
        assert not p["held"]
        sigma = max(p["sigma"], p["sigma_jackknife"])
        assert abs(math.degrees(p["value"]) - OFFSETS_DEG[j - 1]) < 4.0 * math.degrees(sigma)
        assert math.degrees(sigma) < 0.01
    assert "## Robot level" in r["report"]


def test_calibrate_images_refuses_a_level_naming_no_parameter_of_the_robot(rendered):
    with pytest.raises(orbcal.Error, match="'theta9' is not a parameter"):
        orbcal.calibrate_images(_description(rendered), level="theta9")


def test_flange_poses_render_and_calibrate_with_the_lens_check(tmp_path):
    """render_dataset(configs=flange poses) writes images.yaml; calibrate_images on it recovers the scene's hand-eye
    (flange_T_camera: 0.25, 0, 0.10 m, rpy 0, 0, 90 deg in scenes/quick_scene.yaml) and keeps the stated lens."""
    rows = ["index,flange_x_m,flange_y_m,flange_z_m,flange_qw,flange_qx,flange_qy,flange_qz"]
    # Poses looking at the quick scene's board (base_T_board at 6, 4, 6 m, facing -x), from a CLI-planned run.
    planned = tmp_path / "planned"
    orbcal.render_dataset(str(SOURCE_DIR / "scenes" / "quick_scene.yaml"), 12, str(planned), seed=5, joint_noise_rad=0.0)
    robot = orbcal.load_robot(str(planned / "robot.yaml"))
    import csv
    with open(planned / "samples.csv") as f:
        for k, row in enumerate(csv.DictReader(f)):
            T = robot.fk([float(row[f"q{j}_rad"]) for j in range(1, 8)])
            w = math.sqrt(max(0.0, 1.0 + T[0][0] + T[1][1] + T[2][2])) / 2.0
            x, y, z = ((T[2][1] - T[1][2]) / (4 * w), (T[0][2] - T[2][0]) / (4 * w), (T[1][0] - T[0][1]) / (4 * w))
            rows.append(",".join(str(v) for v in [k, T[0][3], T[1][3], T[2][3], w, x, y, z]))
    (tmp_path / "flange.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(orbcal.Error, match="count"):
        orbcal.render_dataset(str(SOURCE_DIR / "scenes" / "quick_scene.yaml"), 3, str(tmp_path / "x"), configs=str(tmp_path / "flange.csv"))
    out = tmp_path / "ds"
    orbcal.render_dataset(str(SOURCE_DIR / "scenes" / "quick_scene.yaml"), 0, str(out), configs=str(tmp_path / "flange.csv"))
    r = orbcal.calibrate_images(str(out / "images.yaml"))
    assert r["accepted"], r["refusals"]
    assert r["level"] == "frames"
    T = r["hand_T_eye"]
    assert math.dist([T[0][3], T[1][3], T[2][3]], [0.25, 0.0, 0.10]) < 1e-3
    assert r["lens"] is not None and not r["lens"]["taken"]
