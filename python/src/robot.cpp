// orbcal.load_robot and the Robot class: a serial arm's forward kinematics and Jacobian (sim/arm.hpp,
// sim/jacobian.hpp), loaded from a robot YAML, a URDF or a built-in file (sim/io.hpp).
#include "bindings.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/jacobian.hpp"

namespace orbcal::python {

namespace {

/// The chain's joint names: the URDF's where the arm came from one, else "joint1" .. "jointN".
std::vector<std::string> jointNames(const sim::Arm& arm) {
  if (!arm.urdf.joint_names.empty()) return arm.urdf.joint_names;
  std::vector<std::string> names;
  for (int j = 1; j <= arm.numJoints(); ++j) names.push_back("joint" + std::to_string(j));
  return names;
}

}  // namespace

void bindRobot(py::module_& m) {
  py::class_<sim::Arm>(m, "Robot",
                       "A serial arm of revolute and prismatic joints (DH or URDF chain) with fixed base and tool "
                       "transforms. Joint values in SI: rad for a revolute joint, m for a prismatic one; lengths in m.")
      .def_readonly("name", &sim::Arm::name, "the robot's name (robot file's `name:`)")
      .def_readonly("source", &sim::Arm::source, "the file it was loaded from")
      .def_property_readonly("convention", [](const sim::Arm& a) { return std::string(sim::conventionName(a.convention)); },
                             "'modified', 'standard', 'hayati' or 'urdf'")
      .def_property_readonly("dof", &sim::Arm::numJoints, "number of joints")
      .def_property_readonly("joint_names", &jointNames, "joint names (the URDF's, else joint1 .. jointN)")
      .def_property_readonly(
          "joint_types",
          [](const sim::Arm& a) {
            std::vector<std::string> types;
            for (const sim::DhRow& r : a.joints) types.emplace_back(sim::jointTypeName(r.type));
            return types;
          },
          "'revolute' or 'prismatic', one per joint")
      .def_readonly("lower", &sim::Arm::lower_rad, "lower joint limits (rad, or m for a prismatic joint), one per joint")
      .def_readonly("upper", &sim::Arm::upper_rad, "upper joint limits (rad, or m for a prismatic joint), one per joint")
      .def_property_readonly("has_masses", [](const sim::Arm& a) { return !a.masses.empty(); },
                             "the robot file has a mass model (gravity torques for compliance)")
      .def(
          "fk",
          [](const sim::Arm& a, const Eigen::VectorXd& q) {
            sim::checkJointVector(a, q, "Robot.fk: q");
            return Eigen::Matrix4d(sim::forwardKinematics(a, q).matrix());
          },
          py::arg("q"),
          "base_T_flange at joint values q (one per joint: rad, or m for a prismatic joint): a 4x4 homogeneous "
          "transform, translation in m.")
      .def(
          "jacobian",
          [](const sim::Arm& a, const Eigen::VectorXd& q) {
            sim::checkJointVector(a, q, "Robot.jacobian: q");
            return Eigen::MatrixXd(sim::manipulatorJacobian(a, q));
          },
          py::arg("q"),
          "Geometric Jacobian (6 x dof) in the base frame at q (SI): rows [v of the flange origin; w], per rad of a "
          "revolute joint, per m of a prismatic one.")
      .def("__repr__", [](const sim::Arm& a) {
        return "<orbcal.Robot " + a.name + ": " + std::to_string(a.numJoints()) + " joints, " + sim::conventionName(a.convention) +
               ", from " + a.source + ">";
      });

  m.def(
      "load_robot",
      [](const std::string& path, const std::optional<std::string>& base_link, const std::optional<std::string>& tip_link) {
        return sim::loadArm(sim::RobotSource{path, base_link.value_or(""), tip_link.value_or("")});
      },
      py::arg("path"), py::arg("base_link") = py::none(), py::arg("tip_link") = py::none(),
      "Loads a robot: a robot YAML, a URDF (.urdf/.xml; base_link and tip_link choose the chain, default the root and "
      "the only leaf link) or a built-in file ('builtin:ssrms.yaml', 'builtin:iiwa7.yaml', ...). Raises orbcal.Error "
      "naming the file and the key on bad input.");
}

}  // namespace orbcal::python
