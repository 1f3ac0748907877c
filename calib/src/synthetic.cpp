#include "orbcal/calib/synthetic.hpp"

namespace orbcal::calib {

std::vector<PoseObservation> syntheticObservations(const PlantSamples& plant, double sp, double so,
                                                   std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<PoseObservation> obs;
  sim::Vector6d var;
  var << Eigen::Vector3d::Constant(sp * sp), Eigen::Vector3d::Constant(so * so);
  for (std::size_t k = 0; k < plant.q_commanded.size(); ++k) {
    sim::Vector6d nu;
    for (int i = 0; i < 6; ++i) nu[i] = n01(rng) * (i < 3 ? sp : so);
    PoseObservation o;
    o.q_rad = plant.q_commanded[k];
    o.base_T_flange = sim::posePlus(plant.base_T_flange_true[k], nu);
    o.covariance = var.asDiagonal();
    obs.push_back(std::move(o));
  }
  return obs;
}

}  // namespace orbcal::calib
