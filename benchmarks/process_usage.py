"""Run the ``belief`` command line as a process of its own; read its exit status, stderr, time and peak memory.

Shared by the hardening scripts.  The peak is the child's own ``ru_maxrss``, read with
``os.wait4`` (the usage that ``resource.getrusage(RUSAGE_CHILDREN)`` accumulates, for this
child alone).  The child inherits the caller's environment unchanged.
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import NamedTuple

CLI = [sys.executable, "-c", "import sys; from belief.cli import main; sys.exit(main())"]
#: What a hostile input may cost, result or refusal.
LIMIT_SECONDS = 10.0
LIMIT_BYTES = 1 << 30


class Usage(NamedTuple):
    status: int
    stderr: str
    seconds: float
    peak: int            # bytes
    killed: bool         # still running after ``kill_after`` seconds


def maxrss_bytes(usage: resource.struct_rusage) -> int:
    """ru_maxrss in bytes (it is in KiB on Linux, in bytes on macOS)."""
    return usage.ru_maxrss if sys.platform == "darwin" else usage.ru_maxrss * 1024


def running(pid: int) -> bool:
    """Whether the child is still running, without reaping it (so that wait4 can read its usage)."""
    return os.waitid(os.P_PID, pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is None


def run_cli(argv: list, folder: Path, *, stdout: Path | None = None, terminate_when: Path | None = None,
            kill_after: float = 60.0, address_space: int | None = None) -> Usage:
    """Run ``belief ARGV`` in ``folder``, standard output to the file ``stdout`` (else discarded).

    With ``terminate_when``, SIGTERM is sent once that file exists.  A process still running
    after ``kill_after`` seconds is killed; ``address_space`` (bytes) caps its memory, so that
    a runaway job cannot take the machine down.
    """
    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (address_space, address_space))

    started = time.perf_counter()
    with open(stdout if stdout is not None else os.devnull, "wb") as out:
        process = subprocess.Popen([*CLI, *[str(a) for a in argv]], cwd=folder, stdout=out, stderr=subprocess.PIPE,
                                   preexec_fn=cap if address_space else None)
        chunks: list[bytes] = []
        reader = threading.Thread(target=lambda: chunks.append(process.stderr.read()))
        reader.start()
        killed = terminated = False
        while running(process.pid):
            if time.perf_counter() - started > kill_after:
                process.send_signal(signal.SIGKILL)
                killed = True
                break
            if terminate_when is not None and not terminated and terminate_when.exists():
                process.send_signal(signal.SIGTERM)
                terminated = True
            time.sleep(0.01)
        _, status, usage = os.wait4(process.pid, 0)
        seconds = time.perf_counter() - started
        process.returncode = os.waitstatus_to_exitcode(status)
        reader.join()
        process.stderr.close()
    return Usage(process.returncode, b"".join(chunks).decode("utf-8", "replace"), seconds, maxrss_bytes(usage),
                 killed)
