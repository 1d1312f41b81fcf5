"""The model families an estimator is built from, one module each: its fitted type, its fit,
its arrays for the file and its C (`calibrate.parts.base.Part`).

`FAMILIES` names them for the file format and the command line; a module is imported only
when its family is used (`--help` stays free of JAX). `OPTIONS` says which of the command
line's model options each family reads (and which of its settings it sets), `METHODS` which
families each method is built from: `fit --method poly --epochs 5` is refused by name.
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
    "gp": ("calibrate.parts.gp", "GP"),
    "deep": ("calibrate.parts.deep", "Deep"),
}


def family(name: str) -> type:
  """The fitted type of the family `name`; KeyError for a name no family has."""
  module, cls = FAMILIES[name]
  return getattr(importlib.import_module(module), cls)


# command-line option -> the family's setting it sets (None: read by the fit, not a setting)
OPTIONS = {
    "linear": {},
    "poly": {"--degree": "degree", "--per-channel": None},
    "mlp": {"--hidden": "hidden", "--epochs": "epochs", "--weight-decay": "weight_decay",
            "--ensemble": None},
    "gru": {"--hidden": "hidden", "--epochs": "steps"},
    "memory": {},
    "gp": {},
    "deep": {"--layers": "layers", "--epochs": "epochs", "--weight-decay": "weight_decay",
             "--ensemble": None},
}

# each method of `python -m calibrate fit --method` and the families it is built from
METHODS = {
    "ls": ("linear",),
    "poly": ("poly", "linear"),
    "lsann": ("linear", "mlp"),
    "nn": ("mlp",),
    "gru": ("linear", "gru"),
    "auto": ("linear", "poly", "mlp", "deep"),
    "lsgp": ("linear", "gp"),
    "mlp": ("linear", "deep"),
}


def options(method: str) -> dict:
  """{option: setting} of every family `method` is built from."""
  out = {}
  for name in METHODS[method]:
    out.update(OPTIONS[name])
  return out
