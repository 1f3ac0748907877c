#pragma once
// The samples of a pass in two halves side by side (this machine's two cores and CI's), combined by the
// caller in a fixed order: the same result whatever the machine's number of cores.
#include <future>
#include <utility>

namespace orbcal::calib {

/// part(k0, k1) on the two halves of the samples 0..n-1 side by side, the lower on this thread (one
/// thread below 64 samples: the upper half is then empty): {lower, upper}, for the caller to combine in
/// that fixed order.
template <class Part>
auto onHalves(int n, const Part& part) {
  const int half = n < 64 ? n : n / 2;
  auto upper = std::async(half < n ? std::launch::async : std::launch::deferred, part, half, n);
  auto lower = part(0, half);
  return std::make_pair(std::move(lower), upper.get());
}

}  // namespace orbcal::calib
