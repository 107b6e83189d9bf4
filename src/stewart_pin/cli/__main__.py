"""``python -m stewart_pin.cli``: the ``stewart-pin`` command without its console script
(a source checkout on ``PYTHONPATH``)."""

import sys

from stewart_pin.cli import main

if __name__ == "__main__":  # not when a tool imports every module of the package
    sys.exit(main())
