"""The text around an estimator's C body: the header, the input and tare code, the resets.

`header` and `source` put the parts' code (`calibrate.cexport.emitter.Emitter`) between the
declarations a user's firmware calls: `estimate`, and for a temporal estimator
`estimate_reset`/`estimate_restart`, and for a tare `estimate_tare_*`.
"""

from __future__ import annotations

import re
from typing import Optional

import numpy as np

from calibrate.cexport.emitter import literal

def comment_text(name: str) -> str:
  """A column name as it may stand inside a C block comment: ASCII only (other characters
  as \\uXXXX escapes), no control characters, and no `*/` or `/*` that would close or nest
  the comment."""
  text = "".join(ch if " " <= ch <= "~" else f"\\u{ord(ch):04x}" for ch in str(name))
  while "*/" in text or "/*" in text:
    text = text.replace("*/", "* /").replace("/*", "/ *")
  return text


def identifiers(names) -> list[str]:
  """C identifiers (upper case, [A-Z0-9_]) for column names, unique: characters outside
  them become `_`, a name that starts with a digit or ends up empty gets a `C` in front,
  and a name that repeats an earlier one gets its position appended."""
  out: list[str] = []
  for k, name in enumerate(names):
    ident = re.sub(r"[^A-Z0-9_]", "_", str(name).upper()) or "C"
    ident = "C" + ident if ident[0].isdigit() else ident
    while ident in out:
      ident = f"{ident}_{k}"
    out.append(ident)
  return out


def _tare(est) -> Optional[dict]:
  """The tare rule the estimator was fitted with (`calibrate.prepare`), or None."""
  if est.info is None:
    return None
  return (est.info.settings.get("prepare") or {}).get("tare")


def integer_inputs(est) -> bool:
  """Whether the estimator's inputs were ADC counts: integers in 0..65535 when it was fitted
  (`fit` records it; an older file without the record: its training range decides). With a
  tare, the raw inputs before it decide: the C function tares them itself."""
  info = est.info
  if info is None:
    return True
  prepared = info.settings.get("prepare") or {}
  known = prepared.get("raw_integer_inputs") if prepared.get("tare") else \
      info.settings.get("integer_inputs")
  if known is not None:
    return bool(known)
  return bool((info.input_lo >= 0).all() and (info.input_hi <= 65535).all()
              and all(u == "counts" for u in info.input_units))


def _tare_code(tare: dict, c: int, counts: bool, info) -> tuple[list[str], list[str]]:
  """(header lines, source lines) of the tare the estimator was fitted with: the caller
  feeds the unloaded samples (the rule is in the comment), the offsets are their per-channel
  median, as `predict` takes them, and `estimate` subtracts them."""
  kind = "const uint16_t counts" if counts else "const float inputs"
  rule = (f"the first {tare['seconds']:g} s of each recording" if tare.get("seconds")
          is not None else f"the samples where {comment_text(tare['flag'])} is 0")
  rate = info.settings.get("prepare", {}).get("sample_rate")
  size = 256 if tare.get("seconds") is None or not rate else \
      max(16, int(np.ceil(tare["seconds"] * rate)) + 8)
  header = [
      f"/* Tare (fit --tare): feed {rule} (unloaded) to estimate_tare_add, then call",
      " * estimate_tare_end; estimate() then subtracts each input's median over them (up to",
      " * ESTIMATOR_TARE_MAX samples; offsets start at 0). */",
      "#ifndef ESTIMATOR_TARE_MAX",
      f"#define ESTIMATOR_TARE_MAX {size}",
      "#endif",
      "void estimate_tare_reset(void);",
      f"void estimate_tare_add({kind}[ESTIMATOR_INPUTS]);",
      "void estimate_tare_end(void);", ""]
  name = "counts" if counts else "inputs"
  source = [
      f"static float tare_offset[{c}];",
      f"static float tare_kept[ESTIMATOR_TARE_MAX][{c}];",
      "static int tare_n;",
      "",
      "void estimate_tare_reset(void) { tare_n = 0; }",
      "",
      f"void estimate_tare_add({kind}[ESTIMATOR_INPUTS]) {{",
      "  if (tare_n >= ESTIMATOR_TARE_MAX) return;",
      f"  for (int i = 0; i < {c}; ++i) tare_kept[tare_n][i] = (float){name}[i];",
      "  ++tare_n;",
      "}",
      "",
      "void estimate_tare_end(void) {  /* the median of each channel, by insertion sort */",
      "  static float v[ESTIMATOR_TARE_MAX];",
      "  if (tare_n == 0) return;",
      f"  for (int i = 0; i < {c}; ++i) {{",
      "    for (int k = 0; k < tare_n; ++k) {",
      "      float e = tare_kept[k][i];",
      "      int j = k;",
      "      for (; j > 0 && v[j - 1] > e; --j) v[j] = v[j - 1];",
      "      v[j] = e;",
      "    }",
      "    tare_offset[i] = (tare_n % 2) ? v[tare_n / 2]",
      "                                 : 0.5f * (v[tare_n / 2 - 1] + v[tare_n / 2]);",
      "  }",
      "}"]
  return header, source




