"""The exceptions a caller of dynaeval catches (public face; defined in ``dynaeval.core.errors``).

``InputError`` (bad input or usage: exit 2, the message names the file and what is wrong;
``PluginError``, a metric plugin's own code failing while a run is set up, is one),
``UndefinedMetricError`` (a metric undefined on this input), ``WeightsUnavailableError`` and
``EmptyRegionError``. Kept at this path for code outside the package (``reference_models``, user
scripts: ``from dynaeval.errors import InputError``); dynaeval's own modules import
``dynaeval.core.errors``.
"""

from dynaeval.core.errors import (
    EmptyRegionError,
    InputError,
    PluginError,
    UndefinedMetricError,
    WeightsUnavailableError,
)

__all__ = ["EmptyRegionError", "InputError", "PluginError", "UndefinedMetricError",
           "WeightsUnavailableError"]
