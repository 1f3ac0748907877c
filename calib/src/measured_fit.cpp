#include "orbcal/calib/measured_fit.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <future>
#include <limits>
#include <map>

#include "stacked_system.hpp"
#include "orbcal/calib/observability.hpp"
#include "orbcal/calib/registration.hpp"
#include "orbcal/calib/rigid_body.hpp"
#include "orbcal/sim/marker_points.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/csv.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/se3.hpp"

namespace orbcal::calib {

bool needsTorque(const std::vector<sim::Effect>& effects) {
  for (const sim::Effect& e : effects) {
    if (e.kind().needs().torque) return true;
  }
  return false;
}

std::vector<MarkerObservation> observationsFrom(const sim::MeasuredData& data, bool needs_torque) {
  if (needs_torque && !data.has_torque && data.arm.masses.empty()) {
    std::string links;
    for (const std::string& l : data.arm.urdf.links_without_inertial) links += (links.empty() ? "" : ", ") + l;
    throw sim::InputError(data.description + ": covariates.torque: compliance needs joint torques: the data has no torque "
                          "column and the robot file (" + data.robot_file + ") " +
                          (links.empty() ? std::string("no masses section") : "no <inertial> on the links the chain moves (" + links + ")") +
                          " to compute them from");
  }
  std::vector<MarkerObservation> obs;
  obs.reserve(data.poses.size());
  for (const sim::MeasuredPose& m : data.poses) {
    MarkerObservation o{m.sample, m.world_T_marker, m.has_rotation, {}, m.point};
    if (needs_torque && !o.sample.hasTorque()) o.sample.tau_Nm = sim::gravityTorques(data.arm, data.arm.masses, o.sample.q_rad);
    obs.push_back(std::move(o));
  }
  return obs;
}

namespace {

bool allRotations(const std::vector<MarkerObservation>& obs) {
  for (const MarkerObservation& o : obs) {
    if (!o.has_rotation) return false;
  }
  return true;
}

/// The chordal mean of rotations, projected onto SO(3), and the mean translation.
Eigen::Isometry3d meanTransform(const std::vector<Eigen::Isometry3d>& Ts) {
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  for (const Eigen::Isometry3d& T : Ts) {
    S += T.linear();
    t += T.translation();
  }
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = sim::projectToSO3(S);
  out.translation() = t / static_cast<double>(Ts.size());
  return out;
}

/// world_T_base with the marker known: from full poses, the mean of T_k M^-1 F_k^-1; from positions,
/// the rigid registration of the predicted marker positions onto the measured ones.
Eigen::Isometry3d baseWithKnownMarker(const std::vector<Eigen::Isometry3d>& T, const std::vector<Eigen::Isometry3d>& F,
                                      const Eigen::Isometry3d& M, bool use_rotation) {
  if (use_rotation) {
    std::vector<Eigen::Isometry3d> W;
    for (std::size_t k = 0; k < T.size(); ++k) W.push_back(T[k] * M.inverse() * F[k].inverse());
    return meanTransform(W);
  }
  Eigen::Matrix3Xd src(3, static_cast<Eigen::Index>(T.size())), dst(3, static_cast<Eigen::Index>(T.size()));
  for (std::size_t k = 0; k < T.size(); ++k) {
    src.col(static_cast<Eigen::Index>(k)) = (F[k] * M).translation();
    dst.col(static_cast<Eigen::Index>(k)) = T[k].translation();
  }
  return Eigen::Isometry3d(Eigen::umeyama(src, dst, false));
}

struct SessionPoses {
  std::vector<Eigen::Isometry3d> T, F;
};

/// The unknown frames of `shape` (its sharing and known frames) from measured poses and the flange
/// poses of a model at the same samples; the frames of `shape` that are estimated are replaced.
void guessFrames(sim::KinematicModel& shape, const std::vector<MarkerObservation>& obs,
                 const std::vector<Eigen::Isometry3d>& F) {
  using sim::FrameSharing;
  const bool rot = allRotations(obs);
  const int S = shape.sessions;
  std::vector<SessionPoses> per(static_cast<std::size_t>(S));
  SessionPoses all;
  for (std::size_t k = 0; k < obs.size(); ++k) {
    per[static_cast<std::size_t>(obs[k].sample.session)].T.push_back(obs[k].world_T_marker);
    per[static_cast<std::size_t>(obs[k].sample.session)].F.push_back(F[k]);
    all.T.push_back(obs[k].world_T_marker);
    all.F.push_back(F[k]);
  }
  std::size_t largest = 0;
  for (std::size_t s = 0; s < per.size(); ++s) {
    if (per[s].T.size() > per[largest].T.size()) largest = s;
  }
  const auto markerGiven = [&](const SessionPoses& sp, const Eigen::Isometry3d& W) { return initialMarker(sp.T, sp.F, W, rot); };
  if (shape.base == FrameSharing::kPerSession) {
    for (int s = 0; s < S; ++s) {
      const SessionPoses& sp = per[static_cast<std::size_t>(s)];
      if (shape.marker == FrameSharing::kKnown) {
        shape.world_T_base[static_cast<std::size_t>(s)] = baseWithKnownMarker(sp.T, sp.F, shape.flange_T_marker[0], rot);
        continue;
      }
      const RegistrationGuess g = initialRegistration(sp.T, sp.F, rot);
      shape.world_T_base[static_cast<std::size_t>(s)] = g.world_T_base;
      if (shape.marker == FrameSharing::kPerSession) shape.flange_T_marker[static_cast<std::size_t>(s)] = g.flange_T_marker;
      if (shape.marker == FrameSharing::kShared && static_cast<std::size_t>(s) == largest) shape.flange_T_marker[0] = g.flange_T_marker;
    }
    return;
  }
  if (shape.base == FrameSharing::kShared) {
    if (shape.marker == FrameSharing::kKnown) {
      shape.world_T_base[0] = baseWithKnownMarker(all.T, all.F, shape.flange_T_marker[0], rot);
      return;
    }
    // With a marker per session, the largest session alone fixes the base.
    const RegistrationGuess g = initialRegistration(shape.marker == FrameSharing::kShared ? all.T : per[largest].T,
                                                    shape.marker == FrameSharing::kShared ? all.F : per[largest].F, rot);
    shape.world_T_base[0] = g.world_T_base;
    if (shape.marker == FrameSharing::kShared) shape.flange_T_marker[0] = g.flange_T_marker;
  }
  if (shape.marker == FrameSharing::kPerSession) {
    for (int s = 0; s < S; ++s) shape.flange_T_marker[static_cast<std::size_t>(s)] = markerGiven(per[static_cast<std::size_t>(s)], shape.world_T_base[0]);
  } else if (shape.marker == FrameSharing::kShared && shape.base == FrameSharing::kKnown) {
    shape.flange_T_marker[0] = markerGiven(all, shape.world_T_base[0]);
  }
}

std::vector<Eigen::Isometry3d> framesFor(sim::FrameSharing sharing, int sessions, const Eigen::Isometry3d& T) {
  return std::vector<Eigen::Isometry3d>(sharing == sim::FrameSharing::kPerSession ? static_cast<std::size_t>(sessions) : 1, T);
}

/// tr(P V_c P V_d) of REML's information (Koch 1999, ch. 3.6), P = W - W A N^-1 A^T W, with W = R^-1
/// block diagonal per sample, A the free columns of the Jacobian and N = A^T W A + S (S the prior):
/// sum_k tr(W V_c W V_d) - 2 tr(N^-1 C_cd) + tr(N^-1 B_c N^-1 B_d), B_c = sum_k A_k^T W V_c W A_k,
/// C_cd = sum_k A_k^T W V_c W V_d W A_k: what the fitted parameters take of each component is not
/// counted as its noise (joint noise above all: the joint corrections' columns lie along J_q).
/// tr(N^-1 C_cd) = sum_k tr(V_c W V_d H_k) with H_k = W A_k N^-1 A_k^T W (3 or 6 square): no p x p
/// matrix per pair. The samples go in chunks, stacked (one product per chunk, not one per sample), the
/// two halves of the samples side by side, summed in a fixed order (the same sums on any machine).
Eigen::Matrix3d remlInformation(const std::vector<Eigen::MatrixXd>& A, const std::vector<std::array<Eigen::MatrixXd, 3>>& V,
                                const Eigen::Vector3d& theta, const Eigen::VectorXd& prior) {
  const Eigen::Index p = prior.size();
  constexpr std::size_t kChunk = 128;
  const auto W = [&](std::size_t k) {
    return Eigen::LDLT<Eigen::MatrixXd>(theta[0] * V[k][0] + theta[1] * V[k][1] + theta[2] * V[k][2]);
  };
  // The samples [k0, k1) stacked: A_k and W A_k.
  const auto stack = [&](std::size_t k0, std::size_t k1, Eigen::MatrixXd& As, Eigen::MatrixXd& WA) {
    Eigen::Index rows = 0;
    for (std::size_t k = k0; k < k1; ++k) rows += A[k].rows();
    As.resize(rows, p);
    WA.resize(rows, p);
    for (std::size_t k = k0, row = 0; k < k1; row += static_cast<std::size_t>(A[k].rows()), ++k) {
      As.middleRows(static_cast<Eigen::Index>(row), A[k].rows()) = A[k];
      WA.middleRows(static_cast<Eigen::Index>(row), A[k].rows()) = W(k).solve(A[k]);
    }
  };
  struct Sums {
    Eigen::MatrixXd N;  ///< lower triangles
    std::array<Eigen::MatrixXd, 3> B;
    Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
  };
  // First pass over [k0, k1): A^T W A, B_c and sum_k tr(W V_c W V_d).
  const auto first = [&](std::size_t k0, std::size_t k1) {
    Sums s;
    s.N = Eigen::MatrixXd::Zero(p, p);
    for (auto& b : s.B) b = Eigen::MatrixXd::Zero(p, p);
    Eigen::MatrixXd As, WA, VWA;
    for (std::size_t c0 = k0; c0 < k1; c0 += kChunk) {
      const std::size_t c1 = std::min(k1, c0 + kChunk);
      stack(c0, c1, As, WA);
      s.N.triangularView<Eigen::Lower>() += As.transpose() * WA;
      VWA.resize(WA.rows(), p);
      for (std::size_t c = 0; c < 3; ++c) {
        for (std::size_t k = c0, row = 0; k < c1; row += static_cast<std::size_t>(A[k].rows()), ++k) {
          const auto rows = Eigen::seqN(static_cast<Eigen::Index>(row), A[k].rows());
          VWA(rows, Eigen::all).noalias() = V[k][c] * WA(rows, Eigen::all);
        }
        s.B[c].triangularView<Eigen::Lower>() += WA.transpose() * VWA;
      }
      for (std::size_t k = c0; k < c1; ++k) {
        const Eigen::LDLT<Eigen::MatrixXd> Wk = W(k);
        std::array<Eigen::MatrixXd, 3> WV;
        for (std::size_t c = 0; c < 3; ++c) WV[c] = Wk.solve(V[k][c]);
        for (int c = 0; c < 3; ++c) {
          for (int d = c; d < 3; ++d) s.F(c, d) += (WV[static_cast<std::size_t>(c)] * WV[static_cast<std::size_t>(d)]).trace();
        }
      }
    }
    return s;
  };
  const std::size_t half = A.size() / 2;
  auto upper = std::async(std::launch::async, first, half, A.size());
  Sums s = first(0, half);
  const Sums s2 = upper.get();
  s.N += s2.N;
  s.N.diagonal() += prior;
  s.N = s.N.selfadjointView<Eigen::Lower>();
  for (std::size_t c = 0; c < 3; ++c) s.B[c] = (s.B[c] + s2.B[c]).selfadjointView<Eigen::Lower>();
  Eigen::Matrix3d F = s.F + s2.F;
  // Second pass: H_k = Y_k^T D^-1 Y_k with N = P^T L D L^T P and Y = L^-1 P A^T W.
  const Eigen::LDLT<Eigen::MatrixXd> Ninv(s.N);
  Eigen::VectorXd Dinv = Ninv.vectorD();
  for (Eigen::Index i = 0; i < p; ++i) Dinv[i] = std::abs(Dinv[i]) > std::numeric_limits<double>::min() ? 1.0 / Dinv[i] : 0.0;
  const auto second = [&](std::size_t k0, std::size_t k1) {
    Eigen::Matrix3d G = Eigen::Matrix3d::Zero();
    Eigen::MatrixXd As, WA, Y;
    for (std::size_t c0 = k0; c0 < k1; c0 += kChunk) {
      const std::size_t c1 = std::min(k1, c0 + kChunk);
      stack(c0, c1, As, WA);
      Y = Ninv.transpositionsP() * WA.transpose();
      Ninv.matrixL().solveInPlace(Y);
      for (std::size_t k = c0, row = 0; k < c1; row += static_cast<std::size_t>(A[k].rows()), ++k) {
        const auto Yk = Y.middleCols(static_cast<Eigen::Index>(row), A[k].rows());
        const Eigen::MatrixXd H = Yk.transpose() * (Dinv.asDiagonal() * Yk);
        const Eigen::LDLT<Eigen::MatrixXd> Wk = W(k);
        for (int c = 0; c < 3; ++c) {
          const Eigen::MatrixXd VcW = Wk.solve(V[k][static_cast<std::size_t>(c)]).transpose();  // V_c W (both symmetric)
          for (int d = c; d < 3; ++d) G(c, d) -= 2.0 * (VcW * V[k][static_cast<std::size_t>(d)] * H).trace();
        }
      }
    }
    return G;
  };
  auto upper2 = std::async(std::launch::async, second, half, A.size());
  F += second(0, half);
  F += upper2.get();
  std::array<Eigen::MatrixXd, 3> NB;
  for (int c = 0; c < 3; ++c) NB[static_cast<std::size_t>(c)] = Ninv.solve(s.B[static_cast<std::size_t>(c)]);
  for (int c = 0; c < 3; ++c) {
    for (int d = c; d < 3; ++d) {
      F(c, d) += (NB[static_cast<std::size_t>(c)] * NB[static_cast<std::size_t>(d)]).trace();
      F(d, c) = F(c, d);
    }
  }
  return F;
}

/// Variance components of the residuals r_k of `m` at y (REML Fisher scoring; Koch, Parameter
/// Estimation and Hypothesis Testing in Linear Models, 1999, ch. 3.6): R_k = sum_c theta_c V_kc with
/// V_k1 = the position rows, V_k2 = the rotation rows, V_k3 = Jq_k Jq_k^T (joint noise through the
/// residual's joint Jacobian). The components `free` are estimated, the others kept at `noise`'s
/// values; each step solves sum tr(P V_c P V_d) theta_d = sum_k r^T W V_c W r (remlInformation; the
/// parameters not in `held` are the fitted ones, `prior` their prior's information), until the free
/// variances change by less than 1e-6 of themselves. Variances are kept >= 0 (sigmas of position and
/// rotation >= 1e-9).
MarkerNoise estimateNoiseComponents(const MarkerPoseModel& m, const Eigen::VectorXd& y, const MarkerNoise& noise,
                                    const std::array<bool, 3>& free, const std::vector<int>& held, const Eigen::VectorXd& prior_sigma,
                                    NoiseComponents* components) {
  const int n = m.numSamples();
  std::vector<int> cols;
  for (int i = 0; i < m.numParams(); ++i) {
    if (!std::binary_search(held.begin(), held.end(), i)) cols.push_back(i);
  }
  Eigen::VectorXd prior = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(cols.size()));
  for (std::size_t c = 0; c < cols.size(); ++c) {
    const double s = prior_sigma.size() > cols[c] ? prior_sigma[cols[c]] : 0.0;
    prior[static_cast<Eigen::Index>(c)] = s > 0.0 ? 1.0 / (s * s) : 0.0;
  }
  // Per sample: the residual, the free Jacobian columns and V_k1..3 (fixed over the iterations).
  std::vector<Eigen::VectorXd> r(static_cast<std::size_t>(n));
  std::vector<Eigen::MatrixXd> A(static_cast<std::size_t>(n));
  std::vector<std::array<Eigen::MatrixXd, 3>> V(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const auto i = static_cast<std::size_t>(k);
    const Eigen::MatrixXd Jq = m.jointJacobian(k, y, &r[i]);
    const Eigen::MatrixXd H = m.linearize(k, y).H;
    A[i].resize(H.rows(), static_cast<Eigen::Index>(cols.size()));
    for (std::size_t c = 0; c < cols.size(); ++c) A[i].col(static_cast<Eigen::Index>(c)) = H.col(cols[c]);
    const Eigen::Index rows = r[i].size();
    V[i][0] = Eigen::MatrixXd::Zero(rows, rows);
    V[i][0].topLeftCorner(3, 3).setIdentity();
    V[i][1] = Eigen::MatrixXd::Zero(rows, rows);
    if (rows == 6) V[i][1].bottomRightCorner(3, 3).setIdentity();
    V[i][2] = Jq * Jq.transpose();
  }
  Eigen::Vector3d theta(noise.sigma_position_m * noise.sigma_position_m, noise.sigma_rotation_rad * noise.sigma_rotation_rad,
                        noise.joint_noise_sigma_rad * noise.joint_noise_sigma_rad);
  std::vector<int> f;
  for (int c = 0; c < 3; ++c) {
    if (free[static_cast<std::size_t>(c)]) f.push_back(c);
  }
  const auto nf = static_cast<Eigen::Index>(f.size());
  Eigen::MatrixXd F_last;
  for (int iteration = 0; iteration < 50 && nf > 0; ++iteration) {
    const Eigen::Matrix3d I = remlInformation(A, V, theta, prior);
    Eigen::MatrixXd F(nf, nf);
    Eigen::VectorXd u = Eigen::VectorXd::Zero(nf);
    for (int k = 0; k < n; ++k) {
      const std::array<Eigen::MatrixXd, 3>& Vk = V[static_cast<std::size_t>(k)];
      const Eigen::LDLT<Eigen::MatrixXd> W(theta[0] * Vk[0] + theta[1] * Vk[1] + theta[2] * Vk[2]);
      const Eigen::VectorXd Wr = W.solve(r[static_cast<std::size_t>(k)]);
      for (Eigen::Index a = 0; a < nf; ++a) u[a] += Wr.dot(Vk[static_cast<std::size_t>(f[static_cast<std::size_t>(a)])] * Wr);
    }
    for (Eigen::Index a = 0; a < nf; ++a) {
      const int ca = f[static_cast<std::size_t>(a)];
      for (int c = 0; c < 3; ++c) {  // the fixed components' share moved to the right-hand side
        if (!free[static_cast<std::size_t>(c)]) u[a] -= theta[c] * I(ca, c);
      }
      for (Eigen::Index b = 0; b < nf; ++b) F(a, b) = I(ca, f[static_cast<std::size_t>(b)]);
    }
    F_last = F;
    const Eigen::VectorXd next = F.completeOrthogonalDecomposition().solve(u);
    double change = 0.0;
    for (Eigen::Index a = 0; a < nf; ++a) {
      const int c = f[static_cast<std::size_t>(a)];
      const double floor = c == 2 ? 0.0 : 1e-18;
      const double v = std::max(floor, next[a]);
      change = std::max(change, std::abs(v - theta[c]) / std::max(v, 1e-300));
      theta[c] = v;
    }
    if (change < 1e-6) break;
  }
  if (components && nf > 0) {
    // The variances' covariance: 2 F^-1 (the information of a Gaussian's covariance parameters is
    // tr(P V_c P V_d) / 2).
    const Eigen::MatrixXd C = 2.0 * F_last.completeOrthogonalDecomposition().pseudoInverse();
    *components = NoiseComponents{};
    for (Eigen::Index a = 0; a < nf; ++a) {
      const auto ca = static_cast<std::size_t>(f[static_cast<std::size_t>(a)]);
      components->estimated[ca] = true;
      for (Eigen::Index b = 0; b < nf; ++b) components->covariance(static_cast<Eigen::Index>(ca), f[static_cast<std::size_t>(b)]) = C(a, b);
    }
    components->variance = theta;
  }
  MarkerNoise out = noise;
  if (free[0]) out.sigma_position_m = std::max(1e-9, std::sqrt(theta[0]));
  if (free[1]) out.sigma_rotation_rad = std::max(1e-9, std::sqrt(theta[1]));
  if (free[2]) out.joint_noise_sigma_rad = std::sqrt(theta[2]);
  return out;
}

}  // namespace

