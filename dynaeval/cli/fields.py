"""How a dataclass field becomes a command-line option: flag, type, default and help from the
field, the rest from a ``Cli`` entry (``options.EXPOSED``)."""

from __future__ import annotations

import ast
import functools
import re
import sys
import typing
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class Cli:
    """How one field appears on the command line, where the field alone does not say it."""

    flags: tuple[str, ...] = ()
    """The spelling; default ``--field-name`` (``--no-field-name`` for a setting on by default)."""
    choices: tuple[str, ...] | None = None
    """The allowed values: the constant the config checks the field against."""
    metavar: str | None = None
    """The value's name in the help (argparse's default: the flag upper-cased, or the choices)."""
    nargs: str | None = None
    """argparse's ``nargs`` (``"+"`` for ``--classes``)."""
    help: str | None = None
    """The help, where the field's docstring speaks Python (``None``, ``True``) or of the
    library; default: the docstring."""
    read: Callable[[Any], Any] | None = None
    """The parsed value -> the field's value; default: as parsed."""


@dataclass(frozen=True)
class Option:
    """One row of the table: a field and its ``add_argument`` call."""

    path: str
    """The field: ``fps``, or ``focus.expand`` for a field of ``ScoreConfig.focus``."""
    flags: tuple[str, ...]
    """The option strings."""
    kwargs: dict[str, Any]
    """The rest of ``add_argument``'s arguments (dest, action or type, default, choices, ...)."""
    read: Callable[[Any], Any]
    """The parsed value -> the field's value."""

    @property
    def dest(self) -> str:
        """The attribute of the parsed arguments holding the value."""
        return self.kwargs["dest"]


@functools.cache
def field_docs(cls: type) -> dict[str, str]:
    """The docstring under each field of dataclass ``cls`` (the string literal after the
    annotated line, as config.py documents fields), whitespace collapsed; ``{}`` where the
    source cannot be read (an install without ``.py`` files: the options then have no help)."""
    try:
        tree = ast.parse(Path(sys.modules[cls.__module__].__file__ or "").read_text("utf-8"))
    except (OSError, KeyError, ValueError):
        return {}
    body = next((n.body for n in tree.body
                 if isinstance(n, ast.ClassDef) and n.name == cls.__name__), [])
    return {node.target.id: " ".join(after.value.value.split())
            for node, after in zip(body, body[1:], strict=False)
            if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)
            and isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant)
            and isinstance(after.value.value, str)}


_hints = functools.cache(typing.get_type_hints)
"""``typing.get_type_hints`` of a class, evaluated once."""


def _help(doc: str) -> str:
    """A field docstring as argparse help, written as the other options' help: ``code`` marks
    dropped, a capitalised first word lower-cased (not an acronym), no final full stop, ``%``
    escaped (``"Frame rate of ``jod``."`` -> ``"frame rate of jod"``)."""
    text = re.sub(r"``([^`]*)``", r"\1", doc).removesuffix(".")
    if text[1:2].islower():
        text = text[:1].lower() + text[1:]
    return text.replace("%", "%%")


def _number_type(hint: Any) -> type | None:
    """``int`` or ``float`` for a field annotated so (or ``X | None``), else None (the string
    as typed: the config reads ``"I/N"``, paths, names)."""
    kinds = [k for k in typing.get_args(hint) or (hint,) if k is not type(None)]
    return kinds[0] if len(kinds) == 1 and kinds[0] in (int, float) else None


def option_of(cls: type, default: Any, path: str, cli: Cli) -> Option:
    """The row of field ``path`` of ``cls`` (whose instance holds ``default``)."""
    name = path.rpartition(".")[2]
    hint = _hints(cls)[name]
    doc = _help(field_docs(cls).get(name, ""))
    dash = name.replace("_", "-")
    if isinstance(default, bool) or hint == bool | None:  # a switch: given -> the other value
        on = not default if isinstance(default, bool) else True
        flags = cli.flags or ((f"--no-{dash}",) if default is True else (f"--{dash}",))
        text = cli.help or (f"do not {doc}" if default is True else doc)
        kwargs: dict[str, Any] = {"action": "store_true", "help": text}
        read = cli.read or (lambda given: on if given else default)
    else:
        flags = cli.flags or (f"--{dash}",)
        text = cli.help or doc
        if default is not None and "default" not in text.lower():
            text += f" (default: {default:g})" if isinstance(default, float) else \
                f" (default: {default})"
        kwargs = {"type": _number_type(hint), "default": default, "choices": cli.choices,
                  "metavar": cli.metavar, "nargs": cli.nargs, "help": text}
        kwargs = {k: v for k, v in kwargs.items() if v is not None or k == "default"}
        read = cli.read or (lambda given: given)
    long = next(f for f in flags if f.startswith("--"))
    return Option(path, flags, {"dest": long[2:].replace("-", "_"), **kwargs}, read)
