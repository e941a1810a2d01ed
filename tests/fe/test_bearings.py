"""The rigid-fit bearing connection and the elimination of the supports (pure numpy)."""
import numpy as np
import pytest
import scipy.sparse as sp

from gimbal_reduction.solver.fe import bearings


def random_region(rng, n=7, bs=6):
    coords = np.column_stack([np.full(n, 3.0), np.linspace(-0.25, 0.25, n), np.zeros(n)])
    nodes = rng.permutation(40)[:n]
    weights = rng.uniform(0.1, 1.0, n)
    return nodes, coords, weights


def rigid_motion(coords, nodes, bs, ndof, u0, w0, origin):
    """DOF vector of the rigid motion u = u0 + w0 x (x - origin), theta = w0."""
    vec = np.zeros(ndof)
    for node, x in zip(nodes, coords):
        vec[node * bs: node * bs + 3] = u0 + np.cross(w0, x - origin)
        if bs == 6:
            vec[node * bs + 3: node * bs + 6] = w0
    return vec


@pytest.mark.parametrize("bs", [3, 6])
def test_rigid_fit_reproduces_rigid_motion(bs):
    rng = np.random.default_rng(1)
    nodes, coords, weights = random_region(rng, bs=bs)
    if bs == 3:  # a solid patch: spread the nodes over a face so rotations are determined
        coords[:, 2] = rng.uniform(-0.3, 0.3, len(nodes))
    ndof = 40 * bs
    point = np.array([3.625, 0.0, 0.0])
    R = bearings.rigid_fit_operator(nodes, coords, weights, point, bs, ndof, 0.25)
    u0, w0 = rng.normal(size=3), rng.normal(size=3)
    motion = R @ rigid_motion(coords, nodes, bs, ndof, u0, w0, point)
    np.testing.assert_allclose(motion, np.concatenate([u0, w0]), atol=1e-12)


def test_rigid_fit_of_a_translation_is_the_weighted_mean():
    rng = np.random.default_rng(2)
    nodes, coords, weights = random_region(rng)
    u = np.zeros(240)
    values = rng.normal(size=len(nodes))
    u[nodes * 6 + 1] = values  # u_y varies along the line: its mean is the fitted u_y
    # line along y through the centroid: the y-translation decouples from the rotations
    expected = np.sum(weights * values) / weights.sum()
    centroid = np.sum(weights[:, None] * coords, axis=0) / weights.sum()
    R = bearings.rigid_fit_operator(nodes, coords, weights, centroid, 6, 240, 0.25)
    assert (R @ u)[1] == pytest.approx(expected, rel=1e-12)


def test_degenerate_region_is_refused():
    with pytest.raises(ValueError, match="empty"):
        bearings.rigid_fit_operator(np.array([], int), np.zeros((0, 3)), np.zeros(0), np.zeros(3), 3, 30, 0.25)
    # collinear nodes with translations only cannot determine the rotation about the line
    coords = np.column_stack([np.zeros(4), np.linspace(0, 1, 4), np.zeros(4)])
    with pytest.raises(ValueError, match="degenerate"):
        bearings.rigid_fit_operator(np.arange(4), coords, np.ones(4), np.zeros(3), 3, 12, 0.25)


def test_admissible_basis_spans_the_constraint_null_space():
    rng = np.random.default_rng(3)
    ndof = 60
    C = sp.csr_matrix(rng.normal(size=(6, ndof)) * (rng.uniform(size=(6, ndof)) < 0.3))
    masters, slaves, S = bearings.admissible_basis(C)
    T = bearings.admissible_basis_matrix(masters, slaves, S, ndof)
    assert T.shape == (ndof, ndof - 6)
    np.testing.assert_allclose((C @ T).toarray(), 0, atol=1e-12)
    assert np.linalg.matrix_rank(T.toarray()) == ndof - 6


def test_dependent_supports_are_refused():
    C = sp.csr_matrix(np.vstack([np.eye(6, 12)[:5], np.eye(6, 12)[4]]))
    with pytest.raises(ValueError, match="dependent"):
        bearings.admissible_basis(C)


def test_support_constraints_pick_the_thesis_components():
    ops = {"input_motor": sp.csr_matrix(np.eye(6, 12)), "input_resolver": sp.csr_matrix(np.eye(6, 12, 6))}
    C = bearings.support_constraints(ops).toarray()
    # motor: u_y, u_z, th_x ; resolver: u_x, u_y, u_z
    assert [int(np.argmax(row)) for row in C] == [1, 2, 3, 6, 7, 8]
