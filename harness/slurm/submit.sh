#!/usr/bin/env bash
# Submits a sharded sweep: an N-task array (array.sh), then the merge (merge.sh) once every task
# has succeeded. Extra arguments go to both sbatch calls (e.g. -p gpu --gres=gpu:1 for the GPU
# renderers' tables, --cpus-per-task=8).
# Usage: submit.sh CONFIG OUT N [sbatch options...]    (set TETBENCH_BIN if tetbench is not on PATH)
# With SLURM_SUBMIT_WAIT=1 it waits for the merge job to finish (sbatch --wait), as CI does.
set -euo pipefail
[ $# -ge 3 ] || { echo "usage: $0 CONFIG OUT N [sbatch options...]" >&2; exit 2; }
config=$(realpath "$1"); out=$(realpath -m "$2"); n=$3; shift 3
here=$(dirname "$(realpath "$0")")
mkdir -p "$out"
export TETBENCH_CONFIG=$config TETBENCH_OUT=$out
export TETBENCH_BIN=${TETBENCH_BIN:-$(command -v tetbench || echo tetbench)}
array=$(sbatch --parsable --array=0-$((n - 1)) --chdir="$out" --export=ALL "$@" "$here/array.sh")
echo "array job: $array ($n tasks)"
wait=()
[ "${SLURM_SUBMIT_WAIT:-0}" = 1 ] && wait=(--wait)
merge=$(sbatch --parsable "${wait[@]}" --dependency=afterok:"${array%%;*}" --kill-on-invalid-dep=yes \
  --chdir="$out" --export=ALL "$@" "$here/merge.sh")
echo "merge job: $merge (after the array succeeds): $out/merged"
