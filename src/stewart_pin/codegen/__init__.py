"""Symbolic generation, operation counts and compiled backends (paper section VII).

- :func:`generate_models` (chosen per architecture in :mod:`._architecture`, the one place
  codegen asks which robot it holds): the IDM and DDM of a robot as straight-line
  CasADi SX functions, the geometry baked in, the 88 base parameters an input; for a robot
  with general legs, the generic models of :mod:`.leg_chain_symbolic` (every number baked
  in, any leg architecture and joint term).
- :func:`cost_table` / :func:`cost_dict` / :func:`architecture_table` (:mod:`.opcount`):
  their operation counts beside the paper's Table IV.
- :func:`compiled_backend` / :class:`CompiledDynamics` (:mod:`.compiled`): the models
  compiled to C and called through :mod:`ctypes`, one state or batches, with a CasADi
  virtual-machine fallback when no C compiler is available.
- :class:`CompiledDerivatives` / :func:`derivatives_backend` (:mod:`.derivatives`): the exact
  Jacobians of both models in the platform state (pose chart, twist, third argument), by
  CasADi's algorithmic differentiation of the generated models, compiled the same way.
- :func:`simulate_batch` (:mod:`.simulator`): many fixed-step RK4 runs in C around the
  compiled direct model, on threads (``simulate`` takes the same C loop by itself).
- :func:`auto_backend`: what the default ``backend="auto"`` of ``StewartRobot`` runs.
- :func:`export_c` (:mod:`.c_export`): the models as a standalone C99 library (no CasADi,
  no Python, no allocation), with a test program, a benchmark and a C++ example.

Importing this subpackage imports none of them (nor CasADi): each name is imported on first
use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from stewart_pin._lazy import lazy_names
from stewart_pin.exceptions import CompilationError, UnsafeCacheError  # their old home

if TYPE_CHECKING:  # what type checkers see; at run time each name is imported on first use
    from stewart_pin.codegen._architecture import generate_models
    from stewart_pin.codegen.c_export import export_c
    from stewart_pin.codegen.compiled import (
        CompiledDynamics,
        auto_backend,
        cache_root,
        compiled_backend,
    )
    from stewart_pin.codegen.derivatives import (
        CompiledDerivatives,
        derivatives_backend,
        symbolic_derivatives,
    )
    from stewart_pin.codegen.opcount import (
        OperationCount,
        architecture_table,
        cost_dict,
        cost_table,
        count_operations,
    )
    from stewart_pin.codegen.simulator import simulate_batch
    from stewart_pin.codegen.symbolic import SymbolicModels

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "CompiledDynamics": "stewart_pin.codegen.compiled",
        "auto_backend": "stewart_pin.codegen.compiled",
        "cache_root": "stewart_pin.codegen.compiled",
        "compiled_backend": "stewart_pin.codegen.compiled",
        "CompiledDerivatives": "stewart_pin.codegen.derivatives",
        "derivatives_backend": "stewart_pin.codegen.derivatives",
        "symbolic_derivatives": "stewart_pin.codegen.derivatives",
        "export_c": "stewart_pin.codegen.c_export",
        "OperationCount": "stewart_pin.codegen.opcount",
        "architecture_table": "stewart_pin.codegen.opcount",
        "cost_dict": "stewart_pin.codegen.opcount",
        "cost_table": "stewart_pin.codegen.opcount",
        "count_operations": "stewart_pin.codegen.opcount",
        "SymbolicModels": "stewart_pin.codegen.symbolic",
        "generate_models": "stewart_pin.codegen._architecture",
        "simulate_batch": "stewart_pin.codegen.simulator",
    },
)

__all__ = [
    "CompilationError",
    "CompiledDerivatives",
    "CompiledDynamics",
    "OperationCount",
    "SymbolicModels",
    "UnsafeCacheError",
    "architecture_table",
    "auto_backend",
    "cache_root",
    "compiled_backend",
    "cost_dict",
    "cost_table",
    "count_operations",
    "derivatives_backend",
    "export_c",
    "generate_models",
    "simulate_batch",
    "symbolic_derivatives",
]
