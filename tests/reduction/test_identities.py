"""Discrete Hughes identities on small models with every supported mode computed.

sum_i Mbar_i = M_inf and sum_i Mbar_i / Omega_i^2 = MGM_inf (thesis eqs 3.32,
3.46) to 1e-8, for constrained-DOF supports (selection T) and multi-point T
(rigid links, rigid-fit bearing connections, a fully dense T), with a
consistent, a lumped (every rotation massless) and a shell-like (massless
drilling rotation in an oblique direction) mass matrix.
"""

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp

from tests import synthetic_bodies as sb  # noqa: E402

from gimbal_reduction.reduction import modal_integrals as mi  # noqa: E402
from gimbal_reduction.reduction import verification as vf  # noqa: E402
from gimbal_reduction.solver.bodydata import rigid_modes


def integrals(body):
    M, K, T, X = body["M"], body["K"], body["T"], body["rigid_modes"]
    P, H = mi.momentum_coefficients(M, X, body["modes"])
    M_inf, details = mi.supported_rigid_mass(M, T, X, mi.node_index(body["dof_coords"]),
                                             return_details=True)
    MGM_inf = mi.flexibility_matrix(M, X, mi.supported_flexibility(K, T, X))
    return P, H, M_inf, MGM_inf, details


CASES = [(c, m, e) for c in ("rods", "rigid_links", "rigid_fit")
         for m in ("consistent", "lumped", "shell_like", "consistent_no_polar")
         for e in ("node", "rigid_fit")]


@pytest.mark.parametrize("connection,mass_model,eccentric", CASES)
def test_hughes_identities(connection, mass_model, eccentric):
    body = sb.ring_body(connection=connection, mass_model=mass_model, eccentric=eccentric)
    P, H, M_inf, MGM_inf, details = integrals(body)
    mass = vf.check_hughes_mass_identity(P, H, M_inf)
    flex = vf.check_hughes_flexibility_identity(P, H, body["eigenvalues"], MGM_inf)
    assert mass["passed"], mass
    assert flex["passed"], flex
    assert details["relative_residual"] < 1e-9 and details["last_change"] < 1e-14


def test_rigid_modes_are_stress_free_and_match_layout():
    body = sb.ring_body()
    X = rigid_modes(body["dof_coords"], body["dof_component"])
    np.testing.assert_allclose(X, sb.rigid_basis(body["dof_coords"], body["dof_component"]))
    K = body["K"]
    assert np.max(np.abs(K @ X)) < 1e-12 * abs(K).max() * np.max(np.abs(X))


def test_dense_multipoint_T():
    """T = an orthonormal basis of null(C) with every column touching every DOF."""
    body = sb.ring_body(connection="rigid_fit", mass_model="consistent", n_elements=16)
    C = sp.vstack([body["bearing_operator"][[1, 2, 3]],
                   body["bearing_operator"][[6, 7, 8]]]).toarray()
    T = sp.csr_matrix(scipy.linalg.null_space(C))
    lam, modes = sb.supported_modes(body["K"], body["M"], T)
    dense = dict(body, T=T, modes=modes, eigenvalues=lam)
    P, H, M_inf, MGM_inf, _ = integrals(dense)
    assert vf.check_hughes_mass_identity(P, H, M_inf)["passed"]
    assert vf.check_hughes_flexibility_identity(P, H, lam, MGM_inf)["passed"]
    # the same admissible space as the sparse T: same M_inf and MGM_inf
    _, _, M_inf_sparse, MGM_sparse, _ = integrals(body)
    np.testing.assert_allclose(M_inf, M_inf_sparse, rtol=1e-10, atol=1e-12 * np.abs(M_inf).max())
    np.testing.assert_allclose(MGM_inf, MGM_sparse, rtol=1e-8, atol=1e-10 * np.abs(MGM_inf).max())


