# Stage 3b: one reduced model of the chain for one scene -- the file a simulation reads
# (solver/dynamics/chainfile.py, docs/models.md).  A simulation job never loads the four
# full body files; this rule reduces them once per (scene, model).
models_mod = importlib.import_module("reduction.models")
scenes_mod = importlib.import_module("solver.dynamics.scenes")

wildcard_constraints:
    scene="[A-Za-z0-9_-]+",


def scene_file(wildcards):
    return os.path.join("config", "scenes", f"{wildcards.scene}.yaml")


def model_inputs(wildcards):
    """What one reduced model needs, and nothing else: every body file (mass properties),
    the reduction files only if the model's selection reads a ranking (xmx, xmgmx, load,
    global), and the scene's load-aware ranking for load-* and global-*.  So the DAG of
    results/sim/thesis/freq-10.h5 is four meshes, four modal solutions, one reduced model
    and one simulation."""
    needed = {"bodies": [f"results/modes/body{n}.h5" for n in BODIES]}
    if models_mod.needs_reduction_rankings(wildcards.model):
        needed["reductions"] = [f"results/reduction/body{n}.h5" for n in BODIES]
    if models_mod.needs_load_ranking(wildcards.model):
        needed["load_ranking"] = f"results/reduction/load/{wildcards.scene}.h5"
    return needed


def ranking_options(wildcards, input):
    """The reduction and load-ranking files of a model, as options of reduction.models."""
    options = []
    if "reductions" in input.keys():
        options.append("--reductions " + " ".join(input.reductions))
    if "load_ranking" in input.keys():
        options.append(f"--load-ranking {input.load_ranking}")
    return " ".join(options)


def scene_elastic_bodies(wildcards):
    """What a reduced model reads from its scene: the elastic bodies (needs.bodies)."""
    return list(scenes_mod.load_scene(scene_file(wildcards)).elastic_bodies)


rule reduced_model:
    input:
        unpack(model_inputs),
    output:
        "results/models/{scene}/{model}.h5",
    params:
        code=code_hash("reduction.models"),
        scene=scene_file,
        elastic_bodies=scene_elastic_bodies,
        rankings=ranking_options,
    log:
        "logs/models/{scene}/{model}.log",
    benchmark:
        "results/benchmarks/rules/models/{scene}/{model}.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m reduction.models --model '{wildcards.model}' --scene {params.scene} "
        "--bodies {input.bodies} {params.rankings} --out {output} > {log} 2>&1"
