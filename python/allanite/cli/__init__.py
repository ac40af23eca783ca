"""The ``allanite`` command line: one module per subcommand, wired here.

Each subcommand module defines ``register(subparsers)`` which adds its parser and sets
``func=run`` (a callable ``run(args) -> int``). Errors the user can fix (:class:`ValueError`,
:class:`TypeError`, :class:`OSError`, :class:`allanite.errors.InputError`, a missing optional
extra :class:`allanite.errors.MissingExtraError`) become one line on
stderr and exit code 2; no partial output file is left behind (write through
:func:`allanite.io.atomic.atomic_output`).
"""

from __future__ import annotations

import argparse
import importlib
import re
import sys
import warnings
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["SUBCOMMANDS", "SUMMARIES", "build_parser", "main"]

from allanite.cli.commands import SUBCOMMANDS, SUMMARIES

EXIT_OK = 0
EXIT_FAILURE = 1  # e.g. a pass/fail check failed
EXIT_USAGE = 2  # bad input, bad arguments, unreadable file


def build_parser(*, top_level_only: bool = False) -> argparse.ArgumentParser:
    """The top-level parser with every available subcommand registered.

    With ``top_level_only`` the subcommands are listed by name and summary only, without
    importing their modules (numpy, scipy, ...): enough for ``allanite --version`` and
    ``allanite --help``, which then answer at once.
    """
    parser = argparse.ArgumentParser(
        prog="allanite",
        description="Gyroscope noise analysis: Allan deviation, noise-term fits, simulation and "
        "sim-to-real diagnosis.",
        epilog="examples:\n  allanite analyze --example\n  allanite analyze rec.csv --fs 100 "
        "--input angle --json\n  allanite fit rec.npy --fs 2000 --units deg/s -o model.json\n"
        "Run 'allanite COMMAND --help' for the options of each command.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    from allanite import __version__

    parser.add_argument("--version", action="version", version=f"allanite {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    if top_level_only:
        for name in SUBCOMMANDS:
            sub.add_parser(name, help=SUMMARIES[name])
        return parser
    for module_name in SUBCOMMANDS.values():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name != module_name:
                raise
            continue
        module.register(sub)
    return parser


#: a library message's fix with its command-line spelling: ``key= (CLI: --key NAME)``
_BOTH_SPELLINGS = re.compile(r"\b\w+=\S* \(CLI: ([^;)]+)(?:; ([^)]*))?\)")


def cli_spelling(message: str) -> str:
    """A library error message as the command line says it: only the option of each fix.

    ``choose one with key= (CLI: --key NAME)`` becomes ``choose one with --key NAME``; a
    second spelling for one subcommand stays in brackets (``--rate HZ (diagnose:
    --sim-rate HZ)``).
    """

    def option(match: re.Match[str]) -> str:
        return match.group(1) + (f" ({match.group(2)})" if match.group(2) else "")

    return _BOTH_SPELLINGS.sub(option, message)


def _warning_printer(command: str, default: Callable[..., None]) -> Callable[..., None]:
    """Return a ``warnings.showwarning`` for a subcommand.

    A library's finding about the input (:class:`~allanite.errors.ImplausibleInputWarning`)
    is printed as ``allanite COMMAND: warning: ...`` in the command line's spelling; any
    other warning as Python shows it.
    """
    from allanite.errors import ImplausibleInputWarning

    def show(message: Warning | str, category: type[Warning], *args: Any, **kwargs: Any) -> None:
        if issubclass(category, ImplausibleInputWarning):
            text = cli_spelling(" ".join(str(message).split()))
            print(f"allanite {command}: warning: {text}", file=sys.stderr)
        else:
            default(message, category, *args, **kwargs)

    return show


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``allanite`` console script; returns the exit code."""
    from allanite.errors import ImplausibleInputWarning, InputError, MissingExtraError

    words = list(sys.argv[1:] if argv is None else argv)
    if not any(word in SUBCOMMANDS for word in words):  # --version, --help: no imports
        build_parser(top_level_only=True).parse_args(words)
    from allanite.io.atomic import guard_inputs  # imports numpy: only for a command

    parser = build_parser()
    args = parser.parse_args(words)
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    try:
        with warnings.catch_warnings(), guard_inputs():  # no output may be an input
            # findings about the input are advice the CLI prints, whatever the -W filters
            warnings.simplefilter("always", ImplausibleInputWarning)
            warnings.showwarning = _warning_printer(args.command, warnings.showwarning)
            from allanite.units import display_angle

            with display_angle(getattr(args, "display_units", None)):
                return int(args.func(args) or 0)
    except BrokenPipeError:  # the reader of stdout went away (e.g. `| head`): not an error
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except (InputError, ValueError, TypeError, OSError, MissingExtraError) as exc:
        message = cli_spelling(" ".join(str(exc).split()))
        print(f"allanite {args.command}: error: {message}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"allanite {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
