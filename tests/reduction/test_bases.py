"""The field's default bases (Craig-Bampton, load-dependent Ritz vectors, dominance) against
independent facts: dense eigenproblems on a null-space basis, direct sparse solves, the static
correction modes of ``static_modes`` and the dominance formula written out with a dense G."""

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse.linalg

from tests import synthetic_bodies as sb

from gimbal_reduction.reduction import bases, models, names
from gimbal_reduction.reduction import static_modes as st
from gimbal_reduction.reduction.errors import MissingBearingError, ReductionError


@pytest.fixture(scope="module", params=["rigid_fit", "rods"])
def ring(request):
    body = sb.ring_body(connection=request.param, mass_model="shell_like", eccentric="rigid_fit",
                        rod_factor=5.0)             # every finite supported mode (dense solve)
    body["number"], body["path"] = 2, f"synthetic ring ({request.param})"
    return body


@pytest.fixture(scope="module")
def stage(ring):
    return bases.craig_bampton_stage(ring, 30)


def dense_fixed_interface(ring):
    """Fixed-interface eigenvalues by a second formulation: a dense null-space basis N of
    C T (T^T K T and T^T M T projected on it), the generalised problem solved in the K inner
    product (massless directions give infinite eigenvalues, left out)."""
    T = ring["T"].toarray()
    CT = np.asarray((bases.output_interface(ring) @ ring["T"]).todense())
    N = T @ scipy.linalg.null_space(CT)
    Kn, Mn = N.T @ (ring["K"] @ N), N.T @ (ring["M"] @ N)
    mu = scipy.linalg.eigh(Mn, Kn, eigvals_only=True)[::-1]           # 1/lambda, descending
    return 1.0 / mu[mu > 1e-12 * mu[0]]


def test_fixed_interface_modes_match_a_dense_null_space_solve(ring, stage):
    lam = stage["fixed_eigenvalues"]
    ref = dense_fixed_interface(ring)[:lam.size]
    assert np.allclose(lam, ref, rtol=1e-8)
    # held: C phi = 0; and the constraint modes move one interface DOF each
    assert stage["held_residual"] < 1e-8
    assert np.allclose(stage["interface"] @ stage["constraint_modes"], np.eye(6), atol=1e-9)
    # interlacing with the supported eigenvalues (six more constraints)
    sup = ring["eigenvalues"]
    assert np.all(lam >= sup[:lam.size] * (1 - 1e-9)) and np.all(lam <= sup[6:6 + lam.size] * (1 + 1e-9))


def test_cb_ritz_values_bound_the_supported_ones_and_converge(ring, stage):
    sup = ring["eigenvalues"]
    previous = None
    for n in (0, 5, 10, 20, 30):
        Y, lam = bases.craig_bampton_basis(ring["M"], ring["K"], stage["constraint_modes"],
                                           stage["fixed_modes"], n)
        assert np.allclose(Y.T @ (ring["M"] @ Y), np.eye(6 + n), atol=1e-10)
        KY = Y.T @ (ring["K"] @ Y)
        assert np.allclose(KY, np.diag(lam), atol=1e-10 * lam.max())
        assert np.all(lam >= sup[:6 + n] * (1 - 1e-10))           # Courant-Fischer: from above
        if previous is not None:     # each Ritz value falls (or stays) as the basis grows
            assert np.all(lam[:previous.size] <= previous * (1 + 1e-10))
        previous = lam
    # with 30 fixed-interface modes the six lowest are within 1 % of the supported ones
    assert np.max(previous[:6] / sup[:6] - 1) < 1e-2


def test_cb0_reproduces_the_static_response_to_interface_loads(ring, stage):
    """cb-0 (the constraint modes alone) against a direct sparse solve of T^T K T."""
    C = stage["interface"]
    F = np.asarray(C.T.todense())                       # unit loads through the six interface DOFs
    T = ring["T"]
    Kt = (T.T @ ring["K"] @ T).tocsc()
    direct = T @ scipy.sparse.linalg.spsolve(Kt, np.asarray(T.T @ F))
    Y, lam = bases.craig_bampton_basis(ring["M"], ring["K"], stage["constraint_modes"],
                                       stage["fixed_modes"], 0)
    reduced = st.reduced_static_response(F, Y, lam)
    assert np.max(np.abs(reduced - direct)) < 1e-9 * np.max(np.abs(direct))
    # a load off the interface (the motor's axial force) is not reproduced by cb-0: the check
    # above can fail
    f_axial = st.load_case_vector(ring["bearing_operator"], "output_motor_fz", ring["bearing_points"])
    u = bases.flexibility(ring)(f_axial)
    assert np.max(np.abs(st.reduced_static_response(f_axial, Y, lam) - u)) > 1e-3 * np.max(np.abs(u))


def _projection_residual(M, V, x):
    """||x - V V^T M x||_M / ||x||_M for M-orthonormal V."""
    r = x - V @ (V.T @ (M @ x))
    return np.sqrt(r @ (M @ r)) / np.sqrt(x @ (M @ x))


