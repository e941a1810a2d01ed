"""The Snakemake workflow: it parses, plans every stage, and refuses a bad config in one line."""
import subprocess
import sys
from pathlib import Path

import yaml

from tests.robustness.test_dag_names import PROFILE_NOTE

ROOT = Path(__file__).resolve().parents[2]


def snakemake(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def output_lines(run):
    """The lines a run printed, less Snakemake's notes that --configfile extends the default and
    that it reads the workflow's profile (profiles/default)."""
    return [line for line in (run.stdout + run.stderr).splitlines()
            if line.strip() and not line.startswith("Config file config/config.yaml is extended")
            and not line.startswith(PROFILE_NOTE)]


def test_dry_run_plans_all_stages(tmp_path):
    run = snakemake("--dry-run", "all", "--forceall")
    assert run.returncode == 0, run.stderr[-2000:]
    for rule in ("mesh_body", "modes_body", "verify_fe", "mode_shapes_body"):
        assert rule in run.stdout


def test_bad_config_stops_with_one_line(tmp_path):
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    config["bodies"]["inner_gimbal"]["thickness"]["value"] = -0.25
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(config))
    run = snakemake("--dry-run", "all", "--configfile", str(bad))
    assert run.returncode != 0
    # Snakemake may first note that --configfile extends the default; nothing else may be printed
    lines = output_lines(run)
    assert lines == ["config error at 'bodies.inner_gimbal.thickness.value': -0.25 is less than or equal to the "
                     "minimum of 0"], run.stderr[-2000:]


def test_stage_shares_from_benchmark_records(tmp_path):
    from gimbal_reduction.results.bench.summary import stage_of, workflow_benchmark

    header = "s\th:m:s\tmax_rss\n"
    for name, seconds in (("mesh_body2.tsv", 1.0), ("modes_body2.tsv", 3.0), ("sim/thesis/truth.tsv", 6.0)):
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(header + f"{seconds}\t0:00:01\t1\n")
    data = workflow_benchmark(str(tmp_path))
    assert data["stage_seconds"] == {"geometry": 1.0, "modes": 3.0, "simulation": 6.0}
    assert abs(sum(data["stage_share"].values()) - 1) < 1e-12
    assert stage_of("verify_convergence_body5.tsv") == "fe verification"


def _planned_jobs(stdout):
    """{rule: count} from the 'Job stats' table of a dry run."""
    lines = stdout.split("Job stats:")[1].splitlines()
    jobs = {}
    for line in lines[3:]:
        parts = line.split()
        if len(parts) != 2 or parts[0] == "total":
            break
        jobs[parts[0]] = int(parts[1])
    return jobs


def test_one_simulation_plans_only_what_it_needs():
    """Issue 6: the DAG of results/sim/thesis/freq-10.h5 holds no other case, and no
    reduction (a frequency cutoff reads the body files only); one reduced-model job sits
    between the body files and the simulation (issue 12: freq-10 is one of rule plain_models's
    set, all from the body files alone); the kernels are compiled once, first."""
    run = snakemake("--dry-run", "--forceall", "results/sim/thesis/freq-10.h5")
    assert run.returncode == 0, run.stderr[-2000:]
    assert _planned_jobs(run.stdout) == {"mesh_body": 4, "modes_body": 4, "plain_models": 1, "simulate": 1,
                                         "kernels": 1}
    run = snakemake("--dry-run", "--forceall", "results/sim/thesis/global-40.h5")
    assert run.returncode == 0, run.stderr[-2000:]
    assert _planned_jobs(run.stdout) == {"mesh_body": 4, "modes_body": 4, "reduction_body": 4,
                                         "load_ranking": 1, "reduced_model": 1, "simulate": 1, "kernels": 1}


