"""The output folder of a run (``--out``): the gate that says whether a run may write there, and the writing.

:class:`OutputFolder` is checked once, before any work:

* the folder must not be, lie inside, or hold one of the run's inputs (a video, an image
  folder or pattern, a sequence folder, det.txt, gt.txt, an init or settings file), whatever
  ``force`` says: a diagnostics.png among the frames of an image folder would be a frame of
  the next run;
* it must be creatable and writable, its names within the file system's limits, and no folder
  may stand where one of the run's files goes;
* unless ``force``, every file in it must have been written by an earlier run, as the
  :data:`MANIFEST` says (name, size, modification time and SHA-256 of each file a run
  wrote): a file of the user's own is never replaced without being asked.

Every file is then staged under a hidden name created in the folder itself with
``O_CREAT | O_EXCL`` (so never through an existing name, a symlink included) and renamed into
place by :meth:`OutputFolder.commit` (:func:`os.replace` replaces a symlink at the final name
instead of following it).  A commit also removes the files an earlier run wrote that this one
did not (an ``annotated.avi`` when this run has ``--no-video``), so that the folder holds the
outputs of its latest run; files that no run wrote are never touched.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import re
import contextlib
import secrets
import signal
import stat
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from os import PathLike
from pathlib import Path
from typing import Any

from .errors import OutputFolderError

__all__ = ["OutputFolder", "MANIFEST", "input_paths", "check_folder"]

#: The hidden file of an output folder that lists what runs wrote there.
MANIFEST = ".belief-outputs.json"
MANIFEST_FORMAT = "belief-outputs/1"

#: A manifest larger than this is not one of ours (it lists a handful of files).
_MAX_MANIFEST_BYTES = 1 << 20

#: How many foreign names a refusal quotes.
_SHOWN = 3

# The staged names: ".tracks.partial.txt", or ".tracks.partial-k3j9x_2a.txt" when the first is taken.
_PARTIAL = re.compile(r"\..+\.partial(-[A-Za-z0-9_]{1,16})?(\.[A-Za-z0-9]{1,8})?")

_NO_FOLLOW = getattr(os, "O_NOFOLLOW", 0)


def input_paths(*paths: Any) -> list[str]:
    """The paths among ``paths`` (None, arrays, scenes and open sources are skipped), as text."""
    return [os.fspath(p) for p in paths if isinstance(p, (str, PathLike)) and os.fspath(p)]


class OutputFolder:
    """The checked output folder of one run, and the files staged in it.

    Parameters
    ----------
    path : path
        The folder (``--out``); created, with its missing parents, when the gate passes (and
        removed again by :meth:`abort` if still empty).
    names : sequence of str
        The file names the run writes there (plain names, no folder).
    inputs : sequence of path
        The run's input files and folders (:func:`input_paths`).
    force : bool
        Run even if the folder holds files no run wrote there; the files of ``names`` among
        them are replaced, the others left as they are.

    Raises
    ------
    OutputFolderError
        The one-line reason the run may not write there.

    Examples
    --------
    >>> folder = Path(tempfile.mkdtemp()) / "run"
    >>> out = OutputFolder(folder, ["tracks.txt"])
    >>> _ = out.path("tracks.txt").write_text("1,1,1,1,2,2,-1,-1,-1,-1\\n")
    >>> [p.name for p in out.commit().values()]
    ['tracks.txt']
    >>> _ = OutputFolder(folder, ["tracks.txt"])          # written by a run: may be written again
    >>> _ = (folder / "notes.txt").write_text("the user's own")
    >>> OutputFolder(folder, ["tracks.txt"])
    Traceback (most recent call last):
    ...
    belief_tracking.errors.OutputFolderError: ... holds a file that no run of belief wrote there: notes.txt; ...
    """

    def __init__(self, path: str | PathLike[str], names: Sequence[str], *, inputs: Iterable[str | PathLike[str]] = (),
                 force: bool = False) -> None:
        self._start(path)
        self.names = tuple(_plain_name(name) for name in names)
        self.force = bool(force)
        self._staged: dict[str, Path] = {}
        self.committed = False
        self._check_inputs(inputs)
        exists = self._check_path()
        self._earlier = self._check_contents() if exists else {}
        self._create()

    # -- the gate -------------------------------------------------------------------------------
    def _start(self, path: str | PathLike[str]) -> None:
        if not isinstance(path, (str, PathLike)) or not os.fspath(path).strip():
            # Path("") is the working directory: an empty --out would scatter the files there.
            raise OutputFolderError(f"the output folder must be a non-empty path, got {path!r}")
        self.out_dir = Path(path)
        self._shown = os.fspath(path)
        self._created_dirs: list[Path] = []

    def _refuse(self, reason: str) -> OutputFolderError:
        return OutputFolderError(f"--out {self._shown}: {reason}")

    def _check_inputs(self, inputs: Iterable[str | PathLike[str]]) -> None:
        """Refuse a folder that is, lies inside or holds an input."""
        out = os.path.realpath(self.out_dir)
        for given in inputs:
            text = os.fspath(given)
            path = text
            if "%" in os.path.basename(text) and not os.path.exists(text):
                path = os.path.dirname(text) or "."  # an image pattern: its folder is the input
            real = os.path.realpath(path)
            if _inside(real, out):
                raise self._refuse(f"it holds the input {text}; write the outputs into another folder")
            if os.path.isdir(real) and _inside(out, real):
                raise self._refuse(f"it is inside the input folder {text} (a run's files there would be read as "
                                   "input next time); write the outputs into another folder")

    def _check_path(self) -> bool:
        """Whether the folder exists; refuse a path that is not a folder or whose names are too long."""
        try:
            os.stat(self.out_dir)
        except FileNotFoundError:
            parent = _existing_parent(self.out_dir)
            if not parent.is_dir():
                raise self._refuse(f"{parent} is not a folder") from None
            self._check_name_lengths(parent, self.out_dir.parts[len(parent.parts):])
            return False
        except OSError as exc:
            raise self._refuse(_reason(exc)) from None
        if not self.out_dir.is_dir():
            raise self._refuse("it exists and is not a folder")
        return True

    def _check_name_lengths(self, parent: Path, parts: Sequence[str]) -> None:
        try:
            limit = os.pathconf(parent, "PC_NAME_MAX")
        except (OSError, ValueError, AttributeError):
            limit = 255
        for part in parts:
            if len(os.fsencode(part)) > limit:
                raise self._refuse(f"the name {part[:40]}... is {len(os.fsencode(part))} bytes long, over the "
                                   f"file system's limit of {limit}")

    def _check_contents(self) -> dict[str, dict]:
        """The earlier run's files by name; refuse a folder in the way, or foreign files unless ``force``."""
        listed = _read_manifest(self.out_dir / MANIFEST)
        manifest = listed or {}
        earlier: dict[str, dict] = {}
        foreign: list[str] = []
        try:
            entries = sorted(os.scandir(self.out_dir), key=lambda e: e.name)
        except OSError as exc:
            raise self._refuse(f"cannot list it: {_reason(exc)}") from None
        for entry in entries:
            name = entry.name
            if (name in self.names or name == MANIFEST) and entry.is_dir(follow_symlinks=False):
                raise self._refuse(f"{name} is a folder, where the run writes its file {name}; move it away")
            if (name == MANIFEST and listed is not None) or (_PARTIAL.fullmatch(name)
                                                             and entry.is_file(follow_symlinks=False)):
                continue  # the list itself, and what a run killed outright left staged
            if name == MANIFEST:                # a file of that name that is no list of a run's: the user's
                foreign.append(name)
                continue
            record = _matching(entry, manifest.get(name, ()))
            if record is not None:
                earlier[name] = record
            else:
                foreign.append(name)
        if foreign and not self.force:
            shown = ", ".join(foreign[:_SHOWN]) + (f" and {len(foreign) - _SHOWN} more" if len(foreign) > _SHOWN
                                                    else "")
            files = "a file" if len(foreign) == 1 else f"{len(foreign)} files"
            raise self._refuse(f"it holds {files} that no run of belief wrote there: {shown}; write the outputs "
                               "into another folder, or add --force to replace the run's own names "
                               f"({', '.join(self.names)}) and leave the rest")
        return earlier

    def _create(self) -> None:
        """Create the folder (remembering what was created, for :meth:`abort`) and make sure files can be made."""
        for folder in (self.out_dir, *self.out_dir.parents):
            if os.path.lexists(folder):
                break
            self._created_dirs.append(folder)
        try:
            self.out_dir.mkdir(parents=True, exist_ok=True)
            handle, probe = tempfile.mkstemp(dir=self.out_dir, prefix=".belief-probe-")
            os.close(handle)
            os.unlink(probe)
        except OSError as exc:
            self.abort()
            raise self._refuse(f"cannot write there: {_reason(exc)}") from None

    # -- the files ------------------------------------------------------------------------------
    def path(self, name: str) -> Path:
        """A new, empty, regular file under which the file ``name`` is written (same suffix), until :meth:`commit`."""
        final = Path(_plain_name(name))
        # Held so that an interruption cannot fall between making the file and recording it for abort().
        with _interruptions_held():
            try:
                staged = _new_file(self.out_dir, f".{final.stem}.partial", final.suffix)
            except OSError as exc:
                raise self._refuse(f"cannot write {name}: {_reason(exc)}") from None
            self._staged[name] = staged
        return staged

    def commit(self) -> dict[str, Path]:
        """Rename every staged file to its final name, ``summary.json`` last; returns the final paths.

        The files of an earlier run that this one did not write are removed, and so is an
        earlier ``summary.json`` before the others are renamed, so that no summary describes a
        mix of two runs even for a moment. Ctrl-C and SIGTERM wait until the commit is over, so
        that a run is either all staged (and :meth:`abort` removes it) or all in place.
        """
        with _interruptions_held():
            return self._commit()

    def _commit(self) -> dict[str, Path]:
        written = {name: staged for name, staged in self._staged.items() if staged.exists()}
        records = {name: _record(staged) for name, staged in written.items()}
        # Listed before the renames with the files they replace: a run killed halfway leaves
        # a folder of files that are all known, whichever of the two each one is.
        both = {name: [r for r in (self._earlier.get(name), records.get(name)) if r is not None]
                for name in {*self._earlier, *records}}
        self._write_manifest(both)
        stale = [name for name in self._earlier if name not in written]
        if "summary.json" in written:
            stale.append("summary.json")
        for name in stale:
            self._remove(name)
        final = {}
        for name in sorted(written, key=lambda name: name == "summary.json"):
            target = self.out_dir / name
            try:
                os.replace(written[name], target)
            except OSError as exc:
                raise self._refuse(f"cannot write {name}: {_reason(exc)}") from None
            final[name] = target
        self._staged.clear()
        self._write_manifest({name: [record] for name, record in records.items()})
        self._created_dirs.clear()
        self.committed = True
        return final

    def abort(self) -> None:
        """Delete the staged files (and the folders created by the gate, if they are left empty)."""
        for staged in self._staged.values():
            try:
                staged.unlink()
            except FileNotFoundError:
                pass
        self._staged.clear()
        for folder in self._created_dirs:
            try:
                folder.rmdir()
            except OSError:
                break
        self._created_dirs.clear()

    def _remove(self, name: str) -> None:
        """Remove ``name`` if it is still the file an earlier run wrote, or the summary this run replaces."""
        target = self.out_dir / name
        try:
            status = os.lstat(target)
        except FileNotFoundError:
            return
        except OSError as exc:
            raise self._refuse(f"cannot read {name}: {_reason(exc)}") from None
        earlier = self._earlier.get(name)
        if name not in self.names and (earlier is None or status.st_size != earlier["size"]
                                       or status.st_mtime_ns != earlier["mtime_ns"]):
            return  # changed since the gate read it: no longer the earlier run's
        try:
            target.unlink()
        except (FileNotFoundError, IsADirectoryError):
            pass
        except OSError as exc:
            raise self._refuse(f"cannot remove {name} of an earlier run: {_reason(exc)}") from None

    def _write_manifest(self, files: dict[str, list[dict]]) -> None:
        text = json.dumps({"format": MANIFEST_FORMAT, "files": dict(sorted(files.items()))}, indent=1) + "\n"
        try:
            staged = _new_file(self.out_dir, ".belief-outputs.partial", ".json")
            try:
                staged.write_text(text, encoding="utf-8")
                os.replace(staged, self.out_dir / MANIFEST)
            except BaseException:
                Path(staged).unlink(missing_ok=True)
                raise
        except OSError as exc:
            raise self._refuse(f"cannot write its list of outputs {MANIFEST}: {_reason(exc)}") from None


