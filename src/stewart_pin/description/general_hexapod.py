"""Deprecated: renamed :mod:`stewart_pin.description.leg_chain_hexapod` (a robot's six leg
chains placed on the base; issue 19 named the ``general_*`` twins after what they hold).

Every name read from this module is that of the new module and warns
(``DeprecationWarning``) naming its new place.
"""

from __future__ import annotations

from stewart_pin._moved import moved_module
from stewart_pin.description import leg_chain_hexapod as _new

__getattr__ = moved_module(__name__, _new)