double NoiseComponents::sigmaSd(int c) const {
  const double v = variance[c], sd = std::sqrt(std::max(0.0, covariance(c, c)));
  return v > sd ? sd / (2.0 * std::sqrt(v)) : std::sqrt(sd);
}

double NoiseComponents::sigmaUpper(int c) const {
  return std::sqrt(std::max(0.0, variance[c]) + 2.0 * std::sqrt(std::max(0.0, covariance(c, c))));
}

bool NoiseComponents::resolved(int c) const {
  return estimated[static_cast<std::size_t>(c)] && variance[c] > 2.0 * std::sqrt(std::max(0.0, covariance(c, c)));
}

double NoiseComponents::correlation(int a, int b) const {
  const double d = std::sqrt(std::max(0.0, covariance(a, a)) * std::max(0.0, covariance(b, b)));
  return d > 0.0 ? covariance(a, b) / d : 0.0;
}

sim::KinematicModel startingModel(const sim::MeasuredData& data, const std::vector<MarkerObservation>& observations,
                                  std::vector<sim::Effect> effects) {
  const int S = data.numSessions();
  std::vector<sim::JointSample> samples;
  for (const MarkerObservation& o : observations) samples.push_back(o.sample);
  for (sim::Effect& e : effects) e = e.kind().adaptTo(e, samples);
  sim::KinematicModel shape = sim::makeKinematicModel(data.arm, S, data.base, data.marker, framesFor(data.base, S, data.world_T_base),
                                                      framesFor(data.marker, S, data.flange_T_marker), std::move(effects));
  std::vector<Eigen::Isometry3d> F;
  for (const MarkerObservation& o : observations) F.push_back(sim::forwardKinematics(data.arm, o.sample.q_rad));
  if (data.points > 0) return rigidBodyStart(data, observations, F, shape);
  try {
    guessFrames(shape, observations, F);
  } catch (const std::invalid_argument& e) {
    throw sim::InputError(data.description + ": registration: the samples cannot fix the unknown frames (" + e.what() + ")");
  }
  return shape;
}

