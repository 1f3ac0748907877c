#pragma once
// How many threads a command should use: the cores this process may run on, not all the machine's
// (a Slurm task, a taskset or a container gets fewer).

namespace orbcal::sim {

/// The CPUs of this process's affinity mask (taskset, cgroup cpusets, Slurm's task/affinity), and at
/// most SLURM_CPUS_PER_TASK inside a Slurm job that sets it (Slurm's task/none binds nothing); at least 1.
int availableCores();

}  // namespace orbcal::sim
