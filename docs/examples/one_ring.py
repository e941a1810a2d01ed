# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
# ---

# # One ring: its modes, and a few milliseconds of the gimbal chain
#
# This example walks through the pipeline on coarse meshes, in well under a minute:
#
# 1. a bare ring (the outer gimbal's band, no bearings) is meshed with the project's
#    geometry code and its free vibration computed with the shell model of
#    `gimbal_reduction.solver.fe`; its first elastic frequency is checked against the classical
#    thin-ring formula;
# 2. the four bodies of the gimbal are meshed coarsely and their first *supported*
#    modes computed by the FE stage (`gimbal_reduction.solver.fe.modes`), written to body files and
#    read back through the one checked reader (`gimbal_reduction.solver.bodydata`);
# 3. a tiny reduced model (two modes per body) is built by `gimbal_reduction.reduction.models`, and
# 4. released with initial gimbal rates for 15 ms (`gimbal_reduction.solver.dynamics`, scene `free`):
#    the case is at rest and nothing drives the chain, so its energy and its angular
#    momentum about the outer drive axis must stay constant.
#
# Run it with `.venv/bin/python docs/examples/one_ring.py`; `tests/test_examples.py`
# imports it and checks its numbers. Units throughout: inch, lbf, second (mass in
# lbf s^2/in), frequencies in Hz unless stated.

# +
import math
import os
import shutil
import tempfile
import time

import numpy as np
from mpi4py import MPI

from gimbal_reduction.geometry.mesh import mesh_from_config
from gimbal_reduction.geometry.verification import band_surface
from gimbal_reduction import api
from gimbal_reduction.solver.bodydata import BODIES, read_body_file
from gimbal_reduction.solver.dynamics import multibody
from gimbal_reduction.solver.fe import eigen, forms, modes
from gimbal_reduction.workflow import config as cfgmod

COMM = MPI.COMM_SELF                  # serial: the example runs inside the test suite
START = time.perf_counter()
config = cfgmod.load_config()         # config/config.yaml: every number with its unit and source
params = cfgmod.body_parameters(config, 2)   # the outer gimbal (thesis body 2)
# -

# ## 1. The free ring against the thin-ring formula
#
# The outer gimbal is a band of mid-radius $R$, radial wall $t$ and axial width $b$.
# Its softest free vibration bends the band in its own plane. For a thin ring
# (Euler-Bernoulli, Hoppe 1871; Blevins, Table 12-1) the flexural mode with $n$
# waves round the circumference has
#
# $$\omega_n^2 = \frac{E I\, n^2 (n^2 - 1)^2}{\rho A R^4 (n^2 + 1)}, \qquad
#   I = \frac{b t^3}{12}, \quad A = b t ,$$
#
# and $n = 2$ (an oval) is the lowest. Our band is not quite thin ($t/R = 0.074$):
# shear deformation and rotary inertia lower the frequency by, to first order
# (Timoshenko),
#
# $$\frac{f}{f_\text{thin}} - 1 \approx -\frac{n^2}{2}\,\frac{t^2}{12 R^2}
#   \Bigl(1 + \frac{E}{\kappa G}\Bigr), \qquad \frac{E}{G} = 2(1 + \nu),$$
#
# about -0.4 % for $n = 2$. The project's verification (`gimbal_reduction.solver.fe.checks`,
# `check_ring_formula`) demands that the finite-element deviation match this
# prediction within 0.3 %.

# +
R, t, b = params["diameter"] / 2, params["thickness"], params["width"]
E, rho, nu = params["youngs_modulus"], params["density"], params["poissons_ratio"]
kappa = cfgmod.value(config, "shell.shear_correction")


def thin_ring_hz(n):
    """In-plane flexural frequency of a free thin ring with n circumferential waves [Hz]."""
    inertia, area = b * t**3 / 12, b * t
    return math.sqrt(E * inertia * n**2 * (n**2 - 1) ** 2 / (rho * area * R**4 * (n**2 + 1))) / (2 * math.pi)


f_thin = thin_ring_hz(2)
expected_deviation = -0.5 * 2**2 * t**2 / (12 * R**2) * (1 + 2 * (1 + nu) / kappa)
# -