ResidualStats residualStats(const std::vector<Eigen::VectorXd>& residuals) {
  ResidualStats s;
  s.samples = static_cast<int>(residuals.size());
  if (residuals.empty()) return s;
  double pos2 = 0.0, rot2 = 0.0;
  int nrot = 0;
  for (const Eigen::VectorXd& r : residuals) {
    const double e = r.head<3>().norm();
    s.position_mean_m += e / s.samples;
    pos2 += e * e;
    s.position_max_m = std::max(s.position_max_m, e);
    if (r.size() == 6) {
      const double a = r.tail<3>().norm();
      rot2 += a * a;
      ++nrot;
      s.rotation_max_rad = std::max(s.rotation_max_rad, a);
    }
  }
  s.position_rms_m = std::sqrt(pos2 / s.samples);
  s.rotation_rms_rad = nrot ? std::sqrt(rot2 / nrot) : 0.0;
  s.rotation_samples = nrot;
  return s;
}

ResidualStats residualStats(const sim::KinematicModel& model, const Eigen::VectorXd& p,
                            const std::vector<MarkerObservation>& observations) {
  std::vector<Eigen::VectorXd> residuals;
  residuals.reserve(observations.size());
  for (const MarkerObservation& o : observations) residuals.push_back(markerResidual(model, p, o));
  return residualStats(residuals);
}

