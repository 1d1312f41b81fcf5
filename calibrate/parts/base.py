"""What every part of an estimator answers to: a family's fitted model, or a composite of parts.

A part reads the first `n_inputs` columns of what it is given (a network fitted on fewer
inputs than the stage before it reads the first of them) and gives `n_outputs` columns. An
estimator is a tree of parts (`calibrate.compose`); its file keeps the tree's structure as
JSON and each part's arrays under the part's path (`calibrate.store`); its C is each part's
block, in the tree's order (`calibrate.cexport`).
"""

from __future__ import annotations

from typing import ClassVar, NamedTuple, Optional

import numpy as np


class Stream(NamedTuple):
  """How samples sit in time, for the parts that read the past: `segments` (N,) each sample's
  recording (filters and recurrent states start afresh where it changes), `contact` (N,) a
  contact flag for the drift tare, `sessions` (N,) the runs of segments a tare carries
  through. None: one recording."""
  segments: Optional[np.ndarray] = None
  contact: Optional[np.ndarray] = None
  sessions: Optional[np.ndarray] = None

  def starts(self, n: int) -> np.ndarray:
    """(n,) True at the first sample of each recording (of each session without segments)."""
    return starts(self.segments if self.segments is not None else self.sessions, n)


def starts(labels: Optional[np.ndarray], n: int) -> np.ndarray:
  """(n,) bool: the first sample of each recording (each change of label; None: one)."""
  out = np.zeros(n, bool)
  if n:
    out[0] = True
  if labels is not None and n > 1:
    s = np.asarray(labels)
    out[1:] = s[1:] != s[:-1]
  return out


class Part:
  """The protocol (a base class for its defaults).

  Class attributes:
    NAME: the part's tag in an estimator file ("linear", "mlp", "residual"...).
    C_TAG: the infix of its C arrays ("LIN", "NET"...).
    LABEL: the method a user knows it by when it stands alone ("LS", "NN"...); a composite
      derives its own (`label`).
  """
  NAME: ClassVar[str] = ""
  C_TAG: ClassVar[str] = ""
  LABEL: ClassVar[str] = ""

  @property
  def n_inputs(self) -> int:
    raise NotImplementedError

  @property
  def n_outputs(self) -> int:
    raise NotImplementedError

  @property
  def label(self) -> str:
    return self.LABEL

  @property
  def tame(self) -> bool:
    """Whether the part stays close to a plane beyond its training box (a linear or
    polynomial stage continued along its tangent); a network may bend anywhere there."""
    return True

  def children(self) -> dict[str, "Part"]:
    """The parts a composite holds, by name (a family's fitted model holds none)."""
    return {}

  def mean_spread(self, x: np.ndarray, stream: Optional[Stream] = None
                  ) -> tuple[np.ndarray, Optional[np.ndarray]]:
    """(N, A) prediction and the spread across members (None where there are none) from
    (N, >= n_inputs) inputs, unchecked."""
    return self.predict(x[:, :self.n_inputs]), None

  def leaves(self) -> tuple[dict[str, np.ndarray], dict]:
    """(its own arrays by name, its own JSON-able settings) for an estimator file."""
    raise NotImplementedError

  @classmethod
  def from_leaves(cls, spec: dict, arrays: dict[str, np.ndarray],
                  children: dict[str, "Part"]) -> "Part":
    """The part from what `leaves` gave; ValueError when the arrays do not fit together."""
    raise NotImplementedError

  def emit_c(self, em, tag: str, c: int, acc: str = "acc") -> None:
    """Appends to `em` the C block that adds this part's output to acc[] from x[] (the
    first `c` inputs are there); `tag` prefixes its arrays."""
    raise NotImplementedError


def check_shapes(what: str, arrays: dict[str, np.ndarray], shapes: dict[str, tuple]) -> None:
  """Raises ValueError naming the arrays of `what` whose shape is not the one expected."""
  bad = [k for k, s in shapes.items() if np.shape(arrays[k]) != s]
  if bad:
    raise ValueError(f"the {what}'s arrays {', '.join(bad)} do not fit together")


BEYOND = ("centre", "clip")  # where a part past its box is taken from (`box_point`)


def box_point(x: np.ndarray, lo: np.ndarray, hi: np.ndarray, beyond: str) -> np.ndarray:
  """`toward_centre` ("centre"), or each input clipped on its own ("clip": files written
  before 2026-11-27 keep it, and give what they gave)."""
  return toward_centre(x, lo, hi) if beyond == "centre" else np.clip(x, lo, hi)


