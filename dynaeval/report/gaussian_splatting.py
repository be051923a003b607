"""dynaeval results as the 3DGS family's ``results.json`` and ``per_view.json`` (``--3dgs-json DIR``).

gaussian-splatting's, 4DGaussians' and Deformable-3DGS' ``metrics.py`` (read, not copied) write,
per model folder, ``json.dump(..., indent=True)`` of::

    results.json   {"ours_30000": {"SSIM": mean, "PSNR": mean, "LPIPS": mean}}
    per_view.json  {"ours_30000": {"SSIM": {"00000.png": v, ...}, "PSNR": {...}, "LPIPS": {...}}}

4DGaussians' ``metrics.py`` writes the same two files with the keys ``SSIM``, ``PSNR``,
``LPIPS-vgg``, ``LPIPS-alex``, ``MS-SSIM``, ``D-SSIM``; a ``--protocol 4dgaussians`` run writes
those (``gs_keys``), its LPIPS under the backbone it ran (``--lpips-net``, default ``LPIPS-vgg``).

One key per ``MODEL/test/ours_<N>`` scored, image names as ``os.listdir`` gives them, means of the
per-image values. ``gs_documents`` builds the same two documents from one dynaeval run (the key is
the scored ``ours_<N>``, or the run's method for other layouts), so scripts that read them keep
working. Their numbers are 3DGS' own only with ``--protocol 3dgs``. A metric not computed is left
out; a PSNR of +infinity (identical images), which their ``json.dump`` writes as the non-JSON
token ``Infinity``, is written as ``null``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from dynaeval.core.errors import InputError
from dynaeval.io.atomic import write_files_atomic
from dynaeval.io.layouts import layout_kind

GS_FILES = ("results.json", "per_view.json")
GS_KEYS = {"SSIM": "ssim", "PSNR": "psnr", "LPIPS": "lpips"}
"""Their key -> dynaeval's whole-frame metric, in their order."""


def gs_keys(results: dict[str, Any]) -> dict[str, str]:
    """Their key -> dynaeval's metric for this run: ``GS_KEYS``, or 4DGaussians' keys under
    ``--protocol 4dgaussians`` (LPIPS named by the run's backbone, MS-SSIM and D-SSIM added)."""
    settings = results.get("settings") or {}
    if (settings.get("protocol") or {}).get("name") != "4dgaussians":
        return GS_KEYS
    net = (settings.get("lpips") or {}).get("net", "vgg")
    return {"SSIM": "ssim", "PSNR": "psnr", f"LPIPS-{net}": "lpips", "MS-SSIM": "msssim",
            "D-SSIM": "dssim"}


def gs_run_key(results: dict[str, Any]) -> str:
    """The top-level key of the two files: ``ours_<N>`` for a 3DGS render, else the method."""
    layout = results.get("inputs", {}).get("layout")
    key = layout_kind(layout["name"]).gs_run_key(layout) if layout else None
    return str(results["method"]) if key is None else key


def gs_documents(results: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(results.json, per_view.json)`` contents of one dynaeval results document.

    Raises:
        InputError: none of SSIM/PSNR/LPIPS was computed, or two frames share an image name
            (their per-view files are keyed by file name only).
    """
    present = [(theirs, ours) for theirs, ours in gs_keys(results).items()
               if ours in results["summary"]]
    if not present:
        raise InputError("the 3DGS results files hold SSIM, PSNR and LPIPS; this run computed "
                         "none of them")
    names = [Path(f["pred"]).name for f in results["frames"]]
    if len(set(names)) != len(names):
        raise InputError("the 3DGS per_view.json is keyed by image file name, and several "
                         "frames of this run share a name (several cameras?): score one "
                         "camera's folder at a time")
    key = gs_run_key(results)
    summary = {theirs: results["summary"][ours] for theirs, ours in present}
    per_view = {theirs: {n: f.get(ours) for n, f in zip(names, results["frames"], strict=True)}
                for theirs, ours in present}
    return {key: summary}, {key: per_view}


def gs_paths(folder: str | Path) -> tuple[Path, Path]:
    """``folder/results.json``, ``folder/per_view.json``."""
    return Path(folder) / GS_FILES[0], Path(folder) / GS_FILES[1]


def write_gs_json(results: dict[str, Any], folder: str | Path, *,
                  overwrite: bool = False) -> tuple[Path, Path]:
    """Write ``results.json`` and ``per_view.json`` into ``folder``, as one atomic write
    (``dynaeval.io.atomic.write_files_atomic``): neither is written when either exists and not
    ``overwrite`` (InputError naming it), or when the disk is full.

    Returns:
        The two paths written.
    """
    write_files_atomic(gs_files(results, folder), overwrite=overwrite)
    return gs_paths(folder)


def gs_files(results: dict[str, Any], folder: str | Path) -> list[tuple[Path, str, str]]:
    """``(path, text, what)`` of the two 3DGS files, for ``write_files_atomic``.

    Raises:
        InputError: as ``gs_documents``.
    """
    docs = gs_documents(results)
    return [(path, json.dumps(doc, indent=True, allow_nan=False), "3DGS results file")
            for path, doc in zip(gs_paths(folder), docs, strict=True)]
