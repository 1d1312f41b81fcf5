"""The model families an estimator is built from, one module each: its fitted type, its fit,
its arrays for the file and its C (`calibrate.parts.base.Part`).

`FAMILIES` names them for the file format and the command line; a module is imported only
when its family is used (`--help` stays free of JAX).
"""

from __future__ import annotations

import importlib

# name in an estimator file -> (module, fitted type)
FAMILIES = {
    "linear": ("calibrate.parts.linear", "LinearFit"),
    "poly": ("calibrate.parts.poly", "PolyFit"),
    "mlp": ("calibrate.parts.mlp", "MLP"),
    "gru": ("calibrate.parts.gru", "GRU"),
    "memory": ("calibrate.parts.memory", "Memory"),
}


def family(name: str) -> type:
  """The fitted type of the family `name`; KeyError for a name no family has."""
  module, cls = FAMILIES[name]
  return getattr(importlib.import_module(module), cls)
