#include "orbcal/sim/marker_points.hpp"

#include <stdexcept>

#include "orbcal/sim/se3.hpp"

namespace orbcal::sim {

namespace {
/// The registration frames' typical translation (model.cpp's frame blocks): a point's offset is guessed
/// to that accuracy by the closed-form start.
constexpr double kTypicalPointOffset = 10e-3;
}  // namespace

ParamBlock pointBlock(int point) {
  ParamBlock b;
  b.effect = "point" + std::to_string(point + 1);
  b.kind = BlockKind::kMarkerPoint;
  for (const char* axis : {"x", "y", "z"}) b.params.push_back(lengthParam(b.effect + "_" + axis, kTypicalPointOffset));
  return b;
}

bool isPointBlock(const ParamBlock& b) { return b.kind == BlockKind::kMarkerPoint; }

int pointBlockIndex(const KinematicModel& m, int point) {
  const int b = m.layout.find("point" + std::to_string(point + 1));
  if (b < 0 || point < 0 || point >= static_cast<int>(m.marker_points.size())) {
    throw std::out_of_range("marker point " + std::to_string(point + 1) + " of " + std::to_string(m.marker_points.size()));
  }
  return b;
}

Eigen::Vector3d pointOffset(const KinematicModel& m, const Eigen::VectorXd& p, int point) {
  const ParamBlock& b = m.layout.block(pointBlockIndex(m, point));
  return m.marker_points[static_cast<std::size_t>(point)] + p.segment<3>(b.offset);
}

Eigen::Vector3d predictMarkerPoint(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s, int point,
                                   Eigen::MatrixXd* J_x_p, Eigen::MatrixXd* J_x_q) {
  const Eigen::Vector3d c = pointOffset(m, p, point);
  Eigen::MatrixXd J_e_p, J_e_q;
  const Eigen::Isometry3d T = predictMarkerPose(m, p, s, J_x_p ? &J_e_p : nullptr, J_x_q ? &J_e_q : nullptr);
  // T(p + dp) = T (Exp(w), v) with [v; w] = J_e dp: x moves by R (v + w x c) = R (v - [c]x w).
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Matrix3d Rc = R * skew(c);
  if (J_x_p) {
    *J_x_p = R * J_e_p.topRows<3>() - Rc * J_e_p.bottomRows<3>();
    J_x_p->middleCols<3>(m.layout.block(pointBlockIndex(m, point)).offset) += R;
  }
  if (J_x_q) *J_x_q = R * J_e_q.topRows<3>() - Rc * J_e_q.bottomRows<3>();
  return T * c;
}

std::vector<Eigen::Vector3d> foldedMarkerPoints(const KinematicModel& m, const Eigen::VectorXd& p) {
  std::vector<Eigen::Vector3d> out;
  for (int k = 0; k < static_cast<int>(m.marker_points.size()); ++k) out.push_back(pointOffset(m, p, k));
  return out;
}

}  // namespace orbcal::sim
