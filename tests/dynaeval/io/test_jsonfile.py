"""Strict JSON reading of the files users give (issue 34 item 3): depth bounded before parsing,
numbers out of range and lone surrogates named by key."""

from __future__ import annotations

import json
import os
import time

import pytest

from dynaeval.errors import InputError
from dynaeval.io.jsonfile import MAX_DEPTH, nesting_depth, parse_json, read_json

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


def _depth(value) -> int:
    """The reference: nesting of a parsed value, by recursion."""
    if isinstance(value, dict):
        return 1 + max(map(_depth, value.values()), default=0)
    if isinstance(value, list):
        return 1 + max(map(_depth, value), default=0)
    return 0


TRICKY = st.text(alphabet='[]{}"\\ab\n\u00e9\U0001f600', max_size=8)
"""Strings full of what the scan must not count: brackets, quotes, backslashes."""

JSON = st.recursive(st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False,
                    allow_infinity=False) | TRICKY,
                    lambda inner: st.lists(inner, max_size=4)
                    | st.dictionaries(TRICKY, inner, max_size=4), max_leaves=40)


@settings(max_examples=200, deadline=None)
@given(JSON, st.booleans(), st.booleans())
def test_nesting_depth_is_the_parsed_depth(value, indent, ascii_only):
    text = json.dumps(value, indent=1 if indent else None, ensure_ascii=ascii_only)
    assert nesting_depth(text) == _depth(value)


def test_brackets_and_escaped_quotes_inside_strings_do_not_count():
    assert nesting_depth(r'{"a": "[[[{{\"[[", "b\\": ["\\\"]"]}') == 2
    assert nesting_depth("") == 0 and nesting_depth("3") == 0


def test_a_deep_document_is_refused_before_parsing_and_fast():
    text = "[" * 500_000 + "]" * 500_000
    start = time.perf_counter()
    with pytest.raises(InputError, match=rf"f\.json: nested deeper than {MAX_DEPTH} levels "
                                         r"\(500000\).*; fix it"):
        parse_json(text, path="f.json", fix="fix it")
    assert time.perf_counter() - start < 2.0  # measured: 0.03 to 0.2 s on a loaded 2-core machine
    assert parse_json("[" * MAX_DEPTH + "]" * MAX_DEPTH, path="f", fix="") is not None


@pytest.mark.parametrize("text,match", [
    ('{"a": [1, 1e999]}', r"a\[1\] is 1e999: out of range"),
    ('{"a": {"b": -1E400}}', r"a\.b is -1E400: out of range"),
    ('{"n": ' + "9" * 5000 + "}", r"n is 999999999999\.\.\.\(5000 characters\): out of range"),
    ('{"n": 1' + "0" * 309 + "}", r"n is 100000000000\.\.\.\(310 characters\): out of range"),
    ('{"a": NaN}', r"a is NaN, which is not strict JSON"),
    ('[-Infinity]', r"\[0\] is -Infinity, which is not strict JSON"),
    ('{"a": "x\\ud800"}', r"a holds a lone UTF-16 surrogate"),
    ('{"\\udfff": 1}', r"\(top level\): a key holds a lone UTF-16 surrogate"),
])
def test_values_json_text_cannot_carry_are_named_by_key(text, match):
    with pytest.raises(InputError, match=match):
        parse_json(text, path="f", fix="fix it")


def test_numbers_at_the_edge_of_the_float_range_are_read():
    doc = parse_json('{"a": 1.7e308, "b": -1e-400, "c": ' + str(10**308) + ', "d": "\\ud83d\\ude00"}',
                     path="f", fix="")
    assert doc == {"a": 1.7e308, "b": -0.0, "c": 10**308, "d": "\U0001f600"}


def test_read_json_names_the_file(tmp_path):
    with pytest.raises(InputError, match=r"nope\.json: results file not found \(hint\)"):
        read_json(tmp_path / "nope.json", what="results file", fix="", missing_hint=" (hint)")
    with pytest.raises(InputError, match=r"is a folder, not a results file"):
        read_json(tmp_path, what="results file", fix="")
    (tmp_path / "b.json").write_bytes(b"\xff\xfe{}")
    with pytest.raises(InputError, match=r"b\.json: not valid JSON: not UTF-8 text"):
        read_json(tmp_path / "b.json", what="results file", fix="")
    os.mkfifo(tmp_path / "fifo.json")  # reading it would wait for a writer for ever
    with pytest.raises(InputError, match=r"fifo\.json: is not a regular file"):
        read_json(tmp_path / "fifo.json", what="results file", fix="")
    (tmp_path / "c.json").write_text("{")
    with pytest.raises(InputError, match=r"c\.json: not valid JSON \(Expecting"):
        read_json(tmp_path / "c.json", what="results file", fix="")
