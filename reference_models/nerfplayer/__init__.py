"""Compact reference NeRFPlayer (temporal hash grid) in plain PyTorch for 2 CPU cores.

The field is ``TemporalHashEncoding`` (a multiresolution hash grid whose rows are read through a
window sliding with time, see ``field.py``); sampling, proposals, decoder, sky, importance
sampling, training loop and rendering are the shared ones in ``reference_models.common``, the
same as K-Planes'. Same command line::

    python -m reference_models.nerfplayer train DATA --out RUN [--size tiny|small] [--iters N]
        [--sampling uniform|isg|ist]
    python -m reference_models.nerfplayer render RUN      # RUN/pred/<camera>/<frame>.png
"""

from reference_models.nerfplayer.field import SPEC, NeRFPlayerConfig, TemporalHashEncoding

__all__ = ["SPEC", "NeRFPlayerConfig", "TemporalHashEncoding"]
