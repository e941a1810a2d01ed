"""Do two runs of the same targets agree (workflow/cluster/slurm_localhost.sh: on Slurm and locally)?

  python workflow/cluster/compare.py CLUSTER_DIR LOCAL_DIR

Meshes: the same nodes and cells (gmsh is deterministic). Body files: the same frequencies to 1e-8
relative (the modal stage ran on two MPI ranks on the cluster, on one locally; modes of a degenerate
pair may differ by a rotation within the pair, so the mode shapes are not compared entry by entry).
Simulation files: the same joint rates to 1e-6 of their largest value. One line per file; exit
status 1 if any file differs.
"""
import glob
import os
import sys

import h5py
import numpy as np


def relative(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


def compare(cluster, local):
    rows, ok = [], True
    for path in sorted(glob.glob(os.path.join(local, "results", "mesh", "*.msh"))):
        rel = os.path.relpath(path, local)
        same = open(path, "rb").read() == open(os.path.join(cluster, rel), "rb").read()
        rows.append((rel, "identical" if same else "DIFFERENT", same))
    for path in sorted(glob.glob(os.path.join(local, "results", "modes", "*.h5"))):
        rel = os.path.relpath(path, local)
        with h5py.File(path, "r") as a, h5py.File(os.path.join(cluster, rel), "r") as b:
            d = relative(b["frequencies_hz"][()], a["frequencies_hz"][()])
            ranks = (int(b.attrs.get("mpi_ranks", 0)), int(a.attrs.get("mpi_ranks", 0)))
        rows.append((rel, f"frequencies rel. diff {d:.1e} (MPI ranks cluster/local {ranks[0]}/{ranks[1]})",
                     d < 1e-8))
    for path in sorted(glob.glob(os.path.join(local, "results", "sim", "*", "*.h5"))):
        rel = os.path.relpath(path, local)
        with h5py.File(path, "r") as a, h5py.File(os.path.join(cluster, rel), "r") as b:
            d = relative(b["gamma_dot"][()], a["gamma_dot"][()])
        rows.append((rel, f"joint rates rel. diff {d:.1e}", d < 1e-6))
    for rel, what, passed in rows:
        ok &= passed
        print(f"compare: {'ok  ' if passed else 'FAIL'} {rel}: {what}")
    if not rows:
        print("compare: FAIL nothing to compare")
        return False
    return ok


if __name__ == "__main__":
    sys.exit(0 if compare(sys.argv[1], sys.argv[2]) else 1)
