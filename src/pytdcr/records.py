"""Typed results at the file boundary: reading a result's JSON back into its dataclasses.

Every run's result is a frozen dataclass whose parts are typed; it writes itself with ``to_json()`` (the keys
and meanings of the file the run writes, plus ``schema_version``) and reads itself back with
``from_json(d)``. The helpers here make those readers say what is wrong in one line:

- :func:`check_schema` refuses a file of another layout (its ``schema_version``; a file without one is of
  version 1, the layout of every file written before the key existed);
- :func:`part` reads a nested object with a missing key reported by its path (``counts.converged``) as a
  :class:`RecordKeyError`, and an object that is not one as a ValueError;
- :func:`optional_part` does the same for a part that may be absent or null.

:class:`RunWarning` is a run's warning as an object: a code a script can test and the text a person reads.

A reader never trusts a file to be well-formed: a missing key, a part of the wrong kind or another schema
version raises a ValueError naming the file and the key, never a bare ``KeyError`` or ``TypeError``.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TypeVar

__all__ = ["JsonDict", "JsonObject", "RecordKeyError", "RunWarning", "check_schema", "optional_part", "part"]

_T = TypeVar("_T")

#: a JSON object read from a file: its values are of any JSON type until a reader has checked them
JsonObject = Mapping[str, object]
#: a JSON-ready object, as a record's ``to_json`` returns it
JsonDict = dict[str, object]


class RecordKeyError(ValueError):
    """A result's JSON lacks a key it must hold: :attr:`key` is its path (``realisable.volume_m3``) and
    :attr:`file` the file's name (``workspace.json``)."""

    def __init__(self, file: str, key: str) -> None:
        super().__init__(f"{file}: the key {key!r} is missing (not this run's result, or written by another "
                         f"version)")
        self.file, self.key = file, key


def check_schema(d: JsonObject, file: str, version: int) -> None:
    """Refuse ``d`` (the JSON of ``file``) unless its ``schema_version`` is ``version``; a file without the key
    is version 1 (written before it existed). ValueError naming the file and both versions."""
    found = d.get("schema_version", 1)
    if found != version:
        raise ValueError(f"{file}: schema_version {found!r}: this version of pytdcr reads {version}")


def part(file: str, where: str, read: Callable[[JsonObject], _T], d: object) -> _T:
    """``read(d)``, where ``d`` is the part of ``file`` at the key path ``where`` (``""`` for the whole file).

    Raises
    ------
    RecordKeyError
        A key ``read`` looked up is missing: its path under ``where``.
    ValueError
        ``d`` is not a JSON object.
    """
    if not isinstance(d, Mapping):
        raise ValueError(f"{file}: {where or 'the file'} must be a JSON object, got {type(d).__name__}")
    try:
        return read(d)
    except RecordKeyError as err:  # a nested part's: its path goes under this one's
        raise RecordKeyError(file, f"{where}.{err.key}" if where else err.key) from None
    except KeyError as err:
        key = str(err.args[0]) if err.args else "?"
        raise RecordKeyError(file, f"{where}.{key}" if where else key) from None


def optional_part(file: str, key: str, read: Callable[[JsonObject], _T], d: JsonObject) -> _T | None:
    """The part at ``key`` of ``d`` (an object of ``file``) read by ``read``, None when absent or null."""
    value = d.get(key)
    return None if value is None else part(file, key, read, value)


@dataclass(frozen=True)
class RunWarning:
    """One warning of a run: a stable ``code`` a script can test (``"search-budget"``) and the ``text`` the run
    prints and writes (a file's ``warnings`` list holds the texts alone, as before codes existed).

    ``str(warning)`` is its text."""

    code: str
    text: str

    def __str__(self) -> str:
        return self.text

    @classmethod
    def from_text(cls, text: str, kinds: Mapping[str, str]) -> RunWarning:
        """The warning whose text is ``text``: its code is the first of ``kinds`` (code → regular expression
        matched at the start of the text) that matches, ``"other"`` when none does (a text of another version)."""
        for code, pattern in kinds.items():
            if re.match(pattern, text):
                return cls(code, text)
        return cls("other", text)
