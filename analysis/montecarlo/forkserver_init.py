"""Imported by the forkserver of local Monte-Carlo workers only (its preload list,
``scheduler``): Ctrl-C reaches the whole process group, and only the parent decides
what to do with it. The forkserver records its signal handlers after its preload and
restores them in every worker it forks, so workers ignore Ctrl-C from their first
instruction (even while they import posfb)."""

import signal

signal.signal(signal.SIGINT, signal.SIG_IGN)
