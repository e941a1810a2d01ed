"""The reduced-model file: a chain of reduced bodies, between the reduction and the simulation.

This module owns the contract ``docs/models.md``.  A reduced model (thesis
Chapter 3: kept vibration modes plus static correction modes of every body)
is reduced once, by ``python -m gimbal_reduction.reduction.models``, into the modal integrals
the equations of motion need (``multibody.Body``); a simulation reads only
this file, never the four full body files, and never refactorises T^T K T.
This mirrors EXUDYN's saved reduced-order body (``ObjectFFRFreducedOrderInterface``).

Layout (HDF5; D = kept coordinates of the body, units in, lbf, s)::

    body{n}/rigid_mass          (6, 6)     M_inf of the body
    body{n}/momentum            (6, D)     [P; H]
    body{n}/inertia_gradient    (D, 6, 6)
    body{n}/coriolis            (D, 3, D)
    body{n}/omega2              (D,)       modal stiffness [(rad/s)^2]
    body{n}/inside_translation  (3, D)     Psi   (bodies 2..4; absent for the platform)
    body{n}/inside_rotation     (3, D)     Theta (bodies 2..4)
    body{n}/labels              (D,)       "mode i" / "static <load case>"
    body{n}/kept                (k,)       kept mode indices into the body file (0-based)
    body{n}/static_cases        (s,)       static load case names
    chain/gimbal_offset (3,), chain/case_to_outer (3, 3), chain/parent_to_child (3, 3)

Attributes: ``format`` (FORMAT), ``model``, ``scene``, ``config_hash`` (of the
body files, the rankings and the scene's elastic bodies it was made from) and
the provenance of every output (versions, git revision, created, wall time).

Damping is a scene property: ``read_chain(path, damping_ratio)`` applies it with
the same formula as ``multibody.make_body`` (2 zeta Omega per mode).
"""
from __future__ import annotations

import json
import os

import h5py
import numpy as np

from gimbal_reduction.solver.bodydata import BODIES
from gimbal_reduction.solver.dynamics import multibody
from gimbal_reduction.workflow.provenance import atomic_h5, content_problem

FORMAT = "gimbal-reduced-model/1"
BODY_DATASETS = ("rigid_mass", "momentum", "inertia_gradient", "coriolis", "omega2", "labels")
INSIDE_DATASETS = ("inside_translation", "inside_rotation")
CHAIN_DATASETS = ("gimbal_offset", "case_to_outer", "parent_to_child")


class ChainFileError(ValueError):
    """A reduced-model file that is missing, corrupt, incomplete or inconsistent (one line)."""

    def __init__(self, message):
        super().__init__(" ".join(str(message).split()))


def write_chain(path, chain, kept, static_cases, attrs):
    """Write ``chain`` (undamped ``multibody.Chain``) atomically.

    kept: {body: (k,) int} kept mode indices; static_cases: {body: tuple of str};
    attrs: extra file attributes (model, scene, config_hash, provenance)."""
    with atomic_h5(path) as h5:
        h5.attrs["format"] = FORMAT
        for key, value in attrs.items():
            h5.attrs[key] = value
        for body in chain.bodies:
            group = h5.create_group(f"body{body.number}")
            for key in BODY_DATASETS[:-1]:
                group[key] = getattr(body, key)
            labels = body.labels or tuple(f"coordinate {i}" for i in range(body.n_modes))
            group["labels"] = np.array(labels, dtype=h5py.string_dtype())
            for key in INSIDE_DATASETS:
                value = getattr(body, key)
                if value is not None:
                    group[key] = value
            group["kept"] = np.asarray(kept[body.number], dtype=np.int64)
            group["static_cases"] = np.array(list(static_cases[body.number]), dtype=h5py.string_dtype())
        group = h5.create_group("chain")
        for key in CHAIN_DATASETS:
            group[key] = getattr(chain, key)


def _dataset(h5, key, where):
    if key not in h5:
        raise ChainFileError(f"{where}: dataset '{key}' missing (stale or incomplete reduced-model file: "
                             f"delete it and rerun its rule)")
    return h5[key][()]


