"""What bounds a whole workflow run: its wall time, its jobs' CPU and its critical path.

``python -m gimbal_reduction.results.bench.workflow_run LOG [LOG ...] --project DIR --out F.json``
reads the Snakemake log of each run (``.snakemake/log/*.snakemake.log``) and the rules'
benchmark files it names, and writes, per run:

* ``wall_s``: from the first job's start to the last job's end (the log's second-resolution
  time stamps; the DAG build before the first job is not in it);
* ``cpu_s``: the sum of the jobs' ``cpu_time`` (Snakemake's ``benchmark:``), and ``cores_busy``
  = cpu_s / (cores * wall_s), how full the run kept its cores;
* ``critical_path``: the chain of jobs, from the last one to finish back to a first one, each
  preceded by the input-producing job that finished last: the jobs the run waited on.  Its
  length ``critical_path_s`` (first start to last end along it) is what no number of cores
  shortens; ``waits_s`` is the time on it when none of its jobs ran (another job held the
  cores);
* ``largest``: the jobs of most CPU.

The ``make benchmark-all`` script (``workflow/benchmark-all.sh``) runs clean clones' ``all``
and calls this; the summary is printed and the JSON kept.  Nothing is timed in a test.
"""
from __future__ import annotations

import argparse
import csv
import json
import re
import statistics
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

_STAMP = re.compile(r"^\[(\w{3} \w{3} +\d+ \d\d:\d\d:\d\d \d{4})\]$")
_START = re.compile(r"^(?:local)?rule (\S+):$")
_FINISHED = re.compile(r"^Finished jobid: (\d+)")
_FIELD = re.compile(r"^    (input|output|jobid|benchmark|wildcards): (.*)$")


@dataclass
class Job:
    """One job of a run: rule, start and end [s since the run's first start], files, CPU [s]."""

    jobid: int
    rule: str
    start: float
    end: float | None = None
    inputs: list[str] = field(default_factory=list)
    outputs: list[str] = field(default_factory=list)
    benchmark: str | None = None
    wildcards: str = ""
    cpu_s: float = 0.0

    @property
    def name(self) -> str:
        return f"{self.rule}[{self.wildcards}]" if self.wildcards else self.rule


def parse_log(text: str) -> list[Job]:
    """The jobs of a Snakemake log (start and end in seconds of the log's clock)."""
    jobs, stamp, current = {}, None, None
    for line in text.splitlines():
        m = _STAMP.match(line)
        if m:
            stamp = datetime.strptime(m.group(1), "%a %b %d %H:%M:%S %Y").timestamp()
            current = None
            continue
        m = _START.match(line)
        if m and stamp is not None:
            current = Job(jobid=-1, rule=m.group(1), start=stamp)
            continue
        m = _FIELD.match(line)
        if m and current is not None:
            key, value = m.groups()
            if key == "jobid":
                current.jobid = int(value)
                jobs[current.jobid] = current
            elif key in ("input", "output"):
                getattr(current, key + "s").extend(v.strip() for v in value.split(", "))
            elif key == "benchmark":
                current.benchmark = value.strip()
            else:
                current.wildcards = value.strip()
            continue
        m = _FINISHED.match(line)
        if m and stamp is not None and int(m.group(1)) in jobs:
            jobs[int(m.group(1))].end = stamp
    done = [j for j in jobs.values() if j.end is not None]
    if not done:
        raise ValueError("no finished job in the log")
    t0 = min(j.start for j in done)
    for j in done:
        j.start, j.end = j.start - t0, j.end - t0
    return sorted(done, key=lambda j: (j.start, j.jobid))


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


def read_cpu(job: Job, project: Path) -> float:
    """The job's ``cpu_time`` [s] from its benchmark file (0 without one)."""
    if not job.benchmark:
        return 0.0
    try:
        rows = list(csv.reader((project / job.benchmark).open(), delimiter="\t"))
        return float(dict(zip(rows[0], rows[1])).get("cpu_time") or 0.0)
    except (OSError, IndexError, ValueError):
        return 0.0


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
    parser.add_argument("logs", nargs="+", type=Path, help="Snakemake logs, one per run")
    parser.add_argument("--project", type=Path, action="append", required=True,
                        help="the run's project folder (its benchmark files), once per log")
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    if len(args.project) != len(args.logs):
        parser.error(f"{len(args.logs)} logs but {len(args.project)} --project folders")
    runs = []
    for log, project in zip(args.logs, args.project):
        jobs = parse_log(log.read_text())
        for j in jobs:
            j.cpu_s = read_cpu(j, project)
        runs.append({"log": str(log), **summarise(jobs, args.cores)})
    walls = [r["wall_s"] for r in runs]
    out = {"runs": runs, "wall_s_median": statistics.median(walls), "cores": args.cores}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(args.out.name + ".tmp")
    tmp.write_text(json.dumps(out, indent=1))
    tmp.replace(args.out)
    for r in runs:
        print(f"workflow_run: {r['log']}: {r['jobs']} jobs, wall {r['wall_s']:.0f} s, CPU {r['cpu_s']:.0f} s "
              f"({r['cores_busy']:.0%} of {args.cores} cores); critical path {r['critical_path_s']:.0f} s "
              f"({r['waits_s']:.0f} s waiting for cores):")
        for step in r["critical_path"]:
            print(f"  {step['start_s']:6.0f}-{step['end_s']:6.0f} s  {step['cpu_s']:6.1f} CPU-s  {step['job']}")
        print("  largest: " + ", ".join(f"{x['job']} {x['cpu_s']:.0f}" for x in r["largest"]))
    print(f"workflow_run: median wall {out['wall_s_median']:.0f} s of {len(runs)} run(s) -> {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
