// Measured data from Python: orbcal.load_measurements (a description and its CSV files, sim/measured.hpp),
// orbcal.measurements_from_arrays (the same data from numpy arrays, no files) and orbcal.simulate
// (tracker-style data of an arm with hidden effects, and its truth; sim/simulate.hpp).
#include <algorithm>
#include <cmath>

#include "bindings.hpp"
#include "orbcal/sim/joint_limits.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/measured.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/simulate.hpp"

namespace orbcal::python {

namespace {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// One row per sample of a per-sample vector (joint readings, torques), N x n.
RowMatrix stackRows(const sim::MeasuredData& d, const Eigen::VectorXd sim::JointSample::*field) {
  const Eigen::Index n = d.poses.empty() ? 0 : (d.poses.front().sample.*field).size();
  RowMatrix out(static_cast<Eigen::Index>(d.poses.size()), n);
  for (std::size_t k = 0; k < d.poses.size(); ++k) out.row(static_cast<Eigen::Index>(k)) = (d.poses[k].sample.*field).transpose();
  return out;
}

/// A scalar covariate per sample (NaN where not measured).
Eigen::VectorXd column(const sim::MeasuredData& d, double sim::JointSample::*field) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(d.poses.size()));
  for (std::size_t k = 0; k < d.poses.size(); ++k) out[static_cast<Eigen::Index>(k)] = d.poses[k].sample.*field;
  return out;
}

py::array_t<double> poseStack(const sim::MeasuredData& d) {
  py::array_t<double> out({static_cast<py::ssize_t>(d.poses.size()), py::ssize_t{4}, py::ssize_t{4}});
  auto a = out.mutable_unchecked<3>();
  for (std::size_t k = 0; k < d.poses.size(); ++k) {
    const Eigen::Matrix4d T = d.poses[k].world_T_marker.matrix();
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) a(static_cast<py::ssize_t>(k), r, c) = T(r, c);
    }
  }
  return out;
}

py::dict noiseDict(const sim::MeasuredData& d) {
  py::dict n;
  n["position_m"] = d.noise_position_m ? py::cast(*d.noise_position_m) : py::none();
  n["rotation_rad"] = d.noise_rotation_rad ? py::cast(*d.noise_rotation_rad) : py::none();
  n["joint_rad"] = d.noise_joint_rad ? py::cast(*d.noise_joint_rad) : py::none();
  return n;
}

/// `value` (SI) of noise key `key` within [lo, hi] (SI), else InputError naming the key and the range.
double noiseWithin(const py::handle& value, const std::string& key, double lo, double hi, const std::string& range) {
  const double v = value.cast<double>();
  if (!(v >= lo && v <= hi)) {
    throw sim::InputError("noise: " + key + ": " + sim::formatNumber("%.9g", v) + " is outside " + range);
  }
  return v;
}

/// The sigmas of a `noise` dict {position_m, rotation_rad, joint_rad} (each optional), within the ranges a
/// description's `noise:` allows (sim/measured.hpp).
void readNoise(const py::dict& noise, sim::MeasuredData& d) {
  for (const auto& [key, value] : noise) {
    const std::string k = key.cast<std::string>();
    if (value.is_none()) continue;
    if (k == "position_m") {
      d.noise_position_m = noiseWithin(value, k, sim::kMinNoisePositionMm * 1e-3, sim::kMaxNoisePositionMm * 1e-3, "1e-9 m to 0.1 m");
    } else if (k == "rotation_rad") {
      d.noise_rotation_rad = noiseWithin(value, k, sim::kMinNoiseRotationDeg * sim::kDegToRad,
                                         sim::kMaxNoiseRotationDeg * sim::kDegToRad, "1e-7 deg to 10 deg in rad");
    } else if (k == "joint_rad") {
      d.noise_joint_rad = noiseWithin(value, k, 0.0, sim::kMaxNoiseJointDeg * sim::kDegToRad, "0 to 10 deg in rad");
    } else {
      throw sim::InputError("noise: " + k + ": unknown key (expected position_m, rotation_rad, joint_rad)");
    }
  }
}

sim::FrameSharing sharingNamed(const std::string& name, const std::string& what) {
  for (sim::FrameSharing s : {sim::FrameSharing::kShared, sim::FrameSharing::kPerSession, sim::FrameSharing::kKnown}) {
    if (name == sim::frameSharingName(s)) return s;
  }
  throw sim::InputError(what + ": '" + name + "': expected shared, per_session or known");
}

