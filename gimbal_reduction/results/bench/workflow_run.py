"""What bounds a whole workflow run: its wall time, its jobs' CPU and its critical path.

``python -m gimbal_reduction.results.bench.workflow_run DIR [DIR ...] --out F.json`` reads the
jobs of each run from Snakemake's records (``DIR/.snakemake/metadata``: per output file its rule,
inputs, start and end) and the rules' benchmark files (``DIR/results/benchmarks``), and writes,
per run:

* ``wall_s``: from the first job's start to the last job's end (the DAG build before the first
  job is not in it);
* ``cpu_s``: the sum of the jobs' ``cpu_time`` (Snakemake's ``benchmark:``), and ``cores_busy``
  = cpu_s / (cores * wall_s), how full the run kept its cores;
* ``critical_path``: the chain of jobs, from the last one to finish back to a first one, each
  preceded by the input-producing job that finished last: the jobs the run waited on.  Its
  length ``critical_path_s`` (first start to last end along it) is what no number of cores
  shortens; ``waits_s`` is the time on it when none of its jobs ran (another job held the
  cores);
* ``largest``: the jobs of most CPU;

and, given ``--noop-s``, the wall times of no-op reruns (Snakemake with nothing to do) and their median;
given ``--scheduler-cpu-s``, the CPU time of Snakemake's own process in each run (its scheduling);
given ``--priorities-out``, the rules' scheduling priorities measured in these runs (each rule's
bottom level, ``bottom_levels``; ``gimbal_reduction.workflow.schedule``).

The ``make benchmark-all`` script (``workflow/benchmark-all.sh``) runs clean clones' ``all``
and calls this; the summary is printed and the JSON kept.  Nothing is timed in a test.
"""
from __future__ import annotations

import argparse
import base64
import csv
import json
import statistics
import sys
from dataclasses import dataclass, field
from pathlib import Path

from gimbal_reduction.workflow import schedule
from gimbal_reduction.workflow.provenance import write_json

# the rules' benchmark files, matched to their jobs by time: Snakemake writes one when its job
# ends, so its modification time is the job's end, and its ``s`` the job's wall time [s]
MATCH_TOLERANCE_S = 3.0


@dataclass
class Job:
    """One job of a run: rule, start and end [s since the run's first start], files, CPU [s]."""

    rule: str
    start: float
    end: float
    inputs: list[str] = field(default_factory=list)
    outputs: list[str] = field(default_factory=list)
    benchmark: str | None = None
    cpu_s: float = 0.0

    @property
    def name(self) -> str:
        if self.benchmark:
            return f"{self.rule}[{Path(self.benchmark).stem}]"
        return f"{self.rule}[{Path(self.outputs[0]).name}]" if self.outputs else self.rule


def read_jobs(project: Path) -> list[Job]:
    """The jobs of a project's last run, from Snakemake's metadata (``.snakemake/metadata``: one
    record per output file with its rule, inputs, start and end; a job is the outputs of one
    ``job_hash``), start and end in seconds from the first start."""
    folder = project / ".snakemake" / "metadata"
    jobs: dict = {}
    for path in sorted(folder.iterdir()) if folder.is_dir() else ():
        try:
            record = json.loads(path.read_text())
            output = base64.b64decode(path.name).decode()
        except (ValueError, OSError):
            continue
        if record.get("incomplete") or record.get("starttime") is None or record.get("endtime") is None:
            continue
        job = jobs.setdefault(record.get("job_hash"), Job(record["rule"], float(record["starttime"]),
                                                          float(record["endtime"]),
                                                          inputs=list(record.get("input") or [])))
        job.outputs.append(output)
    if not jobs:
        raise ValueError(f"{folder}: no finished job recorded")
    done = list(jobs.values())
    t0 = min(j.start for j in done)
    for j in done:
        j.start, j.end = j.start - t0, j.end - t0
        j.outputs.sort()
    _attach_benchmarks(done, project, t0)
    return sorted(done, key=lambda j: (j.start, j.rule))


def _attach_benchmarks(jobs: list[Job], project: Path, t0: float) -> None:
    """Each benchmark file of the run to the job that ended nearest its modification time and
    lasted nearest its ``s`` (within MATCH_TOLERANCE_S), its ``cpu_time`` to the job's cpu_s."""
    for path in sorted((project / "results" / "benchmarks").rglob("*.tsv")):
        try:
            rows = list(csv.reader(path.open(), delimiter="\t"))
            values = dict(zip(rows[0], rows[1]))
            wall, cpu = float(values["s"]), float(values.get("cpu_time") or 0.0)
        except (OSError, IndexError, KeyError, ValueError):
            continue
        end = path.stat().st_mtime - t0
        free = [j for j in jobs if j.benchmark is None]
        best = min(free, key=lambda j: abs(j.end - end) + abs((j.end - j.start) - wall), default=None)
        if best is not None and abs(best.end - end) + abs((best.end - best.start) - wall) <= MATCH_TOLERANCE_S:
            best.benchmark, best.cpu_s = str(path.relative_to(project)), cpu


def critical_path(jobs: list[Job]) -> list[Job]:
    """From the last job to end back to a first job, each preceded by its input-producing job
    that ended last (module docstring); first job first."""
    producer = {out: j for j in jobs for out in j.outputs}
    chain = [max(jobs, key=lambda j: (j.end, j.start))]
    while True:
        before = [producer[f] for f in chain[-1].inputs if f in producer and producer[f] is not chain[-1]]
        if not before:
            break
        chain.append(max(before, key=lambda j: j.end))
    return chain[::-1]


