"""Speed and accuracy benchmarks, run from the repository root (``python benchmarks/NAME.py``).

Not part of the ``dynaeval`` wheel; a package only so that the tests can import ``benchmarks.bench``.
"""
