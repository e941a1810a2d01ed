"""Errors of the reduction stage.

Every error is a ``ValueError`` subclass with a one-line message that names the
culprit (file, load case, bearing, mode count, matrix), raised before the
expensive work (factorisations, solves) wherever the check is cheap.
A bad body file raises ``gimbal_reduction.solver.bodydata.BodyFileError`` (the contract's owner).
"""
from gimbal_reduction.solver.bodydata import BodyFileError  # noqa: F401  (raised by the reduction stage's reads)


class ReductionError(ValueError):
    """Base class: bad input to a reduction function (one-line message)."""

    def __init__(self, message):
        super().__init__(" ".join(str(message).split()))


class UnknownLoadCaseError(ReductionError):
    """A static load case name that is not ``{bearing}_{f|m}{x|y|z}``."""


class BearingIndexError(ReductionError):
    """A bearing index outside 0..3."""


class MissingBearingError(ReductionError):
    """A bearing that the body does not have (platform: output bearings 2, 3)."""


class ModeCountError(ReductionError):
    """More modes asked for than computed, or an invalid kept-mode selection."""


class SingularStiffnessError(ReductionError):
    """The supported stiffness T^T K T is singular (missing supports)."""


class SingularMassError(ReductionError):
    """T^T M T is singular in a way the reduction cannot certify."""


class StaticModeError(ReductionError):
    """A static correction mode vanishes or the static set is degenerate."""
