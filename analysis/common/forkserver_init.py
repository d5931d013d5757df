"""Imported first by every forkserver posfb starts (``FORKSERVER_INIT`` of
``analysis.common.side_by_side``: the Monte-Carlo workers', ``analysis.montecarlo.
scheduler``, and those of ``side_by_side``: ``tune``, the Monte-Carlo report).

Ctrl-C reaches the whole process group, and only the parent decides what to do with it.
The forkserver records its signal handlers after its preload and restores them in every
worker it forks, so workers ignore Ctrl-C from their first instruction (even while they
import posfb).

It also loads ``scipy.stats`` (a third of a second), which every such worker uses (a
sample's draw, a plant family's, a report's ranks): once in the server, not in each
worker. The commands themselves import it only where they use it."""

import signal

signal.signal(signal.SIGINT, signal.SIG_IGN)

import scipy.stats  # noqa: E402, F401  (after the handler: see the docstring)