/// Throws ValueError unless the optional array `a` has `rows` rows of `cols` columns (any count where cols is 0).
void requireRows(const std::optional<Eigen::MatrixXd>& a, Eigen::Index rows, Eigen::Index cols, const char* name) {
  if (a && (a->rows() != rows || (cols > 0 && a->cols() != cols))) {
    throw py::value_error(std::string(name) + ": expected " + std::to_string(rows) + " rows of " + std::to_string(cols) +
                          ", got " + std::to_string(a->rows()) + " x " + std::to_string(a->cols()));
  }
}

/// `T` as a rigid transform: its rotation orthonormal within 1e-6 with det +1 (as a description's matrix
/// columns are checked), its bottom row [0 0 0 1], its translation finite; InputError naming `what` otherwise.
Eigen::Isometry3d rigidTransform(const Eigen::Matrix4d& T, const std::string& what) {
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  const double off = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(off <= 1e-6) || !(R.determinant() > 0.0) || !((T.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() <= 1e-6) ||
      !T.topRightCorner<3, 1>().allFinite()) {
    throw sim::InputError(what + ": not a rigid transform (rotation orthonormal within 1e-6, det R = +1, bottom row [0 0 0 1], "
                          "finite translation)");
  }
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = R;
  X.translation() = T.topRightCorner<3, 1>();
  return X;
}

/// InputError naming `what` unless every value is finite (a NaN would read as "not measured").
void requireFinite(const Eigen::Ref<const Eigen::VectorXd>& v, const std::string& what) {
  if (!v.allFinite()) throw sim::InputError(what + ": not a finite number");
}

/// A temperature (degC) within an arm's range (sim/config.hpp), else InputError naming `what`.
double temperatureWithin(double t, const std::string& what) {
  if (!(t >= sim::kMinTemperatureC && t <= sim::kMaxTemperatureC)) {
    throw sim::InputError(what + ": " + sim::formatNumber("%.9g", t) + " degC is outside " + sim::formatNumber("%g", sim::kMinTemperatureC) +
                          " to " + sim::formatNumber("%g", sim::kMaxTemperatureC) + " degC (an arm's temperature)");
  }
  return t;
}

/// The pose of sample k: `poses[k]` (4x4) or `positions[k]` (rotation unused).
sim::MeasuredPose samplePose(const std::optional<py::array_t<double>>& poses, const std::optional<Eigen::MatrixXd>& positions,
                             std::size_t k) {
  sim::MeasuredPose p;
  p.where = "sample " + std::to_string(k);
  if (positions) {
    p.world_T_marker.translation() = positions->row(static_cast<Eigen::Index>(k)).transpose();
    p.has_rotation = false;
    requireFinite(p.world_T_marker.translation(), "positions[" + std::to_string(k) + "]");
  } else {
    auto a = poses->unchecked<3>();
    Eigen::Matrix4d T;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) T(r, c) = a(static_cast<py::ssize_t>(k), r, c);
    }
    p.world_T_marker = rigidTransform(T, "poses[" + std::to_string(k) + "]");
  }
  return p;
}

struct ArrayInput {
  Eigen::MatrixXd q;
  std::optional<Eigen::MatrixXd> positions;
  std::optional<py::array_t<double>> poses;
  std::optional<Eigen::MatrixXd> torques;
  std::optional<Eigen::VectorXd> temperature, time;
  std::optional<std::vector<int>> session;
  std::optional<Eigen::Matrix4d> world_T_base, flange_T_marker;  ///< exactly where base / marker are known
};

