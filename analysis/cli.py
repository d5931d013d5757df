"""The ``posfb`` command line: parses, calls, prints. Subcommands live in
``analysis.commands``; each module registers its own parser."""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import traceback
from collections.abc import Sequence

from posfb.analysis.errors import InterruptedRunError, UsageError

#: Subcommand modules of ``posfb.analysis.commands``, in the order ``posfb --help`` lists
#: them. Imported by ``build_parser``, inside ``main``: a Ctrl-C while Drake and numpy load
#: (the first seconds) is then one line too.
COMMANDS = ("identify", "design", "scenario", "simulate", "reproduce", "graph", "animate",
            "montecarlo")  # fmt: skip

#: Exit code for bad input (argparse uses the same).
EXIT_BAD_INPUT = 2

#: Exit code of a bug in posfb (a traceback is shown).
EXIT_INTERNAL_ERROR = 3

#: Exit code after Ctrl-C (128 + SIGINT, as shells report it).
EXIT_INTERRUPTED = 130


class _Parser(argparse.ArgumentParser):
    """argparse that reports errors as one line (no usage dump)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"posfb: error: {message}\n")
        raise SystemExit(EXIT_BAD_INPUT)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="posfb", description=__doc__)
    subparsers = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in COMMANDS:
        importlib.import_module(f"posfb.analysis.commands.{name}").register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``posfb``; returns the exit code."""
    try:
        parser = build_parser()
    except KeyboardInterrupt:
        sys.stderr.write("posfb: interrupted\n")
        return EXIT_INTERRUPTED
    args = parser.parse_args(argv)
    try:
        return int(args.handler(args) or 0)
    except (UsageError, ValueError, FileNotFoundError) as error:
        message = str(error).strip().splitlines()[0] if str(error).strip() else repr(error)
        sys.stderr.write(f"posfb {args.command}: error: {message}\n")
        return EXIT_BAD_INPUT
    except InterruptedRunError as interrupt:
        sys.stderr.write(f"posfb {args.command}: interrupted: {interrupt}\n")
        return EXIT_INTERRUPTED
    except KeyboardInterrupt:
        sys.stderr.write(f"posfb {args.command}: interrupted\n")
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # The reader of stdout left early (``posfb design | head``): not an error.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as error:  # the machine's answer to a path or resource the user gave
        where = f": {error.filename}" if error.filename else ""
        sys.stderr.write(f"posfb {args.command}: error: {error.strerror or error}{where}\n")
        return EXIT_BAD_INPUT
    except Exception:  # a bug in posfb, not in the input: show everything
        traceback.print_exc()
        sys.stderr.write(
            f"posfb {args.command}: internal error: this is a bug in posfb, not in your "
            "input; please report it with the traceback above\n"
        )
        return EXIT_INTERNAL_ERROR


if __name__ == "__main__":
    raise SystemExit(main())
