#!/bin/bash
# slamq run as a Slurm array job, no Dask: each array task runs one deterministic shard of
# the planned runs into the config's output folder, which must be on the shared filesystem.
#
#   jid=$(sbatch --parsable --array=0-3 examples/distributed/slurm-array.sh run.yaml)
#   sbatch --dependency=afterany:$jid --wrap "slamq run run.yaml --merge"
#
# The shard count is the array's size (SLURM_ARRAY_TASK_COUNT); the index is
# SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN, so --array=1-4 works as well as 0-3. A task
# that fails or is requeued resumes its shard: finished runs are skipped. The merge (or
# any later plain `slamq run run.yaml`) scores all shards' runs into one results file,
# summary and report; run it again after re-running a shard, it is idempotent.
#SBATCH --job-name=slamq-run
#SBATCH --cpus-per-task=2
#SBATCH --time=04:00:00
#SBATCH --output=slamq-run-%A_%a.log
set -euo pipefail
CONFIG=${1:?usage: sbatch --array=0-N slurm-array.sh CONFIG.yaml}
exec slamq run "$CONFIG" --shard "${SLURM_ARRAY_TASK_COUNT:?not in a Slurm array job}"
