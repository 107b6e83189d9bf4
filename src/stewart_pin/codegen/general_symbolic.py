"""Deprecated: renamed :mod:`stewart_pin.codegen.leg_chain_symbolic` (the generic symbolic
models of leg chains; issue 19 named the ``general_*`` twins after what they hold).

Every name read from this module is that of the new module and warns
(``DeprecationWarning``) naming its new place.
"""

from __future__ import annotations

from stewart_pin._moved import moved_module
from stewart_pin.codegen import leg_chain_symbolic as _new

__getattr__ = moved_module(__name__, _new)
