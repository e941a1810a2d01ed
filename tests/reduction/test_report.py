"""``python -m gimbal_reduction.reduction.report``: ranking table, verification record, benchmark, one-line errors.

Small synthetic bodies (tests/synthetic_bodies.py) go through ``gimbal_reduction.reduction.stage``
and then the report; a ring with every finite supported mode is the coarse body.
"""

import csv
import json
import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

from tests import synthetic_bodies as sb  # noqa: E402

from gimbal_reduction.reduction import report  # noqa: E402
from gimbal_reduction.reduction import stage  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("report")
    ring = sb.ring_body(connection="rigid_fit", mass_model="shell_like", eccentric="rigid_fit",
                        n_elements=24, n_modes=45, body=2)
    plate = sb.ring_body(connection="rigid_fit", mass_model="consistent", output_bearings=False,
                         n_elements=16, n_modes=30, body=5)
    coarse = sb.ring_body(connection="rigid_fit", mass_model="consistent", eccentric="rigid_fit",
                          n_elements=16, n_modes=None, body=4)
    bodies = [sb.write_body_file(folder / "body2.h5", ring),
              sb.write_body_file(folder / "body5.h5", plate)]
    reductions = [folder / "red" / "body2.h5", folder / "red" / "body5.h5"]
    for b, r in zip(bodies, reductions):
        assert stage.main(["--body-file", str(b), "--out", str(r), "--quiet"]) == 0
    coarse_file = sb.write_body_file(folder / "coarse4.h5", coarse)
    out = {"table": folder / "out" / "ranking.csv", "verification": folder / "out" / "reduction.json",
           "benchmark": folder / "out" / "bench.json"}
    return {"folder": folder, "bodies": bodies, "reductions": reductions, "coarse": coarse_file,
            "out": out, "ring": ring, "plate": plate, "coarse_body": coarse}


def argv(inputs, bodies=None, reductions=None, coarse=None, out=None):
    out = out or inputs["out"]
    return (["--bodies", *map(str, bodies or inputs["bodies"]),
             "--reductions", *map(str, reductions or inputs["reductions"]),
             "--coarse-body", str(coarse or inputs["coarse"]),
             "--table", str(out["table"]), "--verification", str(out["verification"]),
             "--benchmark", str(out["benchmark"])])


@pytest.fixture(scope="module")
def written(inputs):
    assert report.main(argv(inputs)) == 0
    out = inputs["out"]
    with open(out["table"], newline="") as f:
        rows = list(csv.DictReader(f))
    return {"rows": rows, "verification": json.loads(out["verification"].read_text()),
            "benchmark": json.loads(out["benchmark"].read_text())}


def test_table_is_table_4_1_with_1_based_mode_numbers(inputs, written):
    rows = written["rows"]
    assert {"body", "rank_1based", "xmx_mode_1based", "xmgmx_mode_1based", "xmx_rho", "xmgmx_rho",
            "same_mode", "top_k_overlap"} <= set(rows[0])
    by_body = {b: [r for r in rows if r["body"] == b] for b in ("body2", "body5")}
    assert len(by_body["body2"]) == 40 and len(by_body["body5"]) == 30  # min(40, modes)
    for label, red in zip(("body2", "body5"), inputs["reductions"]):
        with h5py.File(red, "r") as f:
            a, b = f["rank_xmx"][...], f["rank_xmgmx"][...]
            rho = f["rho_xmx"][...]
        got = by_body[label]
        assert [int(r["rank_1based"]) for r in got] == list(range(1, len(got) + 1))
        np.testing.assert_array_equal([int(r["xmx_mode_1based"]) for r in got], a[:len(got)] + 1)
        np.testing.assert_array_equal([int(r["xmgmx_mode_1based"]) for r in got], b[:len(got)] + 1)
        np.testing.assert_allclose([float(r["xmx_rho"]) for r in got], rho[a[:len(got)]], rtol=1e-5)
        for k, r in enumerate(got, start=1):
            assert int(r["same_mode"]) == int(a[k - 1] == b[k - 1])
            assert int(r["top_k_overlap"]) == len(set(a[:k]) & set(b[:k]))


