#!/usr/bin/env bash
# Merges the shards of a sweep ($TETBENCH_OUT/shard-*) into $TETBENCH_OUT/merged and draws the
# plots. submit.sh queues it with --dependency=afterok on the array; run by hand otherwise.
#SBATCH --job-name=tetbench-merge
#SBATCH --cpus-per-task=1
#SBATCH --output=tetbench-merge-%j.log
set -euo pipefail
: "${TETBENCH_OUT:?set TETBENCH_OUT to the output directory}"
tetbench=${TETBENCH_BIN:-tetbench}
shopt -s nullglob
shards=("$TETBENCH_OUT"/shard-*)
exec "$tetbench" merge --out "$TETBENCH_OUT/merged" "${shards[@]}"
