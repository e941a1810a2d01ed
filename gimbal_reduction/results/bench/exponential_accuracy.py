"""Accuracy of the modal exponential integrator on every scene.

    python -m gimbal_reduction.results.bench.exponential_accuracy --truth-model results/models/thesis/truth.h5 \\
        --reference thesis=results/reference/thesis/truth.h5 free=results/reference/free/truth.h5 ... \\
        --out-json results/verification/exponential.json --out-md results/verification/exponential.md

For every scene given a converged reference of the truth model, the truth model is integrated by the exponential
integrator at its default tolerance (or the scene's exponential_tolerance where that is
tighter, as the workflow runs it: ``long``) and at a tight one (``TIGHT_FACTOR`` times smaller; ``EXPONENTIAL_TIGHT_FACTOR`` against an
exponential reference),
and the error measure of the thesis (eq. 3.53) is computed per gimbal rate against the
reference.  The check: E_max <= ``E_BOUND`` at the default tolerance (the bound
on the truth model), and the tight run no worse than the default one (convergence).
Also recorded: steps, right-hand-side evaluations, bases (re-linearisations, of them
for the phase error), wall time.

A reference is either DOP853 at rtol <= 1e-10 (rule ``reference_simulation``; minutes to an hour
of one core) or, the faster route, the exponential integrator itself at a tolerance
``EXPONENTIAL_REFERENCE_FACTOR`` times tighter than the scene's (rule ``reference_exponential``;
seconds).  The second is only as good as its agreement with the first: ``--anchor SCENE=FILE``
gives DOP853 references of some scenes, and each exponential reference of such a scene is checked
against it, E_max <= ``ANCHOR_BOUND`` (a referee ten times finer than the bound it referees).  A
reference of the same truth model and scene, or a one-line error before any integration.  Other
scenes' references may be made at another Adams order (the workflow's ``ALL_REFERENCE_ORDERS``):
``--anchor-orders N ...`` checks that route too, the anchored scene's truth integrated at its
reference's tolerance with each such order and held to the same bound against DOP853.

``--runs SCENE=FILE`` gives the workflow's own run of a scene's truth at the tolerance it runs the
scene at (the study's results/study/{scene}/sim/truth.h5): the default case is read from it, not
integrated again (checked: the same scene, truth model, integrator and tolerance as the case).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import h5py
import numpy as np

from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.solver.dynamics import chainfile, exponential, integrators, scenes
from gimbal_reduction.solver.dynamics.error_measure import error_measure
from gimbal_reduction.solver.dynamics.simulate import scene_problem
from gimbal_reduction.workflow.provenance import check_record, provenance, versions, write_json, write_text

E_BOUND = 1e-8          # E <= 1e-8 on every rate, truth model
TIGHT_FACTOR = 100.0    # the tight tolerance: default / TIGHT_FACTOR
REFERENCE_RTOL = 1e-10  # a DOP853 reference must be at least this converged
# an exponential reference: at most the scene's tolerance / this; against it the tight run is at the
# tolerance / EXPONENTIAL_TIGHT_FACTOR, judged against something ten times finer than itself
EXPONENTIAL_REFERENCE_FACTOR = 100.0
EXPONENTIAL_TIGHT_FACTOR = 10.0
ANCHOR_BOUND = E_BOUND / 10   # an exponential reference against DOP853 (--anchor), E_max


class AccuracyInputError(ValueError):
    """A bad argument or reference file (one-line message)."""


def parse_references(items):
    """{scene: path} of SCENE=FILE arguments; AccuracyInputError on a malformed or repeated one."""
    out = {}
    for item in items:
        scene, sep, path = item.partition("=")
        if not sep or not scene or not path:
            raise AccuracyInputError(f"--reference takes SCENE=FILE, got {item!r}")
        if scene in out:
            raise AccuracyInputError(f"--reference: scene {scene!r} given twice")
        out[scene] = path
    return out


def read_reference(scene, path, truth_hash, scene_tol=None):
    """(t (T,), gamma_dot (T, 4), kind) of a reference file, checked: same scene, the truth model
    of the same config hash, DOP853 at rtol <= REFERENCE_RTOL or (with ``scene_tol``, the
    tolerance the scene is run at) the exponential integrator at tol <= scene_tol /
    EXPONENTIAL_REFERENCE_FACTOR; kind is "dop853 rtol R" or "exponential tol T"."""
    if not os.path.exists(path):
        raise AccuracyInputError(f"reference of scene {scene!r}: {path} does not exist")
    with h5py.File(path, "r") as f:
        a = dict(f.attrs)
        t, rates = f["t"][()], f["gamma_dot"][()]
    problems = []
    if str(a.get("scene")) != scene:
        problems.append(f"scene {a.get('scene')!r}")
    if str(a.get("model")) != "truth" or str(a.get("model_config_hash")) != truth_hash:
        problems.append(f"model {a.get('model')!r} of another config")
    integrator = str(a.get("integrator"))
    if integrator == "dop853" and float(a.get("stat_rtol", 1.0)) <= REFERENCE_RTOL:
        kind = f"dop853 rtol {float(a['stat_rtol']):g}"
    elif (integrator == "exponential" and scene_tol is not None
          and float(a.get("stat_exponential_tol", 1.0)) <= scene_tol / EXPONENTIAL_REFERENCE_FACTOR * (1 + 1e-9)):
        kind = f"exponential tol {float(a['stat_exponential_tol']):g}" + (
            f", order {int(a['stat_exponential_order'])}" if "stat_exponential_order" in a else "")
    else:
        tol = a.get("stat_rtol") if integrator == "dop853" else a.get("stat_exponential_tol")
        problems.append(f"integrator {integrator} at {tol} (a reference: dop853 at rtol <= {REFERENCE_RTOL:g}"
                        + (f" or exponential at tol <= {scene_tol / EXPONENTIAL_REFERENCE_FACTOR:g}"
                           if scene_tol is not None else "") + ")")
    if problems:
        raise AccuracyInputError(f"reference {path} is not the converged truth of scene {scene!r}: "
                                 + ", ".join(problems))
    return t, rates, kind


def scene_case(chain, scene, t_ref, rates_ref, tol):
    """The record of one scene at one tolerance: E per rate, E_max, counts, wall time."""
    t0 = time.perf_counter()
    prob = scene_problem(chain, scene)
    run = integrators.integrate(prob, scene.duration, scene.output_interval,
                                method="exponential", tol=tol, model="truth")
    wall = time.perf_counter() - t0
    E = np.asarray(error_measure(t_ref, rates_ref, run.yd[:, :4]))
    st = run.stats
    return {"tol": tol, "E": E.tolist(), "E_max": float(np.nanmax(E)), "steps": run.steps,
            "evaluations": int(st["evaluations"]), "bases": int(st["relinearisations"]) + 1,
            "phase_bases": int(st["phase_relinearisations"]), "rejected": int(st["rejected"]),
            "wall_s": wall, "basis_s": float(st["basis_time_s"])}


def file_case(path, scene, truth_hash, t_ref, rates_ref, tol):
    """The record of ``scene_case`` from a simulation file of the truth at ``tol`` (``--runs``), its
    wall time the file's integration time; AccuracyInputError if the file is another scene, model,
    integrator or tolerance, or has another output grid than the reference."""
    if not os.path.exists(path):
        raise AccuracyInputError(f"--runs of scene {scene!r}: {path} does not exist")
    with h5py.File(path, "r") as f:
        a = dict(f.attrs)
        t, rates = f["t"][()], f["gamma_dot"][()]
    file_tol = float(a.get("stat_exponential_tol", np.nan))
    problems = [what for what, bad in (
        (f"scene {a.get('scene')!r}", str(a.get("scene")) != scene),
        (f"model {a.get('model')!r} of another config",
         str(a.get("model")) != "truth" or str(a.get("model_config_hash")) != truth_hash),
        (f"integrator {a.get('integrator')} at tol {file_tol:g} (the case: exponential at {tol:g})",
         str(a.get("integrator")) != "exponential" or not abs(file_tol - tol) <= 1e-9 * tol),
        (f"{len(t)} outputs (the reference: {len(t_ref)})", len(t) != len(t_ref))) if bad]
    if problems:
        raise AccuracyInputError(f"--runs {path} is not the truth of scene {scene!r} at tol {tol:g}: "
                                 + ", ".join(problems))
    E = np.asarray(error_measure(t_ref, rates_ref, rates[:, :4]))
    return {"tol": tol, "E": E.tolist(), "E_max": float(np.nanmax(E)), "steps": int(a["steps"]),
            "evaluations": int(a["stat_evaluations"]), "bases": int(a["stat_relinearisations"]) + 1,
            "phase_bases": int(a["stat_phase_relinearisations"]), "rejected": int(a["stat_rejected"]),
            "wall_s": float(a["integration_time_s"]), "basis_s": float(a["stat_basis_time_s"]),
            "run_file": path}


def anchor_check(scene, reference, anchor):
    """(row, check) of a reference against a DOP853 one of the same scene: E of eq. 3.53 per gimbal
    rate, the reference taken as the case; the check: E_max <= ANCHOR_BOUND.  ``reference`` and
    ``anchor`` are (t (T,) [s], gamma_dot (T, 4) [rad/s], kind) of read_reference, on the same grid."""
    t_anchor, rates_anchor, anchor_kind = anchor
    _, rates_ref, kind = reference
    E = np.asarray(error_measure(t_anchor, rates_anchor, rates_ref))
    row = {"scene": scene, "reference": kind, "anchor": anchor_kind, "E": E.tolist(),
           "E_max": float(np.nanmax(E))}
    return row, check_record(f"{scene}: the reference ({kind}) against DOP853 ({anchor_kind}), E max",
                             row["E_max"], ANCHOR_BOUND)


def route_case(scene, chain, reference_path, order):
    """(t (T,) [s], gamma_dot (T, 4) [rad/s], kind): the truth of ``scene`` integrated as its exponential
    reference (``reference_path``: its tolerance) was, but at Adams order ``order``: the route another
    scene's reference took, for ``anchor_check`` against DOP853."""
    with h5py.File(reference_path, "r") as f:
        tol = float(f.attrs["stat_exponential_tol"])
    run = integrators.integrate(scene_problem(chain, scene), scene.duration, scene.output_interval,
                                method="exponential", tol=tol, order=order, model="truth")
    return run.t, np.asarray(run.yd[:, :4]), f"exponential tol {tol:g}, order {order}"


