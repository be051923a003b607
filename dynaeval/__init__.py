"""dynaeval: evaluation toolkit for dynamic novel view synthesis.

Scores rendered frames against ground truth over the whole frame, in boxes around the action
(*focused*), on moving pixels (*masked*) and over time (*temporal*).

The package root is dynaeval's public face only: ``dynaeval.score(pred_dir, gt_dir, ...)`` runs
a whole evaluation with the defaults of ``dynaeval score`` (``ScoreConfig``, whose ``focus`` is
a ``FocusConfig``); ``ImageMetrics`` accumulates the per-frame metrics in a training loop;
``dynaeval.metrics`` holds the metrics as pure functions and ``dynaeval.metrics.registry``
declares every one of them; ``dynaeval.errors`` the exceptions a caller catches. The work is
done in the layer packages: ``core`` (the ground floor), ``io``, ``regions``, ``metrics``,
``run`` (where a run is made), ``report`` and ``cli``. The names below load on first use, so
``import dynaeval`` stays light (no torch, onnxruntime, pandas nor matplotlib).
"""

from dynaeval.core.version import VERSION as __version__

__all__ = ["DynaevalWarning", "FocusConfig", "ImageMetrics", "Results", "ScoreConfig",
           "__version__", "score"]

_PUBLIC = {
    "score": "dynaeval.run.evaluate", "ScoreConfig": "dynaeval.run.config",
    "Results": "dynaeval.run.evaluate", "DynaevalWarning": "dynaeval.run.evaluate",
    "FocusConfig": "dynaeval.regions.focus", "ImageMetrics": "dynaeval.metrics.accumulate",
}
"""Each public name and the module that defines it."""


def __getattr__(name: str):
    if name in _PUBLIC:
        import importlib

        return getattr(importlib.import_module(_PUBLIC[name]), name)
    raise AttributeError(f"module 'dynaeval' has no attribute {name!r}")