def check_folder(path: str | PathLike[str], inputs: Iterable[str | PathLike[str]] = (), *,
                 create: bool = True) -> Path:
    """The gate of a folder that keeps its own books (an experiment's ``--out``, resumed from its cells).

    The checks of :class:`OutputFolder` without the manifest: the folder must not be, lie
    inside or hold an input, its names must fit the file system, and a file must be possible
    to make in it; a missing folder is created only with ``create``.

    Examples
    --------
    >>> folder = Path(tempfile.mkdtemp())
    >>> check_folder(folder / "grid", inputs=[folder / "grid" / "grid.toml"], create=False)
    Traceback (most recent call last):
    ...
    belief_tracking.errors.OutputFolderError: --out .../grid: it holds the input .../grid.toml; ...
    """
    gate = OutputFolder.__new__(OutputFolder)
    gate._start(path)
    gate._check_inputs(inputs)
    if gate._check_path() or create:
        gate._create()  # an existing folder is only tried: a file is made in it and removed
    return gate.out_dir


#: The signals that end a run early, held back while the output folder is between two states.
_INTERRUPTIONS = {signal.SIGINT, getattr(signal, "SIGTERM", signal.SIGINT)}


@contextlib.contextmanager
def _interruptions_held() -> Iterator[None]:
    """Delay Ctrl-C and SIGTERM until the block is over, then deliver them as they would have been.

    A handler that only remembers the signal stands in for the block: masking the signal would not
    do, since the kernel hands a process's signal to any thread that leaves it unmasked (numpy's
    BLAS threads among them). Outside the main thread Python runs no handler here, so nothing is held.
    """
    pending: list[int] = []

    def remember(signum, frame):
        pending.append(signum)

    try:
        previous = {number: signal.signal(number, remember) for number in _INTERRUPTIONS}
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, signal.SIG_DFL if handler is None else handler)
        for number in dict.fromkeys(pending):
            signal.raise_signal(number)


