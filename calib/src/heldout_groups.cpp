// Leave-one-group-out cross-validation (calib/heldout.hpp): the small sets' judge.
#include <algorithm>
#include <future>
#include <stdexcept>

#include "orbcal/calib/heldout_groups.hpp"

namespace orbcal::calib {

int leaveOneGroupOut(const std::vector<int>& group,
                     const std::function<void(const std::vector<int>& train, const std::vector<int>& held)>& fold) {
  if (group.empty()) return 0;
  const int groups = *std::max_element(group.begin(), group.end()) + 1;
  if (*std::min_element(group.begin(), group.end()) < 0) throw std::invalid_argument("leaveOneGroupOut: a negative group");
  if (groups < 2) return groups;
  std::vector<std::future<void>> jobs;
  for (int g = 0; g < groups; ++g) {
    jobs.push_back(std::async(std::launch::async, [&, g] {
      std::vector<int> train, held;
      for (std::size_t i = 0; i < group.size(); ++i) (group[i] == g ? held : train).push_back(static_cast<int>(i));
      if (!held.empty()) fold(train, held);
    }));
  }
  for (auto& j : jobs) j.get();
  return groups;
}

}  // namespace orbcal::calib
