#!/usr/bin/env bash
# CI: starts a one-node Slurm (local-cluster.sh), runs a small experiment as a 3-task array plus
# its merge job, and checks that the merged rows equal the same experiment run unsharded
# (same keys, errors to 1e-9). One cell is made to fail (the harness's test-only panic), so the
# check also shows that a shard with failed rows (exit 3) still lets the merge run and keeps
# the failed row. Needs root, slurm-wlm and munge. Usage: ci-check.sh TETBENCH_BIN
set -euo pipefail
bin=$(realpath "$1")
here=$(dirname "$(realpath "$0")")
work=$(mktemp -d /tmp/tetbench-slurm-ci.XXXXXX)
"$here/local-cluster.sh" start >/dev/null
cat >"$work/exp.toml" <<TOML
name = "slurm-ci"
datasets = ["spx:1500", { mesh = "torus", tets = 2000, label = "torus-2k" }]
renderers = [{ name = "raycast", integrators = ["partial", "average"] }, { name = "reference" }]
sizes = ["32x32"]
repeats = 1
warmup = 0
cache_dir = "$work/shared-cache"
[views]
named = ["0,0", "90,30", "45,10"]
TOML
export TETBENCH_TEST_PANIC="raycast/average@named:1"
rc=0
"$bin" bench "$work/exp.toml" --out "$work/unsharded" --no-plots >/dev/null 2>&1 || rc=$?
[ "$rc" = 3 ] || { echo "slurm check: the unsharded run should exit 3 (one failed row), got $rc" >&2; exit 1; }
TETBENCH_BIN=$bin SLURM_SUBMIT_WAIT=1 timeout 600 "$here/submit.sh" "$work/exp.toml" "$work/sharded" 3 \
  --cpus-per-task=1
python3 - "$work/unsharded/results.csv" "$work/sharded/merged/results.csv" <<'PY'
import csv, math, sys
def rows(p):
    out = {}
    for r in csv.DictReader(open(p)):
        k = (r["dataset"], r["variant"], r["projection"], r["width"], r["height"], r["view_id"])
        assert k not in out, f"{p}: doubled {k}"
        out[k] = float(r["rmse"]) if r["rmse"] else math.nan
    return out
a, b = rows(sys.argv[1]), rows(sys.argv[2])
assert a.keys() == b.keys(), f"keys differ: {sorted(a.keys() ^ b.keys())}"
for k in a:
    assert abs(a[k] - b[k]) <= 1e-9 or (math.isnan(a[k]) and math.isnan(b[k])), (k, a[k], b[k])
failed = [k for k in b if math.isnan(b[k]) and k[1] == "raycast/average" and k[5] == "named:1"]
assert len(failed) == 2, f"the failed cells should be in the merge: {failed}"
print(f"slurm: merged 3 shards = unsharded run ({len(a)} rows, errors to 1e-9, {len(failed)} failed rows kept)")
PY
rm -rf "$work"
