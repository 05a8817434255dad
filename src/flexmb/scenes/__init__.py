"""Ready-made models built in Python: the wiper, the B5 four-bar, the benchmark Whipple bicycle.

The tutorials, tests and benchmarks use them.

The built-in scenes of the command line (``flexmb run wiper``) are scene
files shipped in ``flexmb/scene/builtin/``, run by :mod:`flexmb.scene`.
"""
