"""Design studies: workspaces, singularity-free regions, actuator sizing, geometry sweeps.

- :mod:`.feasibility`: :func:`feasible`, which poses satisfy every limit, as a mask;
  :func:`leg_distance`, the smallest distance between two legs (interference).
- :mod:`.workspace`: :func:`workspace` (constant orientation), :func:`orientation_workspace`,
  :func:`dexterous_workspace`, each a :class:`Workspace` with a volume, its standard error,
  boundary points and slices.
- :mod:`.regions`: :func:`singularity_free_region` (the largest sphere and cube around a
  pose where the singularity measure stays under a bound, over a set of orientations),
  :func:`singularity_map` (the measure on a slice).
- :mod:`.sizing`: :func:`actuator_loads` (peak / RMS effort, speed and power along given
  motions), :func:`worst_case` (the worst state of a box of states, by optimisation from
  the sampled worst), :func:`dynamic_capability` (the largest platform acceleration in
  each direction under the effort limits, one LP per direction), :func:`wrench_capability`
  (the largest static force or moment the platform exerts in each direction).
- :mod:`.sweep`: :func:`sweep`, a family of geometries evaluated in parallel on Dask.

Sits above the planning, parameters and motion layers and the robot facade (it builds
robots from descriptions), below the viewer, the applications and the command line.
Dask is imported only by :func:`sweep` (``pip install "stewart-pin[design]"``).
"""

from stewart_pin.design.feasibility import feasible, leg_distance, segment_distance
from stewart_pin.design.regions import (
    SingularityFreeRegion,
    singularity_free_region,
    singularity_map,
)
from stewart_pin.design.sizing import (
    ActuatorLoads,
    Capability,
    StateBox,
    WorstCase,
    WrenchCapability,
    actuator_loads,
    dynamic_capability,
    worst_case,
    wrench_capability,
    write_report,
)
from stewart_pin.design.sweep import (
    BASE_GEOMETRY,
    SweepResult,
    SweepSettings,
    evaluate_geometry,
    grid,
    sweep,
)
from stewart_pin.design.workspace import (
    Workspace,
    dexterous_workspace,
    orientation_workspace,
    workspace,
)

__all__ = [
    "BASE_GEOMETRY",
    "ActuatorLoads",
    "Capability",
    "SingularityFreeRegion",
    "StateBox",
    "SweepResult",
    "SweepSettings",
    "Workspace",
    "WorstCase",
    "WrenchCapability",
    "actuator_loads",
    "dexterous_workspace",
    "dynamic_capability",
    "evaluate_geometry",
    "feasible",
    "grid",
    "leg_distance",
    "orientation_workspace",
    "segment_distance",
    "singularity_free_region",
    "singularity_map",
    "sweep",
    "workspace",
    "worst_case",
    "wrench_capability",
    "write_report",
]
