"""Estimators built from parts, as scikit-learn builds them from estimators.

- `Residual(base, residual)`: a base plus a part fitted on its residual (LSANN: LS plus a
  network; GRU: LS plus a recurrent network), as `TransformedTargetRegressor` inverts a
  transform at predict; here the transform y - base(x) depends on x, so the two add.
- `Mean(members)`: the mean of parts fitted from several seeds (`VotingRegressor`), and their
  spread.
- `PerOutput(parts, pick, lo, hi)`: each output from one part (`fit_auto`'s choice), the
  network parts continued along the LS part's plane beyond the training box [lo, hi].
- `Chain(front, stage)`: a temporal front end (`calibrate.parts.memory.Memory`) turning the
  recording into features, then a stage reading them (`Pipeline`; equinox marks its
  stateful layers the same way).

Each composite predicts, lists its children for the file, and writes its C as its children's
blocks in order: the tags and the order are the exported C's contract.
"""

from __future__ import annotations

import dataclasses
from typing import Optional

import numpy as np

from calibrate.cexport.emitter import literal
from calibrate.parts.base import (Part, Stream, box_distance, box_point, check_shapes,
                                  emit_box_distance, emit_box_point, read_beyond)


@dataclasses.dataclass(frozen=True)
class Residual(Part):
  """base(x) + residual(x), the residual part reading the first of the base's inputs."""
  base: Part
  residual: Part
  NAME = "residual"

  @property
  def label(self) -> str:
    return self.residual.RESIDUAL_LABEL

  @property
  def n_inputs(self) -> int:
    return max(self.base.n_inputs, self.residual.n_inputs)

  @property
  def n_outputs(self) -> int:
    return self.base.n_outputs

  @property
  def tame(self) -> bool:
    return self.base.tame and self.residual.tame

  def children(self) -> dict:
    return {"base": self.base, "residual": self.residual}

  def mean_spread(self, x, stream=None):
    return (self.base.mean_spread(x, stream)[0]
            + self.residual.mean_spread(x, stream)[0]), None

  def leaves(self):
    return {}, {}

  @classmethod
  def from_leaves(cls, spec, arrays, children) -> "Residual":
    out = cls(children["base"], children["residual"])
    if out.residual.n_outputs != out.base.n_outputs or \
       out.residual.n_inputs > out.base.n_inputs:
      raise ValueError(f"its {out.residual.NAME} part does not fit its {out.base.NAME} stage")
    return out

  def emit_c(self, em, tag: str, c: int, acc: str = "acc") -> None:
    self.base.emit_c(em, f"{tag}_{self.base.C_TAG}", c, acc)
    self.residual.emit_c(em, f"{tag}_{self.residual.C_TAG}", c, acc)


@dataclasses.dataclass(frozen=True)
class Mean(Part):
  """The mean of members of one method (networks from several seeds) and their spread."""
  members: tuple
  NAME = "mean"

  @property
  def label(self) -> str:
    return self.members[0].label

  @property
  def n_inputs(self) -> int:
    return self.members[0].n_inputs

  @property
  def n_outputs(self) -> int:
    return self.members[0].n_outputs

  @property
  def tame(self) -> bool:
    return all(m.tame for m in self.members)

  def children(self) -> dict:
    return {str(k): m for k, m in enumerate(self.members)}

  def mean_spread(self, x, stream=None):
    each = np.stack([m.mean_spread(x, stream)[0] for m in self.members])
    return each.mean(axis=0), each.std(axis=0)

  def leaves(self):
    return {}, {}

  @classmethod
  def from_leaves(cls, spec, arrays, children) -> "Mean":
    out = cls(tuple(children[str(k)] for k in range(len(children))))
    if not out.members or len({(m.label, m.n_inputs, m.n_outputs)
                               for m in out.members}) != 1:
      raise ValueError("its members are not of one method and shape")
    return out

  def shared_base(self) -> Optional[Part]:
    """The base stage every member holds, equal to the last bit (an ensemble of LSANN fitted
    on one LS stage), or None."""
    bases = [getattr(m, "base", None) for m in self.members]
    if len(bases) < 2 or any(b is None for b in bases):
      return None
    first = bases[0].leaves()[0]
    if all(b.NAME == bases[0].NAME and all(np.array_equal(b.leaves()[0][k], a)
                                           for k, a in first.items()) for b in bases[1:]):
      return bases[0]
    return None

  def emit_c(self, em, tag: str, c: int, acc: str = "acc") -> None:
    """Each member under M{k}; a shared base once, into lin[] (it is not averaged)."""
    shared = self.shared_base()
    if shared is not None:
      shared.emit_c(em, f"{tag}SHARED_{shared.C_TAG}", c, acc="lin")
    for k, m in enumerate(self.members):
      sub = f"{tag}M{k}"
      if shared is not None:
        m.residual.emit_c(em, f"{sub}_{m.residual.C_TAG}", c, acc)
      else:
        emit_member(m, em, sub, c, acc)