@pytest.mark.parametrize("case", [c for c in st.THESIS_LOAD_CASES if c.startswith("output")])
def test_ritz_span_holds_the_static_correction_modes(ring, case):
    Y, lam = bases.ritz_basis(ring, 24)
    M = ring["M"]
    assert np.allclose(Y.T @ (M @ Y), np.eye(24), atol=1e-10)
    assert np.allclose(Y.T @ (ring["K"] @ Y), np.diag(lam), atol=1e-9 * lam.max())
    G = bases.flexibility(ring)
    F = st.load_case_vector(ring["bearing_operator"], case, ring["bearing_points"])
    static = st.static_correction_modes(M, ring["K"], G, F, np.zeros((M.shape[0], 0)), np.zeros(0))
    assert _projection_residual(M, Y, static["modes"][:, 0]) < 1e-8
    # with 8 kept modes the static mode lies in span(kept modes, Ritz vectors) (the low modes are
    # nearly in the Ritz span already, so the joint basis is ill-conditioned: 1e-6)
    kept = np.asarray(ring["modes"])[:, :8]
    with_kept = st.static_correction_modes(M, ring["K"], G, F, kept, ring["eigenvalues"][:8])
    Q, _ = bases.rayleigh_ritz(M, ring["K"], np.hstack([kept, Y]))
    assert _projection_residual(M, Q, with_kept["modes"][:, 0]) < 1e-6
    # and a supported mode high above the Ritz values is not in the span: the check can fail
    assert _projection_residual(M, Y, np.asarray(ring["modes"])[:, -1]) > 0.5


def test_first_six_ritz_vectors_span_the_constraint_modes(ring, stage):
    """The interface loads come first: their static responses are the constraint modes' span
    (K Psi = C^T mu), two constructions of cb-0 that share no code but the flexibility."""
    Y, _ = bases.ritz_basis(ring, 6)
    M = ring["M"]
    for psi in stage["constraint_modes"].T:
        assert _projection_residual(M, Y, psi) < 1e-8
    # a load the interface does not hold (the motor's axial force) is outside that span
    u = bases.flexibility(ring)(np.asarray(bases.free_interface_rows(ring).T.todense())[:, 0])
    assert _projection_residual(M, Y, u) > 1e-3


def test_ritz_deflates_dependent_loads_and_refuses_an_exhausted_sequence(ring):
    M, G = ring["M"], bases.flexibility(ring)
    F, _ = bases.load_vectors(ring)
    twice = np.hstack([F[:, :1], 2.0 * F[:, :1], F[:, 1:2]])      # a repeated direction
    V = bases.load_dependent_ritz(M, G, twice, 4)
    assert np.allclose(V.T @ (M @ V), np.eye(4), atol=1e-10)
    # the second column is the first's multiple: dropped, so V[:, 1] spans G F[:, 1] (block 1)
    u = G(F[:, 1])
    assert _projection_residual(M, V[:, :2], u) < 1e-10
    tiny = sb.grounded_masses([1.0, 2.0], [[0, 0, 0], [1, 0, 0]], [10.0, 30.0])
    with pytest.raises(ReductionError, match="spans only"):
        import gimbal_reduction.reduction.modal_integrals as mi
        G2 = mi.supported_flexibility(tiny["K"], tiny["T"])
        bases.load_dependent_ritz(tiny["M"], G2, np.eye(6)[:, :1], 3)


def test_dominance_matches_the_formula_with_a_dense_flexibility(ring):
    """d_i = ||phi_i^T B^|| ||C^ phi_i|| / Omega_i^2 written out, with G = T (T^T K T)^-1 T^T dense."""
    T = ring["T"].toarray()
    G = T @ np.linalg.solve(T.T @ (ring["K"] @ T), T.T)
    F, _ = bases.load_vectors(ring, transmitted_only=True)
    C = bases.bearing_motion_rows(ring).toarray()
    Phi, lam = np.asarray(ring["modes"]), ring["eigenvalues"]
    expected = []
    b_c = np.array([F[:, j] @ G @ F[:, j] for j in range(F.shape[1])])
    c_c = np.array([C[k] @ G @ C[k] for k in range(C.shape[0])])
    # supported directions: no static response at all (relative to the largest, by far)
    Bh = F[:, b_c > 1e-20 * b_c.max()] / np.sqrt(b_c[b_c > 1e-20 * b_c.max()])
    Ch = C[c_c > 1e-20 * c_c.max()] / np.sqrt(c_c[c_c > 1e-20 * c_c.max()])[:, None]
    for i in range(lam.size):
        expected.append(np.linalg.norm(Phi[:, i] @ Bh) * np.linalg.norm(Ch @ Phi[:, i]) / lam[i])
    scores = bases.body_dominance(ring)
    assert np.allclose(scores, expected, rtol=1e-8)
    # with a mass on every direction (consistent mass, no massless rods: no infinite-frequency
    # modes) the shares
    # over every supported mode add up to the static transfer c^ G b^
    full = sb.ring_body(connection="rigid_fit", mass_model="consistent")
    Tf = full["T"].toarray()
    Gf = Tf @ np.linalg.solve(Tf.T @ (full["K"] @ Tf), Tf.T)
    Ff, Cf = bases.load_vectors(full)[0], bases.bearing_motion_rows(full).toarray()
    assert Ff.shape[1] == 18 and Cf.shape[0] == 6
    Pf, lf = np.asarray(full["modes"]), full["eigenvalues"]
    total = (Cf @ Pf) @ np.diag(1.0 / lf) @ (Pf.T @ Ff)
    assert np.allclose(total, Cf @ Gf @ Ff, rtol=0, atol=1e-8 * np.abs(Cf @ Gf @ Ff).max())
    # unit invariance: loads in other units (moments x 1000) give the same scores
    F2 = F.copy()
    F2[:, 3:6] *= 1000.0
    again = bases.dominance_scores(Phi, lam, F2, bases.bearing_motion_rows(ring), bases.flexibility(ring))
    assert np.allclose(again, scores, rtol=1e-10)