# The band's mid-surface is meshed by gmsh (`gimbal_reduction.geometry.verification.band_surface`) with
# flat triangles of size $h = 0.5$ in (twice the production size). On it `gimbal_reduction.solver.fe.forms`
# builds the Reissner-Mindlin shell: P2 displacement $u$ and rotation $\theta$, so the
# stiffness and mass forms
#
# $$a(w, \hat w) = \int_\Omega \varepsilon(w) : C : \varepsilon(\hat w)\, dA, \qquad
#   m(w, \hat w) = \int_\Omega \rho t\, u\cdot\hat u + \rho \tfrac{t^3}{12}\,\theta\cdot\hat\theta\, dA$$
#
# (membrane, bending, shear and drilling strains in $\varepsilon$; see the module's
# docstring). The free ring has six rigid motions with $\omega = 0$, so SLEPc's
# shift-and-invert Krylov-Schur solver looks just below zero for the eight lowest
# eigenpairs of $K \phi = \omega^2 M \phi$: six rigid motions, then the $n = 2$ pair
# (two ovals at 45 degrees, equal frequency by symmetry).

# +
with tempfile.TemporaryDirectory(prefix="one_ring_") as workdir:
    band = os.path.join(workdir, "band.msh")
    band_surface(R, b, 0.5, band)
    mesh, _, _, _ = forms.load_mesh(band, COMM)
    V, stiffness_form, mass_form = forms.shell_forms(mesh, params, cfgmod.shell_settings(config))
    K, M = forms.assemble_matrix(stiffness_form), forms.assemble_matrix(mass_form)
    shift = -((2 * math.pi * f_thin) ** 2) / 10
    omega2, vectors = eigen.lowest_eigenpairs(K, M, 8, shift, 1e-12, 500, label="band")
free_hz = np.sign(omega2) * np.sqrt(np.abs(omega2)) / (2 * math.pi)
FREE_RING = {"fe_hz": float(free_hz[6]), "pair_hz": float(free_hz[7]), "thin_ring_hz": f_thin,
             "deviation": float(free_hz[6] / f_thin - 1), "expected_deviation": expected_deviation,
             "rigid_hz_max": float(np.abs(free_hz[:6]).max()), "dofs": int(K.getSize()[0])}
print(f"free ring: f(n=2) = {FREE_RING['fe_hz']:.1f} Hz (pair {FREE_RING['pair_hz']:.1f} Hz), thin ring "
      f"{f_thin:.1f} Hz: deviation {100 * FREE_RING['deviation']:+.2f} %, Timoshenko estimate "
      f"{100 * expected_deviation:+.2f} %; rigid modes below {FREE_RING['rigid_hz_max']:.1e} Hz")
# -

# ## 2. The four bodies, supported at their input bearings
#
# In the gimbal each body hangs on its two input bearings. The bearing connection is
# a rigid-fit average: the bearing point's six motions are the rigid motion that best
# fits (least squares) the motion of the band's cross-section there, $r = R_b u$.
# Holding $R_b u = 0$ at both input bearings leaves the admissible displacements
# $u = T \bar u$, and the supported modes solve
#
# $$T^T K T\, \bar\phi = \omega^2\, T^T M T\, \bar\phi, \qquad \phi = T \bar\phi, \quad
#   \phi^T M \phi = 1 .$$
#
# `gimbal_reduction.solver.fe.modes.compute_body` does all of this for one body of the config (shell
# rings, curved P3 tetrahedra for the platform); here with three modes each on coarse
# meshes (0.5 in for the rings, 1 in for the platform, which its 1 in rim patches turn
# into the production mesh anyway). Each result is written as a body file
# (`docs/body-data.md`) and read back by `gimbal_reduction.solver.bodydata.read_body_file`, which
# checks the contract: shapes, ascending positive eigenvalues, mass normalisation,
# rigid modes matching the DOF layout.

# +
MESH_SIZE = {2: 0.5, 3: 0.5, 4: 0.5, 5: 1.0}
body_data, body_files = {}, []
workdir = tempfile.mkdtemp(prefix="one_ring_")       # removed at the end of the example
for number in BODIES:
    mesh_path = os.path.join(workdir, f"body{number}.msh")
    body_path = os.path.join(workdir, f"body{number}.h5")
    mesh_from_config(config, number, mesh_path, MESH_SIZE[number])
    payload = modes.compute_body(number, config, mesh_path, 3, COMM, log=lambda *a, **k: None,
                                 mesh_size=MESH_SIZE[number])
    modes.write_body_file(body_path, payload, config_hash="docs/examples/one_ring.py", wall_time=0.0)
    body_data[number] = read_body_file(body_path)
    body_files.append(body_path)
