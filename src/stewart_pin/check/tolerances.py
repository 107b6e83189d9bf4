"""The check's default tolerances, apart from :mod:`.constrained_dynamics` so that the
``stewart-pin validate`` options can show them without importing Pinocchio."""

__all__ = ["DDM_TOLERANCE", "IDM_TOLERANCE"]

#: Default relative tolerances of :meth:`ValidationReport.passed`: the inverse model, and
#: the direct model with the round trips (the one definition; the CLI's defaults).
IDM_TOLERANCE = 1e-9
DDM_TOLERANCE = 1e-8
