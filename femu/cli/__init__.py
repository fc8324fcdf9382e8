"""The `femu` command.

One pattern for every command: a module in this package named after it, with a docstring whose
first line is the command's help, ``add_arguments(parser)`` and ``run(args) -> int``. A module
is imported only when its command runs, except for its arguments (so `femu model` stays fast).
Errors the user can fix (ValueError, FileNotFoundError, KeyError with a message that names the
file and the field) become one line on stderr and exit code 2.
"""

from __future__ import annotations

import argparse
import importlib
import keyword
import os
import sys
import warnings

#: The commands, in the order `femu --help` lists them: each is the module femu.cli.<name>.
COMMANDS = ("model", "suite", "optimizers", "study", "results", "report", "reproduce", "diagnose", "identify",
            "update", "import", "export")


def _module(name: str):
    """The module of command `name` (a Python keyword's with a trailing _: import_.py)."""
    return importlib.import_module(f"femu.cli.{name}{'_' if keyword.iskeyword(name) else ''}")


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the command docstrings' layout and appends "(default: X)" to the help of every
    option that has a default worth showing (not None, False or a default the help states)."""

    def _get_help_string(self, action):
        text = action.help or ""
        if action.required and action.option_strings:
            return text + " (required)"
        if ("%(default)" in text or "default" in text.lower() or not action.option_strings
                or action.default in (None, False, argparse.SUPPRESS)):
            return text
        return text + " (default: %(default)s)"


class _Version(argparse.Action):
    """`femu --version`: the installed version, looked up only when asked (startup stays fast)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from importlib.metadata import PackageNotFoundError, version

        try:
            text = version("femu-bench")
        except PackageNotFoundError:  # run from a source tree that is not installed
            text = "unknown (not installed)"
        print(f"femu {text} (femu-bench)")
        parser.exit(0)


class ArgumentParser(argparse.ArgumentParser):
    """argparse's parser, whose usage errors are one line (``femu COMMAND: error: ...``, naming
    the argument) and exit code 2, as every other error of the command; `--help` is unchanged."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} (see `{self.prog} --help`)\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of `femu` with every command's sub-parser."""
    p = ArgumentParser(prog="femu", formatter_class=HelpFormatter,
                                description="FE model updating of planar and space frames: models, optimizer "
                                "benchmarks, studies, reports, modal identification and diagnosis. `femu COMMAND --help` "
                                "describes each command's arguments.")
    p.add_argument("--version", action=_Version, help="print the version and exit")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        module = _module(name)
        doc = (module.__doc__ or "").strip()
        sp = sub.add_parser(name, help=doc.splitlines()[0] if doc else None, description=doc or None,
                            formatter_class=HelpFormatter)
        module.add_arguments(sp)
        sp.set_defaults(func=module.run, command_parser=sp)
    return p


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A library warning (something read with a loss, a doubtful input) as one line on stderr."""
    print(f"femu: warning: {message}", file=sys.stderr if file is None else file)


def main(argv=None) -> int:
    """Run `femu` with ``argv`` (default: the command line); returns the exit code."""
    warnings.showwarning = _show_warning
    args, extra = build_parser().parse_known_args(argv)
    if extra:  # named by the command's own parser: "femu study: error: unrecognized arguments: ..."
        args.command_parser.error(f"unrecognized arguments: {' '.join(extra)}")
    try:
        return int(args.func(args) or 0)
    except BrokenPipeError:  # `femu results ... | head`: the reader left; not an error of ours
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except (ValueError, FileNotFoundError, KeyError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"femu {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except OSError as exc:  # a path that is a directory, unreadable, not writable, a full disk
        where = exc.filename if exc.filename is not None else "file system"
        print(f"femu {args.command}: error: {where}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    except (RecursionError, OverflowError, MemoryError) as exc:  # input too deep or too large
        print(f"femu {args.command}: error: the input is too large or too deeply nested to read "
              f"({type(exc).__name__}: {exc})", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
