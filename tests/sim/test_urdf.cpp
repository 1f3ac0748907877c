// URDF in and out (sim/urdf.hpp): the iiwa7 URDF of tests/data (derived from scenes/iiwa7.yaml's DH
// table, see the comment inside it) against the DH file, the write-back of calibrated origins, the
// URDF convention's YAML, and the one-line errors for files that are not what they say.
#include <catch2/catch.hpp>
#include <filesystem>
#include <random>

#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/gravity.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/jacobian.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/truth.hpp"
#include "orbcal/sim/urdf.hpp"
#include "test_util.hpp"

using namespace orbcal::sim;
using orbcal::test::inputError;
using orbcal::test::sourcePath;
using Catch::Matchers::Contains;

namespace {

const std::string kIiwaUrdf = sourcePath("tests/data/iiwa7.urdf");
const std::string kIiwaInertialUrdf = sourcePath("tests/data/iiwa7_inertial.urdf");  // the same with <inertial>s

/// Largest translation difference (m) and rotation difference (rad) of FK over `qs`.
std::pair<double, double> fkDifference(const Arm& a, const Arm& b, const std::vector<Eigen::VectorXd>& qs) {
  double dp = 0.0, dr = 0.0;
  for (const auto& q : qs) {
    const Eigen::Isometry3d Ta = forwardKinematics(a, q), Tb = forwardKinematics(b, q);
    dp = std::max(dp, (Ta.translation() - Tb.translation()).norm());
    dr = std::max(dr, (Ta.linear() - Tb.linear()).norm());
  }
  return {dp, dr};
}

/// A small URDF with what the iiwa7 file lacks: a tilted axis, an origin with every rpy angle, a fixed
/// joint between two revolute ones (folded into the next origin), a continuous joint, a fixed tool,
/// a side branch, and a <transmission> whose <joint> element has no type (must be left alone).
const char* kTwisted = R"(<?xml version="1.0"?>
<robot name="twisted">
  <link name="base"/><link name="l1"/><link name="l1b"/><link name="l2"/><link name="l3"/><link name="tool"/><link name="side"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/>
    <origin xyz="0.1 -0.05 0.3" rpy="0.2 -0.3 0.4"/>
    <axis xyz="0 0.6 0.8"/>
    <limit lower="-2" upper="2.5" effort="1" velocity="1"/>
  </joint>
  <!-- <joint name="j2" type="revolute"><origin xyz="9 9 9"/></joint> a comment that looks like a joint -->
  <joint name="bend" type="fixed">
    <parent link="l1"/><child link="l1b"/>
    <origin xyz="0 0 0.25" rpy="1.0 0.1 -0.2"/>
  </joint>
  <joint name="j2" type="continuous">
    <parent link="l1b"/><child link="l2"/>
    <origin xyz="0.2 0.01 0" rpy="0 0.5 0"/>
    <axis xyz="1 0 0"/>
  </joint>
  <joint name="j3" type="revolute">
    <parent link="l2"/><child link="l3"/>
    <axis xyz="0 0 -1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="flange" type="fixed">
    <parent link="l3"/><child link="tool"/>
    <origin xyz="0.05 0 0.1" rpy="0 0 0.7"/>
  </joint>
  <joint name="to_side" type="fixed">
    <parent link="l1"/><child link="side"/>
  </joint>
  <transmission name="t2"><joint name="j2"><hardwareInterface>x</hardwareInterface></joint></transmission>
</robot>
)";

/// FK of the twisted chain base -> tool written out by hand from the URDF text above.
Eigen::Isometry3d twistedFk(const Eigen::Vector3d& q) {
  const auto rot = [](const Eigen::Vector3d& axis, double a) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(a, axis.normalized()).toRotationMatrix();
    return T;
  };
  return fromXyzRpy({0.1, -0.05, 0.3}, {0.2, -0.3, 0.4}) * rot({0, 0.6, 0.8}, q[0]) *
         fromXyzRpy({0, 0, 0.25}, {1.0, 0.1, -0.2}) * fromXyzRpy({0.2, 0.01, 0}, {0, 0.5, 0}) * rot({1, 0, 0}, q[1]) *
         rot({0, 0, -1}, q[2]) * fromXyzRpy({0.05, 0, 0.1}, {0, 0, 0.7});
}

