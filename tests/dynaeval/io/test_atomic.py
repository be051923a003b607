"""Atomic writes: content, refusal to overwrite, no leftovers, ordinary permissions."""

from __future__ import annotations

import os
import stat

import pytest

from dynaeval.errors import InputError
from dynaeval.io.atomic import write_text_atomic


def test_writes_replaces_only_when_asked_and_leaves_no_temporary(tmp_path):
    out = tmp_path / "r.json"
    write_text_atomic(out, "one")
    with pytest.raises(InputError, match="exists; pass --overwrite"):
        write_text_atomic(out, "two")
    assert out.read_text() == "one"
    write_text_atomic(out, "two", overwrite=True)
    assert out.read_text() == "two"
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]
    with pytest.raises(InputError, match="does not exist"):
        write_text_atomic(tmp_path / "missing" / "r.json", "x")


def test_file_gets_the_permissions_of_a_plain_open(tmp_path):
    """mkstemp creates 0600 files; a results file others cannot read would be a surprise."""
    plain = tmp_path / "plain.txt"
    plain.write_text("x")
    atomic = write_text_atomic(tmp_path / "atomic.txt", "x")
    mode = stat.S_IMODE(os.stat(atomic).st_mode)
    assert mode == stat.S_IMODE(os.stat(plain).st_mode)
