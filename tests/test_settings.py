"""Settings typed from their declarations: parsing, ranges, and every key of every benchmark
refusing bad values with one line that names it."""

import contextlib
import dataclasses
import io
import math
import typing

import pytest
from hypothesis import given, settings as hsettings, strategies as st

from benchmarks import registry
from benchmarks import run as cli
from util import fields
from sim import settings

BENCHMARKS = registry.all_benchmarks()


def _leaves(bench):
  """(key, annotation, metadata) of every key --set takes for the benchmark."""
  root = bench.settings(True, 0)
  out = []

  def walk(obj, prefix):
    hints = fields.types_of(type(obj))
    for f in dataclasses.fields(obj):
      name = prefix + f.name
      if name in bench.fixed:
        continue
      value = getattr(obj, f.name)
      if dataclasses.is_dataclass(value):
        walk(value, name + ".")
      else:
        out.append((name, hints[f.name], f.metadata))
  walk(root, "")
  return out


CASES = [(b, key, tp, meta) for b in sorted(BENCHMARKS) for key, tp, meta in _leaves(BENCHMARKS[b])]


def _innermost(tp):
  tp, _ = fields.optional(tp)
  while typing.get_origin(tp) is tuple:
    tp = typing.get_args(tp)[0]
  return tp


def _shape(tp, meta, item: str) -> str:
  """`item` in the text form of the field: alone, or as one element of a tuple of the right
  length (pairs joined by ';')."""
  tp, _ = fields.optional(tp)
  if typing.get_origin(tp) is not tuple:
    return item
  args = typing.get_args(tp)
  if len(args) == 2 and args[1] is Ellipsis:
    n = (meta.get("length") or (1, 1))[0] or 1
    inner = args[0]
  else:
    n, inner = len(args), args[0]
  one = _shape(inner, meta, item)
  return (";" if typing.get_origin(inner) is tuple else ",").join([one] * n)


def _past_bounds(tp, meta, magnitude: float) -> list[str]:
  """Values just past each finite end of the declared interval."""
  iv = meta.get("interval")
  if iv is None:
    return []
  is_int = _innermost(tp) is int
  out = []
  for end, sign, closed in ((iv.lo, -1, iv.lo_closed), (iv.hi, 1, iv.hi_closed)):
    if math.isinf(end):
      continue
    v = end + sign * (max(1.0, magnitude) if is_int else magnitude * max(abs(end), 1e-3))
    if not closed and magnitude == 0:
      v = end
    out.append(_shape(tp, meta, str(int(v) if is_int else repr(float(v)))))
  return out


def _wrong_type(tp, meta) -> str:
  item = _innermost(tp)
  if item is int:
    return _shape(tp, meta, "0.5")
  if item is bool:
    return "0.5"
  if item is float:
    return _shape(tp, meta, "yes")
  return "1.5"  # a number where a name is taken


def _run(args):
  err = io.StringIO()
  with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
    try:
      code = cli.main(args)
    except SystemExit as exc:  # argparse's own errors
      code = exc.code
  return code, err.getvalue()


def _assert_refused(bench, key, text):
  code, err = _run([bench, "--quick", "--no-progress", "--out", "/nonexistent/never-written",
                    "--set", f"{key}={text}"])
  lines = err.strip().splitlines()
  assert code != 0, (bench, key, text)
  assert len(lines) == 1 and "Traceback" not in err, err
  assert key in lines[0] and "allowed" in lines[0], lines[0]


def _nan_inf_allowed(tp, meta, value: float) -> bool:
  iv = meta.get("interval")
  return iv is not None and _innermost(tp) is float and value in iv


@pytest.mark.parametrize("bench, key, tp, meta", CASES, ids=[f"{c[0]}:{c[1]}" for c in CASES])
def test_every_key_refuses_nan_inf_past_bounds_malformed_and_wrong_types(bench, key, tp, meta):
  bad = [_shape(tp, meta, "nan"), _shape(tp, meta, "1e3e"), _wrong_type(tp, meta)]
  bad += [] if _nan_inf_allowed(tp, meta, math.inf) else [_shape(tp, meta, "inf")]
  bad += [] if _nan_inf_allowed(tp, meta, -math.inf) else [_shape(tp, meta, "-inf")]
  bad += _past_bounds(tp, meta, 0.5)
  for text in bad:
    _assert_refused(bench, key, text)


