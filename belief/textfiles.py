"""Reading text files with errors that name the file and the problem."""

from __future__ import annotations

from pathlib import Path
from typing import Union

from belief.errors import BeliefError, FormatError

__all__ = ["read_text"]


def read_text(path: Union[str, Path], what: str, error: type[BeliefError] = FormatError,
              encoding: str = "utf-8") -> str:
    """The text of a file; any failure raises ``error`` naming ``what`` and the path.

    >>> read_text("no-such-file.json", "BBA file")
    Traceback (most recent call last):
    ...
    belief.errors.FormatError: cannot read BBA file 'no-such-file.json': no such file
    """
    name = str(path)
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
