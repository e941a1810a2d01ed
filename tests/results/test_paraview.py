"""ParaView outputs: the mode-shape VTU carries its frequencies (gimbal_reduction.results.study.mode_shapes), the
deformed bodies over time (gimbal_reduction.results.paraview: PVD + VTU frames) and the headless renderer
(gimbal_reduction.results.render), on small synthetic bodies.

The frame test recomputes every body's pose from the joint table of docs/dynamics.md written out
here (rho, C_1, C, Rx, and E = Rx Ry Rz of Theta q), and the displacement from the body file's
node-major DOF rows, independently of the code under test."""
import json
import re

import h5py
import matplotlib.image as mpimg
import meshio
import numpy as np
import pytest

from gimbal_reduction.reduction import models
from gimbal_reduction.reduction.static_modes import DEFAULT_LOAD_CASE
from gimbal_reduction.results import paraview, render, vtk
from gimbal_reduction.results.study import mode_shapes
from gimbal_reduction.solver.dynamics import chainfile
from gimbal_reduction.solver.dynamics.synthetic import synthetic_modal_chain
from tests import synthetic_bodies as sb

N_MODES = 3
BODIES = (2, 3, 4, 5)
RHO = np.array([0.0, 0.0, -3.375])
C1 = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])     # x_2 = Z, y_2 = X, z_2 = Y
C = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])      # x' = z, y' = y, z' = -x


def rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


# ------------------------------------------------------------------ synthetic inputs
def ring_mesh(radius, n=24, width=0.4):
    """A shell ring in the local x-z plane (axis y): 2 n triangles."""
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    pts = np.array([[radius * np.cos(q), y, radius * np.sin(q)] for y in (-width / 2, width / 2) for q in a])
    tris = [c for i in range(n) for c in ([i, (i + 1) % n, n + i], [(i + 1) % n, n + (i + 1) % n, n + i])]
    return pts, [("triangle", np.array(tris))]


def cube_mesh(h=0.8):
    """A solid box of six tetrahedra (every vertex on the surface)."""
    pts = np.array([[x, y, z] for x in (-h, h) for y in (-h / 2, h / 2) for z in (-h, h)])
    tets = np.array([[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]])
    return pts, [("tetra", tets)]


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """Meshes, body files (6 DOFs per node, node-major), a reduced-model file of a synthetic
    chain and its simulation with modal coordinates (50 samples)."""
    tmp = tmp_path_factory.mktemp("pv")
    rng = np.random.default_rng(7)
    chain = synthetic_modal_chain(N_MODES, seed=2)
    meshes, bodies, phis, points = [], [], {}, {}
    for b, (pts, cells) in zip(BODIES, [ring_mesh(3.375), ring_mesh(2.875), ring_mesh(2.375), cube_mesh()]):
        mesh = tmp / f"body{b}.msh"
        meshio.write(mesh, meshio.Mesh(pts, cells), file_format="gmsh22", binary=False)
        phi = rng.normal(size=(6 * len(pts), 5))            # 5 modes in the file, 3 kept
        body = tmp / f"body{b}.h5"
        with h5py.File(body, "w") as f:
            f["modes"], f["dof_coords"] = phi, np.repeat(pts, 6, axis=0)
            f["dof_component"] = np.tile(np.arange(6), len(pts))
            f["frequencies_hz"] = 1000.0 * np.arange(1, 6)
            f.attrs["body"], f.attrs["config_hash"] = b, f"hash{b}"
        meshes.append(str(mesh))
        bodies.append(str(body))
        phis[b], points[b] = phi[:, [0, 2, 4]], pts
    model = tmp / "model.h5"
    chainfile.write_chain(model, chain, {b: np.array([0, 2, 4]) for b in BODIES}, {b: () for b in BODIES},
                          {"model": "synthetic", "scene": "thesis", "config_hash": "m1",
                           "body_config_hashes": json.dumps([f"hash{b}" for b in BODIES])})
    T = 50
    t = np.linspace(0.0, 0.01, T)
    gamma = np.array([0.0, -np.pi / 2, 0.0, 0.0]) + 0.2 * rng.normal(size=(T, 4))
    q = 0.02 * rng.normal(size=(T, 4 * N_MODES))
    sim = tmp / "sim.h5"
    write_sim(sim, t, gamma, q)
    return {"tmp": tmp, "chain": chain, "meshes": meshes, "bodies": bodies, "model": str(model),
            "sim": str(sim), "phis": phis, "points": points, "t": t, "gamma": gamma, "q": q}