def test_platform_has_no_output_interface():
    platform = sb.ring_body(output_bearings=False, connection="rigid_fit", n_modes=10, body=5)
    platform["number"] = 5
    with pytest.raises(MissingBearingError):
        bases.output_interface(platform)
    F, labels = bases.load_vectors(platform)
    assert labels[0].startswith("input_motor") and F.shape[1] == 18
    assert np.all(np.isfinite(bases.body_dominance(platform)))


def test_stage_file_round_trip_and_a_foreign_body_refused(tmp_path, ring, stage):
    ring = dict(ring, attrs=dict(ring["attrs"], config_hash="abc"))
    path = tmp_path / "cb.h5"
    bases.write_cb_stage(path, stage, ring)
    back = bases.read_cb_stage(path, ring)
    assert np.array_equal(back["fixed_eigenvalues"], stage["fixed_eigenvalues"])
    with pytest.raises(ReductionError, match="another body file"):
        bases.read_cb_stage(path, dict(ring, attrs=dict(ring["attrs"], config_hash="other")))
    with pytest.raises(ReductionError, match="body 2's"):
        bases.read_cb_stage(path, dict(ring, number=3))


def test_model_names_of_the_new_families():
    assert names.parse("cb-10").n_coordinates == 4 * 10 + 18
    assert names.parse("cb-4,4,4,10").n_coordinates == 40          # equal to freq-10
    assert names.parse("ritz-10").n_coordinates == 40
    assert names.parse("dom-10").group == "dom" and names.needs_reduction_rankings("dom-10")
    assert names.needs_basis_stage("cb-3") and not names.needs_basis_stage("ritz-3")
    assert not names.needs_reduction_rankings("cb-3") and not names.needs_reduction_rankings("ritz-3")
    for bad in ("static-cb-5", "ritz-5@2:output_motor_fz"):
        with pytest.raises(names.ModelError, match="takes no static modes"):
            names.parse(bad)
    spec = models.model_spec("cb-5", models.identity_rankings(100))
    assert spec.basis == {2: ("cb", 5), 3: ("cb", 5), 4: ("cb", 5)}
    assert spec.kept[2].size == 0 and list(spec.kept[5]) == [0, 1, 2, 3, 4]
    assert [spec.n_modes(b) for b in (2, 3, 4, 5)] == [11, 11, 11, 5]
    rigid_rings = models.restrict_to_bodies(spec, (5,))
    assert rigid_rings.basis == {} and rigid_rings.n_modes(2) == 0
    with pytest.raises(names.ModelError, match="only 100 computed"):
        models.check_name("cb-101")


def test_a_cb_body_has_orthonormal_coordinates_in_the_chain(ring, stage):
    body = models.build_body(2, ring, [], basis=("cb", 4), cb_stage=stage)
    assert body.n_modes == 10
    Y, lam = bases.craig_bampton_basis(ring["M"], ring["K"], stage["constraint_modes"],
                                       stage["fixed_modes"], 4)
    assert np.allclose(body.omega2, lam, rtol=1e-12)
    ritz = models.build_body(2, ring, [], basis=("ritz", 7))
    assert ritz.n_modes == 7 and list(ritz.labels) == [f"ritz {i}" for i in range(7)]


def test_the_reduction_stage_ranks_by_dominance(ring):
    from gimbal_reduction.reduction import ranking, stage as reduction_stage
    body = {k: v for k, v in ring.items() if not k.startswith("_")}
    result = reduction_stage.reduce_body(body, n_modes=20, static_kept=2)
    scores = bases.body_dominance(ring, np.asarray(ring["modes"])[:, :20], ring["eigenvalues"][:20])
    assert np.allclose(result["score_dominance"], scores, rtol=1e-9)
    assert list(result["rank_dominance"]) == list(ranking.rank_by_radius(result["score_dominance"]))
