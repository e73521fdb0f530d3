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
# Exit 3: merged, with some failed rows (kept, with their messages): the job has done its work.
rc=0
"$tetbench" merge --out "$TETBENCH_OUT/merged" "${shards[@]}" || rc=$?
if [ "$rc" = 3 ]; then
  echo "tetbench: merged with failed rows (see the note column of merged/results.csv)" >&2
  rc=0
fi
exit "$rc"
