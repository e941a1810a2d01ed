# Verification of the finite-element stage (filled in by solver/verification.py).
