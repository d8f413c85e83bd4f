#!/bin/sh
# SLURM batch script: the spraycoat pipeline on several nodes with MPI (README "Many cores and many machines").
#   sbatch cases/slurm_pipeline.sh CASE.ini RUN_DIR
# One rank per node, all of the node's cores as OpenMP threads: rank 0 runs the spray, couple and render stages,
# every rank takes impact runs (or vcrit diameters) from a shared counter.  RUN_DIR must be on a file system every
# node sees.  A job stopped by its time limit gets SIGTERM first (see --signal): the ranks checkpoint their runs,
# and the same command with `resume RUN_DIR` (or a resubmission of this script) continues.
#SBATCH --job-name=spraycoat
#SBATCH --nodes=4
#SBATCH --ntasks-per-node=1
#SBATCH --cpus-per-task=32
#SBATCH --time=12:00:00
#SBATCH --signal=TERM@300
#SBATCH --output=spraycoat-%j.log
set -eu
case_file=${1:?usage: sbatch cases/slurm_pipeline.sh CASE.ini RUN_DIR}
run_dir=${2:?usage: sbatch cases/slurm_pipeline.sh CASE.ini RUN_DIR}
bin=${SPRAYCOAT:-build-mpi/spraycoat}   # a `make MPI=1` build
export OMP_NUM_THREADS="${SLURM_CPUS_PER_TASK:-1}"
export OMP_PROC_BIND=spread OMP_PLACES=cores
if [ -f "$run_dir/stages" ]; then
    srun "$bin" resume "$run_dir"   # or: mpirun "$bin" ..., where OpenMPI was built without SLURM support
else
    srun "$bin" run "$case_file" -o "$run_dir" --threads "$OMP_NUM_THREADS"
fi
