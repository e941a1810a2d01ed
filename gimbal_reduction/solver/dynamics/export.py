"""Export a reduced model's linearised state-space form for control design.

    python -m gimbal_reduction.solver.dynamics.export --model-file results/models/thesis/tol-1e-4.h5 \\
        --scene thesis --out model.mat          (also model.npz beside it; or --out model.npz)
        [--config config/config.yaml]           (refuse a model of body files of another config)

The workflow makes it as a target: ``snakemake --cores 2 results/export/thesis/tol-1e-4.mat``
(rule ``control_export``, workflow/rules/outputs.smk: the .mat and the .npz).

About the scene's initial state (gimbal angles y0, rates and elastic coordinates zero,
case at rest) the chain M(y) y'' + C y' + K y = tau - c(y, y', t) becomes, for the
deviation x = [dy; dy'] (dy = [d gamma (4); q (modal coordinates)]),

    x' = A x + B u,     z = C_out x,

    A = [[0, I], [-M0^-1 K, -M0^-1 C]],  M0 = M(y0) (``linearized.mass_matrix_fast``),
        K = diag(0_4, Omega^2), C = diag(0_4, 2 zeta Omega) (the scene's modal damping).
    u = [tau_1..tau_4 (in lbf, motor torques); alpha_x, alpha_y, alpha_z (rad/s^2, the
        case's angular acceleration in case axes)].
    B = d y''/d u at (y0, 0, t = 0), by central finite differences of the chain's own
        right-hand side (``multibody.accelerations``): exact to round-off, since y'' is linear in the
        torques and, at zero case rate, in the case acceleration (centrifugal terms are
        quadratic in the case rate and vanish to first order).  Rows 0..n-1 (dy) are zero.
    z = [gamma_dot_1..4 (rad/s); phi_x, phi_y, phi_z (rad)]: the gimbal rates and the
        platform's small-angle attitude change, R(y0)^T R(y) ~ I + skew(phi), from
        ``multibody.platform_attitude`` differentiated by central differences (phi in the
        platform's initial axes, relative to the case).  D = 0.

Valid for small motion about y0 with the case near rest: the velocity-dependent terms
(gyroscopic, centrifugal) are dropped, which is exact at the linearisation point only.
The state ordering and names are written with the matrices (``state_names``,
``input_names``, ``output_names``), and the provenance record as JSON text (``provenance``:
config hash of the model file, git revision, versions).  Units: in, lbf, s, rad.
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np
import scipy.io

from gimbal_reduction.solver.bodydata import BODIES
from gimbal_reduction.solver.dynamics import chainfile, linearized, multibody, scenes
from gimbal_reduction.solver.dynamics.multibody import CaseMotion
from gimbal_reduction.workflow import cli
from gimbal_reduction.workflow import config as cfgmod
from gimbal_reduction.workflow.provenance import atomic_path, provenance

INPUT_NAMES = ("tau_outer", "tau_middle", "tau_inner", "tau_platform",
               "case_alpha_x", "case_alpha_y", "case_alpha_z")
OUTPUT_NAMES = ("gamma_dot_outer", "gamma_dot_middle", "gamma_dot_inner", "gamma_dot_platform",
                "attitude_x", "attitude_y", "attitude_z")
FD_TORQUE = 1.0          # in lbf (y'' is linear in the torques: the size does not matter)
FD_ALPHA = 1.0           # rad/s^2 (linear in the case acceleration at zero case rate)
FD_ANGLE = 1e-6          # rad / modal coordinate step of the attitude Jacobian


def _vee(S):
    return np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]]) / 2


def attitude_jacobian(chain, y0, h=FD_ANGLE):
    """J (3, n): phi = J dy, R(y0)^T R(y0 + dy) ~ I + skew(phi) (central differences on the
    coordinates ``platform_attitude`` reads)."""
    n = chain.n_coordinates
    J = np.zeros((3, n))
    R0 = multibody.platform_attitude(chain, y0)[0]
    for i in multibody.attitude_coordinates(chain):
        yp, ym = y0.copy(), y0.copy()
        yp[i] += h
        ym[i] -= h
        Rp, Rm = multibody.platform_attitude(chain, np.vstack([yp, ym]))
        J[:, i] = (_vee(R0.T @ Rp) - _vee(R0.T @ Rm)) / (2 * h)
    return J


def input_matrix(chain, y0):
    """B_acc (n, 7): d y''/d u at (y0, y' = 0, t = 0), u = [tau (4); case alpha (3)]."""
    n = chain.n_coordinates
    yd0 = np.zeros(n)
    cols = []
    for j in range(4):
        tau = np.zeros(4)
        tau[j] = FD_TORQUE
        plus = multibody.accelerations(chain, y0, yd0, 0.0, CaseMotion(), tau)
        minus = multibody.accelerations(chain, y0, yd0, 0.0, CaseMotion(), -tau)
        cols.append((plus - minus) / (2 * FD_TORQUE))
    for k in range(3):
        a = np.zeros(3)
        a[k] = FD_ALPHA
        plus = multibody.accelerations(chain, y0, yd0, 0.0, CaseMotion(amplitude=tuple(a)))
        minus = multibody.accelerations(chain, y0, yd0, 0.0, CaseMotion(amplitude=tuple(-a)))
        cols.append((plus - minus) / (2 * FD_ALPHA))
    return np.column_stack(cols)


def state_space(chain, y0):
    """dict A (2n, 2n), B (2n, 7), C (7, 2n), D (7, 7), M0, K, Cd, y0 and names."""
    n = chain.n_coordinates
    M0 = linearized.mass_matrix_fast(chain, y0)
    M0 = 0.5 * (M0 + M0.T)
    K = np.diag(chain.stiffness_diagonal())
    Cd = np.diag(chain.damping_diagonal())
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -np.linalg.solve(M0, K)
    A[n:, n:] = -np.linalg.solve(M0, Cd)
    B = np.zeros((2 * n, len(INPUT_NAMES)))
    B[n:] = input_matrix(chain, y0)
    C = np.zeros((len(OUTPUT_NAMES), 2 * n))
    C[:4, n:n + 4] = np.eye(4)
    C[4:, :n] = attitude_jacobian(chain, y0)
    labels = [f"gamma_{k}" for k in range(1, 5)]
    for b, sl in zip(chain.bodies, chain.slices):
        labels += [f"q_body{b.number}_{k}" for k in range(sl.stop - sl.start)]
    return {"A": A, "B": B, "C": C, "D": np.zeros((C.shape[0], B.shape[1])), "M0": M0, "K": K,
            "Cd": Cd, "y0": np.asarray(y0, float),
            "state_names": np.array(labels + [f"d_{s}" for s in labels]),
            "input_names": np.array(INPUT_NAMES), "output_names": np.array(OUTPUT_NAMES)}


def export(model_file, scene_name):
    """(state-space dict, info) of a reduced-model file about a scene's initial state."""
    scene = scenes.load_scene(scene_name)
    chain, info = chainfile.read_chain(model_file, scene.damping_ratio)
    y0, yd0 = scenes.initial_state(scene, chain.n_coordinates)
    if np.any(yd0) or not scene.case.at_rest and np.any(scene.case.omega0):
        print("export: note: the scene starts with nonzero rates; the export linearises about "
              "zero rates (velocity terms dropped)", file=sys.stderr)
    ss = state_space(chain, y0)
    ss.update({"scene": scene.name, "model": str(info.get("model", "")),
               "n_modes": np.asarray(chain.n_modes), "units": "in, lbf, s, rad",
               "provenance": json.dumps(provenance(sources=[model_file]), sort_keys=True)})
    return ss


EXTENSIONS = (".mat", ".npz")


def out_pair(out):
    """(.mat, .npz) paths of ``--out`` (either extension names the pair); ValueError, naming the
    path, for any other extension (the export writes no other format)."""
    stem, ext = os.path.splitext(str(out))
    if ext not in EXTENSIONS:
        raise ValueError(f"--out {out}: the export writes .mat and .npz, not {ext or 'a file without extension'} "
                         f"(name the .mat or the .npz)")
    return stem + ".mat", stem + ".npz"


def write(ss, out):
    """Write the .mat (scipy.io.savemat) and the .npz beside each other, both or neither: each
    goes to a temporary file first (``gimbal_reduction.workflow.provenance.atomic_path``), and
    both are renamed into place only when both are written.  Returns both paths; OSError with a
    message naming the file that could not be written."""
    mat, npz = out_pair(out)
    target = mat
    try:
        with atomic_path(mat) as tmp_mat, atomic_path(npz) as tmp_npz:
            scipy.io.savemat(str(tmp_mat), ss, do_compression=True, appendmat=False)
            target = npz
            with open(tmp_npz, "wb") as f:       # a file object: no ".npz" appended
                np.savez_compressed(f, **ss)
    except OSError as exc:
        raise OSError(cli.write_failure(target, exc)) from None
    return mat, npz


def check_config(model_file, config_path):
    """ChainFileError (one line) unless the model file was made from body files of the
    configuration ``config_path`` (the same check as the simulation's, ``chainfile.check_body_hashes``)."""
    _, info = chainfile.read_chain(model_file)
    config = cfgmod.load_config(config_path)
    expected = {b: cfgmod.inputs_hash(cfgmod.body_inputs(config, b)) for b in BODIES}
    chainfile.check_body_hashes(model_file, info, expected)


def main(argv=None):
    ap = cli.OneLineParser(prog="gimbal export",
                                 description="Linearised state space (A, B, C, D) of a reduced model "
                                             "about a scene's initial state, to .mat and .npz.")
    ap.add_argument("--model-file", required=True, help="reduced-model file (gimbal_reduction.reduction.models)")
    ap.add_argument("--scene", required=True, help="scene name or file")
    ap.add_argument("--out", required=True, help="output .mat or .npz (both are written)")
    cli.add_config_option(ap, "the reduced model's body files must have been made from it (their config hashes)")
    args = ap.parse_args(argv)
    try:
        out_pair(args.out)                       # before any work
        if args.config is not None:
            check_config(args.model_file, args.config)
        ss = export(args.model_file, args.scene)
        mat, npz = write(ss, args.out)
    except (ValueError, FileNotFoundError, OSError) as exc:
        print(f"export: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    print(f"export: {mat}, {npz}: {ss['A'].shape[0]} states, {ss['B'].shape[1]} inputs, "
          f"{ss['C'].shape[0]} outputs (model {ss['model']} on scene {ss['scene']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
