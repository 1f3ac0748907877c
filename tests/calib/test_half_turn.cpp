// A half-turn-symmetric board (a circle grid) is detected in an order that may be turned by half a turn;
// calib::resolveHalfTurns tells from the flange motions which views were turned, eye in hand and eye to
// hand: views built from known frames, a seeded third of them turned, each found and turned back.
#include <catch2/catch.hpp>
#include <random>

#include "orbcal/calib/hand_eye.hpp"
#include "orbcal/sim/se3.hpp"

using namespace orbcal;

namespace {

Eigen::Isometry3d randomPose(std::mt19937_64& rng, double angle_rad, double metres) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector3d w = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized() * angle_rad * std::uniform_real_distribution<double>(0.3, 1.0)(rng);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = sim::expSO3(w);
  T.translation() = metres * Eigen::Vector3d(n(rng), n(rng), n(rng));
  return T;
}

}  // namespace

TEST_CASE("half turns of a symmetric circle grid are resolved by the flange motions", "[calib][hand-eye][circles]") {
  sim::Board board;
  board.type = sim::BoardType::kCircles;
  board.corners_x = 9, board.corners_y = 6, board.square_m = 0.08, board.diameter_m = 0.04;
  REQUIRE(sim::halfTurnSymmetric(board));
  const int N = board.numCorners();
  for (const sim::HandEyeSetup setup : {sim::HandEyeSetup::kEyeInHand, sim::HandEyeSetup::kEyeToHand}) {
    CAPTURE(sim::handEyeSetupName(setup));
    std::mt19937_64 rng(setup == sim::HandEyeSetup::kEyeInHand ? 61 : 62);
    const Eigen::Isometry3d Z = randomPose(rng, 1.5, 0.1), X = randomPose(rng, 3.0, 1.0);  // flange_T_marker, the fixed frame
    std::vector<calib::HandEyeView> views(14);
    std::vector<Eigen::Isometry3d> truth;
    std::vector<bool> turned(views.size(), false);
    std::normal_distribution<double> noise(0.0, 1.0);
    for (std::size_t k = 0; k < views.size(); ++k) {
      calib::HandEyeView& v = views[k];
      v.base_T_flange = randomPose(rng, 1.0, 0.5);
      // eye in hand: X = base_T_board, camera_T_board = (base_T_flange Z)^-1 X; eye to hand: X = camera_T_base.
      const Eigen::Isometry3d P = setup == sim::HandEyeSetup::kEyeInHand ? Eigen::Isometry3d((v.base_T_flange * Z).inverse() * X)
                                                                        : Eigen::Isometry3d(X * v.base_T_flange * Z);
      sim::Vector6d e;  // a pose's error: 0.5 mm, 0.05 deg
      for (int a = 0; a < 6; ++a) e[a] = noise(rng) * (a < 3 ? 5e-4 : 0.05 * sim::kDegToRad);
      truth.push_back(sim::posePlus(P, e));
      v.camera_T_board = truth.back();
      for (int i = 0; i < N; ++i) v.ids.push_back(i);
      turned[k] = k % 3 == 1;  // a third, never the majority
      if (turned[k]) {
        v.camera_T_board = v.camera_T_board * sim::halfTurn(board);
        for (int& id : v.ids) id = N - 1 - id;
      }
    }
    const calib::HalfTurnResolution r = calib::resolveHalfTurns(views, board, setup);
    for (std::size_t k = 0; k < views.size(); ++k) {
      CAPTURE(k);
      CHECK(r.turned[k] == turned[k]);
      CHECK_FALSE(r.ambiguous[k]);
      CHECK(views[k].camera_T_board.isApprox(truth[k], 1e-9));
      CHECK(views[k].ids.front() == 0);
      CHECK(views[k].ids.back() == N - 1);
    }
    // The closed form on the resolved views recovers the frames to the poses' noise.
    const calib::HandEyeFrames f = calib::closedFormHandEye(views, setup);
    CHECK((f.flange_T_marker.translation() - Z.translation()).norm() < 5e-3);
    CHECK(sim::rotationAngle(f.flange_T_marker.linear().transpose() * Z.linear()) < 0.2 * sim::kDegToRad);
  }
}
