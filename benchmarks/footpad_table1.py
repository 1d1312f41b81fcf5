"""footpad_table1: the LSANN paper's full protocol, networks trained on Asterisk + Circular."""

from __future__ import annotations

from benchmarks import footpad_table

DESCRIPTION = "footpad: the paper's full protocol (Asterisk + Circular training), Table I"


def run(ctx) -> dict:
  return footpad_table.run_table(ctx, ("asterisk", "circular"))
