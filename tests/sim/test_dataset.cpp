// The dataset tables round-trip with every field; bad rows are named.
#include <catch2/catch.hpp>

#include "orbcal/sim/config.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/se3.hpp"

using namespace orbcal::sim;

TEST_CASE("a Hayati arm's manifest carries beta_deg per joint and round-trips", "[sim][dataset]") {
  DatasetManifest m;
  m.num_samples = 1;
  m.true_errors_per_joint = 5;  // theta, alpha, a, d, beta (arm.hpp)
  m.true_errors = Eigen::VectorXd::LinSpaced(10, 1e-4, 1e-3);
  m.error_set = "random";
  const std::string text = formatManifest(m);
  CHECK(text.find("d_mm: 0.4, beta_deg: ") != std::string::npos);
  const DatasetManifest back = parseManifest(text, "manifest.yaml");
  CHECK(back.true_errors_per_joint == 5);
  CHECK(back == m);
  // beta_deg on one row only: the other rows are named.
  std::string partial = text;
  const auto at = partial.rfind(", beta_deg: ");
  partial.erase(at, partial.find('}', at) - at);
  CHECK_THROWS_WITH(parseManifest(partial, "m.yaml"), "m.yaml: true_errors.joints[1].beta_deg: missing");
}

TEST_CASE("manifest round-trips with the true errors", "[sim][dataset]") {
  DatasetManifest m;
  m.program_version = "9.9.9";
  m.num_samples = 3;
  m.true_errors = paperTable3Errors();
  m.error_set = "table3";
  m.joint_noise_sigma_rad = 0.01 * kDegToRad;
  m.configuration_seed = 1;
  m.noise_seed = 2;
  m.render_seed = 3;
  const DatasetManifest back = parseManifest(formatManifest(m), "manifest.yaml");
  CHECK(back == m);
  CHECK(formatManifest(m).find("- {theta_deg: 0.3, alpha_deg: 0.2, a_mm: 0.5, d_mm: -0.9}") !=
        std::string::npos);  // Table 3, joint 1, in degrees and mm
  DatasetManifest other = back;
  (*other.true_errors)[5] += 1e-9;  // 1 nm: a different error set
  CHECK_FALSE(other == m);
  CHECK_THROWS_WITH(parseManifest("format: other\n", "m.yaml"), "m.yaml: format: expected 'orbcal-dataset-1', got 'other'");

  // The error-set file of a plant with effects (sim/truth.hpp): written, read back, compared; a manifest
  // without it (older, or a named set) reads as none.
  CHECK(back.error_set_file.empty());
  DatasetManifest with_file = m;
  with_file.error_set = "file";
  with_file.error_set_file = "errors.yaml";
  CHECK(formatManifest(with_file).find("  file: errors.yaml") != std::string::npos);
  const DatasetManifest file_back = parseManifest(formatManifest(with_file), "manifest.yaml");
  CHECK(file_back.error_set_file == "errors.yaml");
  CHECK(file_back == with_file);
  with_file.error_set_file.clear();
  with_file.error_set = "file";
  CHECK_FALSE(file_back == with_file);
}

TEST_CASE("samples round-trip, optional columns stay optional", "[sim][dataset]") {
  std::vector<DatasetSample> s(2);
  s[0].index = 0;
  s[0].image = "images/000000.png";
  s[0].q_rad = Eigen::VectorXd::LinSpaced(3, -1, 1);
  s[0].q_true_rad = s[0].q_rad.array() + 1e-4;
  s[0].camera_T_board_true = fromXyzRpy(Eigen::Vector3d(0.1, -0.2, 2.0), Eigen::Vector3d(0.3, -0.2, 2.9));
  s[1].index = 1;
  s[1].image = "images/000001.png";
  s[1].q_rad = Eigen::VectorXd::Constant(3, 0.5);
  const auto back = parseSamplesCsv(formatSamplesCsv(s, 3), "samples.csv", 3);
  REQUIRE(back.size() == 2);
  CHECK(back[0].image == s[0].image);
  CHECK(back[0].q_rad == s[0].q_rad);
  CHECK(*back[0].q_true_rad == *s[0].q_true_rad);
  CHECK((back[0].camera_T_board_true->matrix() - s[0].camera_T_board_true->matrix()).norm() < 1e-14);
  CHECK_FALSE(back[1].q_true_rad.has_value());
  CHECK_FALSE(back[1].camera_T_board_true.has_value());
  // A user's own data: joint readings and images only.
  const auto user = parseSamplesCsv("index,image,q1_rad,q2_rad\n0,a.png,0.1,0.2\n", "mine.csv", 2);
  REQUIRE(user.size() == 1);
  CHECK_FALSE(user[0].q_true_rad.has_value());
  CHECK_THROWS_WITH(parseSamplesCsv("index,image,q1_rad\n0,,0.1\n", "mine.csv", 1), "mine.csv: line 2: image: empty");
}
