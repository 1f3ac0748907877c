#pragma once
// Loading the human-written robot and scene files (YAML under scenes/). `path` may be a file or
// "builtin:ssrms.yaml" / "builtin:default_scene.yaml". Errors are InputError naming file and key.
#include <string>
#include <vector>

#include "orbcal/sim/arm.hpp"
#include "orbcal/sim/scene.hpp"

namespace orbcal::sim {

inline const char* kDefaultRobot = "builtin:ssrms.yaml";
inline const char* kDefaultScene = "builtin:default_scene.yaml";

/// A robot to load: a robot YAML or a URDF, and for a URDF the chain's links (sim/urdf.hpp; empty:
/// the root link and the only leaf link).
struct RobotSource {
  std::string path;
  std::string base_link;
  std::string tip_link;
};

/// Reads a robot file: name, convention, base, joints, tool and the optional `masses:` section
/// (gravity_m_s2, links: one {mass_kg, com_m} per joint with the COM in that joint's body DH frame,
/// payload: {mass_kg, com_m} at the flange) for sim::gravityTorques. A URDF (XML content; the
/// extension .urdf or .xml) is read by sim::armFromUrdf. An extension that contradicts the content
/// (XML in a .yaml, YAML in a .urdf) is an InputError saying so; so are links given for a YAML robot.
/// Convention `urdf` in a YAML (what formatArm writes for a URDF arm): joints
/// {name, xyz_m, rpy_deg, axis, theta_offset_deg, min_deg, max_deg[, fixed_before: {xyz_m, rpy_deg}]}
/// and an optional `urdf: {file, base_link, tip_link}` naming the URDF it came from (file relative
/// to the YAML's folder), where `orbcal calibrate` writes the calibrated origins back.
Arm loadArm(const RobotSource& source);
Arm loadArm(const std::string& path);
/// loadArm(source) of a robot file that another file named at a key (readTextNamedBy's `named_by`).
Arm loadArm(const RobotSource& source, const std::string& named_by);
/// A robot file for `arm` that loadArm reads back to the same kinematics and mass model (numbers
/// written exactly; base and tool as {xyz_m, rpy_deg}; `masses:` only when the arm has one).
/// `header` goes first as '#' comment lines.
std::string formatArm(const Arm& arm, const std::string& header = "");
/// A rigid transform as the flow map {xyz_m: [...], rpy_deg: [...]} that ConfigNode::asTransform reads
/// back (numbers written exactly).
std::string transformYaml(const Eigen::Isometry3d& T);
/// Loads the geometric part of a scene (camera, board, transforms, views). The rendering sections
/// (lighting, degradations, meshes) are read by render::loadRenderSettings from the same file.
Scene loadScene(const std::string& path);
/// Every top-level key a scene file may have (its geometric and rendering sections): loadScene and
/// render::loadRenderSettings both reject any other, so a misspelt section is an error in either.
const std::vector<std::string>& sceneTopLevelKeys();

}  // namespace orbcal::sim