def write_sim(path, t, gamma, q, modal=True, model="synthetic", n_modes=(N_MODES,) * 4, model_hash="m1"):
    with h5py.File(path, "w") as f:
        f["t"], f["gamma"], f["gamma_dot"] = t, gamma, np.zeros_like(gamma)
        if modal:
            f["q"], f["q_dot"] = q, np.zeros_like(q)
        f.attrs["model"], f.attrs["scene"], f.attrs["model_config_hash"] = model, "thesis", model_hash
        f.attrs["n_modes"] = np.array(n_modes)
    return str(path)


def run(inputs, out, *options, sim=None):
    return paraview.main(["--sim", sim or inputs["sim"], "--model-file", inputs["model"], "--bodies",
                          *inputs["bodies"], "--meshes", *inputs["meshes"], "--out", str(out), *options])


def expected_poses(chain, gamma, q):
    """[(o_n, A_n)] of bodies 2..5 by the joint table of docs/dynamics.md."""
    o, A = RHO.copy(), C1 @ rx(gamma[0])
    poses = [(o, A)]
    for j in range(1, 4):
        parent = chain.bodies[j - 1]
        qp = q[(j - 1) * N_MODES:j * N_MODES]
        th = parent.inside_rotation @ qp
        o = o + A @ (parent.inside_translation @ qp)
        A = A @ (rx(th[0]) @ ry(th[1]) @ rz(th[2])) @ C @ rx(gamma[j])
        poses.append((o, A))
    return poses


def body_blocks(mesh):
    ids = mesh.point_data["body_id"]
    return {b: np.flatnonzero(ids == b) for b in BODIES}


# ------------------------------------------------------------------ mode-shape VTU
def test_mode_shape_vtu_carries_the_body_files_frequencies(tmp_path):
    """The VTU read back holds the frequencies as FieldData, exactly the body file's, and each
    mode's array is named with its number and frequency."""
    pts, cells = ring_mesh(1.0, n=16)
    meshio.write(tmp_path / "ring.msh", meshio.Mesh(pts, cells), file_format="gmsh22", binary=False)
    freqs = np.array([123.456789, 2345.5, 10999.94])
    rng = np.random.default_rng(1)
    body = tmp_path / "body2.h5"
    with h5py.File(body, "w") as f:
        f["modes"], f["dof_coords"] = rng.normal(size=(6 * len(pts), 3)), np.repeat(pts, 6, axis=0)
        f["dof_component"], f["frequencies_hz"] = np.tile(np.arange(6), len(pts)), freqs
        f["bearing_points"] = [[1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1]]
        f.attrs["name"], f.attrs["body"] = "outer_gimbal", 2
        f.attrs["config_hash"] = sb.project_body_hash(2)     # made from the configuration in use
    vtu = tmp_path / "shapes" / "body2.vtu"
    assert mode_shapes.main(["--body-file", str(body), "--mesh", str(tmp_path / "ring.msh"), "--png",
                             str(tmp_path / "m.png"), "--vtu", str(vtu), "--lowest", "1"]) == 0
    back = meshio.read(vtu)
    with h5py.File(body, "r") as f:
        stored = f["frequencies_hz"][()]
    assert np.array_equal(back.field_data["frequencies_hz"], stored)
    assert list(back.field_data["mode_number"]) == [1, 2, 3]
    names = sorted(k for k in back.point_data if k.startswith("mode_"))
    assert names == ["mode_001_123.5Hz", "mode_002_2345.5Hz", "mode_003_10999.9Hz"]
    parsed = [float(re.fullmatch(r"mode_\d{3}_([0-9.]+)Hz", n).group(1)) for n in names]
    assert np.allclose(parsed, stored, atol=0.05)
    text = vtu.read_text()
    assert "<FieldData>" in text and 'Name="frequencies_hz"' in text and "inches" in text


