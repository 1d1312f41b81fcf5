"""asterisk_path: the main job. The LSANN paper's Table I with the networks trained on the
Asterisk path: LS on the Z/X/Y strokes, LSANN and NN-only on Asterisk, tested on Testing
Paths 1 and 2."""

from __future__ import annotations

from benchmarks import footpad_table

DESCRIPTION = "footpad: LS, LSANN and NN-only trained on the Asterisk path (paper Table I)"


def run(ctx) -> dict:
  return footpad_table.run_table(ctx, ("asterisk",))