def _new_file(folder: Path, stem: str, suffix: str) -> Path:
    """Create ``folder/stem+suffix``, or ``stem-XXXXXXXX+suffix`` if that exists, as a new empty regular file.

    ``O_EXCL`` fails on any existing name, a symlink included, so nothing is ever written through one; a
    name taken (left by a run killed outright, or somebody's) is neither opened nor removed.
    """
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NO_FOLLOW
    for attempt in range(100):
        path = folder / (f"{stem}{suffix}" if attempt == 0 else f"{stem}-{secrets.token_hex(4)}{suffix}")
        try:
            os.close(os.open(path, flags, 0o666))
        except FileExistsError:
            continue
        return path
    raise FileExistsError(errno.EEXIST, "no free temporary name", os.fspath(folder))  # pragma: no cover


def _plain_name(name: str) -> str:
    """Refuse a name with a folder in it: a run writes into its folder only."""
    if not isinstance(name, str) or name in ("", ".", "..") or os.path.basename(name) != name or "/" in name \
            or "\\" in name or "\0" in name:
        raise OutputFolderError(f"an output name must be a plain file name, got {name!r}")
    return name


def _inside(path: str, folder: str) -> bool:
    """Whether ``path`` is ``folder`` or lies under it (both resolved)."""
    try:
        return os.path.commonpath([path, folder]) == folder
    except ValueError:  # different drives
        return False


