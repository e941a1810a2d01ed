"""The literate examples of docs/examples run, and their numbers hold against independent references.

docs/examples/one_ring.py (~10 s once the FFCx forms and the Numba kernels are cached): the free
ring's first elastic frequency against the thin-ring formula with its first-order Timoshenko
correction (the tolerance of gimbal_reduction.solver.fe.checks.check_ring_formula), and the conservation of
energy and of the outer-axis momentum in a free 15 ms run of a reduced chain.
"""

import importlib.util
from pathlib import Path

import pytest

from gimbal_reduction.solver.fe import checks

EXAMPLES = Path(__file__).resolve().parent.parent / "docs" / "examples"


def run_example(name):
    """Import (and so run) docs/examples/<name>.py; returns the module."""
    spec = importlib.util.spec_from_file_location(f"docs_examples_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def one_ring():
    return run_example("one_ring")


def test_free_ring_matches_the_thin_ring_formula_with_timoshenko_correction(one_ring):
    """The FE n = 2 frequency deviates from Hoppe's thin-ring formula by the predicted
    shear/rotary-inertia correction, within 0.3 % (and lies within 2 % of the formula):
    the criteria of gimbal_reduction.solver.fe.checks.check_ring_formula."""
    ring = one_ring.FREE_RING
    assert abs(ring["deviation"] - ring["expected_deviation"]) < 0.003
    assert abs(ring["deviation"]) < 0.02
    assert ring["pair_hz"] == pytest.approx(ring["fe_hz"], rel=1e-3)      # the degenerate oval pair
    assert ring["rigid_hz_max"] < 1e-3 * ring["fe_hz"]                    # six rigid motions first


def test_example_formulas_agree_with_the_verification_code(one_ring):
    """The formulas written out in the example are the ones the FE verification uses."""
    ex = one_ring
    for n in (2, 3, 4):
        assert ex.thin_ring_hz(n) == pytest.approx(
            checks.thin_ring_frequency(n, ex.R, ex.t, ex.b, ex.E, ex.rho), rel=1e-14)
    assert ex.expected_deviation == pytest.approx(
        checks.timoshenko_ring_correction(2, ex.t / ex.R, ex.nu, ex.kappa), rel=1e-14)


def test_supported_bodies_and_reduced_model(one_ring):
    for number, freqs in one_ring.SUPPORTED_HZ.items():
        assert len(freqs) == 3 and 0 < freqs[0] <= freqs[1] <= freqs[2], number
    assert one_ring.chain.n_coordinates == 4 + 2 * 4


def test_free_motion_conserves_energy_and_outer_axis_momentum(one_ring):
    """Scene free: case at rest, no torque. T + U and p_1 = (M(y) y')_1 are invariants of the
    equations of motion that the integrator does not impose."""
    assert one_ring.SIMULATION["duration_s"] == pytest.approx(0.015)
    assert one_ring.SIMULATION["samples"] == 1501
    assert one_ring.ENERGY_DRIFT < 1e-10
    assert one_ring.MOMENTUM_DRIFT < 1e-10