NUMERIC = [c for c in CASES if "interval" in c[3]]


@hsettings(max_examples=300, deadline=None)
@given(case=st.sampled_from(NUMERIC), magnitude=st.floats(1e-6, 1e6),
       junk=st.text(st.characters(categories=("L", "P", "S")), min_size=1, max_size=6))
def test_random_values_past_bounds_and_random_junk_are_refused(case, magnitude, junk):
  bench, key, tp, meta = case
  for text in _past_bounds(tp, meta, magnitude):
    _assert_refused(bench, key, text)
  try:
    settings.parse(junk, tp)
  except ValueError:
    _assert_refused(bench, key, junk)


def test_booleans_take_only_their_words():
  for text, value in (("true", True), ("On", True), ("1", True), ("no", False), ("0", False),
                      ("OFF", False)):
    assert settings.parse(text, bool) is value
  for text in ("2", "y", "", "nan"):
    with pytest.raises(ValueError):
      settings.parse(text, bool)


def test_values_are_read_by_their_declared_type():
  from sim.footpad import protocol
  from sim.shell import scene
  s = settings.apply(protocol.base(True, 0), {
      "params.crown_radius": "inf", "params.grid": "4,5", "press_depth": "0.001",
      "kernel": "halfspace", "adc.bits": "10", "effects": "friction,ft_noise"})
  assert s.params.crown_radius == math.inf and s.params.grid == (4, 5)
  assert s.press_depth == 0.001 and s.kernel.value == "halfspace" and s.adc.bits == 10
  assert s.effects == ("friction", "ft_noise")
  assert settings.apply(s, {"press_depth": "none"}).press_depth is None
  sh = settings.apply(scene.ShellScene(), {
      "params.spring_xy": "0.03,0.02;-0.03,0.02;0,-0.02", "in_window": "off",
      "sensor.window": "0.0021,0.0039"})
  assert sh.params.spring_xy == ((0.03, 0.02), (-0.03, 0.02), (0.0, -0.02))
  assert sh.in_window is False and sh.sensor.window == (0.0021, 0.0039)


def test_keys_a_benchmark_sets_itself_are_refused():
  for bench, key in (("asterisk_path", "paths"), ("asterisk_path", "seed"),
                     ("shell_table1", "frames"), ("gravity_vectors", "downward_bias"),
                     ("footpad_kernels", "kernel")):
    code, err = _run([bench, "--set", f"{key}=1"])
    assert code == 2 and "set by this benchmark" in err and key in err, err


def test_relations_between_fields_name_the_key():
  code, err = _run(["asterisk_path", "--set", "params.die_depth=0.02"])
  assert code == 2 and "die_depth=0.02 is out of range: allowed (0, 0.013) m" in err, err


def test_a_field_without_an_interval_or_a_doc_cannot_be_declared():
  with pytest.raises(TypeError, match="declares no interval"):
    @fields.declared
    @dataclasses.dataclass(frozen=True)
    class NoBounds:
      """A config.

      Attributes:
        rate: a rate, Hz.
      """
      rate: float = 1.0
  with pytest.raises(TypeError, match="no entry in the class docstring"):
    @fields.declared
    @dataclasses.dataclass(frozen=True)
    class NoDoc:
      """A config."""
      rate: float = fields.setting(1.0, "(0, 10]", "Hz")


def test_help_lines_end_at_a_sentence_not_at_an_abbreviation_or_inside_brackets():
  @fields.declared
  @dataclasses.dataclass(frozen=True)
  class Cols:
    """A config.

    Attributes:
      inputs: the sensor columns (names or globs, e.g. X*). Second sentence.
      rate: a rate (in Hz. or so). More.
    """
    inputs: str = ""
    rate: float = fields.setting(1.0, "(0, 10]", "Hz")
  docs = fields.docs_of(Cols)
  assert docs["inputs"] == "the sensor columns (names or globs, e.g. X*)."
  assert docs["rate"] == "a rate (in Hz. or so)."


def test_intervals_keep_nan_out_and_inf_only_behind_a_closed_bracket():
  assert math.inf in fields.Interval.parse("(0, inf]")
  assert math.inf not in fields.Interval.parse("(0, inf)")
  assert math.nan not in fields.Interval.parse("[-inf, inf]")
  assert 0 not in fields.Interval.parse("(0, 1]") and 1 in fields.Interval.parse("(0, 1]")
