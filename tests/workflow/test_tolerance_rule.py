"""The rule `tolerance` (workflow/rules/bench.smk) is part of `bench`, not of `all`, runs
gimbal_reduction.results.bench.tolerance on every study scene and the fast-spinning one for EPS 1e-2 .. 1e-8, and
is shown by the study report where made (else `all`'s version, tolerance_all)."""
from pathlib import Path

import pytest
from snakemake.api import SnakemakeApi
from snakemake.settings.types import ConfigSettings, OutputSettings, ResourceSettings

from gimbal_reduction.results.study.cases import STUDY_SCENES

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def workflow():
    with SnakemakeApi(OutputSettings(quiet=True)) as api:
        yield api.workflow(resource_settings=ResourceSettings(cores=1), config_settings=ConfigSettings(),
                           snakefile=ROOT / "Snakefile", workdir=ROOT)._workflow


def _files(rule):
    return {str(f) for f in rule.input} | {str(f) for f in rule.output}


def test_tolerance_is_in_bench_and_not_in_all(workflow):
    tolerance = workflow.get_rule("tolerance")
    outputs = {str(f) for f in tolerance.output}
    assert {"results/benchmarks/tolerance.csv", "results/benchmarks/tolerance.json",
            "results/figures/bench/tolerance.png"} <= outputs
    assert outputs <= {str(f) for f in workflow.get_rule("bench").input}
    assert not outputs & {str(f) for f in workflow.get_rule("all").input}


def test_tolerance_runs_every_study_scene_and_spin_for_eps_1e2_to_1e8(workflow):
    tolerance = workflow.get_rule("tolerance")
    scenes = [Path(str(f)).stem for f in tolerance.input.scenes]
    assert scenes == [*STUDY_SCENES, "spin"]
    assert [Path(str(f)).stem for f in tolerance.input.load_rankings] == scenes
    assert [float(e) for e in tolerance.params.eps.split()] == [10.0 ** -k for k in range(2, 9)]
    assert "{GIMBAL} tolerance " in tolerance.shellcmd and "{params.eps}" in tolerance.shellcmd


def test_the_study_report_reads_the_tolerance_bench_or_alls_version(workflow):
    """`all` builds its version (rule tolerance_all: results/all/); the report shows the extended
    one instead where it exists (with its date), never builds it."""
    from snakemake.iocontainers import Wildcards  # Snakemake 9: no longer in snakemake.io
    rule = workflow.get_rule("study_report")
    shown = ("results/benchmarks/tolerance.json" if (ROOT / "results/benchmarks/tolerance.json").exists()
             else "results/all/benchmarks/tolerance.json")
    assert f"--tolerance {shown}" in rule.params.optional(Wildcards())
    assert "results/benchmarks/tolerance.json" not in {str(f) for f in rule.input}
    assert "results/all/benchmarks/tolerance.json" in {str(f) for f in rule.input}
    # the scene and model reports do not take it (gimbal_reduction.results.study.report has no such option)
    assert "--tolerance" not in workflow.get_rule("report_scene").shellcmd
    assert "--tolerance" not in workflow.get_rule("model_report").params.optional(Wildcards())
