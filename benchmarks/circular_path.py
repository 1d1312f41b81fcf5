"""circular_path: the LSANN paper's Table I with the networks trained on the Circular path."""

from __future__ import annotations

from benchmarks import footpad_table

DESCRIPTION = "footpad: LS, LSANN and NN-only trained on the Circular path"


def run(ctx) -> dict:
  return footpad_table.run_table(ctx, ("circular",))
