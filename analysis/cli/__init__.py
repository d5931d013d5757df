"""The ``posfb`` command line: parses, calls, prints. Subcommands live in
``analysis.cli.commands``, one module each; ``build_parser`` imports only the module of the
command being run, so that ``posfb --help`` and a refused option answer at once (the
models, Drake and numpy load when a command runs). ``python -m posfb.analysis.cli`` runs
``main`` (``__main__``), as the ``posfb`` script does."""

from __future__ import annotations

import argparse
import importlib
import os
import re
import sys
import traceback
from collections.abc import Sequence

from posfb import __version__
from posfb.analysis.common.errors import (
    DISK_FULL_ERRNOS,
    EXIT_DISK_FULL,
    EnvironmentFaultError,
    InterruptedRunError,
    UsageError,
)

#: Subcommand (a module of ``posfb.analysis.cli.commands`` with ``configure(parser)``) -> its
#: one-line help, in the order ``posfb --help`` lists them.
COMMANDS = {
    "identify": "theta (Sec. 4.1) of a URDF plant, or a model with its uncertainty from an "
    "encoder log (--log); identify plan: an exciting trajectory",
    "design": "design the position-feedback controller (Sec. 3) and check it",
    "tune": "a robust design for a scenario's arm, verified with a stated guarantee",
    "scenario": "print or check a scenario file",
    "simulate": "one closed-loop run of a scenario: RMS errors and voltages",
    "compare": "several controllers on one scenario: a table and overlaid figures",
    "reproduce": "Sec. 4: 3 controllers x {nominal, payload}, tables, figures, report",
    "codegen": "the designed controller as C99 (no dynamic memory), checked against a log",
    "graph": "render the closed-loop diagram (.svg/.png/.pdf, or .dot text)",
    "animate": "write an offline HTML animation of one run (Meshcat recording)",
    "montecarlo": "Monte-Carlo robustness study over sampled plants",
    "realism": "how far from hardware: non-idealities from the literature vs Tables 3-4",
    "model-error": "how far model error explains the hardware's errors: identification "
    "accuracy, Tables 3-4 on identified arms, a scan of sizes",
}

#: ``posfb --help``, above the list of commands.
DESCRIPTION = """\
posfb: robust joint-position-feedback control of robot manipulators (ASME JDSMC 2013)
on Drake. Design the controller, simulate the closed loop of a scenario (the paper's
two-link arm by default, or your own URDF, trajectory and settings), reproduce the
paper's Sec. 4 and study robustness over sampled plants."""

#: ``posfb --help``, below the list of commands.
EPILOG = """\
examples:
  posfb simulate --controller lin_lc --set timing.sample_time=0.005 --duration 1
      a 1 s run of the Lin + LC controller at T_s = 5 ms, its RMS errors and voltages
  posfb scenario dump > my.yaml && posfb simulate --scenario my.yaml
      every setting of a run written to a file, to edit and run again
  posfb compare --controllers pid,lin_lc,proposed,adrc --out cmp
      four controllers on the paper's arm: a table and overlaid figures in cmp/
  posfb reproduce --out results
      the paper's Sec. 4: tables, figures and a report in results/

exit codes: 0 done; 1 a design check failed (scenario check, --strict), a replayed
sample differs from its stored rows, or codegen --check's C differs from the log by more
than the tolerance; 2 bad input; 3 a bug in posfb; 4 a run diverged
(simulate, compare); 5 a run finished saturated or lost its path (simulate, compare;
a warning says which); 6 a results store is damaged; 7 the disk refused a write (no
space left; what finished is kept, run again to resume); 8 a worker process died on a
sample and its retry (montecarlo run, realism, model-error: recorded as that sample's
error, the run went on); 9 the C compiler is missing, failed or ran past its limit
(codegen --check, simulate --sil; POSFB_COMPILE_TIMEOUT, default 300 s);
130 interrupted; 143 terminated (SIGTERM: a line, and what Ctrl-C keeps is kept).
The same from Python: import posfb (posfb.simulate, posfb.compare, posfb.build).
Run posfb COMMAND --help for the options of a command."""

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


def chosen_command(argv: Sequence[str]) -> str | None:
    """The subcommand ``argv`` runs: its first token that names one (``None``: none)."""
    return next((token for token in argv if token in COMMANDS), None)


def build_parser(argv: Sequence[str] | None = None, every: bool = False) -> argparse.ArgumentParser:
    """The parser of ``posfb``, for the arguments ``argv`` (default: ``sys.argv[1:]``).

    Only the chosen subcommand's module is imported and its options added; every
    other subcommand is a stub with its help line, so that ``posfb --help`` lists all.
    ``every``: every subcommand with all its options (the user guide's CLI reference)."""
    chosen = chosen_command(sys.argv[1:] if argv is None else argv)
    parser = _Parser(
        prog="posfb", description=DESCRIPTION, epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )  # fmt: skip
    parser.add_argument("--version", action="version", version=f"posfb {__version__}")
    subparsers = parser.add_subparsers(
        dest="command", required=True, parser_class=_Parser, title="commands", metavar="COMMAND"
    )
    for name, text in COMMANDS.items():
        if name != chosen and not every:
            subparsers.add_parser(name, help=text)
            continue
        module = importlib.import_module(f"posfb.analysis.cli.commands.{name.replace('-', '_')}")
        module.configure(subparsers.add_parser(name, help=text, description=text))
    return parser


