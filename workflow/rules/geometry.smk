# Stage 1: gmsh meshes of the three rings (shell mid-surfaces) and the platform (solid).


rule mesh_body:
    input:
        GEOMETRY_CODE,
    output:
        "results/mesh/body{n}.msh",
    params:
        cfg=lambda w: cfgmod.section_hash(config, f"bodies.{cfgmod.body_name(w.n)}", "eccentric_mass",
                                          "bearing_connection", "mesh"),
    log:
        "logs/mesh/body{n}.log",
    benchmark:
        "results/benchmarks/rules/mesh_body{n}.tsv"
    shell:
        "{PY} -m geometry.mesh --body {wildcards.n} --out {output} --config {CONFIG} > {log} 2>&1"


rule mesh:
    input:
        expand("results/mesh/body{n}.msh", n=BODIES),
