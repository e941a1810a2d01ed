"""The rules' scheduling priorities: each rule's measured time to the end of the run.

Snakemake starts, among the jobs that are ready, the set of highest total priority that fits
the free cores (its ILP scheduler; ties broken arbitrarily).  With every priority equal, that
choice is arbitrary, and on a 2-core machine an arbitrary choice costs time: a long job started
last runs alone on one core at the end, or a job that a long chain waits for starts late.  The
classic remedy of list scheduling is to start first the job with the longest chain of work still
behind it: its *bottom level*, its own wall time plus the longest bottom level of the jobs that
read its outputs (highest-level-first; Hu 1961, Adam, Chandy and Dickson 1974).

Here that level is measured, not guessed: ``gimbal_reduction.results.bench.workflow_run
--priorities-out`` computes it from the job records of whole clean runs (``make
benchmark-all``), per job, and keeps per rule the largest over its jobs, the median over the
runs, in whole seconds; ``workflow/priorities.json`` holds the result with its source.  The
Snakefile gives every rule its value (``apply``), 0 to a rule without one (a rule of ``verify``
or ``bench`` only, or a new rule).  A rule whose wildcard values differ a lot in level (the
longest study scene against the others) needs a rule of its own for a priority of its own
(``study_scene_first``, ``load_ranking_first``).

Nothing here changes a result: priorities only order the jobs that are ready.  A simulation
of the measured runs (the same jobs and durations, 2 cores, the timing jobs taking both, ties
broken at random over 40 draws) gave 580 and 590 s with these levels against 595 and 605 s
(medians; 581-641 s over the draws) with the hand-set ones they replaced; the work itself
bounds it at 578 and 588 s.

File contract (JSON): {"priorities": {rule: seconds (int >= 0)}, "source": {...}, "provenance":
{...}}.
"""
from __future__ import annotations

import json
from pathlib import Path


class ScheduleError(ValueError):
    """An unreadable priorities file, named with its problem."""


def read_priorities(path) -> dict[str, int]:
    """{rule: priority} of a priorities file (module docstring); ScheduleError naming the file
    for anything else."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ScheduleError(f"{path}: not a readable priorities file ({exc})") from None
    priorities = data.get("priorities") if isinstance(data, dict) else None
    if not isinstance(priorities, dict):
        raise ScheduleError(f"{path}: no 'priorities' mapping of rule names to seconds")
    for rule, value in priorities.items():
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            raise ScheduleError(f"{path}: priority of rule {rule!r} is {value!r}, not a whole "
                                f"number of seconds >= 0")
    return dict(priorities)


def document(priorities: dict[str, int], source: dict) -> dict:
    """The content of a priorities file (rules sorted by name), to write with its provenance
    (``gimbal_reduction.workflow.provenance.write_json``: this module stays free of it, the
    Snakefile imports it on every invocation)."""
    return {"priorities": dict(sorted(priorities.items())), "source": source}


def apply(rules, priorities: dict[str, int]) -> list[str]:
    """Set each rule's ``priority`` (Snakemake ``Rule`` objects) from ``priorities``, 0 where it
    has none; returns the names in ``priorities`` that are no rule (stale entries)."""
    rules = list(rules)
    for rule in rules:
        rule.priority = priorities.get(rule.name, 0)
    names = {rule.name for rule in rules}
    return sorted(set(priorities) - names)