def markdown(rows, anchors=()):
    lines = ["| scene | reference | tol | E max | steps | bases | wall [s] | E max, tight tol | steps |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        d, t = r["default"], r["tight"]
        lines.append(f"| {r['scene']} | {r.get('reference_kind', '')} | {d['tol']:g} | {d['E_max']:.2e} | "
                     f"{d['steps']} | {d['bases']} | {d['wall_s']:.2f} | {t['E_max']:.2e} | {t['steps']} |")
    for a in anchors:
        lines.append(f"\nReference of {a['scene']} ({a['reference']}) against DOP853 ({a['anchor']}): "
                     f"E max {a['E_max']:.2e} (bound {ANCHOR_BOUND:g}).")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m gimbal_reduction.results.bench.exponential_accuracy",
                                 description="E of the exponential integrator against converged "
                                             "DOP853 references, per scene.")
    ap.add_argument("--truth-model", required=True)
    ap.add_argument("--reference", nargs="+", required=True, metavar="SCENE=FILE")
    ap.add_argument("--anchor", nargs="*", default=[], metavar="SCENE=FILE",
                    help="DOP853 references (rtol <= 1e-10) that the exponential references of the same "
                         "scenes are checked against")
    ap.add_argument("--anchor-orders", nargs="*", type=int, default=[], metavar="N",
                    help="Adams orders other scenes' exponential references were made at: each anchored "
                         "scene's truth is integrated at its reference's tolerance at each order that "
                         "reference did not use, and checked against DOP853 too")
    ap.add_argument("--runs", nargs="*", default=[], metavar="SCENE=FILE",
                    help="the workflow's runs of the truth at the scenes' tolerance: each scene's "
                         "default case read from its file instead of integrated")
    ap.add_argument("--tol", type=float, default=exponential.DEFAULTS.tol)
    ap.add_argument("--out-json", required=True)
    ap.add_argument("--out-md", required=True)
    ap.add_argument("--config", help="the current configuration file: input files of another "
                                     "configuration are refused before the work (gimbal_reduction.solver.bodyconfig)")
    args = ap.parse_args(argv)
    start = time.perf_counter()
    try:
        bodyconfig.check_files([args.truth_model], args.config)
        exponential.ExponentialOptions(tol=args.tol)
        for order in args.anchor_orders:
            exponential.ExponentialOptions(tol=args.tol, order=order)
        refs = parse_references(args.reference)
        anchors = parse_references(args.anchor)
        run_files = parse_references(args.runs)
        if set(run_files) - set(refs):
            raise AccuracyInputError(f"--runs of scene(s) {', '.join(sorted(set(run_files) - set(refs)))} "
                                     "without a --reference to judge them")
        if set(anchors) - set(refs):
            raise AccuracyInputError(f"--anchor of scene(s) {', '.join(sorted(set(anchors) - set(refs)))} "
                                     "without a --reference to check")
        loaded, anchored = {}, {}
        for name, path in refs.items():
            scene = scenes.load_scene(name)
            chain, info = chainfile.read_chain(args.truth_model, scene.damping_ratio)
            if str(info.get("model")) != "truth":
                raise AccuracyInputError(f"{args.truth_model} holds {info.get('model')!r}, not the truth")
            truth_hash = str(info.get("config_hash"))
            loaded[name] = (scene, chain, *read_reference(name, path, truth_hash,
                                                          scene.tighter_tolerance(args.tol)))
            if name in anchors:
                anchored[name] = read_reference(name, anchors[name], truth_hash)
                if not anchored[name][2].startswith("dop853"):
                    raise AccuracyInputError(f"--anchor {anchors[name]}: not a DOP853 reference")
                if args.anchor_orders and not loaded[name][4].startswith("exponential"):
                    raise AccuracyInputError(f"--anchor-orders: the reference of scene {name!r} ({path}) "
                                             "is not an exponential one whose tolerance a route could take")
        if args.anchor_orders and not anchors:
            raise AccuracyInputError("--anchor-orders without an --anchor to check the routes against")
        from_files = {name: file_case(path, name, truth_hash, loaded[name][2], loaded[name][3],
                                      loaded[name][0].tighter_tolerance(args.tol))
                      for name, path in run_files.items()}
    except (OSError, ValueError) as exc:
        print(f"exponential_accuracy: {exc}", file=sys.stderr)
        return 2
    rows, checks, anchor_rows = [], [], []
    for name, anchor in anchored.items():
        row, check = anchor_check(name, loaded[name][2:], anchor)
        anchor_rows.append({**row, "anchor_file": anchors[name]})
        checks.append(check)
        print(f"exponential_accuracy: {check['name']}: {row['E_max']:.2e}", flush=True)
        scene, chain, kind = loaded[name][0], loaded[name][1], loaded[name][4]
        for order in sorted(set(args.anchor_orders)):
            if kind.endswith(f", order {order}"):
                continue                                # the reference itself took this route
            row, check = anchor_check(name, route_case(scene, chain, refs[name], order), anchor)
            anchor_rows.append({**row, "anchor_file": anchors[name], "route_order": order})
            checks.append(check)
            print(f"exponential_accuracy: {check['name']}: {row['E_max']:.2e}", flush=True)
    for name, (scene, chain, t_ref, rates_ref, kind) in loaded.items():
        tol = scene.tighter_tolerance(args.tol)         # as the workflow runs the scene
        default = from_files.get(name) or scene_case(chain, scene, t_ref, rates_ref, tol)
        tight_factor = TIGHT_FACTOR if kind.startswith("dop853") else EXPONENTIAL_TIGHT_FACTOR
        tight = scene_case(chain, scene, t_ref, rates_ref, tol / tight_factor)
        rows.append({"scene": name, "reference": refs[name], "reference_kind": kind, "default": default,
                     "tight": tight})
        checks.append(check_record(f"{name}: E max at tol {tol:g} (truth model)",
                                   default["E_max"], E_BOUND))
        checks.append(check_record(f"{name}: E max at tol {tol / tight_factor:g} no worse than "
                                   f"at {tol:g} (x1.5)", tight["E_max"], 1.5 * default["E_max"]))
        print(f"exponential_accuracy: {name}: E {default['E_max']:.2e} ({default['steps']} steps, "
              f"{default['bases']} bases, {default['wall_s']:.2f} s); tight {tight['E_max']:.2e}",
              flush=True)
    record = provenance(sources=[args.truth_model, *refs.values(), *anchors.values(), *run_files.values()])
    write_text(args.out_md, markdown(rows, anchor_rows), record)
    write_json(args.out_json, {"stage": "exponential_accuracy", "rows": rows, "anchors": anchor_rows,
                               "checks": checks,
                               "passed": all(c["passed"] for c in checks), "E_bound": E_BOUND,
                               "inputs": [args.truth_model, *refs.values()],
                               "wall_time_s": time.perf_counter() - start, "versions": versions()}, record)
    failed = [c["name"] for c in checks if not c["passed"]]
    print(f"exponential_accuracy: {len(checks) - len(failed)}/{len(checks)} checks passed"
          + (f"; FAILED: {'; '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
