"""Every finite supported mode by the dense solve (solver.fe.eigen.all_supported_modes).

References: the synthetic rings of tests/synthetic_bodies.py (beam elements, their own dense
solve through the K-inner product), with massless rotations (lumped and shell-like mass: an
oblique massless direction per node), nearly massless ones and none.
"""
import numpy as np
import pytest
import scipy.sparse as sp

from solver.fe import eigen
from tests import synthetic_bodies as sb

RINGS = {
    "shell_like": dict(mass_model="shell_like", connection="rigid_fit", eccentric="rigid_fit"),
    "lumped": dict(mass_model="lumped", connection="rigid_links"),
    "consistent_no_polar": dict(mass_model="consistent_no_polar", connection="rigid_fit"),
    "consistent": dict(mass_model="consistent", connection="rods"),
}


@pytest.fixture(scope="module", params=sorted(RINGS))
def ring(request):
    return sb.ring_body(n_elements=16, **RINGS[request.param])


def test_all_supported_modes_against_the_independent_dense_solve(ring):
    K, M, T = ring["K"], ring["M"], ring["T"]
    values, modes = eigen.all_supported_modes(K, M, T)
    # every finite mode, the same spectrum as the synthetic bodies' own solve
    assert values.shape == ring["eigenvalues"].shape
    np.testing.assert_allclose(values, ring["eigenvalues"], rtol=1e-9)
    assert eigen.relative_residuals(K, M, values, modes, T).max() < 1e-9
    assert eigen.orthonormality_error(M, modes) < 1e-10
    # admissible: in the range of T (the supports hold)
    coords = np.linalg.lstsq(T.toarray(), modes, rcond=None)[0]
    np.testing.assert_allclose(T @ coords, modes, atol=1e-10 * np.abs(modes).max())


def test_massless_split_spans_the_null_space():
    """An oblique massless direction per node (not a coordinate) and a definite rest."""
    rng = np.random.default_rng(3)
    n, blocks = 12, []
    for _ in range(n // 3):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        blocks.append(q @ np.diag([2.0, 0.5, 0.0]) @ q.T)
    m = sp.block_diag(blocks).toarray()
    S, Z = eigen.massless_split(m)
    assert len(S) == 8 and Z.shape == (n, 4)
    assert np.abs(m @ Z).max() < 1e-14
    assert np.linalg.eigvalsh(m[np.ix_(S, S)]).min() > 1e-3
    assert np.linalg.matrix_rank(np.column_stack([np.eye(n)[:, S], Z])) == n
