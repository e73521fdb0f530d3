#!/usr/bin/env bash
# One task of a sharded `tetbench bench` sweep: task I of a job array of N measures shard I/N
# into $TETBENCH_OUT/shard-I. Submit it with submit.sh (which also queues the merge job), or:
#   sbatch --array=0-7 --export=ALL,TETBENCH_CONFIG=exp.toml,TETBENCH_OUT=/shared/out harness/slurm/array.sh
# A task that is requeued or resubmitted continues where it stopped (--resume).
#
# GPU tables (ptint, hapt): add `--gres=gpu:1` (and your GPU partition, -p gpu) to sbatch.
# Threads: RAYON_NUM_THREADS follows --cpus-per-task.
# Reference images: set `cache_dir` in the experiment file to an absolute path on a shared
# filesystem; entries are written atomically under their content hash, so shards share them.
#SBATCH --job-name=tetbench-shard
#SBATCH --cpus-per-task=2
#SBATCH --output=tetbench-shard-%A_%a.log
set -euo pipefail
: "${TETBENCH_CONFIG:?set TETBENCH_CONFIG to the experiment file}"
: "${TETBENCH_OUT:?set TETBENCH_OUT to the output directory}"
: "${SLURM_ARRAY_TASK_ID:?run as a job array (sbatch --array=0-N)}"
tetbench=${TETBENCH_BIN:-tetbench}
export RAYON_NUM_THREADS=${SLURM_CPUS_PER_TASK:-1}
count=${SLURM_ARRAY_TASK_COUNT:-$((SLURM_ARRAY_TASK_MAX + 1))}
i=$SLURM_ARRAY_TASK_ID
# Exit 3 means the shard finished with some failed rows (each is in results.csv with its
# message): that is data for the merge, not a failed task, so the merge (afterok) still runs.
rc=0
"$tetbench" bench "$TETBENCH_CONFIG" --out "$TETBENCH_OUT/shard-$i" \
  --shard "$i/$count" --resume || rc=$?
if [ "$rc" = 3 ]; then
  echo "tetbench: shard $i/$count finished with failed rows (see the note column of results.csv)" >&2
  rc=0
fi
exit "$rc"
