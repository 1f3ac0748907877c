#pragma once
// A dataset folder without images, for the end-to-end tests of the dataset loaders.
#include <catch2/catch.hpp>
#include <filesystem>
#include <string>
#include <vector>

#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/io.hpp"
#include "test_util.hpp"

namespace orbcal::test {

/// DIR/dataset without images (enough for the loaders): the SSRMS, the quick scene, `n` samples within
/// the joint limits; with `truth`, the simulation-truth columns too (the readings as true angles, the
/// board 2 m ahead of the camera).
inline std::string datasetWithoutImages(const std::string& dir, int n, bool truth = false) {
  const std::string folder = dir + "/dataset";
  std::filesystem::create_directories(folder);
  const sim::Arm arm = sim::loadArm(sim::kDefaultRobot);
  write(folder + "/robot.yaml", sim::readTextSource(sim::kDefaultRobot));
  write(folder + "/scene.yaml", slurp(sourcePath("scenes/quick_scene.yaml")));
  sim::DatasetManifest m;
  m.num_samples = n;
  write(folder + "/manifest.yaml", sim::formatManifest(m));
  std::vector<sim::DatasetSample> samples;
  for (const Eigen::VectorXd& q : randomConfigs(arm, n, 7)) {
    sim::DatasetSample s;
    s.index = static_cast<int>(samples.size());
    s.image = "images/" + std::to_string(s.index) + ".png";
    s.q_rad = q;
    if (truth) {
      s.q_true_rad = q;
      s.camera_T_board_true = Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, 2.0));
    }
    samples.push_back(s);
  }
  write(folder + "/samples.csv", sim::formatSamplesCsv(samples, arm.numJoints()));
  REQUIRE(sim::loadDataset(folder).samples.size() == static_cast<std::size_t>(n));
  return folder;
}

}  // namespace orbcal::test
