// orbcal.load_robot and the Robot class: a serial arm's forward kinematics, Jacobian and static gravity
// torques (sim/arm.hpp, sim/jacobian.hpp, sim/gravity.hpp), of one configuration or N at once, loaded from a robot YAML, a URDF or a built-in file (sim/io.hpp).
#include "bindings.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/jacobian.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/config.hpp"

namespace orbcal::python {

namespace {

/// The chain's joint names: the URDF's where the arm came from one, else "joint1" .. "jointN".
std::vector<std::string> jointNames(const sim::Arm& arm) {
  if (!arm.urdf.joint_names.empty()) return arm.urdf.joint_names;
  std::vector<std::string> names;
  for (int j = 1; j <= arm.numJoints(); ++j) names.push_back("joint" + std::to_string(j));
  return names;
}

using Configurations = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// Calls f(q, k) for each configuration of `q` (one: a vector of dof; several: N x dof), after checking
/// each as `context`; returns whether q held several.
template <typename F>
bool forEachConfiguration(const sim::Arm& a, const Configurations& q, const char* context, F f) {
  if (q.ndim() != 1 && q.ndim() != 2) {
    throw std::invalid_argument(std::string(context) + ": expected one configuration (dof) or N x dof, got " +
                                std::to_string(q.ndim()) + " dimensions");
  }
  const bool several = q.ndim() == 2;
  const py::ssize_t n = several ? q.shape(0) : 1, dof = several ? q.shape(1) : q.shape(0);
  for (py::ssize_t k = 0; k < n; ++k) {
    const Eigen::VectorXd qk = Eigen::Map<const Eigen::VectorXd>(q.data() + k * dof, dof);
    sim::checkJointVector(a, qk, context);
    f(qk, k);
  }
  return several;
}

/// An array of `shape` (N first where `several`) filled row-major by fill(k, data of entry k).
template <typename F>
py::array_t<double> stacked(py::ssize_t n, std::vector<py::ssize_t> shape, bool several, F fill) {
  if (several) shape.insert(shape.begin(), n);
  py::array_t<double> out(shape);
  py::ssize_t each = 1;
  for (std::size_t i = several ? 1 : 0; i < shape.size(); ++i) each *= shape[i];
  for (py::ssize_t k = 0; k < n; ++k) fill(k, out.mutable_data() + k * each);
  return out;
}

py::ssize_t count(const Configurations& q) { return q.ndim() == 2 ? q.shape(0) : 1; }

py::array_t<double> forwardKinematicsOf(const sim::Arm& a, const Configurations& q) {
  std::vector<Eigen::Matrix4d> T;
  const bool several = forEachConfiguration(a, q, "Robot.fk: q", [&](const Eigen::VectorXd& qk, py::ssize_t) {
    T.push_back(sim::forwardKinematics(a, qk).matrix());
  });
  return stacked(count(q), {4, 4}, several, [&](py::ssize_t k, double* d) {
    Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>> out(d);
    out = T[static_cast<std::size_t>(k)];
  });
}

py::array_t<double> jacobianOf(const sim::Arm& a, const Configurations& q) {
  std::vector<Eigen::MatrixXd> J;
  const bool several = forEachConfiguration(a, q, "Robot.jacobian: q", [&](const Eigen::VectorXd& qk, py::ssize_t) {
    J.push_back(sim::manipulatorJacobian(a, qk));
  });
  const int n = a.numJoints();
  return stacked(count(q), {6, n}, several, [&](py::ssize_t k, double* d) {
    Eigen::Map<Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor>> out(d, 6, n);
    out = J[static_cast<std::size_t>(k)];
  });
}

py::array_t<double> gravityTorquesOf(const sim::Arm& a, const Configurations& q, double payload_kg,
                                     const std::optional<Eigen::Vector3d>& payload_com_m) {
  if (a.masses.links.empty()) {
    throw sim::InputError(a.source + ": Robot.gravity_torques: the robot has no mass model (a robot file's masses: section, or a "
                          "URDF's <inertial> links)");
  }
  if (!(payload_kg >= 0.0 && payload_kg <= 1e6)) {
    throw sim::InputError("Robot.gravity_torques: payload_kg: " + sim::formatNumber("%.9g", payload_kg) + " is outside 0 kg to 1e6 kg");
  }
  sim::MassModel masses = a.masses;
  masses.payload_kg = payload_kg;
  if (payload_com_m) masses.payload_com_flange_m = *payload_com_m;
  std::vector<Eigen::VectorXd> tau;
  const bool several = forEachConfiguration(a, q, "Robot.gravity_torques: q", [&](const Eigen::VectorXd& qk, py::ssize_t) {
    tau.push_back(sim::gravityTorques(a, masses, qk));
  });
  const int n = a.numJoints();
  return stacked(count(q), {n}, several, [&](py::ssize_t k, double* d) {
    Eigen::Map<Eigen::VectorXd> out(d, n);
    out = tau[static_cast<std::size_t>(k)];
  });
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
      .def("fk", &forwardKinematicsOf, py::arg("q"),
           "base_T_flange at joint values q (one per joint: rad, or m for a prismatic joint): a 4x4 homogeneous transform, "
           "translation in m; for an N x dof array of configurations, an N x 4 x 4 array.")
      .def("jacobian", &jacobianOf, py::arg("q"),
           "Geometric Jacobian (6 x dof) in the base frame at q (SI): rows [v of the flange origin; w], per rad of a "
           "revolute joint, per m of a prismatic one; for an N x dof array of configurations, an N x 6 x dof array.")
      .def("gravity_torques", &gravityTorquesOf, py::arg("q"), py::kw_only(), py::arg("payload_kg") = 0.0,
           py::arg("payload_com_m") = py::none(),
           "Static joint torques under gravity (N m; N for a prismatic joint) holding the arm still at q, from the robot "
           "file's masses plus a payload (kg) at the flange, its centre of mass payload_com_m (3, m, flange frame; default "
           "the robot file's): the actuator's torque about its axis, the sense of measured torques and of what a "
           "compliance multiplies (docs/export.md). q: one configuration (returns dof values) or N x dof (returns N x dof). "
           "Raises orbcal.Error when the robot has no masses.")
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
