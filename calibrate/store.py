"""Estimator files: one .npz, the structure as JSON, each part's arrays under its path.

Format 4 keeps the tree of parts (`calibrate.compose`, `calibrate.parts`) as a spec, as
equinox keeps a PyTree's structure in code and its leaves in the file: `meta["root"]` is
{"part": name, "spec": its settings, "leaves": {name: shape}, "children": {name: spec}},
and each array is named by its path ("root/stage/base/coef", "info/input_lo"). Every leaf's
shape is checked against the spec, and every array of the file must belong to a part. The
format tag, the version and a SHA-256 of the arrays are checked before anything is read;
every array must be finite.

Version 3 (one flat file with key prefixes, the type told by which keys exist) is read by
`_read_v3` into the same tree: files written before keep loading.
"""

from __future__ import annotations

import pathlib

import numpy as np

from calibrate import compose
from calibrate.info import Info
from calibrate.parts import family
from util import errors, files

FORMAT = "testbench-estimator"
VERSION = 4  # 1: no format tag or checksum; 2: no Info, no members; 3: flat key prefixes
COMPOSITES = {c.NAME: c for c in (compose.Residual, compose.Mean, compose.PerOutput,
                                  compose.Chain)}


def part_type(name: str) -> type:
  if name in COMPOSITES:
    return COMPOSITES[name]
  try:
    return family(name)
  except KeyError:
    raise ValueError(f"it holds a part {name!r} this testbench does not know") from None


def flatten(part, path: str = "root") -> tuple[dict, dict]:
  """(arrays named by path, the spec tree) of a part and its children."""
  own, spec = part.leaves()
  arrays = {f"{path}/{k}": np.asarray(a) for k, a in own.items()}
  node = {"part": part.NAME, "spec": spec,
          "leaves": {k: list(np.shape(a)) for k, a in own.items()}, "children": {}}
  for name, child in part.children().items():
    sub, node["children"][name] = flatten(child, f"{path}/{name}")
    arrays.update(sub)
  return arrays, node


def unflatten(node: dict, arrays: dict, path: str = "root", used: set = None):
  """The part a spec tree describes, its leaves read from `arrays` and checked (shape as
  recorded); names each leaf it reads in `used`."""
  cls = part_type(node["part"])
  children = {name: unflatten(sub, arrays, f"{path}/{name}", used)
              for name, sub in node.get("children", {}).items()}
  own = {}
  for name, shape in node.get("leaves", {}).items():
    key = f"{path}/{name}"
    if key not in arrays:
      raise ValueError(f"{key} is missing")
    if list(arrays[key].shape) != list(shape):
      raise ValueError(f"{key} has shape {arrays[key].shape}, its spec says {tuple(shape)}")
    own[name] = arrays[key]
    if used is not None:
      used.add(key)
  return cls.from_leaves(node.get("spec", {}), own, children)


def save(path, kind: str, root, info=None, training=None) -> None:
  """Writes the estimator atomically, with the format tag, the version and a SHA-256 of the
  arrays that `load` checks."""
  arrays, tree = flatten(root)
  meta = {"kind": kind, "root": tree}
  if info is not None:
    arrays.update(info.arrays("info/"))
    meta["info"] = info.to_json()
  if training is not None:
    meta["training"] = {"stop": training.stop.name, "epochs": training.epochs}
  meta.update(format=FORMAT, version=VERSION, sha256=files.array_digest(arrays))
  files.atomic_write(pathlib.Path(path),
                     lambda f: np.savez(f, meta=files.json_text(meta), **arrays))


def load(path) -> tuple[str, object, Info]:
  """(method label, root part, info) of a file `save` (or version 3) wrote, checked.

  Raises:
    errors.DataError naming the file and what is wrong with it.
  """
  path = pathlib.Path(path)
  arrays = files.read_npz(path, f"estimator {path}", text=("meta",))
  try:
    meta = files.from_json(str(arrays.pop("meta")))
  except (KeyError, ValueError) as err:
    raise errors.DataError(f"estimator {path}: no readable settings ({err})") from None
  files.check_header(meta, path, "estimator", FORMAT, set(READERS), files.array_digest(arrays))
  bad = [k for k, a in arrays.items() if a.dtype.kind == "f" and not np.isfinite(a).all()]
  if bad:
    raise errors.DataError(f"estimator {path}: {', '.join(bad)} hold NaN or inf")
  try:
    return READERS[meta["version"]](meta, arrays)
  except (KeyError, ValueError, TypeError, IndexError, AttributeError) as err:
    raise errors.DataError(f"estimator {path}: {err}") from None


