"""dynaeval: evaluation toolkit for dynamic novel view synthesis.

Scores rendered frames against ground truth over the whole frame, in boxes around the action
(*focused*), on moving pixels (*masked*) and over time (*temporal*).
"""

__version__ = "0.1.0"
