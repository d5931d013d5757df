"""One module per ``posfb`` subcommand; each exposes ``configure(parser)``, which adds
the command's arguments to the sub-parser ``analysis.cli`` made for it (with the
one-line help of ``cli.COMMANDS``) and sets ``handler``.

Importing a command module and configuring its parser is cheap: the models, Drake,
numpy and the plotting libraries are imported by the handler when the command runs,
so that ``posfb --help`` and a refused option answer at once.

A command's handler returns the process exit code. It raises ``UsageError``
(or ``ValueError``/``FileNotFoundError`` from validation) for bad input; the
entry point turns those into one line on stderr and a non-zero exit.
"""
