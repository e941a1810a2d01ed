"""The bodies' numbers and bearing names, the constants every stage shares (docs/body-data.md).

No I/O and no imports: the workflow reads them while it builds the DAG, where importing the
body file's reader (``gimbal_reduction.solver.bodydata``: h5py, SciPy) would cost every
invocation of Snakemake a third of a second.
"""

BODIES = (2, 3, 4, 5)   # outer, middle, inner gimbal, stable platform (thesis numbering)
BEARING_NAMES = ("input_motor", "input_resolver", "output_motor", "output_resolver")
