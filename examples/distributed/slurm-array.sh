#!/bin/bash
# slamq run as a Slurm array job, no Dask: each array task runs one deterministic shard of
# the planned runs into the config's output folder, which must be on a filesystem every
# node and the login node share.
#
#   jid=$(sbatch --parsable --array=0-3 examples/distributed/slurm-array.sh run.yaml)
#   sbatch --dependency=afterany:$jid --cpus-per-task=4 --wrap "slamq run run.yaml --merge"
#
# - slamq must be on PATH inside the job: sbatch exports the submitting shell's
#   environment, so submit from a shell where `slamq --version` works (an activated venv),
#   or activate it below. Without it every task ends "slamq: not found" (exit 127).
# - Shards: an evenly spaced array of N tasks (--array=0-3, 1-4, 0-6:2) runs shards 0..N-1
#   by position. To run shards again (cancelled, failed, out of time), name them by
#   index with the first submission's shard count N:
#       sbatch --array=2 examples/distributed/slurm-array.sh run.yaml 4
#       sbatch --array=1,3 examples/distributed/slurm-array.sh run.yaml 4
#   (without N, the count the output folder recorded is used, or the task refuses and
#   prints this command).
# - A task that is requeued (scontrol requeue, preemption) resumes its shard: finished
#   runs are skipped. A second copy of a shard that is still running refuses (exit 2) and
#   names the running one. A shard with a run that is not ok exits 3 (Slurm: FAILED); run
#   it again with --retry-failed.
# - The merge scores every shard's runs into one results file, summary and report; it
#   exits 3 when runs are not finished, naming each shard's state (running, interrupted,
#   missing), so an afterany merge job shows FAILED; --partial accepts a partial merge.
#   Merging again is idempotent. Scoring uses every CPU the merge job gets: give it more
#   than Slurm's default one (--cpus-per-task).
#SBATCH --job-name=slamq-run
#SBATCH --cpus-per-task=2
#SBATCH --time=04:00:00
#SBATCH --output=slamq-run-%A_%a.log
set -euo pipefail
CONFIG=${1:?usage: sbatch --array=0-N slurm-array.sh CONFIG.yaml [SHARDS]}
SHARDS=${2:-auto}
: "${SLURM_ARRAY_TASK_ID:?not in a Slurm array job (sbatch --array=...)}"
if ! command -v slamq >/dev/null 2>&1; then
  echo "slamq is not on PATH inside the job: submit from a shell where slamq runs (an" \
    "activated venv; sbatch exports it) or activate it in this script" >&2
  exit 127
fi
exec slamq run "$CONFIG" --shard "$SHARDS"