/// The samples of `in` on `arm`: shapes, finite numbers, joint limits and rigid poses checked.
std::vector<sim::MeasuredPose> samplesFrom(const sim::Arm& arm, const ArrayInput& in) {
  const Eigen::Index N = in.q.rows(), n = arm.numJoints();
  if (in.positions.has_value() == in.poses.has_value()) throw py::value_error("give exactly one of positions= and poses=");
  requireRows(in.positions, N, 3, "positions");
  requireRows(in.torques, N, n, "torques");
  if (in.poses && (in.poses->ndim() != 3 || in.poses->shape(0) != N || in.poses->shape(1) != 4 || in.poses->shape(2) != 4)) {
    throw py::value_error("poses: expected an array of " + std::to_string(N) + " 4x4 transforms");
  }
  for (const auto* v : {&in.temperature, &in.time}) {
    if (*v && (*v)->size() != N) throw py::value_error("temperature and time: one value per sample (" + std::to_string(N) + ")");
  }
  if (in.session && static_cast<Eigen::Index>(in.session->size()) != N) throw py::value_error("session: one index per sample");
  std::vector<sim::MeasuredPose> out;
  sim::JointLimitWarnings near_limits;
  for (Eigen::Index k = 0; k < N; ++k) {
    sim::MeasuredPose p = samplePose(in.poses, in.positions, static_cast<std::size_t>(k));
    sim::JointSample& s = p.sample;
    s.q_rad = in.q.row(k).transpose();
    sim::checkJointVector(arm, s.q_rad, ("q[" + std::to_string(k) + "]").c_str());
    for (int j = 0; j < arm.numJoints(); ++j) {
      if (near_limits.accept(arm, j, s.q_rad[j])) continue;
      throw sim::InputError("q[" + std::to_string(k) + "]: joint " + std::to_string(j + 1) + ": " + sim::formatNumber("%.9g", s.q_rad[j]) +
                            " " + sim::jointSiUnit(arm, j) + " (" + sim::formatJointValue(arm, j, s.q_rad[j]) + ") " +
                            sim::outsideLimitsText(arm, j));
    }
    const std::string at = "[" + std::to_string(k) + "]";
    if (in.torques) requireFinite(s.tau_Nm = in.torques->row(k).transpose(), "torques" + at);
    if (in.temperature) s.temperature_C = temperatureWithin((*in.temperature)[k], "temperature" + at);
    if (in.time) requireFinite(Eigen::Matrix<double, 1, 1>((*in.time)[k]), "time" + at);
    if (in.time) s.time_s = (*in.time)[k];
    s.session = in.session ? (*in.session)[static_cast<std::size_t>(k)] : 0;
    out.push_back(std::move(p));
  }
  for (const std::string& w : near_limits.lines(arm)) py::module_::import("warnings").attr("warn")(w);
  return out;
}

/// A known frame: given exactly when its sharing is `known` (as a description's keys), identity otherwise.
Eigen::Isometry3d knownFrame(const std::optional<Eigen::Matrix4d>& T, sim::FrameSharing sharing, const std::string& key,
                             const std::string& sharing_key) {
  if ((sharing == sim::FrameSharing::kKnown) != T.has_value()) {
    throw sim::InputError(key + ": given exactly when " + sharing_key + " is 'known' (" + sharing_key + ": '" +
                          sim::frameSharingName(sharing) + "')");
  }
  return T ? rigidTransform(*T, key) : Eigen::Isometry3d::Identity();
}

sim::MeasuredData fromArrays(const sim::Arm& arm, const ArrayInput& in, const py::dict& noise, const std::string& base,
                             const std::string& marker) {
  sim::MeasuredData d;
  d.description = "(arrays)";
  d.robot_file = arm.source;
  d.arm = arm;
  d.poses = samplesFrom(arm, in);
  int sessions = 0;
  for (const sim::MeasuredPose& p : d.poses) {
    if (p.sample.session < 0) throw sim::InputError("session: negative index " + std::to_string(p.sample.session));
    sessions = std::max(sessions, p.sample.session + 1);
  }
  for (int s = 0; s < sessions; ++s) d.files.push_back("(arrays, session " + std::to_string(s) + ")");
  d.base = sharingNamed(base, "base");
  d.marker = sharingNamed(marker, "marker");
  d.world_T_base = knownFrame(in.world_T_base, d.base, "world_T_base", "base");
  d.flange_T_marker = knownFrame(in.flange_T_marker, d.marker, "flange_T_marker", "marker");
  d.has_torque = in.torques.has_value();
  d.has_temperature = in.temperature.has_value();
  d.has_time = in.time.has_value();
  readNoise(noise, d);
  sim::fillApproachDirections(d.poses);
  return d;
}

