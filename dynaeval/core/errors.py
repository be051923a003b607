"""Errors that mean *the user's input is wrong* (exit code 2), as opposed to bugs (exit code 1).

Every message says what was expected, what came, and, where it helps, how to fix it, and names the
file when there is one.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from pathlib import Path


class InputError(ValueError):
    """Bad input or usage: a missing/corrupt file, mismatched sizes, NaN pixels, a bad option.

    The CLI turns it into exit code 2 with the message on stderr (no traceback).
    """

    def __init__(self, message: str, path: str | Path | None = None) -> None:
        self.path = None if path is None else str(path)
        super().__init__(f"{self.path}: {message}" if self.path else message)


class UndefinedMetricError(InputError):
    """A metric is not defined for this input, though the input itself is valid: an image smaller
    than SSIM's 11x11 window or LPIPS's pooling.

    A subclass of ``InputError`` (calling ``ssim`` on a 5x5 image directly is the caller's error),
    but ``dynaeval.score`` records the value as ``null`` with this message as the reason and goes
    on with the metrics that are defined (PSNR has no minimum size).
    """


class PluginError(InputError):
    """A metric plugin's own code failed while a run was set up (its ``build``, ``settings`` or
    ``requires`` function raised): the plugin's failure, named as such, never dynaeval's bug.

    The message names the plugin (entry point and package), the function and what it raised.
    """


class WeightsUnavailableError(RuntimeError):
    """Pretrained weights (e.g. LPIPS's torchvision backbone) are not on this machine.

    Scoring goes on without the metric that needs them and records why in the results' warnings.
    """


class EmptyRegionError(ValueError):
    """The region to score (mask or boxes) holds no pixel, so the metric is undefined.

    Not a user error: ``evaluate`` records the value as ``null`` with this message as the reason
    (never 0, never NaN).
    """


def did_you_mean(name: object, choices: Iterable[str]) -> str:
    """The hint an error about an unknown ``name`` ends with: ``" (did you mean 'ssim'?)"`` for
    the closest of ``choices`` (``difflib``, as pyiqa does), ``""`` when none is close."""
    if not isinstance(name, str):
        return ""
    close = difflib.get_close_matches(name, list(choices), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""