def test_singular_mass_null_space_is_found():
    """Shell-like mass: one massless (radial) rotation per ring node, oblique in x-z."""
    body = sb.ring_body(connection="rigid_links", mass_model="shell_like", eccentric="node")
    T = body["T"]
    Mt = (T.T @ body["M"] @ T).toarray()
    w = np.linalg.eigvalsh(Mt)
    nullity = int(np.sum(w <= 1e-12 * w[-1]))
    assert nullity > 0
    groups = mi.supported_column_groups(T, mi.node_index(body["dof_coords"]))
    N = mi.massless_directions(sp.csr_matrix(Mt), groups)
    assert N.shape[1] == nullity
    assert np.max(np.abs(Mt @ N.toarray())) < 1e-14 * w[-1]
    np.testing.assert_allclose((N.T @ N).toarray(), np.eye(nullity), atol=1e-12)
    # the finite modes number rank(T^T M T)
    assert body["modes"].shape[1] == T.shape[1] - nullity


def test_non_local_massless_directions_use_refinement():
    """A point mass on a rigid-fit region ties drilling rotations of three nodes together."""
    body = sb.ring_body(connection="rigid_fit", mass_model="shell_like", eccentric="rigid_fit")
    T = body["T"]
    Mt = (T.T @ body["M"] @ T).toarray()
    w = np.linalg.eigvalsh(Mt)
    nullity = int(np.sum(w <= 1e-12 * w[-1]))
    P, H, M_inf, MGM_inf, details = integrals(body)
    assert details["n_massless_local"] < nullity  # some null vectors are not node-local
    assert vf.check_hughes_mass_identity(P, H, M_inf)["value"] < 1e-10


def test_M_inf_with_lumped_mass_and_selected_dofs_is_free_dof_rigid_mass():
    """T selecting DOFs, lumped mass: M_inf = X_f^T M_ff X_f; consistent mass: coupling enters."""
    n = 16
    ang = 2 * np.pi * np.arange(n) / n
    nodes = np.c_[3.0 * np.cos(ang), np.zeros(n), 3.0 * np.sin(ang)]
    sec = sb.rect_section(0.5, 0.25)
    elements = [(k, (k + 1) % n, *sb.beam_element(nodes[k], nodes[(k + 1) % n], sec))
                for k in range(n)]
    K, M_consistent = sb.assemble(n, elements)
    coords, comp = sb.node_dofs(nodes)
    X = sb.rigid_basis(coords, comp)
    # supports directly on massive ring nodes 0 and n/2 (no rods)
    constrained = [1, 2, 3, 6 * (n // 2), 6 * (n // 2) + 1, 6 * (n // 2) + 2]
    T = sb.selection_basis(6 * n, constrained)
    free = np.setdiff1d(np.arange(6 * n), constrained)
    lumped = sp.diags(np.where(comp < 3, 0.01, 1e-4)).tocsr()
    for M in (lumped, M_consistent):
        lam, modes = sb.supported_modes(K, M, T)
        P, H = mi.momentum_coefficients(M, X, modes)
        M_inf = mi.supported_rigid_mass(M, T, X, mi.node_index(coords))
        assert vf.check_hughes_mass_identity(P, H, M_inf)["value"] < 1e-9
        free_part = X[free].T @ (M[free][:, free] @ X[free])
        defect = np.max(np.abs(M_inf - free_part)) / np.max(np.abs(M_inf))
        if M is lumped:
            assert defect < 1e-12
        else:
            assert defect > 1e-6  # M_fc X_c couples in: the free-DOF block is not the identity's sum
        # the supports hold a positive semidefinite part of the rigid mass
        held = mi.rigid_mass(M, X) - M_inf
        assert np.linalg.eigvalsh(held)[0] > -1e-12 * np.abs(M_inf).max()


def test_partial_sums_are_below_the_identity():
    """With the 20 lowest modes only, S (sum Mbar) S <= I (Loewner): a share, not an excess."""
    body = sb.ring_body(connection="rigid_fit", mass_model="consistent")
    P, H, M_inf, MGM_inf, _ = integrals(body)
    S = np.linalg.inv(scipy.linalg.sqrtm(M_inf)).real
    C = np.einsum("ai,bi->ab", np.r_[P, H][:, :20], np.r_[P, H][:, :20])
    w = np.linalg.eigvalsh(S @ C @ S)
    assert w.max() <= 1 + 1e-10 and w.min() >= -1e-12