def test_every_check_is_a_record_and_passes(written):
    v = written["verification"]
    names = [c["name"] for c in v["checks"]]
    for c in v["checks"]:
        assert set(c) == {"name", "value", "tolerance", "passed", "details"}
    failed = [c for c in v["checks"] if not c["passed"]]
    assert failed == [] and v["summary"]["failed"] == []
    assert v["summary"]["n_checks"] == len(names)
    for name in ("hand_checkable_three_masses", "coarse_hughes_mass_identity",
                 "coarse_hughes_flexibility_identity",
                 "static_completeness/body2/output_motor_fz",
                 "static_completeness/body5/input_motor_fx",  # platform: no output bearings
                 "static_mass_orthogonality/body2", "static_stiffness_orthogonality/body5",
                 "ranking_invariance/body2/sign_flips", "ranking_invariance/body2/dof_renumbering",
                 "ranking_invariance/body2/density_scaling", "static_modal_mass_conditioning/body5"):
        assert name in names, name


def test_coarse_identities_and_static_checks_values(written):
    checks = {c["name"]: c for c in written["verification"]["checks"]}
    for name in ("coarse_hughes_mass_identity", "coarse_hughes_flexibility_identity"):
        assert checks[name]["tolerance"] == 1e-8 and checks[name]["value"] < 1e-8
        assert checks[name]["details"]["modes_missing"] == 0
        assert abs(checks[name]["details"]["xmx_radii_sum_minus_6"]) < 1e-8
    full = checks["static_completeness/body2/output_motor_fz"]
    assert full["tolerance"] == 1e-10 and full["value"] < 1e-10
    assert full["details"]["kept_modes_0based"] == list(range(10))
    short = checks["static_shortfall_without_static_mode/body2/output_motor_fz"]
    assert short["tolerance"] is None and short["value"] > 1e3 * full["value"]
    assert checks["static_mass_orthogonality/body2"]["value"] < 1e-10
    cond = checks["static_modal_mass_conditioning/body2"]["details"]
    assert cond["static_set_mass_gram_condition"] >= 1.0
    assert abs(cond["kept_plus_default_static_modal_mass_condition"] - 1.0) < 1e-8
    assert checks["hand_checkable_three_masses"]["value"] < 1e-12


def test_per_body_summaries(inputs, written):
    bodies = written["verification"]["bodies"]
    assert set(bodies) == {"body2", "body5"}
    ring = bodies["body2"]
    with h5py.File(inputs["reductions"][0], "r") as f:
        a = f["rank_xmx"][...]
        shares = f["captured_share/xmx/mass_trace"][...]
    assert [m["mode_1based"] for m in ring["top10"]["xmx"]] == list(a[:10] + 1)
    assert len(ring["top10"]["xmgmx"]) == 10
    for ranking in ("frequency", "xmx", "xmgmx"):
        assert set(ring["captured_share"][ranking]) == {"5", "10", "25"}
    assert ring["captured_share"]["xmx"]["10"]["mass_trace"] == pytest.approx(shares[9], rel=1e-10)
    agreement = ring["ranking_agreement"]
    assert agreement["top_k"][:2] == [5, 10] and len(agreement["top_k_overlap"]) == len(agreement["top_k"])
    assert -1.0 <= agreement["spearman_rho_all_modes"] <= 1.0
    assert agreement["thesis_code_emulation_first_difference"] >= 0
    assert set(agreement["dominant_direction"]) == {"xmx", "xmgmx"}
    assert bodies["body5"]["static_modes"]["skipped_load_cases"] == [
        "output_motor_fz", "output_motor_fx", "output_motor_my", "output_motor_mz"]


def test_benchmark_has_medians_and_versions(written):
    bench = written["benchmark"]
    assert set(bench["bodies"]) == {"body2", "body5"}
    for entry in bench["bodies"].values():
        assert len(entry["runs_s"]) == 3
        assert entry["median_s"] == pytest.approx(float(np.median(entry["runs_s"])))
    assert bench["bodies"]["body2"]["n_load_cases"] == 7
    assert bench["bodies"]["body5"]["n_load_cases"] == 3
    assert bench["total_median_s"] == pytest.approx(
        sum(e["median_s"] for e in bench["bodies"].values()))
    assert bench["passed"] and bench["target_total_s"] == 30.0
    assert "numpy" in bench["versions"] and "git" in bench["versions"]


