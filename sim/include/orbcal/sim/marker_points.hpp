#pragma once
// The marker points of a rigid body on the tool (motion capture: several reflective markers, each seen
// as a point): every point is fixed on the tool at its own unknown offset, and its position is what the
// measuring system records, not a pose computed from the points outside orbcal.
//
//   x_k(p, s) = world_T_marker(p, s) * (t_k + dt_k)
//
// world_T_marker as sim/model.hpp predicts it (with rigid-body data the marker frame is known: the
// flange, so the points' offsets are flange_T_point translations), t_k the point's starting offset
// (KinematicModel::marker_points) and dt_k its parameters: the block "point<k+1>" of the layout
// (point1_x, point1_y, point1_z; m), estimated with the registration.
#include <Eigen/Geometry>

#include "orbcal/sim/model.hpp"

namespace orbcal::sim {

/// The parameter block of marker point `point` (from 0): three lengths "point<k+1>_x/_y/_z" with the
/// registration frames' typical magnitude.
ParamBlock pointBlock(int point);

/// True for a marker point's block.
bool isPointBlock(const ParamBlock& b);

/// Index of the layout block of marker point `point` (from 0); throws std::out_of_range when absent.
int pointBlockIndex(const KinematicModel& m, int point);

/// t_k + dt_k: the offset of point `point` in the marker frame at p (m).
Eigen::Vector3d pointOffset(const KinematicModel& m, const Eigen::VectorXd& p, int point);

/// x_k in the measuring system's frame at p for sample s (m). J_x_p (3 x layout.size()) and J_x_q
/// (3 x joints): its derivatives over the parameters and the joint readings. Either may be null.
Eigen::Vector3d predictMarkerPoint(const KinematicModel& m, const Eigen::VectorXd& p, const JointSample& s, int point,
                                   Eigen::MatrixXd* J_x_p = nullptr, Eigen::MatrixXd* J_x_q = nullptr);

/// The model's marker points with p's point parameters folded in (foldParameters' share of them).
std::vector<Eigen::Vector3d> foldedMarkerPoints(const KinematicModel& m, const Eigen::VectorXd& p);

}  // namespace orbcal::sim
