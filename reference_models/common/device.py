"""Where the reference models train and render: ``cpu``, ``cuda`` or ``auto``.

``auto`` is ``cuda`` when ``torch.cuda.is_available()``, else ``cpu``; ``cuda`` on a machine
without one is an ``InputError`` (exit 2) raised before any work. On either device the model
is built on the CPU first (the same initial weights from the same seed) and moved; the ray
sampler, its generator and the uint8 images stay on the CPU (the same rays on every device; a
1080p study's images would not fit next to the model), and only each batch is moved.
"""

from __future__ import annotations

import torch

from dynaeval.errors import InputError

DEVICES = ("cpu", "cuda", "auto")


def resolve_device(name: str) -> str:
    """``cpu`` / ``cuda`` / ``auto`` -> the device to use (``cpu`` or ``cuda``).

    Raises InputError for another name, or for ``cuda`` when torch sees no CUDA device.
    """
    if name not in DEVICES:
        raise InputError(f"device must be one of {', '.join(DEVICES)}, got {name!r}")
    if name == "auto":
        return "cuda" if torch.cuda.is_available() else "cpu"
    if name == "cuda" and not torch.cuda.is_available():
        raise InputError("device 'cuda' asked for but torch.cuda.is_available() is False (no GPU, "
                         f"no driver, or a CPU-only torch build: torch {torch.__version__}); use "
                         "--device cpu (or auto), or install a CUDA build of torch")
    return name


def device_name(device: str) -> str:
    """What trained a run, for its records: the GPU's name on ``cuda`` (e.g. ``NVIDIA GeForce
    RTX 3090``), ``cpu`` otherwise."""
    return torch.cuda.get_device_name(torch.device(device)) if device.startswith("cuda") else "cpu"


def check_clock(device: str, clock: str, minutes: float | None) -> None:
    """Raise InputError for a CPU-seconds budget (``clock="cpu"`` with ``minutes``) on CUDA: the
    process's CPU time there counts kernel launches, not the training, so the budget would
    stop a run at an arbitrary step."""
    if device != "cpu" and clock == "cpu" and minutes is not None:
        raise InputError(f"--clock cpu budgets process CPU seconds, which on {device} count only "
                         "the kernel launches, not the training; use --clock wall (elapsed "
                         "seconds) on a GPU, or --device cpu")

