"""Inertial parameters: base (numerical by QR, analytic by the paper's grouping rules,
eq. 44-50) and essential parameters, and their identification from measurements
(exciting trajectories, weighted least squares with confidence intervals, the flags of
poorly identified parameters), from a
robot's logs of actuator positions and efforts (:mod:`.logs`, :mod:`.state_estimation`,
:mod:`.least_squares`: chunked, bounded memory) and physically consistent estimates
(:mod:`.physical`).

Stands on the regressor of :mod:`stewart_pin.dynamics`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from stewart_pin._lazy import lazy_names

if TYPE_CHECKING:  # what type checkers see; at run time each name is imported on first use
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
        ActuatorLimits,
        IdentificationResult,
        LogIdentification,
        Measurements,
        ParameterFlag,
        base_without,
        exciting_trajectory,
        identify,
        identify_log,
        log_prediction_error,
        read_measurements_csv,
        simulate_measurements,
        write_measurements_csv,
    )
    from .logs import ActuatorLog, read_log, write_log
    from .physical import PhysicalEstimate, physically_consistent

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "BaseParameters": ".base",
        "EssentialParameters": ".base",
        "analytic_base_parameters": ".base",
        "base_parameters": ".base",
        "essential_parameters": ".base",
        "numerical_base_parameters": ".base",
        "paper_essential_parameters": ".base",
        "ActuatorLimits": ".identification",
        "IdentificationResult": ".identification",
        "LogIdentification": ".identification",
        "Measurements": ".identification",
        "ParameterFlag": ".identification",
        "base_without": ".identification",
        "exciting_trajectory": ".identification",
        "identify": ".identification",
        "identify_log": ".identification",
        "log_prediction_error": ".identification",
        "read_measurements_csv": ".identification",
        "simulate_measurements": ".identification",
        "write_measurements_csv": ".identification",
        "ActuatorLog": ".logs",
        "read_log": ".logs",
        "write_log": ".logs",
        "PhysicalEstimate": ".physical",
        "physically_consistent": ".physical",
    },
)

__all__ = [
    "ActuatorLimits",
    "ActuatorLog",
    "BaseParameters",
    "EssentialParameters",
    "IdentificationResult",
    "LogIdentification",
    "Measurements",
    "ParameterFlag",
    "PhysicalEstimate",
    "analytic_base_parameters",
    "base_parameters",
    "base_without",
    "essential_parameters",
    "exciting_trajectory",
    "identify",
    "identify_log",
    "log_prediction_error",
    "numerical_base_parameters",
    "paper_essential_parameters",
    "physically_consistent",
    "read_log",
    "read_measurements_csv",
    "simulate_measurements",
    "write_log",
    "write_measurements_csv",
]
