// thermal: the links expand with temperature, every length of the chain by alpha (T - reference).
#include <stdexcept>

#include "orbcal/sim/model.hpp"

namespace orbcal::sim {
namespace {

class ThermalKind final : public EffectKind {
 public:
  std::string name() const override { return "thermal"; }
  std::string words(const Effect&) const override { return "thermal expansion of the links"; }
  std::string physics() const override {
    return "links lengthen with temperature: every DH length (a, d; a URDF origin's xyz) scales by 1 + alpha (T - 20 degC); "
           "aluminium 23e-6/K, steel 12e-6/K";
  }
  bool takesJoints() const override { return false; }
  double defaultReference() const override { return 20.0; }
  EffectNeeds needs() const override {
    EffectNeeds n;
    n.temperature = true;
    return n;
  }
  std::vector<DrivingVariable> drivingVariables(const Effect&, const Arm&) const override {
    DrivingVariable v;
    v.column = "temperature_C";
    v.name = "temperature";
    v.unit = "degC";
    v.value = [](const JointSample& s) { return s.temperature_C; };
    return {v};
  }
  std::vector<ParamBlock> blocks(const Effect&, const Arm&, int) const override {
    ParamBlock b;
    b.effect = name();
    // Aluminium 23e-6 /K, steel 12e-6 /K.
    b.params.push_back({"alpha_thermal", "1/K", "ppm/K", 1e6, 2.3e-5, Quantity::kOther});
    return {b};
  }
  std::pair<double, double> lengthScale(const Effect& e, const ParamBlock& b, const Eigen::VectorXd& p,
                                        const JointSample& s) const override {
    const double dT = s.temperature_C - e.reference();
    return {1.0 + p[b.offset] * dT, dT};
  }
  void requireCovariates(const JointSample& s, int) const override {
    if (!s.hasTemperature()) throw std::invalid_argument("the thermal effect needs a temperature for every sample");
  }
  std::vector<Effect> candidates(const CandidateContext& c) const override {
    return c.temperature ? std::vector<Effect>{Thermal{}} : std::vector<Effect>{};
  }
  std::pair<std::string, std::string> revealingVariable(const Effect&, const Arm&) const override {
    return {"temperature_C", "temperature (degC)"};
  }
  std::string separateBy() const override { return "measure over a wider temperature range"; }
};

}  // namespace

const EffectKind& thermalKind() {
  static const ThermalKind k;
  return k;
}

}  // namespace orbcal::sim
