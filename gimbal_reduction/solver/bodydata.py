"""The body file: the contract between the FE stage and everything after it.

This module owns ``docs/body-data.md``: the body numbering and bearing names,
the rigid-motion basis X(dof_coords, dof_component), the one checked reader
and the writer's CSR layout.  It sits below both engines (``gimbal_reduction.solver.fe``
writes body files, ``reduction`` and ``gimbal_reduction.solver.dynamics`` read what follows
from them), so it imports nothing from them.

``read_body_file`` checks the contract (every dataset present, shapes
consistent, eigenvalues positive and ascending, modes mass-normalised, rigid
modes matching the DOF layout, optional config hash) and raises
``BodyFileError`` with a one-line message naming the file otherwise -- a
stale, truncated or foreign file is caught before any expensive work.

Body files are written atomically by ``gimbal_reduction.workflow.provenance.atomic_h5`` (a
temporary file in the target's folder, renamed into place when complete).
"""

import os

import h5py
import numpy as np
import scipy.sparse as sp

from gimbal_reduction.solver.bodies import BEARING_NAMES, BODIES
from gimbal_reduction.workflow.provenance import content_problem


class BodyFileError(ValueError):
    """A body file that is missing, truncated, stale or inconsistent (one-line message)."""

    def __init__(self, message):
        super().__init__(" ".join(str(message).split()))


RIGID_MOTION_NAMES = ("ux", "uy", "uz", "rx", "ry", "rz")


