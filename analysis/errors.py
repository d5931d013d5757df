"""Errors the command line reports as one line."""


class UsageError(Exception):
    """Bad input detected after parsing; reported as one line and a non-zero exit."""


class InterruptedRunError(Exception):
    """The user stopped a command (Ctrl-C); the message says what was kept and how to go
    on. Reported as one line with exit code 130."""


#: Exit code of ``posfb simulate`` and ``posfb compare`` when a run diverged
#: (``status == "diverged"``; its metrics and files are still written), so that scripts
#: and sweeps catch it without parsing the output.
EXIT_DIVERGED = 4