std::string tempFile(const std::string& name, const std::string& text) {
  const std::string path = orbcal::test::tempDir("urdf-" + name) + "/" + name;  // tempDir empties its folder
  orbcal::test::write(path, text);
  return path;
}

Eigen::VectorXd randomErrors(const Arm& arm, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  Eigen::VectorXd y(arm.numParams());
  for (int i = 0; i < arm.numParams(); ++i) y[i] = n01(rng) * (isAngleParam(arm, i) ? 0.01 : 0.005);
  return y;
}

}  // namespace

TEST_CASE("the iiwa7 URDF gives the DH file's forward kinematics to 1e-12 m", "[sim][urdf]") {
  const Arm dh = loadArm(sourcePath("scenes/iiwa7.yaml"));
  const Arm urdf = loadArm(kIiwaUrdf);  // root link world and the only leaf iiwa_link_ee by default
  REQUIRE(urdf.convention == DhConvention::kUrdf);
  REQUIRE(urdf.numJoints() == 7);
  CHECK(urdf.numParams() == 49);
  CHECK(urdf.urdf.base_link == "world");
  CHECK(urdf.urdf.tip_link == "iiwa_link_ee");
  CHECK(urdf.urdf.joint_names.front() == "iiwa_joint_1");
  CHECK(urdf.upper_rad.isApprox(dh.upper_rad, 1e-15));
  CHECK(urdf.lower_rad.isApprox(dh.lower_rad, 1e-15));
  const std::vector<Eigen::VectorXd> qs = orbcal::test::randomConfigs(dh, 500, 21);
  const auto [dp, dr] = fkDifference(dh, urdf, qs);
  CHECK(dp < 1e-12);
  CHECK(dr < 1e-12);
  // The same with the links named, the tool left out: FK to iiwa_link_7 = the DH flange without Tz(d7).
  const Arm to7 = loadArm(RobotSource{kIiwaUrdf, "iiwa_link_0", "iiwa_link_7"});
  REQUIRE(to7.numJoints() == 7);
  CHECK(to7.last_T_flange.isApprox(Eigen::Isometry3d::Identity(), 0.0));
  Arm dh7 = dh;
  dh7.last_T_flange = Eigen::Translation3d(0, 0, -0.126) * Eigen::Isometry3d::Identity();
  CHECK(fkDifference(dh7, to7, qs).first < 1e-12);
}

TEST_CASE("URDF parameters: 7 a joint, named and united", "[sim][urdf]") {
  const Arm arm = loadArm(kIiwaUrdf);
  const char* names[] = {"theta3", "x3", "y3", "z3", "roll3", "pitch3", "yaw3"};
  const bool angle[] = {true, false, false, false, true, true, true};
  for (int k = 0; k < 7; ++k) {
    CHECK(paramName(arm, paramIndex(arm, 2, static_cast<ParamKind>(k))) == names[k]);
    CHECK(isAngleParam(arm, paramIndex(arm, 2, static_cast<ParamKind>(k))) == angle[k]);
  }
  CHECK(paramKey(arm, kOx) == "x_mm");
  CHECK(paramKey(arm, kOyaw) == "yaw_deg");
}

TEST_CASE("a fixed joint folds into the next origin, a continuous joint is revolute without limits", "[sim][urdf]") {
  const Arm arm = armFromUrdf(kTwisted, "twisted.urdf", "base", "tool");
  REQUIRE(arm.numJoints() == 3);
  CHECK(arm.urdf.joint_names == std::vector<std::string>{"j1", "j2", "j3"});
  CHECK(arm.lower_rad[1] == Approx(-kPi));
  CHECK(arm.upper_rad[1] == Approx(kPi));
  CHECK(arm.lower_rad[0] == -2.0);
  CHECK(arm.upper_rad[0] == 2.5);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-3, 3);
  for (int k = 0; k < 50; ++k) {
    const Eigen::Vector3d q(u(rng), u(rng), u(rng));
    const Eigen::Isometry3d T = forwardKinematics(arm, q), R = twistedFk(q);
    CHECK((T.translation() - R.translation()).norm() < 1e-14);
    CHECK((T.linear() - R.linear()).norm() < 1e-14);
  }
}