def one_line_error(inputs, capsys, tmp_path, **kwargs):
    out = {k: tmp_path / v.name for k, v in inputs["out"].items()}
    assert report.main(argv(inputs, out=out, **kwargs)) == 2
    err = capsys.readouterr().err
    assert err.startswith("gimbal_reduction.reduction.report: error: ") and err.count("\n") == 1
    assert not any(p.exists() for p in out.values())  # nothing written
    return err


def test_missing_reduction_file(inputs, capsys, tmp_path):
    missing = tmp_path / "nothere.h5"
    err = one_line_error(inputs, capsys, tmp_path, reductions=[inputs["reductions"][0], missing])
    assert str(missing) in err and "not found" in err


def test_missing_body_and_coarse_file(inputs, capsys, tmp_path):
    err = one_line_error(inputs, capsys, tmp_path, coarse=tmp_path / "coarse.h5")
    assert "coarse.h5" in err
    err = one_line_error(inputs, capsys, tmp_path, bodies=[inputs["bodies"][0], tmp_path / "b5.h5"])
    assert "b5.h5" in err


def test_corrupt_reduction_file(inputs, capsys, tmp_path):
    bad = tmp_path / "corrupt.h5"
    bad.write_bytes(inputs["reductions"][0].read_bytes()[:3000])
    err = one_line_error(inputs, capsys, tmp_path, reductions=[bad, inputs["reductions"][1]])
    assert str(bad) in err


def test_reduction_missing_a_dataset_names_it(inputs, capsys, tmp_path):
    bad = tmp_path / "partial.h5"
    bad.write_bytes(inputs["reductions"][0].read_bytes())
    with h5py.File(bad, "a") as f:
        del f["rho_xmgmx"]
    err = one_line_error(inputs, capsys, tmp_path, reductions=[bad, inputs["reductions"][1]])
    assert str(bad) in err and "rho_xmgmx" in err


def test_stale_reduction_of_changed_modes(inputs, capsys, tmp_path):
    changed = dict(inputs["ring"])
    changed["eigenvalues"] = inputs["ring"]["eigenvalues"] * (1 + 1e-6)
    changed["frequencies_hz"] = np.sqrt(changed["eigenvalues"]) / (2 * np.pi)
    body = sb.write_body_file(tmp_path / "body2.h5", changed)
    err = one_line_error(inputs, capsys, tmp_path, bodies=[body, inputs["bodies"][1]])
    assert "stale" in err and str(inputs["reductions"][0]) in err


def test_stale_config_hash_and_wrong_body(inputs, capsys, tmp_path):
    changed = dict(inputs["ring"])
    changed["attrs"] = {**inputs["ring"]["attrs"], "config_hash": "other"}
    body = sb.write_body_file(tmp_path / "body2.h5", changed)
    err = one_line_error(inputs, capsys, tmp_path, bodies=[body, inputs["bodies"][1]])
    assert "config_hash" in err and str(inputs["reductions"][0]) in err
    err = one_line_error(inputs, capsys, tmp_path,
                         reductions=[inputs["reductions"][0], inputs["reductions"][0]])
    assert "second reduction of body 2" in err


def test_coarse_body_without_all_modes(inputs, capsys, tmp_path):
    err = one_line_error(inputs, capsys, tmp_path, coarse=inputs["bodies"][0])
    assert "--all-modes" in err and str(inputs["bodies"][0]) in err


def test_unequal_lists(inputs, capsys, tmp_path):
    err = one_line_error(inputs, capsys, tmp_path, reductions=[inputs["reductions"][0]])
    assert "--reductions" in err


def test_command_line_module(inputs, tmp_path):
    out = {k: tmp_path / v.name for k, v in inputs["out"].items()}
    proc = subprocess.run([sys.executable, "-m", "gimbal_reduction.reduction.report", *argv(inputs, out=out)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "checks passed" in proc.stdout and all(p.exists() for p in out.values())
    bad = subprocess.run([sys.executable, "-m", "gimbal_reduction.reduction.report",
                          *argv(inputs, coarse=tmp_path / "none.h5", out=out)],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "none.h5" in bad.stderr
