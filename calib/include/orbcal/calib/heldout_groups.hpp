#pragma once
// Held-out validation of small sets (calib/heldout.hpp holds the split of larger ones): leave one group
// (configuration) out at a time.
#include <functional>
#include <vector>

namespace orbcal::calib {

/// Leave-one-group-out cross-validation for sets too small to hold out kMinHeldoutConfigurations
/// (10 to 30 camera views, where a fifth held out says nothing): every group (configuration) in turn is
/// held out, `fold(train, held)` fits the items `train` and predicts the items `held`. `group`: the
/// group of each item, 0..G-1. The folds run in parallel (`fold` must be safe to call concurrently);
/// with a single group nothing is run. Returns G.
int leaveOneGroupOut(const std::vector<int>& group,
                     const std::function<void(const std::vector<int>& train, const std::vector<int>& held)>& fold);

}  // namespace orbcal::calib
