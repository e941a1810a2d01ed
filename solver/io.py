"""Reading the body files written by the modal stage (layout: docs/body-data.md)."""
from __future__ import annotations

import scipy.sparse as sp

from workflow.provenance import read_h5_checked

BODY_KEYS = ("frequencies_hz", "eigenvalues", "modes", "M", "K", "T", "rigid_modes", "dof_coords",
             "dof_component", "bearing_points", "bearing_operator", "bearing_modes")
CSR_KEYS = ("M", "K", "T", "bearing_operator")


def read_csr(group) -> sp.csr_matrix:
    """A CSR matrix stored as a group with data, indices, indptr and a ``shape`` attribute."""
    return sp.csr_matrix((group["data"][()], group["indices"][()], group["indptr"][()]),
                         shape=tuple(group.attrs["shape"]))


def write_csr(h5, key: str, matrix) -> None:
    """Store a sparse matrix as the group ``key`` with data, indices, indptr and a ``shape`` attribute."""
    A = sp.csr_matrix(matrix)
    group = h5.create_group(key)
    group.create_dataset("data", data=A.data)
    group.create_dataset("indices", data=A.indices)
    group.create_dataset("indptr", data=A.indptr)
    group.attrs["shape"] = A.shape


def read_body(path) -> dict:
    """All datasets (CSR groups as scipy matrices) and attributes of a body file."""
    with read_h5_checked(path, BODY_KEYS) as h5:
        out = {key: (read_csr(h5[key]) if key in CSR_KEYS else h5[key][()])
               for key in BODY_KEYS}
        out.update({key: h5.attrs[key] for key in h5.attrs})
    out["name"] = str(out["name"])
    return out
