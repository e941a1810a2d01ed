"""Fast and stable: run time against error (Pareto), cost against size (scaling), the
stability stress tests, load-aware selection, and the dynamics verification with its JAX
oracle."""
