// The configuration generator: reproducible, within limits, non-singular, and the camera sees every
// corner of the board in every configuration.
#include <catch2/catch.hpp>
#include <sched.h>

#include <cstdlib>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/cores.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;

TEST_CASE("generator is reproducible and independent of the thread count", "[sim][generator]") {
  const Arm arm = loadArm(kDefaultRobot);
  const Scene scene = loadScene(kDefaultScene);
  GeneratorSettings s;
  s.count = 40;
  s.seed = 17;
  s.threads = 1;
  const auto a = generateConfigurations(arm, scene, s);
  s.threads = 2;
  const auto b = generateConfigurations(arm, scene, s);
  REQUIRE(a.size() == 40);
  REQUIRE(b.size() == 40);
  for (std::size_t k = 0; k < a.size(); ++k) REQUIRE(a[k] == b[k]);  // bit for bit
  s.seed = 18;
  const auto c = generateConfigurations(arm, scene, s);
  CHECK((a[0] - c[0]).norm() > 1e-3);
}

TEST_CASE("fewer configurations, or stop_after, give a prefix of the same list", "[sim][generator]") {
  // The generator returns the first accepted attempts in attempt order, so its batches (sized from the
  // count still needed) must not matter: a shorter list is a prefix of a longer one, bit for bit.
  const Arm arm = loadArm(kDefaultRobot);
  const Scene scene = loadScene(kDefaultScene);
  GeneratorSettings s;
  s.seed = 5;
  s.count = 300;
  const auto all = generateConfigurations(arm, scene, s);
  REQUIRE(all.size() == 300);
  for (int count : {1, 37, 299}) {
    CAPTURE(count);
    GeneratorSettings fewer = s;
    fewer.count = count;
    const auto head = generateConfigurations(arm, scene, fewer);
    REQUIRE(static_cast<int>(head.size()) == count);
    for (int k = 0; k < count; ++k) REQUIRE(head[k] == all[k]);
    GeneratorSettings prefix = s;
    prefix.stop_after = count;
    const auto stopped = generateConfigurations(arm, scene, prefix);
    REQUIRE(static_cast<int>(stopped.size()) == count);
    for (int k = 0; k < count; ++k) REQUIRE(stopped[k] == all[k]);
  }
}

TEST_CASE("every generated configuration sees every board corner inside the image", "[sim][generator]") {
  const Arm arm = loadArm(kDefaultRobot);
  const Scene scene = loadScene(kDefaultScene);
  REQUIRE_FALSE(scene.camera.hasDistortion());  // the check below uses the plain pinhole formula
  GeneratorSettings s;
  s.count = 100;
  s.seed = 3;
  const auto configs = generateConfigurations(arm, scene, s);
  REQUIRE(configs.size() == 100);
  double min_tilt = 1e9, max_tilt = 0, min_dist = 1e9, max_dist = 0;
  for (const auto& q : configs) {
    CHECK(withinLimits(arm, q));
    CHECK(singularityMeasure(arm, q, scene.views.locked_joint) >= scene.views.min_singular_value);
    // Independent of boardVisibility(): compose the chain and project with u = fx x/z + cx.
    const Eigen::Isometry3d base_T_camera = forwardKinematics(arm, q) * scene.flange_T_camera;
    const Eigen::Isometry3d camera_T_board = base_T_camera.inverse() * scene.base_T_board;
    std::vector<Eigen::Vector3d> points = boardCorners(scene.board);
    for (const auto& p : squaresOutline(scene.board)) points.push_back(p);
    for (const Eigen::Vector3d& p_board : points) {
      const Eigen::Vector3d p = camera_T_board * p_board;
      REQUIRE(p.z() > 0.0);
      const double u = scene.camera.fx_px * p.x() / p.z() + scene.camera.cx_px;
      const double v = scene.camera.fy_px * p.y() / p.z() + scene.camera.cy_px;
      CHECK(u >= -0.5);
      CHECK(v >= -0.5);
      CHECK(u <= scene.camera.width_px - 0.5);
      CHECK(v <= scene.camera.height_px - 0.5);
    }
    const Eigen::Vector3d centre = camera_T_board * boardCentre(scene.board);
    const double tilt = std::acos(camera_T_board.linear().col(2).dot(centre.normalized()));
    min_tilt = std::min(min_tilt, tilt);
    max_tilt = std::max(max_tilt, tilt);
    min_dist = std::min(min_dist, centre.norm());
    max_dist = std::max(max_dist, centre.norm());
  }
  // The views spread over the allowed ranges (not one view repeated).
  CHECK(min_dist >= scene.views.min_distance_m);
  CHECK(max_dist <= scene.views.max_distance_m);
  CHECK(max_dist - min_dist > 0.5 * (scene.views.max_distance_m - scene.views.min_distance_m));
  CHECK(max_tilt <= scene.views.max_tilt_rad);
  CHECK(max_tilt - min_tilt > 0.5 * scene.views.max_tilt_rad);
}

TEST_CASE("a board that no configuration can see is a one-line error naming the scene", "[sim][generator][badinput]") {
  const Arm arm = loadArm(kDefaultRobot);
  Scene scene = loadScene(kDefaultScene);
  scene.base_T_board.translation() = Eigen::Vector3d(80.0, 0.0, 0.0);  // far beyond the 17 m reach
  GeneratorSettings s;
  s.count = 10;
  try {
    generateConfigurations(arm, scene, s);
    FAIL("expected an InputError");
  } catch (const InputError& e) {
    const std::string msg = e.what();
    CHECK(msg.find("builtin:default_scene.yaml: base_T_board: only 0 of 10") == 0);
    CHECK(msg.find('\n') == std::string::npos);
  }
}

TEST_CASE("the scene chooses the locked joint, a joint the arm does not have is named", "[sim][generator][badinput]") {
  const Arm arm = loadArm(kDefaultRobot);
  Scene scene = loadScene(kDefaultScene);
  REQUIRE(scene.views.locked_joint == 1);  // theta_2, Wang et al. 2023's choice, written as 2 in the file
  GeneratorSettings s;
  s.count = 10;
  scene.views.locked_joint = -1;  // none: all seven joints move
  const auto free = generateConfigurations(arm, scene, s);
  REQUIRE(free.size() == 10);
  for (const auto& q : free) CHECK(singularityMeasure(arm, q, -1) >= scene.views.min_singular_value);
  scene.views.locked_joint = 8;
  try {
    generateConfigurations(arm, scene, s);
    FAIL("expected an InputError");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()) == "builtin:default_scene.yaml: views.locked_joint: joint 9 but the arm has 7 joints");
  }
}

TEST_CASE("availableCores: the affinity mask, capped by SLURM_CPUS_PER_TASK", "[configurations]") {
  const char* before = std::getenv("SLURM_CPUS_PER_TASK");
  const std::string saved = before ? before : "";
  ::unsetenv("SLURM_CPUS_PER_TASK");
  cpu_set_t set;
  CPU_ZERO(&set);
  REQUIRE(::sched_getaffinity(0, sizeof set, &set) == 0);
  CHECK(availableCores() == CPU_COUNT(&set));
  ::setenv("SLURM_CPUS_PER_TASK", "1", 1);
  CHECK(availableCores() == 1);
  ::setenv("SLURM_CPUS_PER_TASK", "100000", 1);  // never more than the mask
  CHECK(availableCores() == CPU_COUNT(&set));
  if (before) {
    ::setenv("SLURM_CPUS_PER_TASK", saved.c_str(), 1);
  } else {
    ::unsetenv("SLURM_CPUS_PER_TASK");
  }
}