def test_a_scene_target_plans_exactly_its_declared_simulations():
    from gimbal_reduction.solver.dynamics import scenes
    declared = scenes.load_scene("thesis").models
    run = snakemake("--dry-run", "--forceall", "results/sim/thesis/needs.done")
    assert run.returncode == 0, run.stderr[-2000:]
    jobs = _planned_jobs(run.stdout)
    assert jobs["simulate"] == len(declared)
    # the models that read the body files alone come from rule plain_models's one job
    from gimbal_reduction.reduction import names
    plain = [m for m in declared if not (names.needs_reduction_rankings(m) or names.needs_load_ranking(m)
                                         or names.needs_basis_stage(m))]
    assert jobs.get("reduced_model", 0) == len(declared) - len(plain)
    assert jobs.get("plain_models", 0) == (1 if plain else 0)


def _simulate_command(*args, target="results/sim/thesis/freq-10.h5"):
    run = snakemake("--dry-run", "--forceall", "--printshellcmds", target, *args)
    assert run.returncode == 0, run.stderr[-2000:]
    return [line for line in run.stdout.splitlines() if "/gimbal simulate " in line]


def test_the_config_switch_runs_the_simulations_with_rk4(tmp_path):
    """simulation.integrator (issue 13): exponential with its tolerance by default; rk4 (the
    thesis's method) at its default step when switched."""
    (default,) = _simulate_command()
    assert "--integrator exponential --tol 1e-05" in default
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    config["simulation"]["integrator"]["value"] = "rk4"
    rk4 = tmp_path / "rk4.yaml"
    rk4.write_text(yaml.safe_dump(config))
    (switched,) = _simulate_command("--configfile", str(rk4))
    assert "--integrator rk4" in switched and "--tol" not in switched


def test_a_scene_that_states_a_tighter_tolerance_gets_it(tmp_path):
    """config/scenes/long.yaml states exponential_tolerance 5e-7, tighter than the config's
    1e-5: its simulations run at 5e-7; a config tolerance tighter still wins (the tighter of the
    two, common.smk integrator_options)."""
    (long_sim,) = _simulate_command(target="results/sim/long/freq-10.h5")
    assert "--integrator exponential --tol 5e-07" in long_sim
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    config["simulation"]["tolerance"]["value"] = 1e-7
    tight = tmp_path / "tight.yaml"
    tight.write_text(yaml.safe_dump(config))
    (long_sim,) = _simulate_command("--configfile", str(tight), target="results/sim/long/freq-10.h5")
    assert "--tol 1e-07" in long_sim


def test_an_unknown_integrator_in_the_config_stops_with_one_line(tmp_path):
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    config["simulation"]["integrator"]["value"] = "euler"
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(config))
    run = snakemake("--dry-run", "all", "--configfile", str(bad))
    assert run.returncode != 0
    lines = output_lines(run)
    assert len(lines) == 1 and "simulation.integrator" in lines[0] and "euler" in lines[0], lines


def test_duplicate_key_and_bad_unit_stop_the_dag_build(tmp_path):
    """Snakemake's own YAML reading keeps the last duplicate; the DAG build re-reads the file strictly."""
    text = (ROOT / "config" / "config.yaml").read_text()
    line = "  poissons_ratio: {value: 0.3, unit: \"1\", source: \"thesis Table 2.3\"}\n"
    dup = tmp_path / "dup.yaml"
    dup.write_text(text.replace(line, line + line.replace("0.3", "0.33")))
    run = snakemake("--dry-run", "all", "--configfile", str(dup))
    assert run.returncode != 0
    assert output_lines(run) == [f"config error at 'material.poissons_ratio': duplicate key in '{dup}' line 8 "
                                 "(the last value would silently win)"], run.stderr[-2000:]
    config = yaml.safe_load(text)
    config["material"]["density"] = {"value": 2700, "unit": "furlong", "source": "issue 15"}
    bad = tmp_path / "furlong.yaml"
    bad.write_text(yaml.safe_dump(config))
    run = snakemake("--dry-run", "all", "--configfile", str(bad))
    assert run.returncode != 0
    assert output_lines(run) == ["config error at 'material.density': unknown unit 'furlong' (expected a density "
                                 "(mass/volume), e.g. lbf*s^2/in^4)"], run.stderr[-2000:]