def box_distance(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
  """(N,) how far each row of `x` (N, C) lies beyond the box [lo, hi], each input in units
  of its range (a constant input in its own units), Euclidean over the inputs."""
  x = np.asarray(x, float)
  span = np.where(hi > lo, hi - lo, 1.0)
  over = np.maximum(np.maximum(lo - x, x - hi), 0.0) / span
  return np.sqrt(np.sum(over ** 2, axis=1))


def emit_box_distance(lo: str, hi: str, src: str, dst: str, c: int, pad: str = "  "
                      ) -> list[str]:
  """C lines setting float `dst` to `box_distance` of float `src`[c], the box in the arrays
  named `lo` and `hi`: one block for the sum, so its locals stay its own."""
  return [f"{pad}float {dst};",
          f"{pad}{{",
          f"{pad}  float d2 = 0.0f;",
          f"{pad}  for (int i = 0; i < {c}; ++i) {{",
          f"{pad}    float span = {hi}[i] > {lo}[i] ? {hi}[i] - {lo}[i] : 1.0f;",
          f"{pad}    float o = {lo}[i] - {src}[i] > {src}[i] - {hi}[i] ? {lo}[i] - {src}[i] : "
          f"{src}[i] - {hi}[i];",
          f"{pad}    if (o > 0.0f) d2 += (o / span) * (o / span);",
          f"{pad}  }}",
          f"{pad}  {dst} = sqrtf(d2);",
          f"{pad}}}"]


def emit_box_point(lo: str, hi: str, src: str, dst: str, c: int, beyond: str,
                   pad: str = "    ") -> list[str]:
  """C lines setting `dst`[c] to `box_point` of `src`[c]."""
  if beyond == "centre":
    return emit_toward_centre(lo, hi, src, dst, c, pad)
  return [f"{pad}for (int i = 0; i < {c}; ++i) {dst}[i] = {clip_c(src, lo, hi)};"]


def clip_c(src: str, lo: str, hi: str) -> str:
  """The C expression of `src`[i] clipped to [`lo`[i], `hi`[i]]."""
  return f"{src}[i] < {lo}[i] ? {lo}[i] : ({src}[i] > {hi}[i] ? {hi}[i] : {src}[i])"


def read_beyond(spec: dict) -> str:
  """A file's `beyond` (absent: "clip", what files written before it was kept gave)."""
  beyond = str(spec.get("beyond", "clip"))
  if beyond not in BEYOND:
    raise ValueError(f"beyond={beyond!r}: allowed {', '.join(BEYOND)}")
  return beyond


def toward_centre(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
  """(N, C) for each row of `x` (N, C), the point where the segment from the centre of the box
  [lo, hi] to it leaves the box; a row inside is itself (bit for bit), and an input constant
  in training (lo = hi) is held at its value.

  Clipping each input on its own would put a point past the box at a corner whose inputs
  never occurred together (a deeper press reads higher on every channel at once, and its
  clip is every channel's training maximum): there the part itself extrapolates. Pulled
  along the line to the centre, the channels keep their pattern, which on a sensor
  near-linear in its load is that of a lighter load the training held (measured on the
  footpad's 1.5 mm presses past 0.5-1 mm training, auto's NRMSE: NN continued along LS
  from the clip X 11.8 Z 1.56 %, from this point 6.4 and 0.67 %; LS 6.25 and 0.69 %)."""
  x = np.asarray(x, float)
  centre, half = (lo + hi) / 2, (hi - lo) / 2
  d = x - centre
  with np.errstate(divide="ignore", invalid="ignore"):
    share = np.where((half > 0) & (np.abs(d) > half), half / np.abs(d), 1.0)
  t = share.min(axis=1, initial=1.0)[:, None]
  out = np.where(t < 1, centre + t * d, x)
  return np.where(half > 0, out, lo)


def emit_toward_centre(lo: str, hi: str, src: str, dst: str, c: int, pad: str = "    "
                       ) -> list[str]:
  """C lines setting float `dst`[c] to `toward_centre` of float `src`[c], the box in the
  arrays named `lo` and `hi`: one block, so its locals stay its own."""
  return [f"{pad}{{",
          f"{pad}  float pull = 1.0f;",
          f"{pad}  for (int i = 0; i < {c}; ++i) {{",
          f"{pad}    float hw = 0.5f * ({hi}[i] - {lo}[i]), dv = fabsf({src}[i] - 0.5f * "
          f"({lo}[i] + {hi}[i]));",
          f"{pad}    if (hw > 0.0f && dv > hw && hw / dv < pull) pull = hw / dv;",
          f"{pad}  }}",
          f"{pad}  for (int i = 0; i < {c}; ++i) {{",
          f"{pad}    float mid = 0.5f * ({lo}[i] + {hi}[i]);",
          f"{pad}    {dst}[i] = !({hi}[i] > {lo}[i]) ? {lo}[i] : "
          f"(pull < 1.0f ? mid + pull * ({src}[i] - mid) : {src}[i]);",
          f"{pad}  }}",
          f"{pad}}}"]
