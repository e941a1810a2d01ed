# Outputs on request (none is part of `all`): the control-design export and the deformed bodies over
# time for ParaView, of any scene and reduced model.
#   snakemake --cores 2 results/export/thesis/freq-10.mat     linearised state space (.mat and .npz)
#   snakemake --cores 2 results/paraview/thesis/freq-10.pvd   PVD + VTU frames (+ a PNG of the last)
# Lints left, justified in common.smk (above GIMBAL): the rules' shell commands use GIMBAL, CONFIG from outside
# the rule; no rule names a conda environment or container (the project's .venv).


rule control_export:
    """The reduced model's linearised state space about the scene's initial state, for control
    design (gimbal_reduction.solver.dynamics.export; docs/examples/control_export.py loads it).
    """
    input:
        model=checked_model_file("results/export/{scene}/{model}.mat"),
    output:
        mat="results/export/{scene}/{model}.mat",
        npz="results/export/{scene}/{model}.npz",
    log:
        "logs/export/{scene}/{model}.log",
    benchmark:
        "results/benchmarks/rules/export/{scene}/{model}.tsv"
    resources:
        # no record yet: single runs on thesis, freq-10 5.8 s, 191 MB (under load); truth (404
        # coordinates) 4.0 s, 215 MB
        mem_mb=mem_mb(215.3),
        runtime=runtime_min(5.8),
    params:
        code=code_hash("export"),
        # the linearisation point and the damping are the scene's
        physics=scene_physics_hash,
        scene=scene_file,
        # the model's body files are checked against the configuration (--config)
        cfg=body_files_hash,
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} export --model-file {input.model} --scene {params.scene} "
        "--config {CONFIG} --out {output.mat} > {log} 2>&1"


rule simulate_modal:
    """The simulation of rule simulate with the modal coordinates stored (--store-modal), for the
    ParaView output: its own folder, so results/sim/ keeps the files every other stage reads.
    """
    input:
        model=checked_model_file("results/sim_modal/{scene}/{model}.h5"),
        kernels=ancient(KERNELS),
    output:
        "results/sim_modal/{scene}/{model}.h5",
    log:
        "logs/sim_modal/{scene}/{model}.log",
    benchmark:
        "results/benchmarks/rules/sim_modal/{scene}/{model}.tsv"
    resources:
        # as rule simulate (records: sim/thesis/truth.tsv 301.6 s, 780.5 MB, max of 121)
        mem_mb=mem_mb(780.5),
        runtime=runtime_min(301.6),
    params:
        physics=scene_physics_hash,
        scene=scene_file,
        code=code_hash("simulate"),
        integrator=cfgmod.value(config, "simulation.integrator"),
        options=integrator_options,
        cfg=body_files_hash,
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} simulate --scene {params.scene} --model-file {input.model} "
        "--integrator {params.integrator} {params.options} --store-modal --config {CONFIG} --out {output} "
        "> {log} 2>&1"


rule paraview:
    """The deformed bodies over time (gimbal_reduction.results.paraview): a PVD collection of 100 VTU frames at true
    scale, in inches, and a PNG of the last frame (gimbal_reduction.results.render)."""
    input:
        sim="results/sim_modal/{scene}/{model}.h5",
        model=checked_model_file("results/paraview/{scene}/{model}.pvd"),
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        meshes=expand("results/mesh/body{n}.msh", n=BODIES),
    output:
        pvd="results/paraview/{scene}/{model}.pvd",
        frames=directory("results/paraview/{scene}/{model}_frames"),
        png="results/paraview/{scene}/{model}.png",
    log:
        "logs/paraview/{scene}/{model}.log",
    benchmark:
        "results/benchmarks/rules/paraview/{scene}/{model}.tsv"
    resources:
        # no record yet: single runs on thesis (100 of 1501 samples): freq-10 6.0 s, 203 MB; static-8
        # (its static modes rebuilt from the full body files) 21.9 s, 653.1 MB
        mem_mb=mem_mb(653.1),
        runtime=runtime_min(21.9),
    params:
        code=code_hash("paraview"),
        frames=100,
        scale=1.0,
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} paraview --sim {input.sim} --model-file {input.model} "
        "--bodies {input.bodies} --meshes {input.meshes} --frames {params.frames} --scale {params.scale} "
        "--out {output.pvd} --png {output.png} > {log} 2>&1"