FitControls fitControls(const FitOptions& o, const sim::ParamLayout& layout, const Eigen::VectorXd& p0) {
  FitControls controls;
  controls.hold = o.hold;
  controls.fix_unidentifiable = o.fix_unidentifiable;
  controls.covariance = o.analyze;
  controls.normal_equations = o.normal_equations;
  if (o.geometry_prior || o.map) {
    controls.prior_sigma = geometryPriorSigma(layout);
    controls.prior_mean = -p0;  // centred on the starting model: p = p0 + y = 0
  }
  if (o.map) {
    controls.scaled_prior = Eigen::VectorXd::Zero(layout.size());
    const int g = layout.find(sim::BlockKind::kGeometry);
    if (g >= 0) controls.scaled_prior.segment(layout.block(g).offset, layout.block(g).size()) = layout.typical().segment(layout.block(g).offset, layout.block(g).size());
  }
  return controls;
}

Eigen::VectorXd geometryPriorSigma(const sim::ParamLayout& layout) {
  const Eigen::VectorXd typical = layout.typical();
  Eigen::VectorXd sigma = Eigen::VectorXd::Zero(layout.size());
  for (const sim::ParamBlock& b : layout.blocks()) {
    using K = sim::BlockKind;
    if (b.kind != K::kGeometry && b.kind != K::kBase && b.kind != K::kMarker && !sim::isPointBlock(b)) continue;
    sigma.segment(b.offset, b.size()) = typical.segment(b.offset, b.size());
  }
  return sigma;
}