TEST_CASE("calibrated origins written back into the URDF reload to the calibrated FK", "[sim][urdf]") {
  for (const bool iiwa : {true, false}) {
    const std::string xml = iiwa ? orbcal::test::slurp(kIiwaUrdf) : std::string(kTwisted);
    const Arm nominal = iiwa ? loadArm(kIiwaUrdf) : armFromUrdf(xml, "twisted.urdf", "base", "tool");
    const Arm calibrated = withErrors(nominal, randomErrors(nominal, iiwa ? 7 : 8));
    const std::string out = replaceUrdfOrigins(xml, calibrated, "calibrated -- by a test");
    const Arm reloaded = armFromUrdf(out, "out.urdf", nominal.urdf.base_link, nominal.urdf.tip_link);
    // The zero offsets are folded into the origins: the reloaded arm has none, and the same FK.
    for (const DhRow& r : reloaded.joints) CHECK(r.theta_rad == 0.0);
    const std::vector<Eigen::VectorXd> qs = orbcal::test::randomConfigs(nominal, 100, 9);
    const auto [dp, dr] = fkDifference(calibrated, reloaded, qs);
    CHECK(dp < 1e-12);
    CHECK(dr < 1e-12);
    // The errors moved the flange by millimetres: a write-back that changed nothing would fail above.
    CHECK(fkDifference(nominal, reloaded, qs).first > 1e-3);
    // Everything but the chain joints' origins is kept, byte for byte.
    CHECK_THAT(out, Contains("<!-- calibrated - - by a test -->\n<robot name="));
    if (iiwa) {
      CHECK_THAT(out, Contains("<limit lower=\"-2.0943951023931953\" upper=\"2.0943951023931953\" effort=\"300\" velocity=\"10\"/>"));
      CHECK_THAT(out, Contains("<origin xyz=\"0 0 0.126\" rpy=\"0 0 0\"/>"));  // the fixed tool joint
    } else {
      CHECK_THAT(out, Contains("<origin xyz=\"0 0 0.25\" rpy=\"1.0 0.1 -0.2\"/>"));  // the fixed joint
      CHECK_THAT(out, Contains("<origin xyz=\"9 9 9\"/>"));                          // inside the comment
      CHECK_THAT(out, Contains("<joint name=\"j2\"><hardwareInterface>"));           // the transmission
      CHECK(out.find("<origin xyz=\"0.2 0.01 0\" rpy=\"0 0.5 0\"/>") == std::string::npos);  // j2's, replaced
    }
  }
}

TEST_CASE("a URDF arm written as YAML (convention urdf) reads back to the same kinematics", "[sim][urdf]") {
  const Arm nominal = armFromUrdf(kTwisted, "twisted.urdf", "base", "tool");
  Arm arm = withErrors(nominal, randomErrors(nominal, 3));
  arm.urdf.file = "twisted.urdf";
  const std::string path = tempFile("twisted.yaml", formatArm(arm, "test"));
  const Arm back = loadArm(path);
  REQUIRE(back.convention == DhConvention::kUrdf);
  CHECK(back.urdf.joint_names == arm.urdf.joint_names);
  CHECK(back.urdf.file == (std::filesystem::path(path).parent_path() / "twisted.urdf").string());
  CHECK(back.urdf.tip_link == "tool");
  CHECK(back.urdf.fixed_before[1].isApprox(arm.urdf.fixed_before[1], 1e-15));
  CHECK(back.upper_rad.isApprox(arm.upper_rad, 1e-15));
  const auto [dp, dr] = fkDifference(arm, back, orbcal::test::randomConfigs(arm, 50, 4));
  CHECK(dp < 1e-12);
  CHECK(dr < 1e-12);
}

