"""Running many independent tasks: in this process, on local processes, or on a Dask cluster.

:func:`outcomes` calls a function on every item and yields each outcome as it ends, with
the error message of a failed call instead of raising it, so that one failure does not
lose the others.  Local processes are spawned (no copy of this process's OpenCV threads or
open files); a Dask scheduler is reached through the client's
:class:`concurrent.futures.Executor`, the same code path.

A Dask scheduler is sent the function and its items as pickled Python, and its workers run
them; their results come back pickled.  Unpickling runs code, so a scheduler (or worker)
that is not yours can run anything on this machine, and its workers see the data: connect
only to a scheduler you trust, on a network you trust.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import os
from collections.abc import Callable, Iterator, Sequence
from typing import Any, TypeVar

from belief.install import install_command

from .errors import TrackingError

__all__ = ["outcomes", "executor", "runs_here", "describe_error", "MAX_ERROR_CHARS"]

Item = TypeVar("Item")


def runs_here(workers: int | None, scheduler: str | None, tasks: int) -> bool:
    """Whether :func:`outcomes` runs ``tasks`` items in this process, one after the other (no pool)."""
    return scheduler is None and min(workers or os.cpu_count() or 1, tasks) == 1


def outcomes(function: Callable[[Item], Any], items: Sequence[Item], *, workers: int | None = None,
             scheduler: str | None = None,
             pool: concurrent.futures.Executor | None = None) -> Iterator[tuple[Item, Any, str | None]]:
    """Call ``function`` on every item; yield ``(item, result, None)`` or ``(item, None, error)`` as each ends.

    Parameters
    ----------
    function : callable
        A module-level function (it is sent to other processes).
    items : sequence
    workers : int, optional
        Local processes (default: one per core); 1 runs the items here, one after the other.
        With ``scheduler="local"``, the number of workers of the local Dask cluster.
    scheduler : str, optional
        A Dask scheduler's address (``tcp://host:8786``), or ``"local"`` to start a Dask
        cluster on this machine (needs the ``dask`` extra).  A Dask scheduler runs the tasks
        it is sent as pickled Python: whoever controls the scheduler (and its workers) runs
        their own code in this process's name, and the results they send back are unpickled
        here, so connect to trusted schedulers only.
    pool : Executor, optional
        An executor already open (:func:`executor`), used instead of opening one here.

    Raises
    ------
    TrackingError
        Dask is asked for but missing, or its scheduler cannot be reached.

    Examples
    --------
    >>> sorted((item, result) for item, result, _ in outcomes(abs, [-2, 3], workers=1))
    [(-2, 2), (3, 3)]
    """
    if pool is None and runs_here(workers, scheduler, len(items)):
        for item in items:
            try:
                yield item, function(item), None
            except Exception as exc:  # noqa: BLE001 - reported with the item it came from
                yield item, None, describe_error(exc)
        return
    with contextlib.ExitStack() as stack:
        if pool is None:
            pool = stack.enter_context(executor(workers, scheduler, len(items)))
        futures = {pool.submit(function, item): item for item in items}
        try:
            for future in concurrent.futures.as_completed(futures):
                try:
                    result = future.result()
                except Exception as exc:  # noqa: BLE001 - reported with the item it came from
                    yield futures[future], None, describe_error(exc)
                else:
                    yield futures[future], result, None
        except BaseException:
            for future in futures:
                future.cancel()
            raise


#: The most characters of a failed task's error that its report keeps.
MAX_ERROR_CHARS = 500


def describe_error(exc: BaseException) -> str:
    """``Type: message`` of a failed task, on one line of at most :data:`MAX_ERROR_CHARS` characters.

    A task's error can be megabytes long or span lines (a traceback of a worker, a whole input
    quoted); the report of a grid is one line, however its runs failed.

    Examples
    --------
    >>> describe_error(ValueError("bad\\nvalue " + "x" * 1000))[:20], len(describe_error(ValueError("x" * 1000)))
    ('ValueError: bad valu', 500)
    """
    text = " ".join(f"{type(exc).__name__}: {exc}".split())
    return text if len(text) <= MAX_ERROR_CHARS else text[:MAX_ERROR_CHARS - 3] + "..."


@contextlib.contextmanager
def executor(workers: int | None, scheduler: str | None, tasks: int) -> Iterator[concurrent.futures.Executor]:
    """A process pool of ``min(workers, tasks)`` spawned processes, or a Dask client's executor."""
    if scheduler is None:
        import multiprocessing

        with concurrent.futures.ProcessPoolExecutor(min(workers or os.cpu_count() or 1, tasks),
                                                    mp_context=multiprocessing.get_context("spawn")) as pool:
            yield pool
        return
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise TrackingError(f"a Dask scheduler needs the dask extra: {install_command('dask')}") from None
    with contextlib.ExitStack() as stack:
        if scheduler == "local":
            cluster = stack.enter_context(LocalCluster(n_workers=workers or os.cpu_count() or 1,
                                                       threads_per_worker=1, dashboard_address=None))
            client = stack.enter_context(Client(cluster))
        else:
            _probe(scheduler)
            try:
                client = stack.enter_context(Client(scheduler, timeout=30))
            except (OSError, TimeoutError, ValueError) as exc:
                raise TrackingError(f"cannot reach the Dask scheduler at {scheduler!r} ({exc})") from None
            except Exception as exc:  # noqa: BLE001 - something answers there, but not as a Dask scheduler
                detail = (str(exc).splitlines() or [""])[0][:200]
                raise TrackingError(f"cannot reach the Dask scheduler at {scheduler!r}: what answers there is "
                                    f"not a Dask scheduler ({type(exc).__name__}: {detail})") from None
        # pure=False: two tasks are never merged into one, whatever their arguments
        yield client.get_executor(pure=False)


#: Seconds to wait for a TCP connection to a Dask scheduler before the client's own handshake.
PROBE_SECONDS = 5.0


def _probe(address: str) -> None:
    """Fail at once, in one line, when nothing listens at a ``tcp://host:port`` scheduler address.

    Dask's client retries a refused connection until its timeout (30 s); a plain TCP
    connection tells a wrong address or port in a moment.  Other schemes are left to Dask.
    """
    import socket
    from urllib.parse import urlsplit

    parts = urlsplit(address)
    if parts.scheme != "tcp":
        return
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        raise TrackingError(f"cannot reach the Dask scheduler at {address!r}: not a host:port address") from None
    if not host or port is None:
        return
    try:
        with socket.create_connection((host, port), timeout=PROBE_SECONDS):
            pass
    except OSError as exc:
        reason = exc.strerror or str(exc) or type(exc).__name__
        raise TrackingError(f"cannot reach the Dask scheduler at {address!r} ({reason})") from None
