#!/usr/bin/env bash
# The whole answer's cost as a new user meets it: `snakemake --cores 2 all` on clean clones.
#   1. clones the committed HEAD of this project into a temporary folder and runs its
#      `make install` there (timed apart: the budget is the run after installation);
#   2. runs `snakemake --cores 2 all` RUNS times (default 2), each from nothing (results/, logs/
#      and .snakemake/ removed; the installed .venv and its kernels' extension kept, as after
#      `make install`);
#      (and reads the CPU time of Snakemake's own process, the scheduler, apart from its jobs);
#   3. times 5 no-op reruns of the last run (`snakemake --cores 2 all` with nothing to do);
#   4. summarises every run from Snakemake's job records and the benchmark files
#      (gimbal_reduction.results.bench.workflow_run: wall, the jobs' CPU, the critical path) into results/benchmarks/all-clean.json of this project, and prints it;
#      the rules' priorities measured in these runs go to results/benchmarks/priorities.json
#      (copy it over workflow/priorities.json to schedule by them: gimbal_reduction.workflow.schedule).
# Run it on a quiet machine: the runs are timed as they are. KEEP=1 keeps the clone.
#   make benchmark-all            RUNS=1 make benchmark-all
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
runs="${RUNS:-2}"
work="$(mktemp -d /tmp/gimbal-benchmark-all.XXXXXX)"
[ "${KEEP:-0}" = 1 ] || trap 'rm -rf "$work"' EXIT
git clone -q "$root" "$work/clone"
cd "$work/clone"
echo "benchmark-all: $(git rev-parse --short HEAD) cloned into $work/clone; make install ..."
start=$(date +%s)
SNAKEMAKE_BINDIR="${SNAKEMAKE_BINDIR:-/nonexistent}" bash workflow/envs/install.sh > "$work/install.log" 2>&1 \
  || { echo "benchmark-all: make install failed (log: $work/install.log)" >&2; exit 1; }
echo "benchmark-all: install took $(( $(date +%s) - start )) s"
projects=()
scheduler=()
for i in $(seq 1 "$runs"); do
  rm -rf results logs .snakemake
  start=$(date +%s)
  .venv/bin/python -m snakemake --cores 2 all > "$work/run$i.out" 2>&1 &
  pid=$!
  # the scheduler's own CPU (Snakemake's process, not its jobs): its utime + stime, read until it ends
  ticks=0
  while kill -0 "$pid" 2>/dev/null; do
    ticks=$(awk '{print $14 + $15}' "/proc/$pid/stat" 2>/dev/null || echo "$ticks")
    sleep 1
  done
  wait "$pid" || { echo "benchmark-all: run $i failed (output: $work/run$i.out)" >&2; KEEP=1; exit 1; }
  scheduler+=("$(awk -v t="$ticks" -v hz="$(getconf CLK_TCK)" 'BEGIN {printf "%.1f", t / hz}')")
  echo "benchmark-all: run $i of $runs: $(( $(date +%s) - start )) s wall (snakemake's start included);" \
       "Snakemake's own process ${scheduler[-1]} CPU-s"
  # what the summary reads, kept with their times: Snakemake's job records and the benchmark files
  mkdir -p "$work/run$i/.snakemake" "$work/run$i/results"
  cp -a .snakemake/metadata "$work/run$i/.snakemake/"
  cp -a results/benchmarks "$work/run$i/results/"
  projects+=("$work/run$i")
done
# 4. the no-op: `snakemake --cores 2 all` again on the last run's outputs, 5 times
noop=()
TIMEFORMAT=%R
for k in 1 2 3 4 5; do
  noop+=("$( { time .venv/bin/python -m snakemake --cores 2 all -q > "$work/noop$k.out" 2>&1; } 2>&1 )")
done
.venv/bin/python -m gimbal_reduction.results.bench.workflow_run "${projects[@]}" --noop-s "${noop[@]}" \
  --scheduler-cpu-s "${scheduler[@]}" \
  --out "$root/results/benchmarks/all-clean.json" --priorities-out "$root/results/benchmarks/priorities.json" \
  --revision "$(git rev-parse --short HEAD)"