namespace {

/// A planar two-joint arm, both axes along y (gravity -z gives the torques m g x of lever arms x), with
/// mass off the chain: a camera on l1 through a fixed joint, a finger after the tip (tool) through a
/// revolute joint that is not in the chain, turned by its origin's pitch, and a base mass that no
/// joint moves. The camera's inertial frame is turned: only its position counts.
const char* kSideBranch = R"(<?xml version="1.0"?>
<robot name="side">
  <link name="base">
    <inertial>
      <origin xyz="0.3 0 0.1"/>
      <mass value="10"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial>
  </link>
  <link name="l1">
    <inertial>
      <origin xyz="0.2 0 0"/>
      <mass value="2"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial>
  </link>
  <link name="camera">
    <inertial>
      <origin xyz="0.05 0 0" rpy="0 1 0"/>
      <mass value="0.5"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial>
  </link>
  <link name="l2">
    <inertial>
      <origin xyz="0.15 0 0"/>
      <mass value="1"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial>
  </link>
  <link name="tool"/>
  <link name="finger">
    <inertial>
      <origin xyz="0.02 0 0"/>
      <mass value="0.2"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial>
  </link>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/><origin xyz="0 0 0.5"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="to_camera" type="fixed"><parent link="l1"/><child link="camera"/><origin xyz="0.2 0 0.1"/></joint>
  <joint name="j2" type="revolute">
    <parent link="l1"/><child link="l2"/><origin xyz="0.4 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="to_tool" type="fixed"><parent link="l2"/><child link="tool"/><origin xyz="0.3 0 0"/></joint>
  <joint name="finger_joint" type="revolute">
    <parent link="tool"/><child link="finger"/><origin xyz="0.1 0 0" rpy="0 -1.5707963267948966 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
)";

}  // namespace

TEST_CASE("gravity torques of the iiwa7 URDF's <inertial>s equal those of the DH file's masses", "[sim][urdf][gravity]") {
  // iiwa7_inertial.urdf's COMs were converted from scenes/iiwa7.yaml's (see its comment), link 7's mass
  // split across the fixed joint to iiwa_link_ee, and a base mass added that must not count.
  const Arm dh = loadArm(sourcePath("scenes/iiwa7.yaml"));
  const Arm urdf = loadArm(kIiwaInertialUrdf);
  REQUIRE(dh.masses.links.size() == 7);
  REQUIRE(urdf.masses.links.size() == 7);
  CHECK(urdf.masses.gravity_base == Eigen::Vector3d(0.0, 0.0, -9.80665));
  CHECK(urdf.masses.payload_kg == 0.0);
  for (std::size_t j = 0; j < 7; ++j) CHECK(urdf.masses.links[j].mass_kg == Approx(dh.masses.links[j].mass_kg).epsilon(1e-15));
  double worst = 0.0, largest = 0.0;
  for (const Eigen::VectorXd& q : orbcal::test::randomConfigs(dh, 50, 31)) {
    const Eigen::VectorXd tau_dh = gravityTorques(dh, dh.masses, q), tau_urdf = gravityTorques(urdf, urdf.masses, q);
    worst = std::max(worst, (tau_dh - tau_urdf).cwiseAbs().maxCoeff());
    largest = std::max(largest, tau_dh.cwiseAbs().maxCoeff());
  }
  INFO("worst difference " << worst << " N m of torques up to " << largest << " N m");
  CHECK(worst < 1e-9);
  CHECK(largest > 10.0);  // the configurations do load the joints
  // The calibrated URDF keeps the <inertial>s byte for byte, and so the same masses.
  const std::string xml = orbcal::test::slurp(kIiwaInertialUrdf);
  const std::string out = replaceUrdfOrigins(xml, withErrors(urdf, randomErrors(urdf, 12)));
  for (std::size_t i = xml.find("<inertial>"); i != std::string::npos; i = xml.find("<inertial>", i + 1)) {
    CHECK_THAT(out, Contains(xml.substr(i, xml.find("</inertial>", i) + 11 - i)));
  }
  const Arm reloaded = armFromUrdf(out, "out.urdf");
  REQUIRE(reloaded.masses.links.size() == 7);
  for (std::size_t j = 0; j < 7; ++j) {
    CHECK(reloaded.masses.links[j].mass_kg == urdf.masses.links[j].mass_kg);
    CHECK(reloaded.masses.links[j].com_m == urdf.masses.links[j].com_m);
  }
}

