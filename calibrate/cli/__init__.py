"""The command line, one module per subcommand: each adds its parser (`add_parser(sub)`)
and runs it (`run(args) -> exit code`). `COMMANDS` lists them in `--help`'s order."""

from __future__ import annotations

import argparse
import importlib

from calibrate import csvfile

COMMANDS = ("fit", "compare", "predict", "evaluate", "merge", "export", "example")


def module(command: str):
  return importlib.import_module(f"calibrate.cli.{command}")


def layout() -> str:
  """The CSV layout's bullets from `csvfile`'s docstring, each with its continuation lines."""
  text = csvfile.__doc__.split("The layout", 1)[1].split("\n\n", 2)[1]
  return text.rstrip()


def parser() -> argparse.ArgumentParser:
  out = argparse.ArgumentParser(
      prog="python -m calibrate", formatter_class=argparse.RawDescriptionHelpFormatter,
      description="Fit, apply, score and export force estimators on CSV recordings.",
      epilog="CSV layout:\n" + layout())
  sub = out.add_subparsers(dest="command", required=True, metavar="COMMAND")
  for command in COMMANDS:
    module(command).add_parser(sub)
  return out