Fit fitMarkerModel(const sim::KinematicModel& start, const std::vector<MarkerObservation>& obs, const FitOptions& o,
                   const Eigen::VectorXd& p0_in) {
  Fit fit;
  fit.model = start;
  fit.p0 = p0_in.size() ? p0_in : Eigen::VectorXd::Zero(start.layout.size());
  fit.noise.joint_noise_sigma_rad = o.joint_noise_sigma_rad;
  if (o.sigma_position_m) fit.noise.sigma_position_m = *o.sigma_position_m;
  if (o.sigma_rotation_rad) fit.noise.sigma_rotation_rad = *o.sigma_rotation_rad;
  fit.noise_estimated = !(o.sigma_position_m && o.sigma_rotation_rad) || o.estimate_joint_noise;
  const int rounds = fit.noise_estimated ? 3 : 1;
  int rows = 0;
  for (const MarkerObservation& x : obs) rows += x.has_rotation ? 6 : 3;
  for (int round = 0; round < rounds; ++round) {
    const MarkerPoseModel m(start, obs, fit.noise, fit.p0);
    if (round == 0 && o.analyze) {
      std::vector<std::string> names;
      for (int i = 0; i < m.numParams(); ++i) names.push_back(m.paramName(i));
      // From the whitened Jacobian's R factor (its column norms, singular values and right vectors).
      fit.identifiability = sim::analyzeJacobian(whitenedRFactor(m, Eigen::VectorXd::Zero(m.numParams())), names,
                                                 m.numSamples(), sim::kRankTolerance);
      fit.identifiability.num_rows = rows;
    }
    // Without analyses the last round starts where the round before ended (not the 2nd: docs/benchmarks.md).
    FitControls controls = fitControls(o, start.layout, fit.p0);
    if (!o.analyze && round > 0 && round + 1 == rounds) controls.start = fit.estimate.y;
    fit.estimate = runMethod(findMethod(comparisonMethods(o.joint_noise_sigma_rad), o.method, "method"), m, controls);
    fit.p = fit.p0 + fit.estimate.y;
    fit.chi2 = 2.0 * fit.estimate.cost;
    const int free = m.numParams() - static_cast<int>(fit.estimate.held.size());
    fit.effective_parameters = o.map ? fit.estimate.effective_parameters : free;
    fit.prior_scale = fit.estimate.prior_scale;
    fit.dof = std::max(1, rows - static_cast<int>(std::lround(fit.effective_parameters)));
    if (round + 1 == rounds) {
      if (o.analyze) fit.observability = observability(m, Eigen::VectorXd::Zero(m.numParams()), fit.estimate.held);
      break;
    }
    const double correction = static_cast<double>(rows) / fit.dof;
    if (o.estimate_joint_noise) {
      const bool rotations = std::any_of(obs.begin(), obs.end(), [](const MarkerObservation& x) { return x.has_rotation; });
      fit.noise = estimateNoiseComponents(m, fit.estimate.y, fit.noise, {!o.sigma_position_m, !o.sigma_rotation_rad && rotations, true},
                                          fit.estimate.held, o.geometry_prior ? geometryPriorSigma(start.layout) : Eigen::VectorXd(),
                                          &fit.noise_components);
      continue;
    }
    // Variance components: position and rotation sigmas from their residuals, corrected for the
    // parameters fitted (rows / dof).
    double pos2 = 0.0, rot2 = 0.0;
    int npos = 0, nrot = 0;
    for (const MarkerObservation& x : obs) {
      const Eigen::VectorXd r = markerResidual(start, fit.p, x);
      pos2 += r.head<3>().squaredNorm();
      npos += 3;
      if (r.size() == 6) {
        rot2 += r.tail<3>().squaredNorm();
        nrot += 3;
      }
    }
    if (!o.sigma_position_m) fit.noise.sigma_position_m = std::max(1e-9, std::sqrt(pos2 / npos * correction));
    if (!o.sigma_rotation_rad && nrot) fit.noise.sigma_rotation_rad = std::max(1e-9, std::sqrt(rot2 / nrot * correction));
  }
  fit.residuals = residualStats(start, fit.p, obs);
  if (!o.analyze) return fit;
  const Eigen::VectorXd typical = start.layout.typical();
  for (int i = 0; i < start.layout.size(); ++i) {
    if (std::binary_search(fit.estimate.held.begin(), fit.estimate.held.end(), i)) continue;
    if (fit.estimate.covariance.rows() > i && std::sqrt(std::max(0.0, fit.estimate.covariance(i, i))) > typical[i]) {
      fit.weak.push_back(i);
    }
  }
  return fit;
}