TEST_CASE("URDF masses: side branches and links after the tip move with their chain joint", "[sim][urdf][gravity]") {
  const Arm arm = armFromUrdf(kSideBranch, "side.urdf", "base", "tool");
  REQUIRE(arm.numJoints() == 2);
  REQUIRE(arm.masses.links.size() == 2);
  CHECK(arm.masses.links[0].mass_kg == 2.5);  // l1 and the camera; not the base's 10 kg
  CHECK(arm.masses.links[1].mass_kg == Approx(1.2).epsilon(1e-15));  // l2 and the finger
  // By hand, in the x-z plane: joint 1 at the base origin, joint 2 at x = 0.4 in l1; a point (x, z) of
  // l1 is at horizontal distance x c1 + z s1 from joint 1, one of l2 at x c12 + z s12 from joint 2
  // (c12 = cos(q1 + q2)). In l1: l1's COM (0.2, 0), the camera's (0.2 + 0.05, 0.1). In l2: l2's COM
  // (0.15, 0), the finger's (0.3 + 0.1, 0.02) (finger_joint at its zero, pitched -90 deg: its x is l2's z).
  // Each mass m at horizontal distance x from the joint takes a hold of -m g x (axes along +y).
  const double g = 9.80665;
  for (const Eigen::Vector2d& q : {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.3, -0.9), Eigen::Vector2d(-1.2, 1.7)}) {
    CAPTURE(q.transpose());
    const double c1 = std::cos(q[0]), s1 = std::sin(q[0]), c12 = std::cos(q[0] + q[1]), s12 = std::sin(q[0] + q[1]);
    const double outer = 1.0 * 0.15 * c12 + 0.2 * (0.4 * c12 + 0.02 * s12);  // sum m x of l2 and the finger about joint 2
    const double tau2 = -g * outer;
    const double tau1 = -g * (2.0 * 0.2 * c1 + 0.5 * (0.25 * c1 + 0.1 * s1) + 1.2 * 0.4 * c1 + outer);
    const Eigen::VectorXd tau = gravityTorques(arm, arm.masses, q);
    CHECK(tau[0] == Approx(tau1).epsilon(1e-13));
    CHECK(tau[1] == Approx(tau2).epsilon(1e-13));
  }
  // At q = 0 in numbers: tau2 = -g (0.15 + 0.2 * 0.4), tau1 = -g (0.4 + 0.125 + 0.48 + 0.23).
  const Eigen::VectorXd tau0 = gravityTorques(arm, arm.masses, Eigen::Vector2d::Zero());
  CHECK(tau0[1] == Approx(-g * 0.23).epsilon(1e-14));
  CHECK(tau0[0] == Approx(-g * 1.235).epsilon(1e-14));

  // A joint whose links carry no <inertial> gets mass 0; none on any moving link: no mass model.
  std::string light = kSideBranch;
  for (const char* link : {"l2", "finger"}) {
    const std::size_t at = light.find("<link name=\"" + std::string(link) + "\">");
    const std::size_t end = light.find("</link>", at) + 7;
    light.replace(at, end - at, "<link name=\"" + std::string(link) + "\"/>");
  }
  const Arm first_only = armFromUrdf(light, "light.urdf", "base", "tool");
  REQUIRE(first_only.masses.links.size() == 2);
  CHECK(first_only.masses.links[1].mass_kg == 0.0);
  CHECK(first_only.masses.links[1].com_m == Eigen::Vector3d::Zero());
  CHECK(gravityTorques(first_only, first_only.masses, Eigen::Vector2d(0.3, 0.2))[1] == 0.0);
  CHECK(armFromUrdf(kTwisted, "twisted.urdf", "base", "tool").masses.empty());
  CHECK(loadArm(kIiwaUrdf).masses.empty());
  // From l1 on, l1 and its camera are on the base side: joint 2 carries l2 and the finger alone.
  CHECK(armFromUrdf(kSideBranch, "side.urdf", "l1", "tool").masses.links[0].mass_kg == Approx(1.2).epsilon(1e-15));
}

