// A half-turn-symmetric board's views put into one orientation by the flange motions (hand_eye.hpp).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "orbcal/calib/hand_eye.hpp"

namespace orbcal::calib {

namespace {

/// Lengths enter the disagreement at 1 rad per metre: a half turn of a board moves its frame by the
/// board's size (tenths of a metre), far beyond a pose's translation error (millimetres).
constexpr double kRadPerMetre = 1.0;
/// A view's orientation is kept when it disagrees with the others (median) less than half as much as the
/// other orientation would.
constexpr double kMaxAgreementRatio = 0.5;

/// The conjugation invariants of a motion: its rotation angle and the length of its translation along
/// the rotation axis (of the whole translation when the angle is below 1e-3 rad: no axis).
Eigen::Vector2d screwInvariants(const Eigen::Isometry3d& T) {
  const Eigen::AngleAxisd aa(T.linear());
  const double along = aa.angle() > 1e-3 ? std::abs(aa.axis().dot(T.translation())) : T.translation().norm();
  return {aa.angle(), along};
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

std::vector<std::array<double, 2>> halfTurnDisagreements(const std::vector<HandEyeView>& views, const sim::Board& board,
                                                        sim::HandEyeSetup setup) {
  const std::size_t n = views.size();
  const Eigen::Isometry3d F = sim::halfTurn(board);
  const bool in_hand = setup == sim::HandEyeSetup::kEyeInHand;
  std::vector<std::array<double, 2>> cost(n * n, {0.0, 0.0});
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      // A Z = Z B: A the flange's motion, B the camera's (eye in hand) or the board's (eye to hand); B's invariants depend
      // on whether one of the two views is turned, not on which.
      const Eigen::Vector2d a = screwInvariants(views[i].base_T_flange.inverse() * views[j].base_T_flange);
      for (int turned = 0; turned < 2; ++turned) {
        const Eigen::Isometry3d Pi = views[i].camera_T_board, Pj = turned ? Eigen::Isometry3d(views[j].camera_T_board * F) : views[j].camera_T_board;
        const Eigen::Vector2d b = screwInvariants(in_hand ? Eigen::Isometry3d(Pi * Pj.inverse()) : Eigen::Isometry3d(Pi.inverse() * Pj));
        const double c = std::abs(a[0] - b[0]) + kRadPerMetre * std::abs(a[1] - b[1]);
        cost[i * n + j][static_cast<std::size_t>(turned)] = cost[j * n + i][static_cast<std::size_t>(turned)] = c;
      }
    }
  }
  return cost;
}

HalfTurnResolution resolveHalfTurns(std::vector<HandEyeView>& views, const sim::Board& board, sim::HandEyeSetup setup) {
  const std::size_t n = views.size();
  HalfTurnResolution res;
  res.turned.assign(n, false);
  res.ambiguous.assign(n, false);
  if (!sim::halfTurnSymmetric(board) || n < 3) return res;
  const std::vector<std::array<double, 2>> cost = halfTurnDisagreements(views, board, setup);
  const auto c = [&](std::size_t i, std::size_t j, bool turned) { return cost[i * n + j][turned ? 1 : 0]; };
  // Each view as the reference in turn labels every other by the orientation that agrees with it better; the labelling
  // with the least disagreement over all pairs stands.
  double best = std::numeric_limits<double>::max();
  std::vector<bool> label(n, false);
  for (std::size_t r = 0; r < n; ++r) {
    std::vector<bool> l(n, false);
    for (std::size_t j = 0; j < n; ++j) l[j] = j != r && c(r, j, true) < c(r, j, false);
    double total = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t j = i + 1; j < n; ++j) total += c(i, j, l[i] != l[j]);
    }
    if (total < best) best = total, label = l;
  }
  // The board frame is the one most views' detector order gives (the first view's on a tie).
  const auto turned_count = static_cast<std::size_t>(std::count(label.begin(), label.end(), true));
  if (2 * turned_count > n || (2 * turned_count == n && label[0])) label.flip();
  const Eigen::Isometry3d F = sim::halfTurn(board);
  const int last = board.numCorners() - 1;
  for (std::size_t j = 0; j < n; ++j) {
    std::vector<double> agree, other;
    for (std::size_t k = 0; k < n; ++k) {
      if (k == j) continue;
      agree.push_back(c(j, k, label[j] != label[k]));
      other.push_back(c(j, k, label[j] == label[k]));
    }
    res.ambiguous[j] = !(median(agree) < kMaxAgreementRatio * median(other));
    res.turned[j] = label[j];
    if (!label[j]) continue;
    views[j].camera_T_board = views[j].camera_T_board * F;
    for (int& id : views[j].ids) id = last - id;
  }
  return res;
}

}  // namespace orbcal::calib
