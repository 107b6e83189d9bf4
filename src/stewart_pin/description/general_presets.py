"""Deprecated: renamed :mod:`stewart_pin.description.leg_chain_presets` (the presets built
of leg chains: ups-offset, rus, pus, random; issue 19 named the ``general_*`` twins after
what they hold).

Every name read from this module is that of the new module and warns
(``DeprecationWarning``) naming its new place.
"""

from __future__ import annotations

from stewart_pin._moved import moved_module
from stewart_pin.description import leg_chain_presets as _new

__getattr__ = moved_module(__name__, _new)
