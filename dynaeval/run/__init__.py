"""Where a run is made: settings, resolved once, scored camera by camera, into results.

``config`` (``ScoreConfig``: every setting, checked when made) → ``plan`` (``RunPlan``: the run
resolved once, frozen) → ``executor`` (pool, cameras at once, frame caches, timing) → ``scoring``
(one camera: its regions, then the ``stages``: frame metrics, presence, temporal, video) →
``evaluate`` (``score``: pairs + regions + metrics → the results document). Beside them:
``prepare`` writes a prepared ground truth (``dynaeval prepare``), ``prepared_gt`` reads it back
(``--prepared``), ``distributed`` fans jobs out to Dask, ``suite`` runs many methods x scenes
(``dynaeval suite``). The package re-exports nothing: ``dynaeval.score`` and
``dynaeval.ScoreConfig`` are the public names.
"""
