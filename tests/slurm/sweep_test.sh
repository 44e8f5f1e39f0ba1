#!/usr/bin/env bash
# CTest slurm.sweep_matches_the_sequential_suite: brings up a single-node Slurm cluster
# (scripts/slurm/local-cluster), runs the CI suite through scripts/slurm/sweep and checks that the
# merged results equal those of the sequential 'terrain regress' run (every value but timings);
# then makes one array task fail (its output directory is a file) and checks that the merge fails
# naming that shard; takes the cluster down however it ends.
# Usage: sweep_test.sh SOURCE_DIR TERRAIN WORK_DIR SEQUENTIAL_RESULTS_JSON
set -euo pipefail
src=$1 terrain=$2 work=$3 sequential=$4

[ -f "$sequential" ] || { echo "FAIL: no sequential results at $sequential (the regress.ci_suite fixture)"; exit 1; }
cluster="$work/cluster"
"$src/scripts/slurm/local-cluster" down "$cluster" > /dev/null 2>&1 || true
rm -rf "$work"
mkdir -p "$work"
trap '"$src/scripts/slurm/local-cluster" down "$cluster"' EXIT
"$src/scripts/slurm/local-cluster" up "$cluster"
export SLURM_CONF="$cluster/slurm.conf"

# the CI suite, two scenarios a task, against the committed baseline
rc=0
"$src/scripts/slurm/sweep" --suite "$src/evaluation/suites/ci.yaml" --baseline "$src/evaluation/baselines/ci.json" \
  --out "$work/ci" --per-task 2 --terrain "$terrain" --wait || rc=$?
echo "ci sweep exit=$rc"
[ "$rc" -eq 0 ] || { echo "FAIL: the CI suite through Slurm exited $rc"; cat "$work/ci/logs/"task-*.out; exit 1; }
[ -f "$work/ci/junit.xml" ] || { echo "FAIL: no junit.xml"; exit 1; }
python3 - "$work/ci/merged/suite_results.json" "$sequential" <<'PY'
import json, sys
merged, sequential = (json.load(open(p)) for p in sys.argv[1:3])
if sorted(merged) != sorted(sequential):
    sys.exit(f"FAIL: scenarios differ: {sorted(merged)} vs {sorted(sequential)}")
compared = 0
for scenario, metrics in sequential.items():
    keys = {k for k in metrics if not k.startswith("timing.")}
    other = {k for k in merged[scenario] if not k.startswith("timing.")}
    if keys != other:
        sys.exit(f"FAIL: {scenario}: metrics only in one run: {sorted(keys ^ other)[:10]}")
    for k in sorted(keys):
        if merged[scenario][k] != metrics[k]:
            sys.exit(f"FAIL: {scenario} {k}: {merged[scenario][k]} through Slurm, {metrics[k]} sequential")
        compared += 1
print(f"merged results equal the sequential run in {compared} values of {len(sequential)} scenarios")
PY

# a task that fails: shard 2's output directory cannot be made (a file stands there)
mkdir -p "$work/fail/shards"
echo "in the way" > "$work/fail/shards/2"
rc=0
"$src/scripts/slurm/sweep" --suite "$src/tests/data/shard-suite.yaml" --write-baseline "$work/fail/baseline.json" \
  --out "$work/fail" --per-task 1 --terrain "$terrain" --wait --force > "$work/fail.log" 2>&1 || rc=$?
cat "$work/fail.log"
echo "failing sweep exit=$rc"
[ "$rc" -eq 2 ] || { echo "FAIL: a failed task gave exit $rc, not 2"; exit 1; }
grep -q "task 2 (shard 2/3) failed" "$work/fail.log" || { echo "FAIL: the merge did not name task 2"; exit 1; }
[ ! -e "$work/fail/baseline.json" ] || { echo "FAIL: a baseline was written from a failed sweep"; exit 1; }
echo "PASS"