def read_chain(path, damping_ratio=0.0):
    """(Chain, info) from a reduced-model file, with modal damping ratio ``damping_ratio``.

    info: the file's attributes plus ``kept`` and ``static_cases`` per body.
    Checks: format, every dataset present, shapes consistent with D = omega2.size,
    finite values, omega2 >= 0; ChainFileError (one line naming the file and the
    dataset) otherwise."""
    where = str(path)
    if not os.path.isfile(where):
        raise ChainFileError(f"{where}: reduced-model file not found (make it with "
                             f"snakemake {where} or python -m gimbal_reduction.reduction.models)")
    try:
        with h5py.File(where, "r") as h5:
            info = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in h5.attrs.items()}
            if info.get("format") != FORMAT:
                raise ChainFileError(f"{where}: not a reduced-model file of format {FORMAT} "
                                     f"(format {info.get('format')!r})")
            bodies, kept, static = [], {}, {}
            for number in BODIES:
                group = f"body{number}"
                data = {key: _dataset(h5, f"{group}/{key}", where) for key in BODY_DATASETS}
                for key in INSIDE_DATASETS:
                    data[key] = h5[f"{group}/{key}"][()] if f"{group}/{key}" in h5 else None
                kept[number] = _dataset(h5, f"{group}/kept", where).astype(int)
                static[number] = tuple(s.decode() if isinstance(s, bytes) else str(s)
                                       for s in _dataset(h5, f"{group}/static_cases", where))
                bodies.append(_body(number, data, damping_ratio, f"{where}: {group}"))
            fixed = {key: _dataset(h5, f"chain/{key}", where) for key in CHAIN_DATASETS}
            changed = content_problem(h5, where)
            if changed:
                raise ChainFileError(changed)
    except OSError:
        raise ChainFileError(f"{where}: not a readable HDF5 file (corrupt or truncated): delete it and "
                             f"rerun its rule") from None
    info.update(kept=kept, static_cases=static)
    try:
        chain = multibody.Chain(tuple(bodies), name=str(info.get("model", "")), **fixed)
    except ValueError as exc:
        raise ChainFileError(f"{where}: {exc}") from None
    return chain, info


def check_body_hashes(path, info, expected):
    """ChainFileError (one line naming the file and what to rerun) unless the reduced model was
    made from body files with the config hashes ``expected`` ({body: hash}: what the current
    configuration gives, ``gimbal_reduction.workflow.config.inputs_hash(body_inputs(config, n))``).  The file
    records them in its attribute ``body_config_hashes`` (JSON list, bodies 2..5)."""
    where = str(path)
    stored = info.get("body_config_hashes")
    if stored is None:
        raise ChainFileError(f"{where}: attribute body_config_hashes missing (made before the body "
                             f"files' hashes were recorded, so its configuration is unknown): rerun its "
                             f"target: snakemake --cores 2 --forcerun {where}")
    try:
        found = dict(zip(BODIES, json.loads(stored)))
    except (TypeError, ValueError):
        raise ChainFileError(f"{where}: attribute body_config_hashes unreadable ({stored!r}): rerun its "
                             f"target: snakemake --cores 2 --forcerun {where}") from None
    stale = [b for b in BODIES if str(found.get(b)) != str(expected[b])]
    if stale:
        targets = " ".join(f"results/modes/body{b}.h5" for b in stale)
        raise ChainFileError(f"{where}: made from body file(s) of another configuration (bodies "
                             f"{', '.join(map(str, stale))}: config_hash {found.get(stale[0])!r}, the "
                             f"current configuration gives {expected[stale[0]]!r}): rerun snakemake "
                             f"--cores 2 {targets} {where}")


def _remedy(where):
    path = where.rsplit(": ", 1)[0]
    return f"corrupt or stale reduced-model file, rerun its target: snakemake --cores 2 --forcerun {path}"


def _body(number, data, damping_ratio, where):
    """multibody.Body of one group, after the shape and value checks."""
    omega2 = np.asarray(data["omega2"], float)
    D = omega2.size
    shapes = {"rigid_mass": (6, 6), "momentum": (6, D), "inertia_gradient": (D, 6, 6),
              "coriolis": (D, 3, D), "labels": (D,)}
    shapes.update({key: (3, D) for key in INSIDE_DATASETS if data[key] is not None})
    for key, shape in shapes.items():
        if np.shape(data[key]) != shape:
            raise ChainFileError(f"{where}/{key} has shape {np.shape(data[key])}, expected {shape}: "
                                 f"{_remedy(where)}")
    for key in ("rigid_mass", "momentum", "inertia_gradient", "coriolis", "omega2", *INSIDE_DATASETS):
        if data[key] is not None and not np.all(np.isfinite(data[key])):
            raise ChainFileError(f"{where}/{key} holds non-finite values: {_remedy(where)}")
    if np.any(omega2 < 0):
        raise ChainFileError(f"{where}/omega2 holds negative modal stiffness: {_remedy(where)}")
    labels = tuple(s.decode() if isinstance(s, bytes) else str(s) for s in data["labels"])
    integrals = {key: data[key] for key in ("rigid_mass", "momentum", "inertia_gradient", "coriolis",
                                            *INSIDE_DATASETS) if data[key] is not None}
    return multibody.make_body(number, integrals, omega2, damping_ratio, labels)
