"""The workflow's real body files, for the tests that use them (they skip in a clean clone).

The synthetic bodies and the JAX oracle live in ``gimbal_reduction.results.bench.oracle`` (the
dynamics verification runs them too)."""

import os

import pytest

from gimbal_reduction.reduction import models
from gimbal_reduction.results.bench.verify_dynamics import reduce_and_simulate
from gimbal_reduction.solver.bodydata import BODIES

# The real body files of the workflow (FE and reduction stages), for the tests that use
# them; those tests skip in a clean clone, before `make all` has run.
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REAL_MODES = os.path.join(ROOT, "results", "modes")
REAL_REDUCTION = os.path.join(ROOT, "results", "reduction")
HAVE_REAL_BODIES = all(os.path.exists(os.path.join(d, f"body{b}.h5"))
                       for d in (REAL_MODES, REAL_REDUCTION) for b in models.BODIES)
real_bodies_only = pytest.mark.skipif(not HAVE_REAL_BODIES,
                                      reason="real body files missing (run the workflow)")


def load_real_bodies():
    """(rankings, {body: body-file dict}) of the workflow's real bodies."""
    rankings = models.load_rankings(REAL_REDUCTION)
    data = {b: models.load_body_file(os.path.join(REAL_MODES, f"body{b}.h5")) for b in models.BODIES}
    return rankings, data



def run_model(scene, model, modes_dir, reduction_dir, out_dir, options=(), load_ranking=None):
    """The workflow's two jobs for one simulation, in process: reduce (python -m
    gimbal_reduction.reduction.models, into out_dir/models/SCENE/MODEL.h5), then simulate (python -m
    gimbal_reduction.solver.dynamics.simulate, into out_dir/SCENE/MODEL.h5).  Returns the exit status of the
    first job that fails, or 0."""
    stem = os.path.splitext(os.path.basename(scene))[0]
    return reduce_and_simulate(
        model, scene, {b: os.path.join(modes_dir, f"body{b}.h5") for b in BODIES},
        {b: os.path.join(reduction_dir, f"body{b}.h5") for b in BODIES},
        os.path.join(out_dir, "models", stem, f"{model}.h5"), os.path.join(out_dir, stem, f"{model}.h5"),
        options, load_ranking)
