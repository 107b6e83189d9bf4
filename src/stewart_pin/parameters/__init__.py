"""Inertial parameters: base (numerical by QR, analytic by the paper's grouping rules,
eq. 44-50) and essential parameters, and their identification from measurements
(exciting trajectories, weighted least squares with confidence intervals).

Stands on the regressor of :mod:`stewart_pin.dynamics`.
"""

from .base import (
    BaseParameters,
    EssentialParameters,
    analytic_base_parameters,
    base_parameters,
    essential_parameters,
    numerical_base_parameters,
    paper_essential_parameters,
)
from .identification import (
    IdentificationResult,
    Measurements,
    exciting_trajectory,
    identify,
    read_measurements_csv,
    simulate_measurements,
    write_measurements_csv,
)

__all__ = [
    "BaseParameters",
    "EssentialParameters",
    "IdentificationResult",
    "Measurements",
    "analytic_base_parameters",
    "base_parameters",
    "essential_parameters",
    "exciting_trajectory",
    "identify",
    "numerical_base_parameters",
    "paper_essential_parameters",
    "read_measurements_csv",
    "simulate_measurements",
    "write_measurements_csv",
]