def tare_rule(est) -> Optional[dict]:
  """The tare rule the estimator was fitted with (`calibrate.prepare`), or None."""
  if est.info is None:
    return None
  return (est.info.settings.get("prepare") or {}).get("tare")


def _argument(counts: bool) -> str:
  return "const uint16_t counts[ESTIMATOR_INPUTS]" if counts else \
      "const float inputs[ESTIMATOR_INPUTS]"


def _method_line(est) -> str:
  members, parts = est.members, est.parts
  return (f" * Method {est.kind.value}" + (f", mean of {len(members)} members" if members
                                            else "")
          + (": " + ", ".join(f"{comment_text(n)} from {parts[k].kind.value}"
                              for n, k in zip(est.info.outputs, est.pick)) if parts else "")
          + "; float32 weights; C99, <math.h> only.")


def _temporal_lines(mem) -> list[str]:
  if mem is None:
    return []
  return ["/* A temporal estimator: estimate() reads the recording's past (drift tracking,",
          " * filters, a recurrent network's state), so call it on every sample, in order,",
          f" * every {mem.dt:g} s. estimate_reset(): a new session (power-up; the tare's",
          " * offset back to zero). estimate_restart(): a new episode of the same session",
          " * (the filters and the recurrent state start afresh; the tare's offset carries",
          " * on, as the drift does). */",
          f"#define ESTIMATOR_SAMPLE_SECONDS {literal(mem.dt)}",
          "void estimate_reset(void);", "void estimate_restart(void);", ""]


def header(est, c: int, a: int, counts: bool, tare: Optional[dict]) -> str:
  """estimator.h: what the estimator reads and gives, and the functions to call."""
  info = est.info
  names = info.outputs if info is not None else tuple(f"out{j}" for j in range(a))
  units = info.output_units if info is not None else ("",) * a
  inputs = info.inputs if info is not None else tuple(f"in{i}" for i in range(c))
  in_units = info.input_units if info is not None else ("counts",) * c
  unwrapped = info is not None and (info.settings.get("prepare") or {}).get("unwrap_periods")
  tare_h = _tare_code(tare, c, counts, info)[0] if tare else []
  return "\n".join([
      "/* Force estimator exported by the tactile testbench (python -m calibrate export).",
      _method_line(est),
      " * Inputs: " + ", ".join(f"{comment_text(n)} ({comment_text(u)})"
                                for n, u in zip(inputs, in_units))
      + ("." if counts else "; as float: they were not integer counts when fitted.")
      + ("\n * fit undid the registers' wrap-around (--unwrap): unwrap them before estimate()."
         if unwrapped else ""),
      " * Outputs: " + ", ".join(f"{comment_text(n)} ({comment_text(u)})"
                                 for n, u in zip(names, units)) + ". */",
      "#ifndef TESTBENCH_ESTIMATOR_H", "#define TESTBENCH_ESTIMATOR_H", "",
      "#include <stdint.h>", "",
      f"#define ESTIMATOR_INPUTS {c}", f"#define ESTIMATOR_OUTPUTS {a}", "",
      f"/* where each column sits in {'counts' if counts else 'inputs'}[] and out[] */"]
      + [f"#define ESTIMATOR_IN_{n} {i}" for i, n in enumerate(identifiers(inputs))]
      + [f"#define ESTIMATOR_OUT_{n} {j}" for j, n in enumerate(identifiers(names))] + ["",
      f"void estimate({_argument(counts)}, float out[ESTIMATOR_OUTPUTS]);", ""]
      + _temporal_lines(est.memory) + tare_h + ["#endif", ""])


def source(em, est, c: int, width: int, counts: bool, tare: Optional[dict], front: list[str],
           body: list[str]) -> str:
  """estimator.c: the arrays, the state and its resets, the tare, and `estimate`: the inputs
  (tared), the front end's features, the parts' body."""
  mem = est.memory
  name = "counts" if counts else "inputs"
  first = (" - tare_offset[i];" if tare else ";")
  tare_c = _tare_code(tare, c, counts, est.info)[1] if tare else []
  if mem is None:
    inputs_code = [f"  float x[{c}];",
                   f"  for (int i = 0; i < {c}; ++i) x[i] = (float){name}[i]" + first]
  else:
    inputs_code = [f"  float raw[{c}], x[{width}];",
                   f"  for (int i = 0; i < {c}; ++i) raw[i] = (float){name}[i]" + first
                   ] + front
  reset = ["", "void estimate_restart(void) {"] + em.resets + ["}", "",
           "void estimate_reset(void) {"] + em.session_resets + ["  estimate_restart();", "}"] \
      if mem is not None else []
  return "\n".join(
      ['#include "estimator.h"', "#include <math.h>", ""] + em.arrays + em.state + tare_c
      + reset + ["", f"void estimate({_argument(counts)}, float out[ESTIMATOR_OUTPUTS]) {{"]
      + inputs_code + body + ["}", ""])
