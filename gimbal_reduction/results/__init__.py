"""Stage 5: the study (``gimbal_reduction.results.study``) and the benchmarks and verification of the
dynamics (``gimbal_reduction.results.bench``).  Generated files go to the sibling folders results/<stage>/."""