def emit_member(part: Part, em, tag: str, c: int, acc: str = "acc") -> None:
  """One estimator's stages under `tag`: a family's block tagged with its C_TAG, or a
  composite's children in order."""
  if part.children():
    part.emit_c(em, tag, c, acc)
  else:
    part.emit_c(em, f"{tag}_{part.C_TAG}", c, acc)


def emit_estimate(part: Part, em, label: str, c: int, a: int, dest: str,
                  prefix: str = "") -> list[str]:
  """C lines that compute one estimator (or an ensemble) from x[] into dest[a]: its block
  between an accumulator acc[] and lin[], the shared base of an ensemble, which is not
  averaged; the members' mean is acc / their count."""
  before = len(em.code)
  if isinstance(part, Mean):
    part.emit_c(em, prefix, part.n_inputs)
    n, mean = len(part.members), f", mean of {len(part.members)}"
  else:
    emit_member(part, em, f"{prefix}M0", part.n_inputs)  # the first of the inputs it reads
    n, mean = 1, ""
  code = em.take(before)
  em.macs += a * n
  return ([f"  {{ /* {label}{mean} */", f"    float acc[{a}], lin[{a}];",
           f"    for (int j = 0; j < {a}; ++j) {{ acc[j] = 0.0f; lin[j] = 0.0f; }}"]
          + ["  " + line for line in code]
          + [f"    for (int j = 0; j < {a}; ++j) {dest}[j] = lin[j] + acc[j] * "
             f"{literal(1.0 / n)};", "  }"])


REACH_FLOOR = 0.01  # training ranges: the fade's length where no held-out sample lay past its
# fold's box (reach 0), so that the estimate stays continuous at the box's faces


def faded(distance: np.ndarray, reach: float) -> np.ndarray:
  """(N,) the share of the correction part(c) - LS(c) that `PerOutput` drops at each
  `distance` (N,) past the training box (training ranges): none up to `reach`, past it
  1 - exp(-(d - reach) / max(reach, `REACH_FLOOR`))."""
  over = (distance - reach) / max(reach, REACH_FLOOR)
  return np.where(over > 0, -np.expm1(-np.maximum(over, 0.0)), 0.0)