/// `orbcal simulate`'s spec from the Python arguments, simulated; returns (data, truth).
py::tuple simulateData(const sim::Arm& robot, int samples, std::uint64_t seed, const std::vector<std::string>& effects,
                       const std::optional<Eigen::VectorXd>& values, int sessions, const py::object& payload_kg,
                       const py::dict& noise, const std::string& geometry, bool rotation, const std::string& base,
                       const std::string& marker) {
  sim::SimulationSpec s;
  s.samples = samples;
  s.sessions = sessions;
  s.seed = seed;
  s.effects = parseEffects(effects, robot.numJoints(), "effects");
  if (values) s.effect_values = *values;
  // One payload for every session, or one per session.
  s.payload_kg = py::isinstance<py::sequence>(payload_kg) ? payload_kg.cast<std::vector<double>>()
                                                           : std::vector<double>{payload_kg.cast<double>()};
  s.geometry.name = geometry;
  s.geometry.seed = seed;
  s.rotation = rotation;
  s.base = sharingNamed(base, "base");
  s.marker = sharingNamed(marker, "marker");
  sim::MeasuredData stated;
  readNoise(noise, stated);
  s.noise_position_m = stated.noise_position_m.value_or(s.noise_position_m);
  s.noise_rotation_rad = stated.noise_rotation_rad.value_or(s.noise_rotation_rad);
  s.joint_noise_rad = stated.noise_joint_rad.value_or(s.joint_noise_rad);
  sim::SimulatedData d = sim::simulateMeasured(robot, s);
  const sim::FoldedModel truth = sim::foldParameters(d.truth, d.p_true);
  return py::make_tuple(d.data, PyModel{truth.model, truth.p, exactRows(d.truth, d.p_true), py::dict(), "", {}});
}

}  // namespace

std::vector<sim::Effect> parseEffects(const std::vector<std::string>& specs, int joints, const std::string& what) {
  std::vector<sim::Effect> effects;
  for (const std::string& e : specs) effects.push_back(sim::parseEffect(e, joints, what));
  return effects;
}

std::vector<sim::ParameterRow> exactRows(const sim::KinematicModel& model, const Eigen::VectorXd& p) {
  std::vector<sim::ParameterRow> rows;
  for (int i = 0; i < model.layout.size(); ++i) {
    const sim::ParamInfo& info = model.layout.param(i);
    rows.push_back({info.name, model.layout.block(model.layout.blockOf(i)).effect, info.unit, p[i], std::nan(""), false});
  }
  return rows;
}