TEST_CASE("a URDF arm's masses written as YAML read back the same", "[sim][urdf][gravity]") {
  const Arm arm = loadArm(kIiwaInertialUrdf);
  const std::string path = tempFile("iiwa7_inertial.yaml", formatArm(arm, "test"));
  const Arm back = loadArm(path);
  orbcal::test::checkSameMasses(back.masses, arm.masses);
  for (const Eigen::VectorXd& q : orbcal::test::randomConfigs(arm, 20, 5)) {
    CHECK((gravityTorques(back, back.masses, q) - gravityTorques(arm, arm.masses, q)).cwiseAbs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("URDF input errors name the file and the link or joint", "[sim][urdf]") {
  const std::string yaml_text = orbcal::test::slurp(sourcePath("scenes/iiwa7.yaml"));
  const std::string urdf_text = orbcal::test::slurp(kIiwaUrdf);
  const std::string yaml_as_urdf = tempFile("yaml.urdf", yaml_text);
  CHECK(inputError([&] { loadArm(yaml_as_urdf); }) ==
        yaml_as_urdf + ": the extension says URDF, but the file is not XML (it looks like a robot YAML: rename it to .yaml)");
  const std::string urdf_as_yaml = tempFile("urdf.yaml", urdf_text);
  CHECK(inputError([&] { loadArm(urdf_as_yaml); }) ==
        urdf_as_yaml + ": the extension says YAML, but the file is XML (a URDF: rename it to .urdf)");
  CHECK(inputError([&] { loadArm(RobotSource{sourcePath("scenes/iiwa7.yaml"), "a", ""}); }) ==
        sourcePath("scenes/iiwa7.yaml") + ": --base-link and --tip-link choose a chain in a URDF; this robot file is YAML");
  CHECK(inputError([&] { loadArm(RobotSource{kIiwaUrdf, "iiwa_link_9", ""}); }) ==
        kIiwaUrdf + ": no link 'iiwa_link_9' (the base link) in the URDF");
  CHECK(inputError([&] { loadArm(RobotSource{kIiwaUrdf, "", "gripper"}); }) ==
        kIiwaUrdf + ": no link 'gripper' (the tip link) in the URDF");
  CHECK(inputError([&] { loadArm(RobotSource{kIiwaUrdf, "iiwa_link_5", "iiwa_link_2"}); }) ==
        kIiwaUrdf + ": tip link 'iiwa_link_2' is not below base link 'iiwa_link_5' (going up from 'iiwa_link_2' reaches the root "
                    "link 'world')");
  CHECK(inputError([&] { loadArm(RobotSource{kIiwaUrdf, "iiwa_link_7", "iiwa_link_ee"}); }) ==
        kIiwaUrdf + ": no movable joint between links 'iiwa_link_7' and 'iiwa_link_ee'");
  CHECK(inputError([&] { armFromUrdf(kTwisted, "t.urdf", "base", ""); }) ==
        "t.urdf: the URDF has 2 leaf links below 'base' (side, tool): give the tip link (--tip-link)");

  std::string planar = kTwisted;
  planar.replace(planar.find("type=\"continuous\""), 17, "type=\"planar\"   ");
  CHECK(inputError([&] { armFromUrdf(planar, "p.urdf", "base", "tool"); }) ==
        "p.urdf: joint 'j2' is planar: an orbcal arm has revolute (or continuous) and prismatic joints only");

  // A revolute joint without <limit>: urdfdom refuses the file; its reason (naming the joint) is kept.
  std::string no_limit = urdf_text;
  const std::size_t j4 = no_limit.find("<joint name=\"iiwa_joint_4\"");
  const std::size_t lim = no_limit.find("<limit", j4);
  no_limit.erase(lim, no_limit.find("/>", lim) + 2 - lim);
  const std::string no_limit_path = tempFile("no_limit.urdf", no_limit);
  const std::string msg = inputError([&] { loadArm(no_limit_path); });
  CHECK_THAT(msg, Contains(no_limit_path + ": not a valid URDF: "));
  CHECK_THAT(msg, Contains("iiwa_joint_4"));

  // A negative mass on a moving link (the camera, off the chain).
  std::string negative = kSideBranch;
  negative.replace(negative.find("<mass value=\"0.5\"/>"), 19, "<mass value=\"-0.5\"/>");
  const std::string negative_path = tempFile("negative.urdf", negative);
  CHECK(inputError([&] { loadArm(RobotSource{negative_path, "base", "tool"}); }) ==
        negative_path + ": link 'camera': <inertial> mass -0.5 kg must be finite and not negative");
  // A non-finite mass: urdfdom cannot read it (it would keep the link with mass 0); its reason is kept.
  for (const char* bad : {"nan", "inf"}) {
    std::string text = kSideBranch;
    text.replace(text.find("<mass value=\"1\"/>"), 17, "<mass value=\"" + std::string(bad) + "\"/>");
    const std::string bad_path = tempFile(std::string(bad) + ".urdf", text);
    const std::string bad_msg = inputError([&] { loadArm(RobotSource{bad_path, "base", "tool"}); });
    CHECK_THAT(bad_msg, Contains(bad_path + ": link 'l2': <inertial> not readable (urdfdom: "));
    CHECK_THAT(bad_msg, Contains(std::string("mass [") + bad + "]"));
  }

  const std::string junk = tempFile("junk.urdf", "<robot name=\"x\"><link name=\"a\"/>");
  CHECK_THAT(inputError([&] { loadArm(junk); }), Contains(junk + ": not a valid URDF: "));
}

TEST_CASE("error-set files and manifests carry a URDF arm's 7 errors a joint by name", "[sim][urdf]") {
  const Arm arm = loadArm(kIiwaUrdf);
  std::string rows;
  for (int j = 0; j < 7; ++j) {
    rows += "  - {theta_deg: 0.1, x_mm: " + std::to_string(j + 1) +
            ", y_mm: -0.5, z_mm: 0.25, roll_deg: 0.2, pitch_deg: -0.3, yaw_deg: 0.4}\n";
  }
  const std::string file = tempFile("errors.yaml", "format: orbcal-errors-1\ngeometry:\n" + rows);
  ErrorSetSpec spec;
  spec.name = file;
  const Eigen::VectorXd y = makeTrueArm(arm, spec, "--errors").geometryErrors();
  REQUIRE(y.size() == 49);
  CHECK(y[paramIndex(arm, 2, kOx)] == Approx(3e-3));
  CHECK(y[paramIndex(arm, 2, kOy)] == Approx(-0.5e-3));
  CHECK(y[paramIndex(arm, 2, kOyaw)] == Approx(0.4 * kDegToRad));
  CHECK(y[paramIndex(arm, 2, kTheta)] == Approx(0.1 * kDegToRad));
  // The manifest's true_errors: written and read back by the same keys.
  DatasetManifest m;
  m.program_version = "test";
  m.error_set = "custom";
  m.true_errors = y;
  m.true_errors_per_joint = 7;
  const DatasetManifest back = parseManifest(formatManifest(m), "manifest.yaml");
  CHECK(back == m);
  CHECK_THAT(formatManifest(m), Contains("pitch_deg: -0.3, yaw_deg: 0.4}"));
  // A DH row on a URDF arm names the key.
  std::string dh_rows;
  for (int j = 0; j < 7; ++j) dh_rows += "  - {theta_deg: 0, alpha_deg: 0, a_mm: 0, d_mm: 0}\n";
  const std::string dh = tempFile("dh_errors.yaml", "format: orbcal-errors-1\ngeometry:\n" + dh_rows);
  spec.name = dh;
  CHECK_THAT(inputError([&] { makeTrueArm(arm, spec, "--errors"); }), Contains(dh + ": geometry[0].alpha_deg: unknown key"));
}