def full_parser() -> argparse.ArgumentParser:
    """``posfb``'s parser with every subcommand's options (for generated documentation)."""
    return build_parser([], every=True)


def _user_frames(error: BaseException) -> list[traceback.FrameSummary]:
    """The traceback frames of ``error`` in a user's plug-in controller (none unless a
    plug-in was loaded)."""
    plugin = sys.modules.get("posfb.models.controllers.plugin")
    return plugin.user_frames(error) if plugin is not None else []


def _setting_without_value(argv: Sequence[str]) -> str | None:
    """The first ``--set KEY`` whose value has no ``=`` (``--set timing.duration 5``)."""
    for flag, value in zip(argv, argv[1:], strict=False):
        if flag == "--set" and "=" not in value:
            return value
    return None


def plain_numbers(message: str) -> str:
    """``message`` with numpy scalar reprs (``np.float64(1.0)``) written as plain numbers:
    the last line of defence, for a value that reached a message unconverted."""
    return _NUMPY_SCALAR.sub(r"\1", message)


#: ``np.float64(1.5)``, ``np.int64(3)``, ``np.True_`` ...
_NUMPY_SCALAR = re.compile(r"np\.(?:float|int|uint|complex)\d*\(([^()]*)\)")


def _interrupted_import(error: ImportError) -> bool:
    """Whether ``error`` is a Ctrl-C or SIGTERM that arrived while a compiled module
    initialised (Python reports it as ``ImportError: initialization failed``)."""
    seen: BaseException | None = error
    while seen is not None:
        if isinstance(seen, KeyboardInterrupt):
            return True
        seen = seen.__cause__ or seen.__context__
    return False


def _stopped(command: str | None, what: str = "") -> int:
    """The line and exit code of a command stopped by Ctrl-C or SIGTERM."""
    from posfb.analysis.common import termination

    terminated = termination.terminated()
    word = "terminated" if terminated else "interrupted"
    prefix = "posfb" if command is None else f"posfb {command}"
    sys.stderr.write(f"{prefix}: {word}{': ' + what if what else ''}\n")
    return termination.EXIT_TERMINATED if terminated else EXIT_INTERRUPTED


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``posfb``; returns the exit code. SIGTERM is answered as Ctrl-C
    is, with a line and ``EXIT_TERMINATED`` (``analysis.common.termination``)."""
    from posfb.analysis.common import termination

    termination.install()
    arguments = sys.argv[1:] if argv is None else list(argv)
    missing = _setting_without_value(arguments)
    if missing is not None:
        sys.stderr.write(
            f"posfb: error: --set {missing}: KEY=VALUE is required, one argument "
            f"(e.g. --set {missing.rstrip('=')}=5)\n"
        )
        return EXIT_BAD_INPUT
    try:
        parser = build_parser(argv)
    except KeyboardInterrupt:
        return _stopped(None)
    except ImportError as error:
        if _interrupted_import(error):
            return _stopped(None)
        raise
    args = parser.parse_args(argv)
    try:
        return int(args.handler(args) or 0)
    except (UsageError, ValueError, FileNotFoundError) as error:
        message = str(error).strip().splitlines()[0] if str(error).strip() else repr(error)
        sys.stderr.write(f"posfb {args.command}: error: {plain_numbers(message)}\n")
        return EXIT_BAD_INPUT
    except EnvironmentFaultError as fault:  # the disk, the store file, a killed process
        sys.stderr.write(f"posfb {args.command}: error: {fault}\n")
        return fault.exit_code
    except InterruptedRunError as interrupt:
        return _stopped(args.command, str(interrupt))
    except KeyboardInterrupt:
        return _stopped(args.command)
    except BrokenPipeError:
        # The reader of stdout left early (``posfb design | head``): not an error.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as error:  # the machine's answer to a path or resource the user gave
        where = f": {error.filename}" if error.filename else ""
        sys.stderr.write(f"posfb {args.command}: error: {error.strerror or error}{where}\n")
        return EXIT_DISK_FULL if error.errno in DISK_FULL_ERRNOS else EXIT_BAD_INPUT
    except Exception as error:  # a bug in posfb, not in the input: show everything
        if isinstance(error, ImportError) and _interrupted_import(error):
            return _stopped(args.command)
        frames = _user_frames(error)
        if frames:  # raised in the user's own controller: show the user's code only
            sys.stderr.write("".join(traceback.format_list(frames)))
            sys.stderr.write("".join(traceback.format_exception_only(error)))
            sys.stderr.write(
                f"posfb {args.command}: error in your controller ({frames[-1].filename}, "
                f"line {frames[-1].lineno}): {type(error).__name__}: {error}\n"
            )
            return EXIT_BAD_INPUT
        traceback.print_exc()
        sys.stderr.write(
            f"posfb {args.command}: internal error: this is a bug in posfb, not in your "
            "input; please report it with the traceback above\n"
        )
        return EXIT_INTERNAL_ERROR
