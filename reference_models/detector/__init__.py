"""The default person + ball detector shipped as ``dynaeval/models/detector.onnx``.

Trained from scratch on renders of the synthetic scenes (``reference_models.scenes``), exported in
the YOLO output convention that ``dynaeval.regions.detector`` decodes, and evaluated through that
runtime on held-out seeds. See ``docs/detector.md``.

    python -m reference_models.detector train --out RUN [--size tiny|small] [--seed S]
    python -m reference_models.detector export RUN/model.pt --out dynaeval/models/detector.onnx
    python -m reference_models.detector evaluate dynaeval/models/detector.onnx --out RUN/eval.md
"""