# ------------------------------------------------------------------ time series
def test_frame_selection_and_collection(inputs, tmp_path):
    out = tmp_path / "a" / "sim.pvd"
    assert run(inputs, out, "--frames", "7") == 0
    frames = vtk.read_pvd(out)
    expected = np.round(np.linspace(0, 49, 7)).astype(int)
    assert [t for t, _ in frames] == pytest.approx(inputs["t"][expected].tolist(), abs=0)
    assert sorted(p.name for p in (tmp_path / "a" / "sim_frames").iterdir()) == [f"frame_{i:04d}.vtu" for i in range(7)]
    fd = vtk.read_field_data(frames[3][1])
    assert fd["sample_index"][0] == expected[3] and fd["TimeValue"][0] == inputs["t"][expected[3]]
    assert np.array_equal(fd["gamma [rad]"], inputs["gamma"][expected[3]]) and fd["displacement_scale"][0] == 1.0
    assert "inches" in out.read_text() and "inches" in open(frames[0][1]).read()
    out2 = tmp_path / "b" / "sim.pvd"
    assert run(inputs, out2, "--every", "10") == 0
    assert [t for t, _ in vtk.read_pvd(out2)] == pytest.approx(inputs["t"][[0, 10, 20, 30, 40, 49]].tolist(), abs=0)
    assert paraview.frame_indices(50).size == 50 and paraview.frame_indices(1501).size == paraview.DEFAULT_FRAMES


@pytest.mark.parametrize("scale", [1.0, 3.0])
def test_points_and_displacement_by_formula(inputs, tmp_path, scale):
    """At a frame, every body's points are o_n + A_n (X + s u) with the poses of the joint table at
    the elastic coordinates s q, and the displacement array is A_n u, u = Phi q at each vertex's
    node (true scale)."""
    out = tmp_path / "sim.pvd"
    assert run(inputs, out, "--every", "7", "--scale", repr(scale)) == 0
    frames = vtk.read_pvd(out)
    k, i = 2, 14                                          # the third frame is sample 14
    mesh = meshio.read(frames[k][1])
    assert vtk.read_field_data(frames[k][1])["displacement_scale"][0] == scale
    gamma, q = inputs["gamma"][i], inputs["q"][i]
    blocks = body_blocks(mesh)
    for n, (b, (o, A)) in enumerate(zip(BODIES, expected_poses(inputs["chain"], gamma, scale * q))):
        X = inputs["points"][b]
        rows = 6 * np.arange(len(X))[:, None] + np.arange(3)                 # node-major DOF rows
        u = inputs["phis"][b][rows] @ q[n * N_MODES:(n + 1) * N_MODES]      # (nodes, 3), body axes
        assert len(blocks[b]) == len(X)
        np.testing.assert_allclose(mesh.points[blocks[b]], o + (X + scale * u) @ A.T, rtol=0, atol=1e-12)
        np.testing.assert_allclose(mesh.point_data["displacement [in]"][blocks[b]], u @ A.T, rtol=0, atol=1e-12)
        np.testing.assert_allclose(mesh.point_data["displacement_magnitude [in]"][blocks[b]],
                                   np.linalg.norm(u, axis=1), rtol=1e-12)


def test_a_pure_gimbal_rotation_turns_the_bodies_by_its_angle(inputs, tmp_path):
    """No elastic motion: turning gamma_1 by a turns every body about the case Z axis through the
    gimbal point by a; turning gamma_4 by b turns only the platform, by b about its drive axis."""
    a, b = 0.3, 0.5
    base = np.array([0.0, -np.pi / 2, 0.0, 0.0])
    gamma = np.array([base, base + [a, 0, 0, 0], base + [0, 0, 0, b]])
    sim = write_sim(tmp_path / "rot.h5", np.array([0.0, 1e-3, 2e-3]), gamma, np.zeros((3, 4 * N_MODES)))
    out = tmp_path / "rot.pvd"
    assert run(inputs, out, "--frames", "3", sim=sim) == 0
    m0, m1, m2 = (meshio.read(f) for _, f in vtk.read_pvd(out))
    np.testing.assert_allclose(m1.points, RHO + (m0.points - RHO) @ rz(a).T, atol=1e-12)
    blocks = body_blocks(m0)
    for body in (2, 3, 4):
        np.testing.assert_allclose(m2.points[blocks[body]], m0.points[blocks[body]], atol=1e-12)
    # the platform: the rotation taking frame 0 to frame 2 (Kabsch fit about the gimbal point)
    P0, P2 = m0.points[blocks[5]] - RHO, m2.points[blocks[5]] - RHO
    U, _, Vt = np.linalg.svd(P2.T @ P0)
    R = U @ np.diag([1, 1, np.linalg.det(U @ Vt)]) @ Vt
    np.testing.assert_allclose(P0 @ R.T, P2, atol=1e-12)
    assert np.arccos((np.trace(R) - 1) / 2) == pytest.approx(b, abs=1e-12)
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / (2 * np.sin(b))
    drive = C1 @ C @ rx(-np.pi / 2) @ C @ C @ np.array([1.0, 0.0, 0.0])   # A_5 e_x at base angles
    np.testing.assert_allclose(axis, drive, atol=1e-12)