def bottom_levels(jobs: list[Job]) -> dict[str, float]:
    """{rule: seconds}: per job its wall time plus the largest bottom level of the jobs that read
    one of its outputs (its time to the run's end with unlimited cores), the largest over each
    rule's jobs (``gimbal_reduction.workflow.schedule``: the rules' priorities)."""
    producer = {out: k for k, j in enumerate(jobs) for out in j.outputs}
    readers: list[set[int]] = [set() for _ in jobs]
    for k, j in enumerate(jobs):
        for f in j.inputs:
            if f in producer and producer[f] != k:
                readers[producer[f]].add(k)
    level: dict[int, float] = {}
    # a reader starts after its producers end, so in order of decreasing start every reader of a
    # job has its level before the job does
    for k in sorted(range(len(jobs)), key=lambda k: (-jobs[k].start, -jobs[k].end)):
        level[k] = (jobs[k].end - jobs[k].start) + max((level.get(r, 0.0) for r in readers[k]),
                                                       default=0.0)
    out: dict[str, float] = {}
    for k, j in enumerate(jobs):
        out[j.rule] = max(out.get(j.rule, 0.0), level[k])
    return out


def median_priorities(runs: list[list[Job]]) -> dict[str, int]:
    """{rule: whole seconds}: the median over the runs of each rule's bottom level (a rule
    missing from a run is left out of that run's values)."""
    levels = [bottom_levels(jobs) for jobs in runs]
    rules = sorted({r for lv in levels for r in lv})
    return {r: int(round(statistics.median(lv[r] for lv in levels if r in lv))) for r in rules}


def summarise(jobs: list[Job], cores: int, largest: int = 12) -> dict:
    """The run's figures (module docstring)."""
    wall = max(j.end for j in jobs)
    cpu = sum(j.cpu_s for j in jobs)
    chain = critical_path(jobs)
    busy = sum(j.end - j.start for j in chain)
    return {
        "jobs": len(jobs), "wall_s": wall, "cpu_s": round(cpu, 1),
        "cores_busy": round(cpu / (cores * wall), 3) if wall > 0 else None,
        "critical_path_s": chain[-1].end - chain[0].start,
        "waits_s": (chain[-1].end - chain[0].start) - busy,
        "critical_path": [{"job": j.name, "start_s": j.start, "end_s": j.end, "cpu_s": j.cpu_s}
                          for j in chain],
        "largest": [{"job": j.name, "cpu_s": j.cpu_s, "wall_s": j.end - j.start}
                    for j in sorted(jobs, key=lambda j: -j.cpu_s)[:largest]],
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("projects", nargs="+", type=Path,
                        help="project folders, one per run (their .snakemake/metadata and results/benchmarks)")
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--noop-s", type=float, nargs="*", default=[],
                        help="wall times [s] of no-op reruns (snakemake with nothing to do), to record")
    parser.add_argument("--scheduler-cpu-s", type=float, nargs="*", default=[],
                        help="CPU time [s] of Snakemake's own process in each run (not its jobs'), to record")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--priorities-out", type=Path,
                        help="also write the rules' priorities measured in these runs "
                             "(gimbal_reduction.workflow.schedule: workflow/priorities.json's contract)")
    parser.add_argument("--revision", default=None,
                        help="the git revision the runs ran, recorded with the priorities")
    args = parser.parse_args(argv)
    try:                                    # every folder read before anything is written
        jobs = [read_jobs(project) for project in args.projects]
    except ValueError as exc:
        print(f"workflow_run: {exc}", file=sys.stderr)
        return 2
    runs = [{"project": str(project), **summarise(j, args.cores)} for project, j in zip(args.projects, jobs)]
    walls = [r["wall_s"] for r in runs]
    out = {"runs": runs, "wall_s_median": statistics.median(walls), "cores": args.cores,
           "noop_s": args.noop_s, "noop_s_median": statistics.median(args.noop_s) if args.noop_s else None,
           "scheduler_cpu_s": args.scheduler_cpu_s}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(args.out.name + ".tmp")
    tmp.write_text(json.dumps(out, indent=1))
    tmp.replace(args.out)
    if args.priorities_out:
        write_json(args.priorities_out, schedule.document(median_priorities(jobs), {
            "what": "each rule's bottom level [s]: its wall time plus the longest chain of jobs "
                    "after it, the largest over its jobs, the median over these clean runs",
            "runs": [{"project": r["project"], "wall_s": round(r["wall_s"], 1)} for r in runs],
            "revision": args.revision, "cores": args.cores}))
        print(f"workflow_run: the rules' priorities -> {args.priorities_out}")
    for r in runs:
        print(f"workflow_run: {r['project']}: {r['jobs']} jobs, wall {r['wall_s']:.0f} s, CPU {r['cpu_s']:.0f} s "
              f"({r['cores_busy']:.0%} of {args.cores} cores); critical path {r['critical_path_s']:.0f} s "
              f"({r['waits_s']:.0f} s waiting for cores):")
        for step in r["critical_path"]:
            print(f"  {step['start_s']:6.0f}-{step['end_s']:6.0f} s  {step['cpu_s']:6.1f} CPU-s  {step['job']}")
        print("  largest: " + ", ".join(f"{x['job']} {x['cpu_s']:.0f}" for x in r["largest"]))
    if args.noop_s:
        print(f"workflow_run: no-op rerun {out['noop_s_median']:.2f} s (median of {len(args.noop_s)})")
    print(f"workflow_run: median wall {out['wall_s_median']:.0f} s of {len(runs)} run(s) -> {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
