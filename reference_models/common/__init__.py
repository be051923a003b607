"""Pieces the reference models share, so K-Planes and NeRFPlayer differ only in their encoding.

* ``data``: load generator / nerfstudio / D-NeRF datasets into views (uint8 pixels, cameras, times).
* ``rays``: pixel rays, scene contraction, sample spacing along rays.
* ``sampling``: stratified and proposal (inverse-CDF) samples, volume rendering weights,
  interlevel and distortion losses.
* ``encodings``: K-Planes' multiscale planes (also the proposal fields), view-direction harmonics.
* ``model``: ``DynamicRadianceModel`` = proposals + any encoding + decoder + sky.
* ``importance``: uniform / ISG / IST ray sampling via ``dynaeval.regions.motion``.
* ``train``: the training loop, checkpoints, logs, rendering of the eval cameras.
* ``cli``: the ``train`` / ``render`` command line of every model.
"""
