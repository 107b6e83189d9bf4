"""Programs built on the library, kept out of its layers: the demo (the whole workflow on
a preset into one folder), the payload demo (an arm's fast move compensated by the
hexapod, :mod:`.payload_demo`) and the benchmark (medians and ratios against
``pin.constraintDynamics`` in one run). The command line runs them
(``stewart-pin demo``, ``stewart-pin demo --payload``, ``stewart-pin bench``).
"""
