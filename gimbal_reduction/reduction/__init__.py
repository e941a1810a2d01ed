"""Model reduction of one elastic body (thesis Chapter 3): modal integrals,
XMX/XMGMX rankings and static correction modes, as pure functions on
numpy/scipy arrays.  Stage entry point: ``python -m gimbal_reduction.reduction.stage``.
Method notes, output layout and deviations from the thesis: docs/reduction.md.
"""
