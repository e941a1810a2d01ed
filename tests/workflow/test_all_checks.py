"""`all` builds every check the reports show, each in its cheap version (results/all/); a report shows the
extended version of `verify` or `bench` where it exists; timing rules run alone (every core of the
run, an exclusive node under slurm)."""
import os
import subprocess
import sys
from pathlib import Path

import pytest
from snakemake.api import SnakemakeApi
from snakemake.iocontainers import Wildcards  # Snakemake 9: no longer in snakemake.io
from snakemake.settings.types import ConfigSettings, OutputSettings, ResourceSettings

ROOT = Path(__file__).resolve().parents[2]
CORES = 4
# the rules whose stages report medians of repeated runs in one process; `all`'s dynamics
# verification times nothing (its untimed runs give E; the truth's times alone are pareto_all's),
# pareto_errors_all and tolerance_untimed_all make the untimed runs of pareto_all and tolerance_all
TIMING_RULES = {"dynamics_verification", "exponential_bench", "pareto", "scaling", "tolerance", "runtime"}
UNTIMED_ALL = {"dynamics_verification_all"}


@pytest.fixture(scope="module")
def workflow():
    with SnakemakeApi(OutputSettings(quiet=True)) as api:
        yield api.workflow(resource_settings=ResourceSettings(cores=CORES), config_settings=ConfigSettings(),
                           snakefile=ROOT / "Snakefile", workdir=ROOT)._workflow


def _shown(workflow):
    g = workflow.globals
    return [*g["REPORT_OPTIONAL"].values(), *g["REPORT_BENCH_FIGURES"], "results/benchmarks/tolerance.json"]


def test_every_check_a_report_shows_is_an_input_of_the_reports_in_alls_version(workflow):
    g = workflow.globals
    inputs = {str(f) for name in ("model_report", "study_report")
              for f in workflow.get_rule(name).input.checks}
    for path in _shown(workflow):
        cheap = g["all_version"](path)
        assert cheap.startswith("results/all/") and cheap.endswith(path[len("results"):])
        assert cheap in inputs, cheap
        makers = [r.name for r in workflow.rules if r.is_producer(cheap)]
        assert makers and all(m.endswith("_all") for m in makers), (cheap, makers)
        # the extended version is made by another rule (verify, bench), not by `all`'s
        assert not any(r.is_producer(path) for r in workflow.rules if r.name in makers)
    report_inputs = {str(f) for f in workflow.get_rule("report").input}
    assert {str(f) for f in workflow.get_rule("all").input} >= report_inputs


def test_a_report_shows_the_extended_version_where_made(workflow, tmp_path, monkeypatch):
    g = workflow.globals
    monkeypatch.chdir(tmp_path)
    before = g["optional_report_inputs"](Wildcards())
    assert "--pareto results/all/benchmarks/pareto.csv" in before
    assert g["extended_report_inputs"](Wildcards()) == []
    (tmp_path / "results" / "benchmarks").mkdir(parents=True)
    (tmp_path / "results" / "benchmarks" / "pareto.csv").write_text("")
    after = g["optional_report_inputs"](Wildcards())
    assert "--pareto results/benchmarks/pareto.csv" in after
    assert "--scaling results/all/benchmarks/scaling.json" in after
    assert g["extended_report_inputs"](Wildcards()) == ["results/benchmarks/pareto.csv"]


def test_timing_rules_take_every_core_and_a_node_of_their_own(workflow):
    """Every job takes at least one core, so a job with all --cores runs alone (Snakemake's
    scheduler); under slurm (no core limit) --exclusive gives it its node."""
    timing = (TIMING_RULES | {f"{r}_all" for r in TIMING_RULES}) - UNTIMED_ALL
    for rule in workflow.rules:
        repeats = "--repeats" in (rule.shellcmd or "")
        if rule.name in timing:
            assert rule.resources["_cores"].value == CORES, rule.name
            assert "--exclusive" in str(rule.resources["slurm_extra"].value), rule.name
        else:
            assert not repeats, f"{rule.name} times repeated runs: add it to the timing rules"
            assert rule.resources["_cores"].value in (1, 2), rule.name     # 2: the MPI check's two ranks


def test_a_dry_run_gives_a_timing_job_every_core():
    run = subprocess.run([sys.executable, "-m", "snakemake", "--cores", str(CORES), "--dry-run", "--nolock", "--forceall",
                          "results/all/benchmarks/scaling.json"], cwd=ROOT, capture_output=True, text=True,
                         timeout=600, env={**os.environ, "PYTHONWARNINGS": "ignore"})
    assert run.returncode == 0, run.stderr[-2000:]
    assert f"threads: {CORES}" in run.stdout and "slurm_extra='--exclusive'" in run.stdout, run.stdout[-2000:]
