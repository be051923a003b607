"""Writing a study's generated block into its Markdown document."""

from __future__ import annotations

from pathlib import Path


def replace_block(doc: Path, begin: str, end: str, block: str) -> None:
    """Replace the text between the ``begin`` and ``end`` marker lines of ``doc`` by ``block``
    (markers kept), so the hand-written prose around a generated table survives a rerun."""
    text = doc.read_text()
    i, j = text.index(begin) + len(begin), text.index(end)
    doc.write_text(text[:i] + "\n" + block + "\n" + text[j:])
