"""``python -m stewart_pin.cli``: the ``stewart-pin`` command without its console script
(a source checkout on ``PYTHONPATH``)."""

import sys

from stewart_pin.cli import main

sys.exit(main())
