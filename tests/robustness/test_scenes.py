"""Bad scene files given to simulate: refused in one line naming the file and the key before
the model file is read, no simulation file written."""
import pytest

from gimbal_reduction.solver.dynamics import simulate

from .conftest import write_scene

MODEL = ("models", "scene", "xmx-2.h5")

CASES = {
    "interval longer than duration": (dict(output_interval=2e-3), ("output_interval", "longer")),
    "interval not dividing the duration": (dict(output_interval=3e-4), ("output_interval", "divide")),
    "negative duration": (dict(duration=-1e-3), ("duration",)),
    "zero duration": (dict(duration=0.0), ("duration must be > 0 s",)),
    "gimbal rates of 1e5 rad/s": (dict(initial_rates=[1e5, 0.0, 0.0, 0.0]), ("initial_rates", "100000 rad/s",
                                                                             "10000 rad/s")),
    "nan duration": (dict(duration=float("nan")), ("duration",)),
    "zero interval": (dict(output_interval=0.0), ("output_interval",)),
    "negative damping": (dict(damping_ratio=-0.1), ("damping_ratio",)),
    "three angles": (dict(initial_angles=[0.0, 0.0, 0.0]), ("initial_angles",)),
    "unit furlong": (dict(duration={"value": 1e-3, "unit": "furlong"}), ("duration",)),
    "unit of another dimension": (dict(duration={"value": 1e-3, "unit": "in"}), ("duration",)),
    "missing duration": (dict(duration=None), ("duration",)),
    "unknown key": (dict(durration={"value": 1, "unit": "s"}), ("durration",)),
    "name of another scene": (dict(name="thesis"), ("name", "thesis")),
    "needs: bad body": (dict(needs={"bodies": {"value": [1, 2], "unit": "body number"}}), ("needs.bodies",)),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_scene(case, work, refused):
    changes, words = CASES[case]
    scene = write_scene(work / "bad.yaml", **changes)
    refused(simulate.main, ["--scene", scene, "--model-file", work.joinpath(*MODEL),
                            "--out", work / "out" / "s.h5"], ("bad.yaml", *words), work / "out")


def test_case_spin_of_a_million_rad_per_s(work, refused):
    """The case spun at 1e6 rad/s: refused by the scene check naming the key, not by the default
    integrator's step falling to nothing."""
    import yaml
    raw = yaml.safe_load(write_scene(work / "spun.yaml").read_text())
    raw["case_motion"]["initial_angular_velocity"]["value"] = [1e6, 0.0, 0.0]
    scene = write_scene(work / "spun.yaml", case_motion=raw["case_motion"])
    refused(simulate.main, ["--scene", scene, "--model-file", work.joinpath(*MODEL),
                            "--out", work / "out" / "s.h5"],
            ("spun.yaml", "case_motion.initial_angular_velocity", "1e+06 rad/s", "10000 rad/s"), work / "out")


@pytest.mark.parametrize("stem", ["my scene", "szene_\u00fc", "a;b"])
def test_scene_name_outside_the_rule(stem, work, refused):
    """The rule for names, stated once (scenes.NAME_RULE): the CLI refuses what Snakemake refuses,
    with the same message (tests/robustness/test_dag_names.py)."""
    scene = write_scene(work / f"{stem}.yaml")
    refused(simulate.main, ["--scene", scene, "--model-file", work.joinpath(*MODEL),
                            "--out", work / "out" / "s.h5"],
            (f"scene name {stem!r} refused", "ASCII letters, digits"), work / "out")


def test_duplicate_key(work, refused):
    scene = write_scene(work / "dup.yaml")
    scene.write_text(scene.read_text() + "damping_ratio: {value: 0.5, unit: '1'}\n")
    refused(simulate.main, ["--scene", scene, "--model-file", work.joinpath(*MODEL),
                            "--out", work / "out" / "s.h5"], ("damping_ratio", "duplicate"), work / "out")


def test_invalid_yaml(work, refused):
    scene = work / "broken.yaml"
    scene.write_text("duration: {value: 1e-3, unit: s\nname: broken\n")
    refused(simulate.main, ["--scene", scene, "--model-file", work.joinpath(*MODEL),
                            "--out", work / "out" / "s.h5"], ("broken.yaml", "YAML"), work / "out")


def test_unknown_scene_name(work, refused):
    refused(simulate.main, ["--scene", "no_such_scene", "--model-file", work.joinpath(*MODEL),
                            "--out", work / "out" / "s.h5"], ("no_such_scene",), work / "out")


LAUGHS = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{b}: &{b} [{', '.join(['*' + a] * 9)}]\n" for a, b in zip("abcdefgh", "bcdefghi"))


@pytest.mark.parametrize("case", ["billion laughs", "100,000 deep", "900 deep", "not UTF-8", "2 MiB"])
def test_yaml_that_could_hang_or_crash_the_loader(case, work, refused):
    """Refused in one line before libyaml builds anything (no hang, no SIGSEGV, no RecursionError);
    the message names the file and the limit."""
    scene = work / "evil.yaml"
    text, words = {
        "billion laughs": (LAUGHS, ("evil.yaml", "line 2", "alias '*a'")),
        "100,000 deep": ("name: evil\nx: " + "[" * 100_000 + "]" * 100_000 + "\n", ("evil.yaml", "32 deep")),
        "900 deep": ("name: evil\n" + "".join(" " * i + f"k{i}:\n" for i in range(900)) + " " * 900 + "v: 1\n",
                     ("evil.yaml", "32 deep")),
        "not UTF-8": ("name: \udce9vil\n", ("evil.yaml", "not UTF-8")),
        "2 MiB": ("name: evil\n" + "# padding\n" * 210_000, ("evil.yaml", "bytes")),
    }[case]
    scene.write_bytes(text.encode("utf-8", "surrogateescape"))
    refused(simulate.main, ["--scene", scene, "--model-file", work.joinpath(*MODEL),
                            "--out", work / "out" / "s.h5"], words, work / "out")
