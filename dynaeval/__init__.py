"""dynaeval: evaluation toolkit for dynamic novel view synthesis.

Scores rendered frames against ground truth over the whole frame, in boxes around the action
(*focused*), on moving pixels (*masked*) and over time (*temporal*).

``dynaeval.score(pred_dir, gt_dir, ...)`` runs a whole evaluation with the defaults of
``dynaeval score`` (``ScoreConfig``); ``dynaeval.metrics`` holds the metrics as pure functions and
``dynaeval.metrics.registry`` declares every one of them. Heavy dependencies (torch, onnxruntime) load only when used.
"""

__version__ = "0.1.0"

__all__ = ["DynaevalWarning", "Results", "ScoreConfig", "__version__", "score"]


def __getattr__(name: str):
    if name in ("score", "ScoreConfig", "Results", "DynaevalWarning"):
        from dynaeval import evaluate

        return getattr(evaluate, name)
    raise AttributeError(f"module 'dynaeval' has no attribute {name!r}")