def skew(r):
    """Cross-product matrix: ``skew(r) @ v == np.cross(r, v)``; r (..., 3) -> (..., 3, 3)."""
    r = np.asarray(r, dtype=float)
    s = np.zeros(r.shape[:-1] + (3, 3))
    s[..., 0, 1], s[..., 0, 2] = -r[..., 2], r[..., 1]
    s[..., 1, 0], s[..., 1, 2] = r[..., 2], -r[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -r[..., 1], r[..., 0]
    return s


def rigid_modes(dof_coords, dof_component):
    """Rigid modes X (ndof, 6) from DOF positions (ndof, 3) [in] and components (ndof,).

    Columns: unit translations x, y, z [in/in], then unit (small) rotations
    about x, y, z through the origin [in/rad on translations, rad/rad on
    rotations]: a translation DOF of component c at r moves by (e_a x r)_c.
    """
    coords = np.asarray(dof_coords, dtype=float)
    comp = np.asarray(dof_component)
    ndof = comp.shape[0]
    X = np.zeros((ndof, 6))
    rows = np.arange(ndof)
    is_translation = comp < 3
    X[rows[is_translation], comp[is_translation]] = 1.0
    X[rows[~is_translation], comp[~is_translation]] = 1.0
    for axis in range(3):
        moved = np.cross(np.eye(3)[axis], coords)  # (ndof, 3)
        X[rows[is_translation], 3 + axis] = moved[rows[is_translation], comp[is_translation]]
    return X



def remedy(path):
    """What a bad body file's message tells the user to do: rerun the file's own target."""
    return f"rerun its target: snakemake --cores 2 --forcerun {path}"

DENSE_DATASETS = ("frequencies_hz", "eigenvalues", "modes", "rigid_modes", "dof_coords",
                  "dof_component", "bearing_points", "bearing_modes")
SPARSE_DATASETS = ("M", "K", "T", "bearing_operator")


def _read_csr(group, where):
    try:
        shape = tuple(int(n) for n in group.attrs["shape"])
        return sp.csr_matrix((group["data"][...], group["indices"][...], group["indptr"][...]),
                             shape=shape)
    except KeyError as exc:
        raise BodyFileError(f"{where}: sparse dataset {group.name.lstrip('/')!r} lacks {exc} "
                            f"(stale or corrupt body file): {remedy(where)}") from None
    except ValueError as exc:
        raise BodyFileError(f"{where}: sparse dataset {group.name.lstrip('/')!r} is inconsistent ({exc}): "
                            f"{remedy(where)}") from None


def read_body_file(path, expect_config_hash=None, mass_normalisation_tol=1e-6, check=True):
    """Load and check a body file; the one reader of the contract (docs/body-data.md).

    Returns a dict: the dense datasets as numpy arrays, the sparse ones (M, K, T,
    bearing_operator) as CSR, ``attrs`` (dict of the file's attributes, bytes decoded),
    ``path`` and ``number`` (the body, 2..5).  ``check=False`` skips the contract
    checks (``check_body``), for a caller that checks later.
    """
    where = str(path)
    if not os.path.isfile(where):
        raise BodyFileError(f"{where}: body file not found (make it: snakemake --cores 2 {where})")
    try:
        with h5py.File(where, "r") as f:
            missing = [k for k in DENSE_DATASETS + SPARSE_DATASETS if k not in f]
            if missing:
                raise BodyFileError(
                    f"{where}: dataset(s) {', '.join(missing)} missing (stale or incomplete body file): "
                    f"{remedy(where)}")
            body = {k: f[k][...] for k in DENSE_DATASETS}
            for k in SPARSE_DATASETS:
                body[k] = _read_csr(f[k], where)
            attrs = {}
            for k, v in f.attrs.items():
                attrs[k] = v.decode() if isinstance(v, bytes) else v
            body["attrs"] = attrs
            changed = content_problem(f, where)
    except BodyFileError:
        raise
    except OSError:
        raise BodyFileError(f"{where}: not a readable HDF5 file (corrupt or truncated): "
                            f"{remedy(where)}") from None
    except (KeyError, ValueError, TypeError) as exc:
        raise BodyFileError(f"{where}: cannot read body file ({exc}): {remedy(where)}") from None
    body["path"] = where
    body["number"] = int(body["attrs"].get("body", 0))
    if check:
        check_body(body, expect_config_hash, mass_normalisation_tol)
    if changed:                 # after the contract's checks, which name a broken value as such
        raise BodyFileError(changed)
    return body


def check_body(body, expect_config_hash=None, mass_normalisation_tol=1e-6):
    """Contract checks on a body dict (see ``read_body_file``); BodyFileError if violated."""
    where = body.get("path", "body")
    modes = np.asarray(body["modes"])
    if modes.ndim != 2:
        raise BodyFileError(f"{where}: modes must be (ndof, D), got shape {modes.shape}")
    ndof, D = modes.shape
    m = body["T"].shape[1]
    expected = {
        "eigenvalues": (D,), "frequencies_hz": (D,), "rigid_modes": (ndof, 6),
        "dof_coords": (ndof, 3), "dof_component": (ndof,), "bearing_points": (4, 3),
        "bearing_modes": (D, 4, 6), "M": (ndof, ndof), "K": (ndof, ndof), "T": (ndof, m),
        "bearing_operator": (24, ndof)}
    for key, shape in expected.items():
        if tuple(body[key].shape) != shape:
            raise BodyFileError(f"{where}: dataset {key} has shape {tuple(body[key].shape)}, "
                                f"expected {shape} (stale or corrupt body file): {remedy(where)}")
    if D == 0:
        raise BodyFileError(f"{where}: no modes")
    lam = np.asarray(body["eigenvalues"], float)
    bad = np.flatnonzero(~np.isfinite(lam) | (lam <= 0))
    if bad.size:
        raise BodyFileError(f"{where}: dataset eigenvalues must be finite and positive "
                            f"(entry {int(bad[0])} is {float(lam[bad[0]])!r}): corrupt body file, {remedy(where)}")
    down = np.flatnonzero(np.diff(lam) < -1e-9 * lam.max())
    if down.size:
        raise BodyFileError(f"{where}: dataset eigenvalues is not ascending (entry {int(down[0]) + 1} "
                            f"< entry {int(down[0])}): corrupt body file, {remedy(where)}")
    freq = np.asarray(body["frequencies_hz"], float)
    if not np.allclose(freq, np.sqrt(lam) / (2 * np.pi), rtol=1e-9, atol=0.0):
        raise BodyFileError(f"{where}: dataset frequencies_hz does not match eigenvalues "
                            f"(sqrt(lambda) / 2 pi): corrupt body file, {remedy(where)}")
    if not np.all(np.isfinite(modes)):
        raise BodyFileError(f"{where}: dataset modes contains non-finite values: corrupt body file, {remedy(where)}")
    for key in ("M", "K", "T", "bearing_operator"):
        if not np.all(np.isfinite(body[key].data)):
            raise BodyFileError(f"{where}: dataset {key} contains non-finite values: corrupt body file, "
                                f"{remedy(where)}")
    for key in ("dof_coords", "rigid_modes"):
        if not np.all(np.isfinite(np.asarray(body[key], float))):
            raise BodyFileError(f"{where}: dataset {key} contains non-finite values: corrupt body file, "
                                f"{remedy(where)}")
    comp = np.asarray(body["dof_component"])
    if comp.min() < 0 or comp.max() > 5:
        raise BodyFileError(f"{where}: dataset dof_component outside 0..5: corrupt body file, {remedy(where)}")
    X = rigid_modes(body["dof_coords"], comp)
    scale = max(np.max(np.abs(X)), 1.0)
    if np.max(np.abs(X - body["rigid_modes"])) > 1e-8 * scale:
        raise BodyFileError(f"{where}: dataset rigid_modes does not match dof_coords/dof_component: "
                            f"corrupt body file, {remedy(where)}")
    Mphi = body["M"] @ modes
    mass = np.einsum("ij,ij->j", modes, Mphi)
    if np.max(np.abs(mass - 1.0)) > mass_normalisation_tol:
        raise BodyFileError(f"{where}: dataset modes is not mass-normalised with M "
                            f"(max |phi^T M phi - 1| = {np.max(np.abs(mass - 1.0)):.1e}): corrupt or "
                            f"stale body file, {remedy(where)}")
    # M-orthonormality of every mode pair, and the eigenpairs: phi^T K phi = diag(lambda).
    # A corrupted mode or eigenvalue (one entry changed, a column scaled, a NaN sorted
    # away) breaks one of them; the modal stage makes both hold to ~1e-14.
    gram = modes.T @ Mphi
    off = np.max(np.abs(gram - np.eye(D)))
    if off > mass_normalisation_tol:
        raise BodyFileError(f"{where}: dataset modes is not M-orthonormal "
                            f"(max |Phi^T M Phi - I| = {off:.1e} > {mass_normalisation_tol:g}): "
                            f"corrupt or stale body file, {remedy(where)}")
    stiffness = modes.T @ (body["K"] @ modes)
    mismatch = np.max(np.abs(stiffness - np.diag(lam))) / lam.max()
    if mismatch > mass_normalisation_tol:
        worst = int(np.argmax(np.abs(np.diag(stiffness) - lam)))
        raise BodyFileError(f"{where}: datasets eigenvalues and modes disagree (max |Phi^T K Phi - "
                            f"diag(lambda)| / lambda_max = {mismatch:.1e}, worst at mode {worst}): "
                            f"corrupt or stale body file, {remedy(where)}")
    if expect_config_hash is not None:
        check_config_hash(body, expect_config_hash)


def check_config_hash(body, expect_config_hash):
    """BodyFileError (one line naming the file and the target to rerun) unless the body file's
    ``config_hash`` attribute is ``expect_config_hash`` (the current configuration's hash of
    what the body's stages read: ``gimbal_reduction.workflow.config.inputs_hash(body_inputs(config, n))``)."""
    where = body.get("path", "body")
    found = body["attrs"].get("config_hash")
    if str(found) != str(expect_config_hash):
        raise BodyFileError(f"{where}: made from another configuration (attribute config_hash "
                            f"{found!r}, the current configuration gives {expect_config_hash!r}): "
                            f"{remedy(where)}")


# ---------------------------------------------------------------- the writer's layout
BODY_KEYS = ("frequencies_hz", "eigenvalues", "modes", "M", "K", "T", "rigid_modes", "dof_coords",
             "dof_component", "bearing_points", "bearing_operator", "bearing_modes")
CSR_KEYS = ("M", "K", "T", "bearing_operator")


def write_csr(h5, key: str, matrix) -> None:
    """Store a sparse matrix as the group ``key`` with data, indices, indptr and a ``shape`` attribute."""
    A = sp.csr_matrix(matrix)
    group = h5.create_group(key)
    group.create_dataset("data", data=A.data)
    group.create_dataset("indices", data=A.indices)
    group.create_dataset("indptr", data=A.indptr)
    group.attrs["shape"] = A.shape