SUPPORTED_HZ = {number: body_data[number]["frequencies_hz"].tolist() for number in BODIES}
for number in BODIES:
    attrs = body_data[number]["attrs"]
    print(f"body {number} ({attrs['name']}, {body_data[number]['M'].shape[0]} DOFs): supported modes "
          + ", ".join(f"{f:.0f}" for f in SUPPORTED_HZ[number]) + " Hz")
# -

# ## 3. A reduced model of the chain
#
# The chain is the case, three gimbals and the platform, each turning on its drive
# axis by $\gamma_j$, each body deforming in its kept modes $q$. A body's modes enter
# the equations of motion through modal integrals of its mass matrix, chiefly the
# momentum coefficients
#
# $$\begin{bmatrix} P \\ H \end{bmatrix}_i = X^T M \phi_i ,$$
#
# the linear and angular momentum a unit modal rate carries ($X$: the six rigid
# motions), and through the modes' motion at the bearings, which moves the next body.
# The model name `freq-2` keeps each body's two lowest supported modes
# (`gimbal_reduction.reduction.names` holds the grammar: `xmx-10`, `static-8`, ...).
# `gimbal_reduction.api.reduce` builds it from the body files, as the workflow's
# `gimbal model` stage does (here without a configuration to check the files against).

# +
model = api.reduce("freq-2", "free", bodies=body_files, config=None)
chain = model.chain
print(f"reduced model {model.name}: {chain.n_coordinates} coordinates (4 gimbal angles + "
      f"{chain.n_coordinates - 4} modal), largest kept modal frequency "
      f"{chain.omega_max / (2 * math.pi):.0f} Hz")
# -

# ## 4. Fifteen milliseconds of free motion
#
# With $y = (\gamma, q)$ the chain obeys $M(y)\,\ddot y = f(y, \dot y, t)$
# (`docs/dynamics.md`), integrated here by RK4 at half its stability limit
# $h \le 2.785 / \omega_\text{max}$, where $\omega_\text{max}$ is the highest frequency
# of the *coupled* chain (not of the kept modes alone). Scene `free`
# (`config/scenes/free.yaml`) holds the case at rest, applies no torque and starts the
# gimbals at rates of a few tenths of a rad/s. Two quantities must then stay constant:
#
# * the energy $E = T + U$, kinetic plus elastic, $T = \tfrac12 \dot y^T M(y) \dot y$,
#   $U = \tfrac12 q^T \Omega^2 q$;
# * the momentum conjugate to the outer gimbal's angle, $p_1 = (M(y)\,\dot y)_1$: no
#   torque acts about the outer drive axis, which is fixed in the resting case.
#
# Neither is imposed by the integrator, so their drift measures the whole chain of
# modal integrals, equations of motion and time stepping.

# +
run = api.simulate(model, "free", integrator="rk4")
shutil.rmtree(workdir)
energy = run.energy["kinetic"] + run.energy["potential"] - run.energy["input_work"]   # work = 0: nothing drives the chain
p1 = np.array([(multibody.mass_matrix(chain, y) @ yd)[0] for y, yd in zip(run.y[::100], run.yd[::100])])
ENERGY_DRIFT = float(np.max(np.abs(energy - energy[0])) / abs(energy[0]))
MOMENTUM_DRIFT = float(np.max(np.abs(p1 - p1[0])) / abs(p1[0]))
SIMULATION = {"steps": int(run.stats["steps"]), "step_s": float(run.stats["step"]), "samples": int(run.t.size),
              "duration_s": float(run.t[-1]), "rates_end": run.yd[-1, :4].tolist(),
              "max_modal_amplitude": float(np.abs(run.y[:, 4:]).max())}
print(f"{run.scene}: {SIMULATION['duration_s'] * 1e3:g} ms in {SIMULATION['steps']} RK4 steps of "
      f"{SIMULATION['step_s']:.2e} s; relative drift of T + U {ENERGY_DRIFT:.1e}, of p_1 {MOMENTUM_DRIFT:.1e}")
print(f"example done in {time.perf_counter() - START:.1f} s")
# -
