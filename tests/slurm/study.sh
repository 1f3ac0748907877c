#!/usr/bin/env bash
# A study through the real one-node Slurm cluster (tools/slurm-cluster.sh; SLURM_CONF set by CTest)
# against the same study run locally:
#  1. `orbcal study run` locally, `orbcal study submit --wait` through sbatch: every merged CSV is
#     byte-for-byte the same;
#  2. a task cancelled mid-run (scancel of its array element) is reported failed by `orbcal study
#     status`; resubmitting runs only the missing and failed tasks and the merged CSVs are again the
#     local run's.
# Usage: study.sh ORBCAL WORK_DIR   (WORK_DIR under the build tree; made and wiped here)
set -euo pipefail
[[ $# -eq 2 ]] || { echo "usage: $0 ORBCAL WORK_DIR" >&2; exit 2; }
[[ -n "${SLURM_CONF:-}" && -f "$SLURM_CONF" ]] || { echo "FAIL: SLURM_CONF not set to a slurm.conf" >&2; exit 1; }
orbcal=$(realpath "$1")
work=$(realpath -m "$2")
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; timeout 5 squeue --states=all >&2 || true; exit 1; }

# Wang et al. 2023's Table 5 protocol (four noise levels + rendered images), 4 seeds, small sets.
cat >"$work/t5.yaml" <<'EOF'
format: orbcal-study-1
name: t5-slurm-test
job: experiment
preset: table5
options: {ident: 30, valid: 40, repetitions: 2, quiet: true, no-plots: true}
seeds: {first: 1, count: 4}
slurm: {throttle: 2, time: "00:10:00", mem: 1G}
EOF

same_csvs() {  # every CSV under merged/ of $1 equals $2's, and they have the same files
  local a=$1/merged b=$2/merged n=0
  diff <(cd "$a" && find . -name '*.csv' | sort) <(cd "$b" && find . -name '*.csv' | sort) >&2 ||
    fail "$a and $b hold different CSV files"
  while read -r f; do
    cmp "$a/$f" "$b/$f" >&2 || fail "$a/$f differs from $b/$f"
    n=$((n + 1))
  done < <(cd "$a" && find . -name '*.csv' | sort)
  ((n >= 3)) || fail "only $n merged CSVs"
  echo "$n merged CSVs identical: $1 and $2"
}

t0=$(date +%s.%N)
"$orbcal" study run "$work/t5.yaml" -o "$work/local" --no-plots >"$work/local.log" 2>&1 || fail "local run: $(cat "$work/local.log")"
t1=$(date +%s.%N)
timeout 240 "$orbcal" study submit "$work/t5.yaml" -o "$work/slurm" --wait >"$work/slurm.log" 2>&1 ||
  fail "submit --wait: $(cat "$work/slurm.log")"
"$orbcal" study merge "$work/slurm" --no-plots >>"$work/slurm.log" 2>&1 || fail "merge: $(cat "$work/slurm.log")"
t2=$(date +%s.%N)
awk -v a="$t0" -v b="$t1" -v c="$t2" 'BEGIN { printf "wall time: local %.1f s, Slurm (submit, wait, merge) %.1f s\n", b - a, c - b }'
grep -q "submitted as job" "$work/slurm.log" || fail "no job submitted: $(cat "$work/slurm.log")"
grep -q "^#SBATCH --array=0-3%2$" "$work/slurm/slurm/submit-1.sh" || fail "submit-1.sh: array line: $(grep array "$work/slurm/slurm/submit-1.sh")"
grep -q "slurm_job:" "$work/slurm/shards/task-000000/task.yaml" || fail "task 0 did not run under Slurm"
same_csvs "$work/local" "$work/slurm"

# --- 2. scancel one task mid-run, then resubmit ----------------------------------------------------
"$orbcal" study submit "$work/t5.yaml" -o "$work/cancel" >"$work/cancel.log" 2>&1 || fail "submit: $(cat "$work/cancel.log")"
job=$(sed -n 's/.*submitted as job \([0-9]*\).*/\1/p' "$work/cancel.log")
[[ -n "$job" ]] || fail "no job id in: $(cat "$work/cancel.log")"
victim=""
for _ in $(seq 1 600); do  # up to 60 s for a task to start writing
  for i in 0 1 2 3; do
    if [[ -f "$work/cancel/shards/task-00000$i.tmp/log.txt" ]]; then victim=$i; break 2; fi
  done
  sleep 0.1
done
[[ -n "$victim" ]] || fail "no task started within 60 s"
scancel "${job}_${victim}"
for _ in $(seq 1 240); do  # the rest of the array finishes
  [[ -z "$(squeue --noheader --jobs="$job" 2>/dev/null)" ]] && break
  sleep 0.5
done
[[ -z "$(squeue --noheader --jobs="$job" 2>/dev/null)" ]] || fail "job $job still queued or running after 120 s"
set +e
"$orbcal" study status "$work/cancel" >"$work/status.log" 2>&1
rc=$?
set -e
[[ $rc -eq 3 ]] || fail "status after scancel: exit $rc, expected 3: $(cat "$work/status.log")"
grep -q "1 failed" "$work/status.log" || fail "status does not report the cancelled task failed: $(cat "$work/status.log")"
grep -q "failed: $victim$" "$work/status.log" || fail "status does not name task $victim: $(cat "$work/status.log")"
"$orbcal" study merge "$work/cancel" >"$work/merge-refused.log" 2>&1 && fail "merge of an unfinished study succeeded"
timeout 240 "$orbcal" study submit "$work/t5.yaml" -o "$work/cancel" --wait >"$work/resubmit.log" 2>&1 ||
  fail "resubmit: $(cat "$work/resubmit.log")"
grep -q "^tasks $victim of 4$" "$work/resubmit.log" || fail "the resubmission ran more than task $victim: $(cat "$work/resubmit.log")"
"$orbcal" study merge "$work/cancel" --no-plots >/dev/null 2>&1 || fail "merge after resubmission"
same_csvs "$work/local" "$work/cancel"
echo "PASS"
