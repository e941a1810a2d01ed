"""The whole-run summary read from a Snakemake log: jobs, critical path, waiting (a made-up log)."""
import json

import pytest

from gimbal_reduction.results.bench import workflow_run

LOG = """Building DAG of jobs...
[Sat Nov 28 09:00:00 2026]
localrule mesh:
    output: results/mesh.msh
    jobid: 1
    benchmark: bench/mesh.tsv
    wildcards: n=2
[Sat Nov 28 09:00:00 2026]
localrule other:
    output: results/other.json
    jobid: 2
[Sat Nov 28 09:00:10 2026]
Finished jobid: 1 (Rule: mesh)
[Sat Nov 28 09:00:30 2026]
Finished jobid: 2 (Rule: other)
[Sat Nov 28 09:00:30 2026]
localrule modes:
    input: results/mesh.msh, results/other.json
    output: results/modes.h5
    jobid: 3
    benchmark: bench/modes.tsv
[Sat Nov 28 09:01:00 2026]
Finished jobid: 3 (Rule: modes)
[Sat Nov 28 09:01:05 2026]
localrule report:
    input: results/mesh.msh, results/modes.h5
    output: results/report.pdf
    jobid: 4
[Sat Nov 28 09:01:10 2026]
Finished jobid: 4 (Rule: report)
"""


def test_the_critical_path_follows_the_input_that_ended_last(tmp_path):
    jobs = workflow_run.parse_log(LOG)
    assert [j.name for j in jobs] == ["mesh[n=2]", "other", "modes", "report"]
    assert [(j.start, j.end) for j in jobs] == [(0, 10), (0, 30), (30, 60), (65, 70)]
    chain = workflow_run.critical_path(jobs)
    # report waited on modes (not on mesh, which ended earlier); modes on other (ended at 30 s)
    assert [j.name for j in chain] == ["other", "modes", "report"]
    (tmp_path / "bench").mkdir()
    (tmp_path / "bench" / "modes.tsv").write_text("s\tcpu_time\n30.0\t28.5\n")
    (tmp_path / "bench" / "mesh.tsv").write_text("s\tcpu_time\n10.0\t9.5\n")
    log = tmp_path / "run.log"
    log.write_text(LOG)
    out = tmp_path / "summary.json"
    assert workflow_run.main([str(log), "--project", str(tmp_path), "--out", str(out)]) == 0
    run = json.loads(out.read_text())["runs"][0]
    assert run["wall_s"] == 70 and run["cpu_s"] == 38.0
    assert run["critical_path_s"] == 70 and run["waits_s"] == 5     # 60-65 s: nothing on the path ran
    assert run["cores_busy"] == pytest.approx(38.0 / 140.0, abs=1e-3)


def test_a_log_without_a_finished_job_is_refused():
    with pytest.raises(ValueError, match="no finished job"):
        workflow_run.parse_log(LOG.split("[Sat Nov 28 09:00:10 2026]")[0])