def test_a_simulation_without_modal_coordinates_is_refused_in_one_line(inputs, tmp_path, capsys):
    sim = write_sim(tmp_path / "plain.h5", inputs["t"], inputs["gamma"], inputs["q"], modal=False)
    assert run(inputs, tmp_path / "x.pvd", sim=sim) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and sim in err and "--store-modal" in err
    assert not (tmp_path / "x.pvd").exists() and not (tmp_path / "x_frames").exists()


@pytest.mark.parametrize("model, n_modes, model_hash", [("other", (N_MODES,) * 4, "m1"),
                                                       ("synthetic", (N_MODES, 2, 4, N_MODES), "m1"),
                                                       ("synthetic", (N_MODES,) * 4, "m2")])
def test_a_simulation_of_another_model_is_refused_in_one_line(inputs, tmp_path, capsys, model, n_modes, model_hash):
    sim = write_sim(tmp_path / "other.h5", inputs["t"], inputs["gamma"], inputs["q"], model=model, n_modes=n_modes,
                    model_hash=model_hash)
    assert run(inputs, tmp_path / "x.pvd", sim=sim) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and sim in err and inputs["model"] in err
    assert not (tmp_path / "x.pvd").exists()


def test_a_body_file_of_another_configuration_is_refused(inputs, tmp_path, capsys):
    bodies = list(inputs["bodies"])
    stale = tmp_path / "body3.h5"
    with h5py.File(bodies[1], "r") as src, h5py.File(stale, "w") as dst:
        for key in src:
            src.copy(key, dst)
        dst.attrs.update(src.attrs)
        dst.attrs["config_hash"] = "another"
    bodies[1] = str(stale)
    code = paraview.main(["--sim", inputs["sim"], "--model-file", inputs["model"], "--bodies", *bodies,
                          "--meshes", *inputs["meshes"], "--out", str(tmp_path / "x.pvd")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and str(stale) in err and "configuration" in err


# ------------------------------------------------------------------ renderer
def test_render_draws_every_body_in_its_colour(inputs, tmp_path):
    out = tmp_path / "r.pvd"
    assert run(inputs, out, "--frames", "2", "--png", str(tmp_path / "last.png")) == 0
    image = mpimg.imread(tmp_path / "last.png")[..., :3]
    assert image.shape[:2] == (6 * render.DPI, 6 * render.DPI)
    for b in BODIES:
        rgb = np.array(render.matplotlib.colors.to_rgb(render.BODY_COLORS[b]))
        # the faces are the colour times a shade 0.45..1 (the legend patches: 1): pixels on that ray
        scale = (image @ rgb) / (rgb @ rgb)
        close = np.linalg.norm(image - scale[..., None] * rgb, axis=-1) < 0.02
        assert np.count_nonzero(close & (scale > 0.4) & (scale < 0.95)) > 50, b   # shaded: not the legend
    assert render.main(["--pvd", str(out), "--frame", "0", "--color", "magnitude",
                        "--png", str(tmp_path / "first.png")]) == 0
    assert (tmp_path / "first.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_static_correction_modes_are_the_reduced_models_basis(tmp_path):
    """With static correction modes, the basis the writer rebuilds from the body file is the one
    the reduced model was made of: its momentum coefficients X^T M Phi are the model's [P; H]
    (column order and signs included)."""
    body = sb.ring_body(connection="rods", n_elements=16, n_modes=12)
    path = sb.write_body_file(tmp_path / "body2.h5", body)
    kept = np.array([0, 1, 3, 6])
    data = models.load_body_file(str(path))
    reduced = models.build_body(2, data, kept, (DEFAULT_LOAD_CASE,))
    Phi, coords, comp = paraview.body_basis(str(path), kept, (DEFAULT_LOAD_CASE,))
    assert Phi.shape == (len(coords), 5) and np.array_equal(comp, data["dof_component"])
    momentum = np.asarray(data["rigid_modes"]).T @ (data["M"] @ Phi)
    np.testing.assert_allclose(momentum, reduced.momentum, rtol=0, atol=1e-10 * np.abs(reduced.momentum).max())
    plain, _, _ = paraview.body_basis(str(path), np.array([6, 0, 3]), ())      # any order of kept modes
    np.testing.assert_array_equal(plain, np.asarray(data["modes"])[:, [6, 0, 3]])