@dataclasses.dataclass(frozen=True)
class PerOutput(Part):
  """Each output j from part pick[j]. Beyond the training box [lo, hi] (the raw inputs'),
  an output whose part is not `tame` (a network, a cubic) and whose `plane` flag is set takes
  that part at c, where the line from the box's centre to x leaves the box
  (`base.toward_centre`; `beyond` "clip": each input clipped alone, as files written
  before 2026-11-27 do), continued along the plane of the `guard` part (the LS one):
  part(c) + LS(x) - LS(c). A network's held-out score inside the box says nothing of inputs
  past it, where it may bend anywhere (measured on the footpad's 1.5 mm presses past
  0.5-1 mm training: NN-only Fz NRMSE 6.6 % where LS keeps 0.9 %); the plane is the tamest
  continuation the data support, and it meets the part at the box's faces. `fit_auto`
  clears an output's flag where the part's own extrapolation held out better beyond the
  folds' boxes (`methods._continuations`); `plane` None: every flag set (files written
  before 2026-11-29).

  The held-out samples checked that continuation only as far past their fold's box as they
  lay (`reach`, in training ranges, `base.box_distance`). Past it nothing tells whether the
  part's correction to LS at the box, part(c) - LS(c), still holds, so the correction fades
  out over the reach's own length (`faded`): far out the estimate is LS's plane, the
  simplest fit, as a Gaussian process returns to its mean function far from its data.
  Measured, the auto / LS error ratio with the correction carried whole, faded to half, and
  faded out: on the footpad's 1.5 mm presses past 0.5-1 mm training (0.5 ranges past the
  box, where the folds reached 0.02-0.04; 4 draws), a network's Fz on one draw 1.43, 1.11,
  0.95; on a printed F/T sensor (public recordings, the heaviest weight held out), a
  channel's cube's Fz 1.61, 1.38, 1.19. The cube's correction did hold on the footpad's
  shear: Fy 0.65-0.72x the best baseline carried whole, 0.89-0.95x faded out, the price of
  never trusting what no held-out sample checked. `reach` None: carried whole (files
  written before 2026-11-29)."""
  parts: tuple
  pick: tuple
  lo: Optional[np.ndarray] = None
  hi: Optional[np.ndarray] = None
  beyond: str = "centre"
  plane: Optional[tuple] = None
  reach: Optional[float] = None
  NAME, LABEL = "per_output", "AUTO"

  @property
  def n_inputs(self) -> int:
    return max(p.n_inputs for p in self.parts)

  @property
  def n_outputs(self) -> int:
    return len(self.pick)

  @property
  def tame(self) -> bool:
    return all(self.parts[k].tame for k in self.pick)

  @property
  def guard(self) -> Optional[int]:
    """The index of the LS part whose plane carries the network parts beyond the box (None:
    no LS part, no network part, or no box)."""
    labels = [p.label for p in self.parts]
    if self.lo is None or all(p.tame for p in self.parts) or "LS" not in labels:
      return None
    return labels.index("LS")

  def guarded(self) -> list[bool]:
    """Per output, whether it is continued along the LS plane beyond the box."""
    ls = self.guard
    flags = self.plane or (True,) * len(self.pick)
    return [ls is not None and on and not self.parts[k].tame
            for k, on in zip(self.pick, flags)]

  def children(self) -> dict:
    return {str(k): p for k, p in enumerate(self.parts)}

  def mean_spread(self, x, stream=None):
    each = [p.mean_spread(x, stream) for p in self.parts]
    spreads = [np.zeros_like(m) if s is None else s for m, s in each]
    cols = np.arange(len(self.pick))
    mean = np.stack([m for m, _ in each])[list(self.pick), :, cols].T
    spread = np.stack(spreads)[list(self.pick), :, cols].T
    guarded = self.guarded()
    ls = self.guard
    if any(guarded) and ((x < self.lo) | (x > self.hi)).any():
      inside = box_point(x, self.lo, self.hi, self.beyond)
      at_c = self.parts[ls].mean_spread(inside)[0]
      plane = self.parts[ls].mean_spread(x)[0] - at_c
      fade = 0.0 if self.reach is None else faded(box_distance(x, self.lo, self.hi),
                                                  self.reach)
      rows = np.flatnonzero(guarded)
      at_box = {k: self.parts[k].mean_spread(inside) for k in {self.pick[j] for j in rows}}
      for j in rows:
        m, s = at_box[self.pick[j]]
        # as written, a row with nothing faded is part(c) + plane bit for bit
        mean[:, j] = m[:, j] + plane[:, j] - fade * (m[:, j] - at_c[:, j])
        spread[:, j] = 0.0 if s is None else s[:, j]
    return mean, spread

  def leaves(self):
    arrays = {} if self.lo is None else {"lo": self.lo, "hi": self.hi}
    spec = {"pick": list(self.pick), "beyond": self.beyond}
    if self.plane is not None:
      spec["plane"] = [bool(v) for v in self.plane]
    if self.reach is not None:
      spec["reach"] = float(self.reach)
    return arrays, spec

  @classmethod
  def from_leaves(cls, spec, arrays, children) -> "PerOutput":
    parts = tuple(children[str(k)] for k in range(len(children)))
    pick = tuple(int(k) for k in spec["pick"])
    if not parts or not all(0 <= k < len(parts) for k in pick) or \
       any(p.n_outputs != len(pick) for p in parts):
      raise ValueError("its parts do not fit its outputs")
    plane = spec.get("plane")
    if plane is not None and (len(plane) != len(pick)
                              or not all(isinstance(v, bool) for v in plane)):
      raise ValueError("its continuation flags do not fit its outputs")
    reach = spec.get("reach")
    if reach is not None and not (isinstance(reach, (int, float)) and 0 <= reach < np.inf):
      raise ValueError(f"its reach past the training box is {reach!r}: allowed a number >= 0")
    if "lo" in arrays:
      c = max(p.n_inputs for p in parts)
      check_shapes("training box", arrays, {"lo": (c,), "hi": (c,)})
    return cls(parts, pick, arrays.get("lo"), arrays.get("hi"), read_beyond(spec),
               None if plane is None else tuple(plane),
               None if reach is None else float(reach))

  def emit_c(self, em, tag: str, c: int, acc: str = "acc") -> list[str]:
    """Each part into its own row of part[K][A] (at x), the parts that continue along the
    plane for some output also into held[K][A] (at the box point), then each output from
    its part's row, as `mean_spread` computes it. Returns the lines (they write out[]
    directly)."""
    a = self.n_outputs
    guarded = self.guarded()
    ls = self.guard
    held = {self.pick[j] for j in range(a) if guarded[j]}
    # at x: every part but those only read at the box point
    raw = set(range(len(self.parts))) - held | {self.pick[j] for j in range(a)
                                                if not guarded[j]}
    # a part read both at x and at the box point keeps the latter in held[][]
    both = held & raw
    where = {k: f"held[{k}]" if k in both else f"part[{k}]" for k in held}
    body = [f"  float part[{len(self.parts)}][{a}];"]
    if held:
      lo, hi = em.array("BOX_LO", self.lo), em.array("BOX_HI", self.hi)
      body += [f"  float inside[{c}], plane[{a}]"
               + (f", held[{len(self.parts)}][{a}];" if both else ";"),
               *emit_box_point(lo, hi, "x", "inside", c, self.beyond, pad="  ")]
      # the LS part where the line to the box's centre leaves it (x shadowed by it there)
      body += self._at_box(emit_estimate(self.parts[ls], em, self.parts[ls].label, c, a,
                                           "plane", "BOX_"))
      if self.reach is not None:
        body += self._emit_fade(lo, hi, c)
        # the distance: a subtraction, a division and a multiply-add per input; sqrtf and,
        # past the reach, expm1f, each costed as a tanhf
        em.costs(macs=3 * c, tanh=2)
    for k, part in enumerate(self.parts):
      if k in raw:
        body += emit_estimate(part, em, part.label, c, a, f"part[{k}]", f"P{k}_")
      if k in held:
        body += self._at_box(emit_estimate(part, em, part.label, c, a, where[k],
                                           f"H{k}_" if k in both else f"P{k}_"))
    for j, k in enumerate(self.pick):
      if not guarded[j]:
        body.append(f"  out[{j}] = part[{k}][{j}];")
        continue
      fade = "" if self.reach is None else f" - fade * ({where[k]}[{j}] - plane[{j}])"
      body.append(f"  out[{j}] = {where[k]}[{j}] + part[{ls}][{j}] - plane[{j}]{fade};")
    return body

  def _emit_fade(self, lo: str, hi: str, c: int) -> list[str]:
    """C lines setting float `fade` to `faded` of x's distance past the box."""
    scale = max(self.reach, REACH_FLOOR)
    return [*emit_box_distance(lo, hi, "x", "past", c),
            f"  float over = (past - {literal(self.reach)}) / {literal(scale)};",
            "  float fade = over > 0.0f ? -expm1f(-over) : 0.0f;"]

  @staticmethod
  def _at_box(lines: list[str]) -> list[str]:
    return ["  {", "    const float *x = inside;"] + ["  " + line for line in lines] + ["  }"]


@dataclasses.dataclass(frozen=True)
class Chain:
  """A temporal front end, then a stage reading its features (the stage's inputs are the
  first of them). Its inputs are the raw channels, read as recordings in time order."""
  front: object  # calibrate.parts.memory.Memory
  stage: Part
  NAME = "chain"

  @property
  def label(self) -> str:
    return self.stage.label

  @property
  def n_inputs(self) -> int:
    return self.front.channels

  @property
  def n_outputs(self) -> int:
    return self.stage.n_outputs

  @property
  def tame(self) -> bool:
    return self.stage.tame

  def children(self) -> dict:
    return {"front": self.front, "stage": self.stage}

  def mean_spread(self, x, stream=None):
    stream = stream or Stream()
    return self.stage.mean_spread(self.front.features(x, *stream), stream)

  def leaves(self):
    return {}, {}

  @classmethod
  def from_leaves(cls, spec, arrays, children) -> "Chain":
    front, stage = children["front"], children["stage"]
    if stage.n_inputs > front.width or (stage.label != "NN" and stage.n_inputs != front.width):
      raise ValueError(f"its stages read {stage.n_inputs} features, its temporal front end "
                       f"gives {front.width}")
    return cls(front, stage)
