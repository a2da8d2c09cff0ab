// `mpirun -n N cdshear sweep`: the sweep's jobs handed out to MPI ranks (docs/campaigns.md, "On a
// cluster (MPI)"). Declared always, defined only in a build with MPI (CDSHEAR_WITH_MPI).
#pragma once

#include <functional>
#include <vector>

#include "job_scheduler.hpp"

namespace cdshear {

/// Runs jobs on the MPI ranks, one at a time each, rank 0's as its own child process; same
/// contract as run_jobs (its periodic `tick` called by rank 0's loop).
using RemoteScheduler =
    std::function<ScheduleResult(const std::vector<Job>&, const JobEndCallback&, const JobTick&)>;

/// True if the environment says that an MPI launcher (mpirun, srun) started this process among
/// more than one rank. Reads only the environment: MPI is not initialized.
bool mpi_launch_detected();

/// Initializes MPI, and on rank 0 calls sweep(scheduler, ranks) with a scheduler that hands
/// jobs to every rank (`ranks` of them, rank 0 included), one at a time each; the other ranks
/// run the jobs they are handed until rank 0 is done. Finalizes MPI. Returns the sweep's exit
/// code on every rank (a ConfigError or other exception of rank 0 is rethrown there; the workers
/// return 2 or 1). With one rank, calls sweep(nullptr, 0).
int run_sweep_under_mpi(const std::function<int(const RemoteScheduler*, int ranks)>& sweep);

}  // namespace cdshear
