#include "orbcal/sim/cores.hpp"

#include <sched.h>

#include <algorithm>
#include <cstdlib>
#include <thread>

namespace orbcal::sim {

int availableCores() {
  int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  cpu_set_t set;
  CPU_ZERO(&set);
  if (::sched_getaffinity(0, sizeof set, &set) == 0) cores = std::max(1, CPU_COUNT(&set));
  if (const char* slurm = std::getenv("SLURM_CPUS_PER_TASK")) {
    const int n = std::atoi(slurm);
    if (n > 0) cores = std::min(cores, n);
  }
  return cores;
}

}  // namespace orbcal::sim
