"""Stage 5: the study (``results.study``) and the benchmarks and verification of the
dynamics (``results.bench``).  Generated files go to the sibling folders results/<stage>/."""