def _existing_parent(path: Path) -> Path:
    for parent in path.absolute().parents:
        if os.path.lexists(parent):
            return parent
    return Path(path.absolute().anchor)  # pragma: no cover - the root always exists


def _reason(exc: OSError) -> str:
    if exc.errno == errno.ENAMETOOLONG:
        return "a name in the path is over the file system's length limit"
    return exc.strerror or str(exc)


def _read_manifest(path: Path) -> dict[str, list[dict]] | None:
    """The manifest's records by name; None where there is none, or what is there is not one of a run's.

    An unreadable, oversized or malformed file, a symlink, a FIFO or a folder at that name is
    not a run's list: it is the user's, and :meth:`OutputFolder._check_contents` keeps it.
    """
    try:
        # Non-blocking: a FIFO put there must not hang the gate; then only a regular file is read.
        handle = os.open(path, os.O_RDONLY | _NO_FOLLOW | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return None
    try:
        if not stat.S_ISREG(os.fstat(handle).st_mode):
            os.close(handle)
            return None
        with os.fdopen(handle, "rb") as stream:
            text = stream.read(_MAX_MANIFEST_BYTES + 1)
        data = json.loads(text) if len(text) <= _MAX_MANIFEST_BYTES else None
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("format") != MANIFEST_FORMAT or not isinstance(data.get("files"), dict):
        return None
    return {name: [r for r in records if _valid_record(r)]
            for name, records in data["files"].items() if isinstance(records, list)}


def _valid_record(record: Any) -> bool:
    return (isinstance(record, dict) and isinstance(record.get("sha256"), str)
            and all(isinstance(record.get(key), int) and not isinstance(record.get(key), bool)
                    for key in ("size", "mtime_ns")))


def _record(path: Path) -> dict:
    status = os.lstat(path)
    return {"size": status.st_size, "mtime_ns": status.st_mtime_ns, "sha256": _sha256(path)}


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _matching(entry: os.DirEntry, records: Sequence[dict]) -> dict | None:
    """The record of ``records`` that the regular file ``entry`` still is, if any."""
    try:
        if not records or not entry.is_file(follow_symlinks=False):
            return None
        status = entry.stat(follow_symlinks=False)
        sized = [r for r in records if r["size"] == status.st_size]
        for record in sized:
            if record["mtime_ns"] == status.st_mtime_ns:
                return record
        if sized:
            # Touched but perhaps not changed: the content decides.
            digest = _sha256(Path(entry.path))
            return next((dict(r, mtime_ns=status.st_mtime_ns) for r in sized if r["sha256"] == digest), None)
    except OSError:
        return None
    return None
