"""Reading text files and JSON with errors that name the file and the problem."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path
from typing import Any, Union

from belief.errors import BeliefError, FormatError

__all__ = ["read_text", "regular_file", "load_json", "MAX_INTEGER_DIGITS", "MAX_TEXT_BYTES"]

#: Bytes of a text file read whole (a BBA, model or settings file): a mass function of a million
#: focal elements is about 30 MB of JSON.  Checked before the file is read.
MAX_TEXT_BYTES = 256 * 2**20

#: JSON integers longer than this are refused: no mass, rate or probability needs one, and a
#: float cannot hold an integer of more than 309 digits anyway.
MAX_INTEGER_DIGITS = 308


def read_text(path: Union[str, Path], what: str, error: type[BeliefError] = FormatError,
              encoding: str = "utf-8") -> str:
    """The text of a file; any failure raises ``error`` naming ``what`` and the path.

    >>> read_text("no-such-file.json", "BBA file")
    Traceback (most recent call last):
    ...
    belief.errors.FormatError: cannot read BBA file 'no-such-file.json': no such file
    """
    name = str(path)
    info = regular_file(path, what, error)
    if info.st_size > MAX_TEXT_BYTES:
        raise error(f"cannot read {what} {_path_text(name)}: it holds {info.st_size:,} bytes, more than "
                    f"belief.textfiles.MAX_TEXT_BYTES = {MAX_TEXT_BYTES:,}")
    try:
        return Path(path).read_text(encoding=encoding)
    except FileNotFoundError:
        raise error(f"cannot read {what} {name!r}: no such file") from None
    except IsADirectoryError:
        raise error(f"cannot read {what} {name!r}: it is a directory") from None
    except UnicodeDecodeError:
        raise error(f"cannot read {what} {name!r}: not {encoding.upper().replace('-SIG', '')} text") from None
    except OSError as exc:
        raise error(f"cannot read {what} {name!r}: {exc.strerror or exc}") from None


def regular_file(path: Union[str, Path], what: str, error: type[BeliefError] = FormatError) -> os.stat_result:
    """The ``stat`` of ``path`` if it is a regular file (a symbolic link to one is), else ``error`` naming ``what``.

    A FIFO would block the reader and a device (``/dev/zero``) never ends, so neither is opened.

    >>> regular_file("/dev/null", "BBA file")
    Traceback (most recent call last):
    ...
    belief.errors.FormatError: cannot read BBA file '/dev/null': it is a device, not a regular file
    """
    name = _path_text(os.fspath(path))
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise error(f"cannot read {what} {name}: no such file") from None
    except ValueError:                          # a NUL in the name
        raise error(f"cannot read {what} {name}: not a valid file name") from None
    except OSError as exc:
        raise error(f"cannot read {what} {name}: {exc.strerror or exc}") from None
    if stat.S_ISDIR(info.st_mode):
        raise error(f"cannot read {what} {name}: it is a directory")
    if not stat.S_ISREG(info.st_mode):
        kind = ("a FIFO" if stat.S_ISFIFO(info.st_mode) else "a socket" if stat.S_ISSOCK(info.st_mode)
                else "a device" if stat.S_ISCHR(info.st_mode) or stat.S_ISBLK(info.st_mode) else "not a file")
        raise error(f"cannot read {what} {name}: it is {kind}, not a regular file")
    return info


#: Characters of a file name quoted in a message (a name of 100 000 characters would make a line of that size).
_SHOWN_NAME = 240


def _path_text(name: str) -> str:
    """A file name for a message: quoted, cut in the middle beyond :data:`_SHOWN_NAME` characters."""
    if len(name) <= _SHOWN_NAME:
        return repr(name)
    half = _SHOWN_NAME // 2
    return f"{name[:half]!r}...{name[-half:]!r} ({len(name):,} characters)"


def load_json(text: Union[str, bytes], where: str = "") -> Any:
    """Parse JSON text strictly; any problem raises :class:`FormatError` prefixed with ``where``.

    Unlike :func:`json.loads`, a key given twice in one object is refused (instead of the
    last one silently winning), as are integers of more than :data:`MAX_INTEGER_DIGITS`
    digits and nesting deeper than the interpreter's recursion limit.

    >>> load_json('{"a": 0.5, "b": 0.5}')
    {'a': 0.5, 'b': 0.5}
    >>> load_json('{"a": 0.5, "a": 0.5}', "BBA file 'x.json'")
    Traceback (most recent call last):
    ...
    belief.errors.FormatError: BBA file 'x.json': the key "a" appears twice in one JSON object
    """
    prefix = f"{where}: " if where else ""

    def unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        data = dict(pairs)
        if len(data) != len(pairs):
            seen: set[str] = set()
            for key, _ in pairs:
                if key in seen:
                    raise FormatError(f"{prefix}the key {_quoted(key)} appears twice in one JSON object")
                seen.add(key)
        return data

    def integer(digits: str) -> int:
        if len(digits) > MAX_INTEGER_DIGITS:
            raise FormatError(f"{prefix}an integer of {len(digits.lstrip('-')):,} digits ({digits[:12]}…) is too large "
                              f"(at most {MAX_INTEGER_DIGITS} digits)")
        return int(digits)

    try:
        return json.loads(text, object_pairs_hook=unique_keys, parse_int=integer)
    except json.JSONDecodeError as exc:
        invalid = f"{where} is not valid JSON" if where else "not valid JSON"
        raise FormatError(f"{invalid}: {exc.msg} at line {exc.lineno} column {exc.colno}") from None
    except RecursionError:
        raise FormatError(f"{prefix}the JSON is nested too deeply") from None


def _quoted(key: str) -> str:
    """A JSON key for a message: in double quotes, with invisible characters escaped."""
    return json.dumps(key) if not key.isprintable() else f'"{key}"' if len(key) <= 60 else f'"{key[:60]}…"'
