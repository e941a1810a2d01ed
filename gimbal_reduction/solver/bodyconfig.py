"""Which configuration made an intermediate file, checked against the current one.

The modal stage writes ``gimbal_reduction.workflow.config.inputs_hash(body_inputs(config, n))`` into a body file
as its ``config_hash`` attribute (``expected_hashes`` gives it for every body); the reduction
stage copies it (with ``body``) into its file, and the load-aware ranking and the reduced-model
file record the four as ``body_config_hashes`` (JSON list, bodies 2..5).  A stage given
``--config FILE`` calls ``check_files`` on the files it reads, before any work: a file made
from another configuration (copied in, or kept by a run whose Snakemake records were lost) is
refused with a one-line ``BodyFileError`` naming the file and the target to rerun, instead of
giving a wrong answer.  Only the attributes are read; a missing or unreadable file is left to
its checked reader (``gimbal_reduction.solver.bodydata.read_body_file``, ``gimbal_reduction.reduction.models``, ``chainfile``).

This module is imported by the stages that read body files, not by the modal stage that writes
them, so editing it reruns no modal solution.
"""
from __future__ import annotations

import json

import h5py

from gimbal_reduction.solver.bodydata import BODIES, BodyFileError, remedy
from gimbal_reduction.workflow import config as cfgmod


def expected_hashes(config) -> dict:
    """{body: config_hash} the configuration ``config`` (a validated dict, or a file's path) gives
    each body file."""
    if not isinstance(config, dict):
        config = cfgmod.load_config(config)
    return {b: cfgmod.inputs_hash(cfgmod.body_inputs(config, b)) for b in BODIES}


def _attributes(path) -> dict | None:
    try:
        with h5py.File(path, "r") as f:
            return {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
    except (OSError, ValueError, TypeError):    # missing or unreadable: its checked reader says so
        return None


def check_slots(paths) -> None:
    """Refuse (BodyFileError, one line) a body or reduction file given in another body's slot:
    ``paths`` are the files of bodies 2, 3, 4, 5 in that order, and each one's ``body`` attribute
    must be its slot's (no configuration needed: body 3's file copied over body 4's is caught
    here).  A file without the attribute, or unreadable, is left to its checked reader."""
    for slot, path in zip(BODIES, map(str, paths)):
        attrs = _attributes(path)
        try:
            body = int(attrs["body"])
        except (TypeError, KeyError, ValueError):
            continue
        if body != slot:
            raise BodyFileError(f"{path}: the file of body {body} given as body {slot}'s (the files go in "
                                f"the order of bodies 2, 3, 4, 5)")


def check_files(paths, config) -> None:
    """Refuse (BodyFileError, one line) the first of ``paths`` made from another configuration than
    ``config`` (a validated dict or a file's path; None checks nothing): a body or reduction file
    whose ``config_hash`` is not the one the configuration gives its ``body``, or a ranking or
    reduced-model file whose ``body_config_hashes`` differ from the four it gives."""
    if config is None:
        return
    expected = expected_hashes(config)
    current = "the current configuration" + ("" if isinstance(config, dict) else f" ({config})")

    def rerun(path):
        """The target to rerun, with the configuration in use (Snakemake's default is another)."""
        return remedy(path) + ("" if isinstance(config, dict) else f" --configfile {config}")

    for path in map(str, paths):
        attrs = _attributes(path)
        if attrs is None:
            continue
        if "body_config_hashes" in attrs:
            try:
                found = dict(zip(BODIES, json.loads(attrs["body_config_hashes"])))
            except (TypeError, ValueError):
                raise BodyFileError(f"{path}: attribute body_config_hashes unreadable "
                                    f"({attrs['body_config_hashes']!r}): {rerun(path)}") from None
            stale = [b for b in BODIES if str(found.get(b)) != expected[b]]
            if stale:
                b = stale[0]
                raise BodyFileError(f"{path}: made from body files of another configuration (body {b}: "
                                    f"config_hash {found.get(b)!r}, {current} gives {expected[b]!r}): "
                                    f"{rerun(path)}")
            continue
        try:
            body = int(attrs["body"])
        except (KeyError, TypeError, ValueError):
            body = None
        if "config_hash" not in attrs or body not in expected:
            raise BodyFileError(f"{path}: attribute body_config_hashes, or body and config_hash, missing "
                                f"(the configuration it was made from is unknown): {rerun(path)}")
        if str(attrs["config_hash"]) != expected[body]:
            raise BodyFileError(f"{path}: made from another configuration (attribute config_hash "
                                f"{attrs['config_hash']!r}, {current} gives {expected[body]!r}): "
                                f"{rerun(path)}")
