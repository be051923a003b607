"""The ground floor every layer of dynaeval stands on (numpy only at import).

``errors`` (``InputError`` = exit 2, the metric-undefined errors), ``outcome`` (what became of a
value: ``Outcome(value, status, detail)`` and the one place a warning's text is made), ``deps``
(the optional packages, imported in one place), ``boxes`` (box geometry: IoU, NMS, clip, union
mask, grow), ``runtime`` (device rule, onnxruntime providers and sessions, OpenCV threads, file
hashes), ``validation`` (the one image validator), ``progress`` (the run's one progress bar) and
``terminal`` (control characters shown on the console, never run).
It imports nothing of dynaeval above it; this package re-exports nothing, so importing one of
its modules loads only that module.
"""
