"""The simulation file: what a simulation writes and every later stage reads.

This module owns the contract.  Datasets: ``t`` (T,) [s], ``gamma`` (T, 4)
[rad], ``gamma_dot`` (T, 4) [rad/s], optionally ``q``, ``q_dot`` (T, sum D)
modal coordinates (``--store-modal``), ``energy/{kinetic, potential, total,
input_work}`` (T,) [in lbf] (unless the run was told ``--no-energy``), ``platform_attitude`` (T, 3, 3) the stable platform's frame
in case axes (``multibody.platform_attitude``; rotation matrices, dimensionless).  Attributes: scene, model, integrator, step [s],
steps, config_hash, omega_max [rad/s], modal_omega_max, stability_limit [s], n_modes (4,),
units, created, the provenance (versions, git revision) and the integrator's ``stat_*``
counters.  Timings [s] in the process that wrote the file: ``integration_time_s`` the
integration (bases, steps, outputs) without ``kernel_load_s``, the loading or compiling of
Numba JIT kernels during it (a fresh process's first run; 0 when every kernel came from the
extension); ``wall_time_s`` both and the output arrays' set-up; ``kernels`` "extension" (the
kernels compiled ahead of time, ``kernels.extension``) or "jit".  None includes the start of
the interpreter, the imports, the model's reading and assembly, or the energy history.
Written atomically (``gimbal_reduction.workflow.provenance.atomic_h5``).
"""
from __future__ import annotations

import os

import h5py
import numpy as np

from gimbal_reduction.solver.dynamics.error_measure import ErrorsInputError
from gimbal_reduction.workflow.provenance import atomic_h5, content_problem


def write_sim(path, run, energies, attrs, store_modal=False, attitude=None):
    """Write a run atomically.  run: ``integrators.Run`` (t, y, yd, stats);
    energies: (kinetic, potential, input_work) (T,) each [in lbf], or None (no energy group);
    attrs: file attributes;
    attitude: the platform's frame (T, 3, 3) in case axes, if computed."""
    with atomic_h5(path) as f:
        f["t"] = run.t
        f["gamma"] = run.y[:, :4]
        f["gamma_dot"] = run.yd[:, :4]
        if attitude is not None:
            f["platform_attitude"] = attitude
        if store_modal:
            f["q"] = run.y[:, 4:]
            f["q_dot"] = run.yd[:, 4:]
        if energies is not None:
            T, U, W = energies
            g = f.create_group("energy")
            g["kinetic"], g["potential"], g["total"], g["input_work"] = T, U, T + U, W
        for k, v in attrs.items():
            f.attrs[k] = v
        for k, v in run.stats.items():
            f.attrs[f"stat_{k}"] = v
    return path


def read_sim(path) -> dict:
    """A simulation file as {t (T,), gamma (T,4), gamma_dot (T,4), platform_attitude (T,3,3) or
    None, attrs, path}."""
    if not os.path.exists(path):
        raise ErrorsInputError(f"{path}: simulation file missing (run gimbal_reduction.solver.dynamics.simulate first)")
    try:
        with h5py.File(path, "r") as f:
            for key in ("t", "gamma_dot"):
                if key not in f:
                    raise ErrorsInputError(f"{path}: dataset '{key}' missing (not a simulation file)")
            out = {"t": f["t"][()], "gamma_dot": f["gamma_dot"][()],
                   "gamma": f["gamma"][()] if "gamma" in f else None,
                   "attrs": {k: _plain(v) for k, v in f.attrs.items()}}
            if "energy" in f:
                out["energy"] = {k: f["energy"][k][()] for k in f["energy"]}
            out["platform_attitude"] = f["platform_attitude"][()] if "platform_attitude" in f else None
            changed = content_problem(f, path)
    except OSError as exc:
        raise ErrorsInputError(f"{path}: unreadable HDF5 file ({exc.__class__.__name__})") from None
    t, gd = np.asarray(out["t"], float), np.asarray(out["gamma_dot"], float)
    if t.ndim != 1 or gd.shape != (t.size, 4):
        raise ErrorsInputError(f"{path}: gamma_dot has shape {gd.shape}, expected ({t.size}, 4)")
    if not (np.all(np.isfinite(gd)) and np.all(np.isfinite(t))):
        raise ErrorsInputError(f"{path}: non-finite gamma_dot or t (diverged run)")
    if changed:
        raise ErrorsInputError(changed)
    out["t"], out["gamma_dot"], out["path"] = t, gd, str(path)
    out["model"] = str(out["attrs"].get("model") or os.path.splitext(os.path.basename(path))[0])
    return out


def mismatches(attrs: dict, want: dict, rel_tol: dict | None = None) -> dict:
    """{key: the file's value (None if absent)} of every entry of ``want`` that a simulation
    file's ``attrs`` does not hold: a value matches when it is equal or has the same str form
    (an HDF5 attribute read back as bytes or a NumPy scalar), or, for a key of ``rel_tol``
    {key: relative tolerance}, when it lies within that tolerance of the wanted number.  The
    readers that take a file as a given run (a reference, the study's truth) name these in
    their one-line refusal."""
    wrong = {}
    for key, value in want.items():
        got = _plain(attrs.get(key))
        if key in (rel_tol or {}):
            try:
                ok = abs(float(got) - float(value)) <= rel_tol[key] * abs(float(value))
            except (TypeError, ValueError):
                ok = False
        else:
            ok = got == value or str(got) == str(value)
        if not ok:
            wrong[key] = got
    return wrong


def _plain(v):
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    return v


