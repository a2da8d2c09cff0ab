#!/bin/bash
# An example SLURM batch script for a campaign on a cluster (docs/campaigns.md, "On a cluster
# (MPI)"): `sbatch campaigns/slurm_example.sh`, from the repository, with cdshear built against
# the cluster's MPI (CMake finds it; `cmake -DCDSHEAR_MPI=OFF` builds without). Adapt the
# #SBATCH lines to your cluster; submit the same script again to resume after a time limit.
#
# Rank 0 reads the campaign, holds the folder lock, has the packings prepared and hands the runs
# out, costliest first, to every rank, itself included: each rank (rank 0 too, while it
# coordinates) runs one run at a time as a child process. So ask for as many tasks as runs at once.
#SBATCH --job-name=cdshear-paper
#SBATCH --ntasks=32                # 32 runs at once, one per rank (rank 0 included)
#SBATCH --cpus-per-task=1          # = --threads below: solver threads of each run
#SBATCH --mem-per-cpu=2G
#SBATCH --time=24:00:00
#SBATCH --signal=TERM@120          # SIGTERM 2 min before the time limit: runs write a checkpoint
#SBATCH --output=cdshear-%j.out
set -euo pipefail

campaign=campaigns/paper.toml
# The campaign folder must be on a file system that every node sees under the same path (the
# ranks share nothing else): your home or project space, not the node-local /tmp.
folder=$PWD/campaigns/paper

# --threads: solver threads (OpenMP) of each run; keep it equal to --cpus-per-task. One thread
# per run is the most efficient use of cores for a campaign of many runs (docs/performance.md);
# more helps only the largest systems when there are fewer runs than cores.
threads=${SLURM_CPUS_PER_TASK:-1}

# srun gives SIGTERM (scancel, --signal, the time limit) straight to every rank: the sweep then
# stops its runs with their checkpoint and exits 130; the same script again resumes them.
srun --kill-on-bad-exit=0 build/cdshear sweep "$campaign" -o "$folder" --threads "$threads"

# Or with Open MPI's own launcher. Open MPI 4's mpirun passes a SIGTERM on to the ranks only
# after odls_base_sigkill_timeout seconds (default 1) and SIGKILLs them as much later: give the
# runs time to write their checkpoint, and expect mpirun's own exit code (1) after a stop.
#   export OMPI_MCA_odls_base_sigkill_timeout=60
#   mpirun -n "$SLURM_NTASKS" build/cdshear sweep "$campaign" -o "$folder" --threads "$threads"
