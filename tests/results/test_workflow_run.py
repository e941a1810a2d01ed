"""The whole-run summary read from Snakemake's job records: jobs, CPU, critical path, waiting
(a made-up project folder)."""
import base64
import json
import os

import pytest

from gimbal_reduction.results.bench import workflow_run
from gimbal_reduction.workflow import schedule

T0 = 1_800_000_000.0
# rule, start, end [s after T0], inputs, outputs, benchmark file (or None)
JOBS = [
    ("mesh", 0, 10, [], ["results/mesh.msh"], "mesh.tsv"),
    ("other", 0, 30, [], ["results/other.json"], None),
    ("modes", 30, 60, ["results/mesh.msh", "results/other.json"], ["results/modes.h5", "results/modes.json"],
     "modes.tsv"),
    ("report", 65, 70, ["results/mesh.msh", "results/modes.h5", "config/config.yaml"], ["results/report.pdf"],
     None),
]


def make_project(folder, cpu):
    meta = folder / ".snakemake" / "metadata"
    bench = folder / "results" / "benchmarks"
    meta.mkdir(parents=True)
    bench.mkdir(parents=True)
    for k, (rule, start, end, inputs, outputs, benchmark) in enumerate(JOBS):
        for out in outputs:
            name = base64.b64encode(out.encode()).decode()
            (meta / name).write_text(json.dumps({"rule": rule, "input": inputs, "starttime": T0 + start,
                                                 "endtime": T0 + end, "job_hash": k, "incomplete": False}))
        if benchmark:
            path = bench / benchmark
            path.write_text(f"s\tcpu_time\n{end - start}\t{cpu[rule]}\n")
            os.utime(path, (T0 + end + 0.5, T0 + end + 0.5))     # written as its job ended
    return folder


def test_the_critical_path_follows_the_input_that_ended_last(tmp_path):
    project = make_project(tmp_path, {"mesh": 9.5, "modes": 28.5})
    jobs = workflow_run.read_jobs(project)
    assert [j.rule for j in jobs] == ["mesh", "other", "modes", "report"]
    assert [(j.start, j.end) for j in jobs] == [(0, 10), (0, 30), (30, 60), (65, 70)]
    assert [j.cpu_s for j in jobs] == [9.5, 0.0, 28.5, 0.0]      # matched by end time and length
    chain = workflow_run.critical_path(jobs)
    # report waited on modes (not on mesh, which ended earlier); modes on other (ended at 30 s)
    assert [j.rule for j in chain] == ["other", "modes", "report"]
    out = tmp_path / "summary.json"
    assert workflow_run.main([str(project), "--noop-s", "2.5", "1.5", "1.9", "--out", str(out)]) == 0
    summary = json.loads(out.read_text())
    assert summary["noop_s_median"] == 1.9
    run = summary["runs"][0]
    assert run["wall_s"] == 70 and run["cpu_s"] == 38.0 and run["jobs"] == 4
    assert run["critical_path_s"] == 70 and run["waits_s"] == 5     # 60-65 s: nothing on the path ran
    assert run["cores_busy"] == pytest.approx(38.0 / 140.0, abs=1e-3)


def test_a_benchmark_file_of_no_job_is_left_out_and_an_empty_record_refused(tmp_path):
    project = make_project(tmp_path / "run", {"mesh": 9.5, "modes": 28.5})
    stray = project / "results" / "benchmarks" / "stray.tsv"      # from an earlier run
    stray.write_text("s\tcpu_time\n40\t39\n")
    os.utime(stray, (T0 - 500, T0 - 500))
    assert sum(j.cpu_s for j in workflow_run.read_jobs(project)) == 38.0
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="no finished job"):
        workflow_run.read_jobs(tmp_path / "empty")
    out = tmp_path / "summary.json"           # the command: one line, exit 2, nothing written
    assert workflow_run.main([str(project), str(tmp_path / "empty"), "--out", str(out)]) == 2
    assert not out.exists()


def test_bottom_levels_are_each_jobs_time_to_the_end_along_its_readers(tmp_path):
    """By hand: report 5 s; modes 30 + 5; mesh 10 + max(modes 35, report 5); other 30 + 35.  A
    rule of two jobs keeps the larger level; the priorities are the median over the runs."""
    jobs = workflow_run.read_jobs(make_project(tmp_path / "run", {"mesh": 9.5, "modes": 28.5}))
    assert workflow_run.bottom_levels(jobs) == {"report": 5, "modes": 35, "mesh": 45, "other": 65}
    late = workflow_run.Job("report", 80, 100, inputs=["results/report.pdf"], outputs=["results/b.pdf"])
    assert workflow_run.bottom_levels(jobs + [late])["report"] == 25        # 5 + 20, not 20
    slower = [workflow_run.Job(j.rule, 2 * j.start, 2 * j.end, j.inputs, j.outputs) for j in jobs]
    third = [workflow_run.Job(j.rule, 3 * j.start, 3 * j.end, j.inputs, j.outputs) for j in jobs]
    assert workflow_run.median_priorities([jobs, slower, third]) == \
        {"mesh": 90, "modes": 70, "other": 130, "report": 10}
    out, priorities = tmp_path / "summary.json", tmp_path / "priorities.json"
    assert workflow_run.main([str(tmp_path / "run"), "--out", str(out), "--priorities-out",
                              str(priorities), "--revision", "abc1234"]) == 0
    assert schedule.read_priorities(priorities) == {"mesh": 45, "modes": 35, "other": 65, "report": 5}
    assert json.loads(priorities.read_text())["source"]["revision"] == "abc1234"