void bindMeasurements(py::module_& m) {
  py::class_<sim::MeasuredData>(m, "Measurements",
                                "Measured data: per sample the joint readings, the marker's pose measured in the "
                                "measuring system's frame, and covariates. SI units.")
      .def_readonly("robot", &sim::MeasuredData::arm, "the nominal robot")
      .def_readonly("description", &sim::MeasuredData::description, "the description file ('(arrays)' when built from arrays)")
      .def_readonly("files", &sim::MeasuredData::files, "one per session")
      .def("__len__", [](const sim::MeasuredData& d) { return d.poses.size(); }, "number of samples")
      .def_property_readonly("sessions", &sim::MeasuredData::numSessions, "number of sessions")
      .def_property_readonly("q", [](const sim::MeasuredData& d) { return stackRows(d, &sim::JointSample::q_rad); },
                             "joint readings (N x dof): rad for a revolute joint, m for a prismatic one")
      .def_property_readonly("poses", &poseStack, "measured world_T_marker (N x 4 x 4, m); rotation identity for position-only data")
      .def_property_readonly(
          "positions", [](const sim::MeasuredData& d) {
            RowMatrix p(static_cast<Eigen::Index>(d.poses.size()), 3);
            for (std::size_t k = 0; k < d.poses.size(); ++k) p.row(static_cast<Eigen::Index>(k)) = d.poses[k].world_T_marker.translation().transpose();
            return p;
          },
          "measured marker positions (N x 3, m)")
      .def_property_readonly("torques", [](const sim::MeasuredData& d) -> py::object {
            return d.has_torque ? py::cast(stackRows(d, &sim::JointSample::tau_Nm)) : py::none();
          }, "joint torques (N x dof, N m; a prismatic joint's force, N; actuator sense) or None")
      .def_property_readonly("temperature", [](const sim::MeasuredData& d) -> py::object {
            return d.has_temperature ? py::cast(column(d, &sim::JointSample::temperature_C)) : py::none();
          }, "temperature per sample (degC) or None")
      .def_property_readonly("time", [](const sim::MeasuredData& d) -> py::object {
            return d.has_time ? py::cast(column(d, &sim::JointSample::time_s)) : py::none();
          }, "time per sample (s) or None")
      .def_property_readonly("session", [](const sim::MeasuredData& d) {
            std::vector<int> s;
            for (const sim::MeasuredPose& p : d.poses) s.push_back(p.sample.session);
            return s;
          }, "session index per sample")
      .def_property_readonly("noise", &noiseDict, "stated noise, 1 sigma per axis: {position_m, rotation_rad, joint_rad} (None: estimated)")
      .def_property_readonly("registration", [](const sim::MeasuredData& d) {
            return py::dict(py::arg("base") = sim::frameSharingName(d.base), py::arg("marker") = sim::frameSharingName(d.marker));
          }, "how the base and marker frames are shared: shared, per_session or known")
      .def("save", [](const sim::MeasuredData& d, const std::string& folder, const std::string& robot_file) {
            return sim::writeMeasuredData(d, folder, robot_file);
          }, py::arg("folder"), py::arg("robot_file"),
          "Writes a description (measurements.yaml) and one CSV per session into `folder` (each file atomically); "
          "`robot_file` is written as given (relative to the folder, absolute or builtin:NAME). Returns the description's path.")
      .def("__repr__", [](const sim::MeasuredData& d) {
        return "<orbcal.Measurements " + std::to_string(d.poses.size()) + " samples in " + std::to_string(d.numSessions()) +
               " session(s) of " + d.arm.name + ">";
      });

  m.def("load_measurements", &sim::loadMeasuredData, py::arg("description_path"),
        "Reads a measurement description (YAML, format orbcal-measurements-1) and the CSV files it names. Raises "
        "orbcal.Error with a one-line message naming the file, the line and the column (or the key) on bad input.");

  m.def(
      "measurements_from_arrays",
      [](const sim::Arm& robot, const Eigen::MatrixXd& q, std::optional<Eigen::MatrixXd> positions,
         std::optional<py::array_t<double>> poses, std::optional<Eigen::MatrixXd> torques, std::optional<Eigen::VectorXd> temperature,
         std::optional<Eigen::VectorXd> time, std::optional<std::vector<int>> session, const py::dict& noise,
         const std::string& base, const std::string& marker, std::optional<Eigen::Matrix4d> world_T_base,
         std::optional<Eigen::Matrix4d> flange_T_marker) {
        return fromArrays(robot, {q, positions, poses, torques, temperature, time, session, world_T_base, flange_T_marker}, noise,
                          base, marker);
      },
      py::arg("robot"), py::kw_only(), py::arg("q"), py::arg("positions") = py::none(), py::arg("poses") = py::none(),
      py::arg("torques") = py::none(), py::arg("temperature") = py::none(), py::arg("time") = py::none(),
      py::arg("session") = py::none(), py::arg("noise") = py::dict(), py::arg("base") = "shared", py::arg("marker") = "shared",
      py::arg("world_T_base") = py::none(), py::arg("flange_T_marker") = py::none(),
      "Measured data from arrays, without files: q (N x dof; rad, m for a prismatic joint), and positions (N x 3, m) or poses (N x 4 x 4, m), "
      "optional torques (N x dof, N m; N for a prismatic joint; actuator sense), temperature (N, degC), time (N, s), session (N ints from 0), noise "
      "{position_m, rotation_rad, joint_rad} (1 sigma per axis; absent ones are estimated from the fit), base and marker "
      "'shared' | 'per_session' (unknown frames, estimated) or 'known', with world_T_base / flange_T_marker (4x4, m) "
      "given exactly then. Approach directions follow from the sample order.");

  m.def(
      "simulate",
      &simulateData,
      py::arg("robot"), py::kw_only(), py::arg("samples") = 200, py::arg("seed") = 1,
      py::arg("effects") = std::vector<std::string>{}, py::arg("values") = py::none(), py::arg("sessions") = 1,
      py::arg("payload_kg") = 0.0, py::arg("noise") = py::dict(), py::arg("geometry") = "random",
      py::arg("rotation") = true, py::arg("base") = "shared", py::arg("marker") = "per_session",
      "Simulates what a laser tracker records of `robot` with random DH errors ('random', 'zero' or 'table3') and the "
      "hidden `effects` ('compliance:2', 'cyclic:4', 'thermal', ...; joints from 1), seen in an unknown frame through an "
      "unknown marker, as `orbcal simulate` does. values: the effects' parameters (SI, layout order; default drawn). "
      "payload_kg: at the flange, one value or one per session. noise {position_m, rotation_rad, joint_rad}: 1 sigma per axis "
      "(default 0.05 mm, 0.01 deg, 0). rotation=False: position-only data. Returns (data, truth), truth an orbcal Model.");
}

}  // namespace orbcal::python
