"""results.bench.truth_basis: the comparison of the truth with a larger basis."""
import numpy as np
import pytest

from results.bench import truth_basis
from solver.dynamics import multibody


def sim(rates, angle):
    t = np.linspace(0.0, 0.015, 151)
    return {"t": t, "gamma_dot": np.outer(np.sin(300 * t), rates),
            "platform_attitude": multibody._rotations(2, np.full(t.size, angle))}


def test_compare_gives_eq_3_53_and_the_attitude_angle():
    large = sim([1.0, 1.0, 1.0, 1.0], 0.0)
    truth = sim([1.1, 1.0, 0.9, 1.0], 1e-6)             # E = a^2 per rate
    out = truth_basis.compare(truth, large)
    assert out["E"] == pytest.approx([0.01, 0.0, 0.01, 0.0], abs=1e-14)
    assert out["E_max"] == pytest.approx(0.01)
    assert out["attitude_max_arcsec"] == pytest.approx(1e-6 * 180 * 3600 / np.pi, rel=1e-9)


def test_bad_body_files_fail_in_one_line(tmp_path, capsys):
    rc = truth_basis.main(["--bodies", *[str(tmp_path / f"b{n}.h5") for n in range(4)],
                           "--scenes", "config/scenes/thesis.yaml", "--out", str(tmp_path / "o.json")])
    assert rc == 2 and not (tmp_path / "o.json").exists()
