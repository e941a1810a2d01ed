"""The on-request outputs of workflow/rules/outputs.smk: the control-design export and the ParaView
series plan exactly what they need (dry runs), are not part of `all`, and a bad model name in
their target stops the DAG build in one line."""
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def snakemake(*args):
    return subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", "--dry-run", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


def planned_jobs(stdout):
    """{rule: count} from the 'Job stats' table of a dry run."""
    jobs = {}
    for line in stdout.split("Job stats:")[1].splitlines()[3:]:
        parts = line.split()
        if len(parts) != 2 or parts[0] == "total":
            break
        jobs[parts[0]] = int(parts[1])
    return jobs


def test_export_target_plans_the_model_and_its_export():
    run = snakemake("--forceall", "--printshellcmds", "results/export/thesis/freq-10.mat")
    assert run.returncode == 0, run.stderr[-2000:]
    assert planned_jobs(run.stdout) == {"mesh_body": 4, "modes_body": 4, "plain_models": 1, "control_export": 1}
    # the rule's command is the CLI's, with the config check, writing the .mat and the .npz
    assert "/gimbal export --model-file results/models/thesis/freq-10.h5" in run.stdout
    assert "--out results/export/thesis/freq-10.mat" in run.stdout and "--config" in run.stdout
    assert "results/export/thesis/freq-10.npz" in run.stdout


def test_paraview_target_plans_a_simulation_with_modal_coordinates():
    run = snakemake("--forceall", "--printshellcmds", "results/paraview/thesis/freq-10.pvd")
    assert run.returncode == 0, run.stderr[-2000:]
    assert planned_jobs(run.stdout) == {"mesh_body": 4, "modes_body": 4, "plain_models": 1, "kernels": 1,
                                        "simulate_modal": 1, "paraview": 1}
    assert "--store-modal" in run.stdout and "results/sim_modal/thesis/freq-10.h5" in run.stdout


def test_bad_model_name_stops_in_one_line():
    run = snakemake("results/export/thesis/nonsense-3.mat")
    assert run.returncode != 0
    text = run.stdout + run.stderr
    # besides Snakemake's own banner (its command line) and progress lines: one line, naming the target
    named = [ln for ln in text.splitlines() if "nonsense-3" in ln and not ln.strip().startswith("Command:")]
    assert named == [named[0]] and named[0].startswith("results/export/thesis/nonsense-3.mat: unknown model")
    assert "Traceback" not in text and "Exception" not in text


def test_not_part_of_all():
    run = snakemake("--forceall", "all")
    assert run.returncode == 0, run.stderr[-2000:]
    jobs = planned_jobs(run.stdout)
    assert not {"control_export", "simulate_modal", "paraview"} & set(jobs)