CalibratedModel calibratedModel(const Fit& fit) {
  sim::FoldedModel f = sim::foldParameters(fit.model, fit.p);
  return {std::move(f.model), std::move(f.p)};
}

CalibratedModel calibratedModel(const Fit& fit, const std::vector<MarkerObservation>& fitted_on) {
  CalibratedModel c = calibratedModel(fit);
  std::vector<sim::JointSample> samples;
  for (const MarkerObservation& o : fitted_on) samples.push_back(o.sample);
  for (sim::Effect& e : c.model.effects) e = sim::recordFittedRanges(e, c.model.arm, samples);
  return c;
}

Fit predictWithModel(const CalibratedModel& c, const sim::MeasuredData& data, const std::vector<MarkerObservation>& obs,
                     const FitOptions& options) {
  using sim::FrameSharing;
  const sim::KinematicModel& cm = c.model;
  const int S = data.numSessions();
  // The data's per-session frames are refitted; every other frame is the model's (its first where
  // the model had one per session).
  const auto sharing = [](FrameSharing in_data) {
    return in_data == FrameSharing::kPerSession ? FrameSharing::kPerSession : FrameSharing::kKnown;
  };
  const FrameSharing base = sharing(data.base), marker = sharing(data.marker);
  sim::KinematicModel m = sim::makeKinematicModel(cm.arm, S, base, marker, framesFor(base, S, cm.world_T_base.front()),
                                                  framesFor(marker, S, cm.flange_T_marker.front()), cm.effects, false,
                                                  cm.marker_points);
  // Effect values by name (mount changes are per session: refitted, not carried).
  std::map<std::string, double> value;
  for (const sim::ParamBlock& b : cm.layout.blocks()) {
    for (int i = 0; i < b.size(); ++i) value[b.params[static_cast<std::size_t>(i)].name] = c.p[b.offset + i];
  }
  Eigen::VectorXd p0 = Eigen::VectorXd::Zero(m.layout.size());
  FitOptions o = options;
  o.hold.clear();
  for (const sim::ParamBlock& b : m.layout.blocks()) {
    const bool refit = sim::isRegistrationFrame(b.kind);
    for (int i = 0; i < b.size(); ++i) {
      if (refit) continue;
      o.hold.push_back(b.offset + i);
      const auto it = value.find(b.params[static_cast<std::size_t>(i)].name);
      if (it != value.end()) p0[b.offset + i] = it->second;
    }
  }
  if (static_cast<int>(o.hold.size()) == m.layout.size()) {
    // Nothing to refit: the model predicts the data as it is.
    Fit fit;
    fit.model = m;
    fit.p0 = fit.p = p0;
    fit.estimate.held = o.hold;  // every parameter: none was fitted
    fit.residuals = residualStats(m, p0, obs);
    return fit;
  }
  // Per-session frames from the calibrated model's flange poses.
  std::vector<Eigen::Isometry3d> F;
  for (const MarkerObservation& x : obs) F.push_back(sim::flangePose(m, p0, x.sample));
  try {
    guessFrames(m, obs, F);
  } catch (const std::invalid_argument& e) {
    throw sim::InputError(data.description + ": registration: the samples cannot fix the per-session frames (" + e.what() + ")");
  }
  return fitMarkerModel(m, obs, o, p0);
}

std::vector<sim::RangeExcess> rangeExcesses(const sim::KinematicModel& model, const std::vector<MarkerObservation>& observations) {
  std::vector<sim::JointSample> samples;
  for (const MarkerObservation& o : observations) samples.push_back(o.sample);
  return sim::rangeExcesses(model.effects, model.arm, samples);
}

std::vector<std::string> outsideTrustedRange(const sim::KinematicModel& model, const std::vector<MarkerObservation>& observations) {
  std::vector<std::string> out;
  for (const sim::RangeExcess& r : rangeExcesses(model, observations)) {
    if (r.outside > 0) out.push_back(sim::rangeExcessText(r));
  }
  return out;
}

}  // namespace orbcal::calib