def _read_v4(meta: dict, arrays: dict):
  used = set()
  root = unflatten(meta["root"], arrays, "root", used)
  info = None
  if "info" in meta:
    info = Info.from_saved(meta["info"], arrays, "info/")
    used |= {k for k in arrays if k.startswith("info/")}
    _fits(root, info)
  stray = sorted(set(arrays) - used)
  if stray:
    raise ValueError(f"it holds arrays no part reads ({', '.join(stray[:5])})")
  return str(meta["kind"]), root, info


def _fits(root, info: Info) -> None:
  if (root.n_inputs, root.n_outputs) != (len(info.inputs), len(info.outputs)):
    raise ValueError(f"its parts read {root.n_inputs} inputs and give {root.n_outputs} "
                     f"outputs, its description names {len(info.inputs)} and "
                     f"{len(info.outputs)}")


def _strip(arrays: dict, prefix: str) -> dict:
  return {k[len(prefix):]: a for k, a in arrays.items() if k.startswith(prefix)}


def _read_v3(meta: dict, arrays: dict):
  """Version 3: `memory_` (the front end), `m{k}_` (members), `p{k}_` (AUTO's parts) and
  `linear_ poly_ net_ rnn_` (the stages) prefixes; the box of AUTO's guard is its Info's
  training range."""
  if "memory" in meta:
    front = family("memory").from_leaves(meta["memory"], _strip(arrays, "memory_"))
    kind, stage, info = _read_v3({k: v for k, v in meta.items() if k != "memory"},
                                 {k: a for k, a in arrays.items()
                                  if not k.startswith("memory_")})
    return kind, compose.Chain.from_leaves({}, {}, {"front": front, "stage": stage}), info
  kind = str(meta["kind"])
  info = Info.from_saved(meta["info"], arrays) if "info" in meta else None
  for key, prefix in (("members", "m"), ("parts", "p")):
    if key in meta:
      children = {str(i): _read_v3(m, _strip(arrays, f"{prefix}{i}_"))[1]
                  for i, m in enumerate(meta[key])}
      if key == "members":
        return kind, compose.Mean.from_leaves({}, {}, children), info
      if kind != "AUTO":
        raise ValueError("its parts do not fit its outputs")
      box = {} if info is None else {"lo": info.input_lo, "hi": info.input_hi}
      return kind, compose.PerOutput.from_leaves({"pick": meta["pick"]}, box, children), info
  return kind, _v3_stages(kind, meta, arrays), info


def _v3_stages(kind: str, meta: dict, arrays: dict):
  stage = {name: _strip(arrays, f"{prefix}_") for name, prefix in
           (("linear", "linear"), ("poly", "poly"), ("mlp", "net"), ("gru", "rnn"))}
  if stage["poly"]:
    if kind != "POLY":
      raise ValueError("the polynomial's arrays do not fit together")
    return family("poly").from_leaves(meta, stage["poly"])
  lin = family("linear").from_leaves(meta, stage["linear"]) if stage["linear"] else None
  net = family("mlp").from_leaves({}, stage["mlp"]) if stage["mlp"] else None
  rnn = family("gru").from_leaves({}, stage["gru"]) if stage["gru"] else None
  if (kind != "NN" and lin is None) or (kind in ("NN", "LSANN") and net is None) \
     or ((kind == "GRU") != (rnn is not None)):
    raise ValueError(f"a {kind} estimator needs its "
                     f"{'linear stage' if lin is None else 'network'}")
  if kind in ("LS", "POLY"):
    return lin
  if kind == "NN":
    return net
  return compose.Residual.from_leaves({}, {}, {"base": lin,
                                                "residual": net if kind == "LSANN" else rnn})


READERS = {3: _read_v3, 4: _read_v4}
