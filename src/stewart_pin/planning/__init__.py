"""Motions planned by optimisation on the exact closed-form models.

- :func:`optimal_point_to_point` (:mod:`.point_to_point`): the minimum-effort rest-to-rest
  motion under actuator effort and speed limits and the stroke, by direct multiple
  shooting on the generated direct model, solved by IPOPT through CasADi; its result
  :class:`OptimalMotion` replays itself open loop in the simulator.

Importing this subpackage imports CasADi; ``import stewart_pin`` does not.
"""

from stewart_pin.planning.point_to_point import OptimalMotion, optimal_point_to_point

__all__ = ["OptimalMotion", "optimal_point_to_point"]
