"""The results document's layout as shipped (``dynaeval/schemas/results-v2.schema.json``): its
version, its file, and the names it gives its own fields, which no metric may take.

Ground floor: every layer may import this module; it imports nothing of dynaeval.
"""

from __future__ import annotations

import functools
import json
from pathlib import Path

RESULTS_SCHEMA = "dynaeval/results/v2"
"""The layout of the results documents this version writes (``schema`` in each)."""


def results_schema_path(schema: str = RESULTS_SCHEMA) -> Path:
    """Path of the JSON Schema of the results document (of layout ``schema``, default this
    version's) shipped in the package."""
    version = schema.rsplit("/", 1)[-1]
    return Path(__file__).resolve().parent.parent / "schemas" / f"results-{version}.schema.json"


_WHERE = (  # (path of properties in the schema, how a message names one of them)
    (("properties", "frames", "items"), "the frame rows' field {!r}"),
    (("properties", "summary"), "the field {!r} of summary and of each camera"),
    (("properties", "cameras", "additionalProperties"), "the field {!r} of summary and of each "
                                                        "camera"),
    (("properties", "timing"), "the timing phase {!r}"),
    (("properties", "settings"), "the settings section {!r}"),
    (("properties", "warnings", "items"), "the warnings' field {!r}"),
    ((), "the results document's key {!r}"),
)


@functools.cache
def results_fields() -> dict[str, str]:
    """Every name the results document uses for a field of its own, where a metric's result
    key could land beside it (a frame row's ``gt``, ``n_frames``, the timing phase ``read``,
    the settings section ``protocol``, the document's keys), read from the shipped schema ->
    how a message names it (the first place it is used, in the order of ``_WHERE``)."""
    schema = json.loads(results_schema_path().read_text(encoding="utf-8"))
    out: dict[str, str] = {}
    for path, where in _WHERE:
        node = schema
        for key in path:
            node = node[key]
        for name in node.get("properties", {}):
            out.setdefault(name, where.format(name))
    return out
