#!/usr/bin/env bash
# Smoke test of the test cluster (tools/slurm-cluster.sh; SLURM_CONF set by CTest):
#  1. a 4-task job array submitted with `sbatch --wait` runs every task: each writes a file named
#     by its SLURM_ARRAY_TASK_ID holding that id, and all four are there with that content;
#  2. `scancel` of a running array task ends it in a non-COMPLETED state before its work is done.
# Usage: job-array.sh WORK_DIR   (a folder under the build tree; made and wiped here)
set -euo pipefail
[[ $# -eq 1 ]] || { echo "usage: $0 WORK_DIR" >&2; exit 2; }
[[ -n "${SLURM_CONF:-}" && -f "$SLURM_CONF" ]] || { echo "FAIL: SLURM_CONF not set to a slurm.conf" >&2; exit 1; }
work=$(realpath -m "$1")
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; timeout 5 squeue --states=all >&2 || true; exit 1; }

# Job state of job (or array task) $1, as squeue prints it ("" once slurmctld forgot it).
state_of() { squeue --noheader --states=all --jobs="$1" --format=%T 2>/dev/null | head -n 1; }

# --- 1. a 4-task array, waited for by sbatch --wait -------------------------------------------
out=$work/array
mkdir -p "$out"
t0=$(date +%s)
# `timeout` bounds the wait; sbatch --wait exits with the highest exit code of the tasks.
timeout 90 sbatch --wait --quiet --array=0-3 --job-name=orbcal-smoke --chdir="$work" \
  --output="$work/slurm-%A_%a.out" \
  --wrap "printf '%s\n' \"task \$SLURM_ARRAY_TASK_ID of \$SLURM_ARRAY_JOB_ID\" >$out/\$SLURM_ARRAY_TASK_ID.tmp && mv $out/\$SLURM_ARRAY_TASK_ID.tmp $out/\$SLURM_ARRAY_TASK_ID" ||
  fail "sbatch --wait of the 4-task array failed or took over 90 s (exit $?)"
echo "array of 4 tasks done in $(($(date +%s) - t0)) s"
shopt -s nullglob
files=("$out"/*)
((${#files[@]} == 4)) || fail "expected 4 files in $out, found ${#files[@]}: ${files[*]}"
array_id=""
for id in 0 1 2 3; do
  [[ -f "$out/$id" ]] || fail "task $id wrote no file $out/$id"
  line=$(cat "$out/$id")
  [[ "$line" =~ ^task\ $id\ of\ ([0-9]+)$ ]] || fail "file $out/$id holds '$line', not 'task $id of <array job id>'"
  [[ -z "$array_id" || "$array_id" == "${BASH_REMATCH[1]}" ]] || fail "tasks report two array job ids"
  array_id=${BASH_REMATCH[1]}
done
for id in 0 1 2 3; do
  st=$(state_of "${array_id}_$id")
  [[ "$st" == COMPLETED ]] || fail "array task ${array_id}_$id is in state '$st', not COMPLETED"
done

# --- 2. scancel of a running array task ---------------------------------------------------------
# Task 0 sleeps 60 s and then, if the sleep was not killed, writes done_0; we cancel it while it
# runs. Task 1 writes done_1 at once.
cancel=$work/cancel
mkdir -p "$cancel"
job=$(sbatch --parsable --array=0-1 --job-name=orbcal-cancel --chdir="$work" --output=/dev/null \
  --wrap "if [ \$SLURM_ARRAY_TASK_ID = 0 ]; then touch $cancel/started; sleep 60 && touch $cancel/done_0; else touch $cancel/done_1; fi")
job=${job%%;*}
task=${job}_0
for ((i = 0; i < 150; i++)); do   # up to 30 s for the task to start running
  [[ "$(state_of "$task")" == RUNNING && -f "$cancel/started" ]] && break
  sleep 0.2
done
[[ "$(state_of "$task")" == RUNNING ]] || { scancel "$job" || true; fail "task $task did not start running within 30 s"; }
scancel "$task"
st=""
for ((i = 0; i < 100; i++)); do   # up to 20 s for it to end
  st=$(state_of "$task")
  [[ "$st" != RUNNING && "$st" != COMPLETING && "$st" != PENDING ]] && break
  sleep 0.2
done
scancel "$job" 2>/dev/null || true
[[ -n "$st" ]] || fail "slurmctld forgot task $task right after scancel"
[[ "$st" != RUNNING && "$st" != COMPLETING && "$st" != PENDING ]] || fail "task $task still '$st' 20 s after scancel"
[[ "$st" != COMPLETED ]] || fail "cancelled task $task ended COMPLETED"
[[ ! -e "$cancel/done_0" ]] || fail "cancelled task $task ran to its end (wrote done_0)"
echo "cancelled task $task ended in state $st"
rm -rf "$work"
echo "slurm job array smoke test passed"
