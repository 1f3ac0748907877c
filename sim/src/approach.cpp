// The direction each joint last moved in, from the order of the readings (what backlash needs where
// the data do not record it; declared in sim/measured.hpp).
#include <cmath>
#include <map>
#include <stdexcept>

#include "orbcal/sim/measured.hpp"

namespace orbcal::sim {

void fillApproachDirections(std::vector<MeasuredPose>& poses, double threshold_rad) {
  std::map<int, std::pair<Eigen::VectorXd, Eigen::VectorXd>> previous;  // last readings and directions of each session
  for (MeasuredPose& p : poses) {
    const Eigen::VectorXd& q = p.sample.q_rad;
    Eigen::VectorXd& dir = p.sample.direction;
    const auto it = previous.find(p.sample.session);
    if (it == previous.end()) {
      dir = Eigen::VectorXd::Zero(q.size());
    } else {
      const auto& [q_prev, dir_prev] = it->second;
      if (q_prev.size() != q.size()) throw std::invalid_argument("fillApproachDirections: " + p.where + ": joint count changed");
      dir = dir_prev;
      for (Eigen::Index j = 0; j < q.size(); ++j) {
        const double dq = q[j] - q_prev[j];
        if (std::abs(dq) >= threshold_rad) dir[j] = dq > 0.0 ? 1.0 : -1.0;
      }
    }
    previous[p.sample.session] = {q, dir};
  }
}

}  // namespace orbcal::sim
