"""Reading a JSON file a user gives dynaeval (a results file, a boxes file) as strict JSON.

Every way such a file can be unusable is an ``InputError`` naming the file, never a traceback:
missing, a folder, unreadable, not UTF-8, not JSON, nested deeper than ``MAX_DEPTH`` levels
(refused before parsing: Python's parser recurses and a deep file would end in a
``RecursionError``), a ``NaN`` / ``Infinity`` token, or a number beyond the float range
(``1e999`` would be read as +infinity, an integer of 400 digits could not become a float; an
integer of more than 4300 digits is an error of Python's own), or a string with a lone UTF-16
surrogate (``"\\ud800"``: printing or writing it again would fail). The last three name the
key, e.g. ``frames[3].psnr``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from dynaeval.core.errors import InputError

MAX_DEPTH = 64
"""Deepest nesting of arrays and objects read (the files dynaeval writes nest 8 levels at most)."""

_STEP = np.zeros(256, dtype=np.int8)
_STEP[[ord("["), ord("{")]] = 1
_STEP[[ord("]"), ord("}")]] = -1


def nesting_depth(text: str) -> int:
    """Deepest nesting of arrays and objects in a JSON text, without parsing it: brackets inside
    strings do not count (an escaped quote does not end a string). Linear time, no recursion
    (about 10 ms for 1 MB). For a text that is not JSON the count may be anything."""
    bare = text.replace("\\\\", "").replace('\\"', "")  # escapes left to right, as JSON reads them
    data = np.frombuffer(bare.encode("utf-8", "surrogatepass"), dtype=np.uint8)
    in_string = np.logical_xor.accumulate(data == ord('"'))  # from an opening quote to its closing
    step = _STEP[data]
    step = step[(step != 0) & ~in_string]
    return int(np.cumsum(step, dtype=np.int64).max(initial=0))


class NonFinite:
    """Stands, in a parsed document, for a number JSON cannot carry, so the key holding it can
    be named: a ``NaN`` / ``Infinity`` / ``-Infinity`` token, or a number beyond the float range
    (``out_of_range``)."""

    def __init__(self, token: str, out_of_range: bool = False) -> None:
        self.token = token
        """The text as it stands in the file."""
        self.out_of_range = out_of_range
        """A number literal too large for a float (else a NaN/Infinity token)."""

    def problem(self) -> str:
        """What is wrong with it, for a message (``"is NaN, which is not strict JSON"``)."""
        if not self.out_of_range:
            return (f"is {self.token}, which is not strict JSON (dynaeval writes an undefined or "
                    "infinite value as null, with a warning)")
        shown = self.token if len(self.token) <= 24 else (
            f"{self.token[:12]}...({len(self.token)} characters)")
        return (f"is {shown}: out of range (numbers are read as floats, which end at "
                f"±{sys.float_info.max:.3g}: this one would become infinite)")


def _parse_float(token: str) -> float | NonFinite:
    value = float(token)
    return value if abs(value) <= sys.float_info.max else NonFinite(token, out_of_range=True)


_LONGEST_INT = len(str(int(sys.float_info.max)))


def _parse_int(token: str) -> int | NonFinite:
    digits = len(token) - token.startswith("-")
    if digits > _LONGEST_INT or (digits == _LONGEST_INT and abs(int(token)) > sys.float_info.max):
        return NonFinite(token, out_of_range=True)
    return int(token)


def _not_text(value: str) -> bool:
    """A string holding a lone UTF-16 surrogate (``"\\ud800"`` in the file): no UTF-8 text
    can hold it, so printing or writing it again would fail."""
    if value.isascii():
        return False
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        return True
    return False


def unusable_value(obj: Any, where: str = "") -> tuple[str, str] | None:
    """``(key path, problem)`` of the first value in a parsed document that JSON text cannot
    carry: a ``NonFinite`` (``("frames[3].psnr", "is NaN, which is not strict JSON")``) or a
    key or string with a lone surrogate; None when there is none."""
    if isinstance(obj, NonFinite):
        return where or "(top level)", obj.problem()
    if isinstance(obj, str):
        return (where or "(top level)", _SURROGATE) if _not_text(obj) else None
    if isinstance(obj, dict):
        bad_key = next((k for k in obj if _not_text(k)), None)
        if bad_key is not None:
            return f"{where or '(top level)'}: a key", _SURROGATE
        items: Any = ((f"{where}.{k}" if where else k, v) for k, v in obj.items())
    elif isinstance(obj, list):
        items = ((f"{where}[{i}]", v) for i, v in enumerate(obj))
    else:
        return None
    for sub, value in items:
        found = unusable_value(value, sub)
        if found:
            return found
    return None


_SURROGATE = ("holds a lone UTF-16 surrogate (an escape such as \\ud800 without its pair), "
              "which is not text")


def parse_json(text: str, *, path: str | Path | None, fix: str) -> Any:
    """Parse ``text`` as strict JSON of at most ``MAX_DEPTH`` levels.

    Args:
        text: the file's content.
        path: the file, named in every error.
        fix: what the user should do, appended to the messages of a deep file and of a bad number.

    Raises:
        InputError: not JSON, nested too deep, a NaN/Infinity token or a number out of range (the
            key named).
    """
    depth = nesting_depth(text)
    if depth > MAX_DEPTH:
        raise InputError(f"nested deeper than {MAX_DEPTH} levels ({depth}): not a file dynaeval "
                         f"writes (those nest a few levels); {fix}", path=path)
    try:
        doc = json.loads(text, parse_constant=NonFinite, parse_float=_parse_float,
                         parse_int=_parse_int)
    except json.JSONDecodeError as err:
        raise InputError(f"not valid JSON ({err})", path=path) from err
    found = unusable_value(doc)
    if found:
        raise InputError(f"{found[0]} {found[1]}; {fix}", path=path)
    return doc


def read_json(path: str | Path, *, what: str, fix: str, missing_hint: str = "") -> Any:
    """Read and parse a JSON file (``parse_json``), every failure an ``InputError`` naming it.

    Args:
        what: the kind of file, in messages: ``"results file"``, ``"boxes file"``.
        fix: see ``parse_json``.
        missing_hint: appended to "not found" (e.g. how to make the file).
    """
    path = Path(path)
    kind = what.split()[0]
    if path.is_dir():
        raise InputError(f"is a folder, not a {what} (give the {kind} JSON inside it)", path=path)
    if path.exists() and not path.is_file():
        raise InputError(f"is not a regular file (a {what} is a JSON file)", path=path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError as err:
        raise InputError(f"{what} not found{missing_hint}", path=path) from err
    except PermissionError as err:
        raise InputError(f"{what} is not readable (permission denied)", path=path) from err
    except UnicodeDecodeError as err:
        raise InputError(f"not valid JSON: not UTF-8 text ({err})", path=path) from err
    except OSError as err:
        raise InputError(f"cannot read the {what} ({err.strerror or err})", path=path) from err
    return parse_json(text, path=path, fix=fix)
