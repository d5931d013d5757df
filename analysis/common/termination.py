"""SIGTERM answered as Ctrl-C is (issue 43): a command's process turns it into
``TerminatedError`` (a ``KeyboardInterrupt``), so every ``finally`` and cleanup an
interrupt runs (a store's finished samples kept, a compiler's process group stopped,
temporary folders removed) runs for it too, and the command line then says "terminated"
with ``EXIT_TERMINATED``. A process forked from the command (a worker) keeps the
signal's default action. Handlers that defer Ctrl-C (the Monte-Carlo scheduler's) defer
SIGTERM alike and call ``mark_terminated``."""

from __future__ import annotations

import os
import signal

#: Exit code after SIGTERM (128 + 15, the shell's convention).
EXIT_TERMINATED = 128 + signal.SIGTERM


class TerminatedError(KeyboardInterrupt):
    """SIGTERM, raised in the command's process as Ctrl-C is (module docstring)."""


#: The command's process id (``install``) and whether SIGTERM arrived.
_STATE: dict[str, object] = {"owner": None, "terminated": False}


def install() -> None:
    """Answer SIGTERM in this process (the command's) with ``TerminatedError``, unless
    someone installed a handler of their own."""
    _STATE.update(owner=os.getpid(), terminated=False)
    if signal.getsignal(signal.SIGTERM) in (signal.SIG_DFL, None):
        signal.signal(signal.SIGTERM, _on_terminate)


def mark_terminated() -> None:
    """Record that SIGTERM arrived (for a handler that defers it)."""
    _STATE["terminated"] = True


def terminated() -> bool:
    """Whether SIGTERM arrived in this command."""
    return bool(_STATE["terminated"])


def in_command_process() -> bool:
    """Whether this is the command's own process (not a worker forked from it)."""
    return os.getpid() == _STATE["owner"]


def received() -> bool:
    """In a SIGTERM handler: outside the command's process (a forked worker), end this
    process as the signal's default action would and return ``False``; in it, record the
    signal (``mark_terminated``) and return ``True``: the handler then answers it."""
    if not in_command_process():
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGTERM)
        return False
    mark_terminated()
    return True


def _on_terminate(signum: int, frame: object) -> None:
    if received():
        raise TerminatedError
