"""One module per ``posfb`` subcommand; each exposes ``register(subparsers)``.

A command's handler returns the process exit code. It raises ``UsageError``
(or ``ValueError``/``FileNotFoundError`` from validation) for bad input; the
entry point turns those into one line on stderr and a non-zero exit.
"""
