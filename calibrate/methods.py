"""Recipes: how each method fits its parts on training data, and the fits built on them.

A recipe (scikit-learn's unfitted estimator: hyperparameters in the constructor, data in
`fit`) fits one method's parts on (x, y) and says how far they miss on a validation hold-out:

- `LinearRecipe`: LS (degree 1) or the shell paper's per-channel polynomial (degree > 1);
- `PolyRecipe`: the polynomial with cross terms, ridge-regularised (`calibrate.parts.poly`);
- `NetworkRecipe`: the network alone (NN) or on LS's residual (LSANN: `compose.Residual`),
  from one seed or several (an ensemble: `compose.Mean`).

`fit` runs a recipe with the selection it asks for (`calibrate.select`: the poly's degree and
ridge, the network's width, LSANN's LS-only outputs) and grouped cross-validation for the
interval; `fit_auto` fits every candidate and picks per output; `calibrate.temporal_fit`
puts a memory front end before them.
"""

from __future__ import annotations

import dataclasses
import importlib
import warnings
from typing import Optional

import numpy as np

from calibrate import compose, parts, select, splits
from calibrate.fitted import Estimator, Kind
from calibrate.info import (GROWTH_MIN, Info, data_digest, fold_distance, fold_nearest,
                            held_out, integer_counts, reference)
from calibrate.parts import linear, mlp
from calibrate.parts import poly as poly_lib
from util import errors


@dataclasses.dataclass(frozen=True)
class Validation:
  """The validation hold-out of one fit: `fraction` of the samples, whole groups when the
  fit has groups, else single samples or contiguous blocks of `block` samples."""
  fraction: float = 0.15
  block: Optional[int] = None

  def split(self, where, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(train, validation) indices of `where` (a `splits.Groups`, or a sample count)."""
    if isinstance(where, splits.Groups):
      return splits.holdout(where, self.fraction, seed)
    return splits.validation(where, self.fraction, seed, self.block)


@dataclasses.dataclass(frozen=True)
class Fitted:
  """What a recipe fitted: its members (one, or an ensemble's), each one's validation
  residual spread (A,) and its training run (None for the closed-form fits)."""
  parts: tuple
  sds: tuple
  trainings: tuple


@dataclasses.dataclass(frozen=True)
class LinearRecipe:
  """LS (degree 1), or each channel's powers up to `degree` (the shell paper's cubic)."""
  degree: int = 1
  SEEDED = False  # no random start: an ensemble's seeds would agree

  def fit(self, x, y, where, val: Validation, seed: int, given=None, progress=None) -> Fitted:
    tr, va = val.split(where, seed)
    held = linear.fit_linear(x[tr], y[tr], degree=self.degree)
    sd = np.std(y[va] - held.predict(x[va]), axis=0)
    return Fitted((linear.fit_linear(x, y, degree=self.degree),), (sd,), (None,))


@dataclasses.dataclass(frozen=True)
class PolyRecipe:
  """The polynomial with cross terms up to `degree`, ridge weight `ridge` per sample."""
  degree: int = 3
  ridge: float = 0.0
  SEEDED = False

  def fit(self, x, y, where, val: Validation, seed: int, given=None, progress=None) -> Fitted:
    tr, va = val.split(where, seed)
    held = poly_lib.fit(x[tr], y[tr], self.degree, self.ridge * len(tr))
    sd = np.std(y[va] - held.predict(x[va]), axis=0)
    return Fitted((poly_lib.fit(x, y, self.degree, self.ridge * len(x)),), (sd,), (None,))


@dataclasses.dataclass(frozen=True)
class NetworkRecipe:
  """The network (`calibrate.parts.mlp`) on the targets (NN) or on LS's residual (LSANN),
  from `ensemble` seeds spawned from the fit's seed; it reads the first `net_inputs` input
  columns (None: all); `snapshots`: epoch caps to keep the best network at."""
  config: mlp.LMConfig = mlp.LMConfig()
  residual: bool = False
  ensemble: int = 1
  net_inputs: Optional[int] = None
  snapshots: tuple = ()
  SEEDED = True

  def fit(self, x, y, where, val: Validation, seed: int, given=None, progress=None) -> Fitted:
    """`given`: for LSANN, the LS stage fitted before (else fitted on x, y)."""
    lin = None
    targets = y
    if self.residual:
      lin = given or linear.fit_linear(x, y)
      targets = y - lin.predict(x)
    xn = x if self.net_inputs is None else x[:, :self.net_inputs]

    def train(xt, yt, xv, yv, member_seed):
      return mlp.train(xt, yt, xv, yv, self.config, member_seed, progress,
                       snapshots=self.snapshots)
    return members(train, xn, targets, lin, where, val, seed, self.ensemble)


@dataclasses.dataclass(frozen=True)
class DeepRecipe:
  """LS, then the perceptron (`calibrate.parts.deep`) on its residual, trained by AdamW,
  from `ensemble` seeds: stopped on the validation hold-out, or with `config.checks` set
  trained that many checks on every sample (nothing held out)."""
  config: object = None  # deep.DeepConfig; None: its defaults
  ensemble: int = 1
  residual = True
  SEEDED = True

  def fit(self, x, y, where, val: Validation, seed: int, given=None, progress=None) -> Fitted:
    from calibrate.parts import deep
    config = self.config or deep.DeepConfig()
    lin = given or linear.fit_linear(x, y)

    def train(xt, yt, xv, yv, member_seed):
      return deep.train(xt, yt, xv, yv, config, member_seed)
    return members(train, x, y - lin.predict(x), lin, where, None if config.checks else val,
                   seed, self.ensemble, progress)


def members(train, x, targets, lin, where, val: Validation, seed: int, ensemble: int,
            progress=None) -> Fitted:
  """An ensemble's networks, each trained by `train(x, y, x_val, y_val, seed)` on `targets`
  (N, A) from its own seed and validation hold-out, on LS `lin`'s residual when given: the
  members (Residual(lin, net) or the net), their validation residual spreads, their runs.
  `val` None holds nothing out: every member trains on every sample, and its spread is
  NaN (`fit` takes the cross-validation's). `progress`, when given, hears of each member
  done."""
  parts, sds, runs = [], [], []
  for member_seed in member_seeds(seed, ensemble):
    tr, va = (np.arange(len(x)), np.arange(0)) if val is None else \
        val.split(where, member_seed)
    res = train(x[tr], targets[tr], x[va], targets[va], member_seed)
    sds.append(np.full(targets.shape[1], np.nan) if val is None else
               np.std(targets[va] - res.net.predict(x[va]), axis=0))
    parts.append(res.net if lin is None else compose.Residual(lin, res.net))
    runs.append(res)
    if progress is not None:
      progress(len(parts), ensemble)
  return Fitted(tuple(parts), tuple(sds), tuple(runs))


def member_seeds(seed: int, n: int) -> list[int]:
  """The seeds of an ensemble's `n` members, spawned from the fit's (the seed itself for one)."""
  if n == 1:
    return [seed]
  return [int(s.generate_state(1)[0]) for s in np.random.SeedSequence(seed).spawn(n)]


@dataclasses.dataclass(frozen=True)
class ResidualRecipe:
  """LS, then a family's part fitted on its residual by the family module's
  `fit(x, y, config, seed)` (LSGP: `calibrate.parts.gp`)."""
  family: str
  config: object = None  # the family's settings; None: its defaults
  residual = True
  SEEDED = False

  def fit(self, x, y, where, val: Validation, seed: int, given=None, progress=None) -> Fitted:
    module = importlib.import_module(parts.FAMILIES[self.family][0])
    config = self.config or module.Config()
    lin = given or linear.fit_linear(x, y)
    targets = y - lin.predict(x)
    tr, va = val.split(where, seed)
    held = module.fit(x[tr], targets[tr], config, seed)
    sd = np.std(targets[va] - held.predict(x[va]), axis=0)
    part = module.fit(x, targets, config, seed)
    return Fitted((compose.Residual(lin, part),), (sd,), (None,))


def predictor(fitted: Fitted):
  """One part that predicts what the fit gives: its member, or their mean."""
  return fitted.parts[0] if len(fitted.parts) == 1 else compose.Mean(fitted.parts)


def subset(g: splits.Groups, idx: np.ndarray) -> splits.Groups:
  """The groups of the samples `idx`, relabelled 0..G'-1."""
  _, labels = np.unique(g.labels[idx], return_inverse=True)
  return splits.Groups(labels.astype(int), g.how, g.block)


def cross_validate(recipe, x, y, groups: splits.Groups, folds: int, val: Validation,
                   seed: int, plane: bool = False, prefit=None) -> tuple:
  """Grouped K-fold cross-validation of `recipe`: (held-out residuals (N, A) of the
  estimator as kept, per-output mask of LSANN outputs whose network lost to its LS stage
  there, statistics, and with `plane` the held-out residuals (N, A) as `fit_auto` would
  continue the estimator beyond the box (`compose.PerOutput`), None where it is tame). LSANN's LS
  stage is refitted per fold (a given one saw every sample). `prefit`: each fold's `Fitted`,
  as `recipe` fits that fold's training samples, already at hand (`_deep_curve`'s)."""
  parts = splits.folds(groups, folds, seed)
  residual_of = getattr(recipe, "residual", False)
  tame = [True]
  given = iter(prefit or ())

  def fold(tr, va):
    fitted = next(given) if prefit else recipe.fit(x[tr], y[tr], subset(groups, tr), val, seed)
    est = predictor(fitted)
    out = [est.mean_spread(x[va])[0]]
    if residual_of:
      out.append(fitted.parts[0].base.mean_spread(x[va])[0])
    if plane:
      tame[0] = tame[0] and est.tame
      # as `fit_auto`'s estimator continues it: this fold's LS plane beyond this fold's box
      out.append(out[0] if est.tame else compose.PerOutput(
          (est, linear.fit_linear(x[tr], y[tr])), (0,) * y.shape[1], x[tr].min(axis=0),
          x[tr].max(axis=0)).mean_spread(x[va])[0])
    return out

  runs = select.held_out(fold, y, parts, 1 + residual_of + plane)
  residual = runs[0]
  stats = select.stats(residual, parts, groups)
  only = np.zeros(y.shape[1], bool)
  if residual_of:
    rmse = np.array(stats["cv_rmse"])
    ls_rmse = np.sqrt(np.mean(runs[1] ** 2, axis=0))
    only = select.ls_only(rmse, ls_rmse)
    residual[:, only] = runs[1][:, only]
    stats = {**select.stats(residual, parts, groups), "cv_rmse_ls_stage": ls_rmse.tolist()}
  beyond = None
  if plane and not tame[0]:
    beyond = runs[-1]
    if residual_of:  # an LS stage alone continues as its own plane
      beyond[:, only] = runs[1][:, only]
  return residual, only, stats, beyond


def choose(candidates: dict, x, y, groups, folds, val, seed, plane=False, done=None):
  """(the recipe of lowest held-out error among `candidates` {label: recipe}, its
  cross-validation, table {label: held-out error}); the error sums each output's held-out
  MSE over its variance; `plane` as `cross_validate` takes it. `done` {label: (recipe, its
  cross-validation)}: candidates cross-validated before, first in the table (a tie keeps
  them)."""
  spread = output_variance(y)
  runs, table = dict(done or {}), {}
  for label, cand in candidates.items():
    runs[label] = (cand, cross_validate(cand, x, y, groups, folds, val, seed, plane))
  for label, (_, run) in runs.items():
    table[label] = float(np.sum(np.square(run[2]["cv_rmse"]) / spread))
  best = select.lowest(table)
  return runs[best][0], runs[best][1], table


def output_variance(y) -> np.ndarray:
  """(A,) each output's variance (1 where it is constant): the held-out errors' weights."""
  spread = np.var(y, axis=0)
  return np.where(spread > 0, spread, 1.0)


def width_grid(recipe: NetworkRecipe, choices) -> dict:
  """{width: the recipe at that many hidden units} (`--hidden auto`)."""
  out = {}
  for w in choices:
    cfg = dataclasses.replace(recipe.config, hidden=int(w))
    cfg.validate()
    out[str(int(w))] = dataclasses.replace(recipe, config=cfg)
  return out


def layer_grid(recipe: "DeepRecipe", choices) -> dict:
  """{"64x64": the recipe with those hidden layers} (the perceptron's sizes)."""
  return {"x".join(map(str, layers)): dataclasses.replace(
      recipe, config=dataclasses.replace(recipe.config, layers=tuple(layers)))
      for layers in choices}


def choose_poly(x, y, parts, degrees) -> tuple[int, float, dict]:
  """(degree, ridge, table) of the polynomial with cross terms with the lowest grouped
  cross-validated mean squared error over `parts` ((train, held-out) pairs): every degree in
  `degrees`, ridge weights `poly.RIDGES` x the training samples, and past the largest of
  them while the held-out error still falls there (ten times more each step, up to
  `RIDGE_STEPS` steps). The SVD of each fold is shared by its ridge weights.

  One choice for every output, on the squared error summed over them (so the outputs in
  the largest units weigh most). Each output choosing its own (as scikit-learn's
  `RidgeCV(alpha_per_target)`) lowered the grouped CV error on the footpad, both shells and
  a printed F/T sensor, but tested worse on the footpad (measured 2026-12-03 with
  `real_recordings`, seeds 0-4: auto / best baseline Y 0.81 -> 0.88, Z 0.92 -> 1.01; better
  on shell_static's Fz alone, 0.92 -> 0.79). The outputs' own choices took smaller ridges
  (seed 0 Y 1e-7 against 1e-3 x samples, seed 2 Z 1e-3 against 1e-2), and the test
  recordings, a third of them past the training box, punished them: POLY's NRMSE seed 0 Y
  3.09 against 2.54 % (4.33 against 3.01 past the box), seed 2 Z 1.28 against 0.98 %."""
  table = {}
  for deg in degrees:
    ridges = list(poly_lib.RIDGES)
    sse = _poly_sse(x, y, parts, deg, ridges)
    while np.argmin(sse) == len(sse) - 1 and len(ridges) < len(poly_lib.RIDGES) + RIDGE_STEPS:
      ridges.append(ridges[-1] * 10)  # the error still falls at the grid's edge
      sse = np.append(sse, _poly_sse(x, y, parts, deg, ridges[-1:]))
    for r, e in zip(ridges, sse):
      table[(deg, r)] = float(e / len(y))
  deg, r = select.lowest(table)
  return deg, r * len(x), {f"degree {d}, ridge {r:g} x samples": v
                           for (d, r), v in table.items()}


RIDGE_STEPS = 6  # the ridge weights tried past the grid: up to 1e6 x the samples


def _poly_sse(x, y, parts, deg, ridges) -> np.ndarray:
  """(R,) the held-out sum of squared errors at each ridge weight (x the training samples)."""
  def fold(tr, va):
    f = poly_lib.factor(x[tr], y[tr], deg, True, 1e-10)
    return [f.solve(r * len(tr)).predict(x[va]) for r in ridges]
  return select.fold_sums(select.held_out(fold, y, parts, len(ridges)), parts)


class FewStatesWarning(UserWarning):
  """Training targets with few distinct values for the network's size."""


def warn_few_states(inputs: int, forces: np.ndarray, config: mlp.LMConfig) -> None:
  """Warns when the targets take few distinct values (load states, told apart at 1 % of
  each output's range) for the network's weights: it will interpolate between them. Loads
  that vary continuously fill the bins they can (at most 101 per output at 1 %: one output
  has no more however many samples), so states are few only below half of that."""
  span = np.ptp(forces, axis=0)
  states = len(np.unique(np.round(forces / np.where(span > 0, span, 1.0) * 100), axis=0))
  weights = config.hidden * (inputs + 1) + forces.shape[1] * (config.hidden + 1)
  room = min(len(forces), 101.0 ** forces.shape[1])
  if states < 2 * weights and states < 0.5 * room:
    warnings.warn(f"the targets take only {states} distinct load states (told apart at 1 % of "
                  f"each output's range) for a network of at least {weights} weights: it "
                  f"will interpolate between them{FEW_STATES_ADVICE}", FewStatesWarning,
                  stacklevel=4)


# what to do, said by a network's own fit; `auto` says what it already does instead
FEW_STATES_ADVICE = ("; average several networks (--ensemble 5), and compare LS and POLY "
                     "(--method auto)")


def names(c: int, a: int, inputs, outputs, input_units, output_units) -> dict:
  """The names and units `Info` keeps (default in0.., out0.., "counts", "N")."""
  given = {}
  for key, (value, default, n) in {
      "inputs": (inputs, [f"in{i}" for i in range(c)], c),
      "outputs": (outputs, [f"out{i}" for i in range(a)], a),
      "input_units": (input_units, ["counts"] * c, c),
      "output_units": (output_units, ["N"] * a, a)}.items():
    value = list(default if value is None else value)
    if len(value) != n:
      raise errors.SettingError(f"{key}: {len(value)} names for {n} columns")
    given[key] = tuple(str(v) for v in value)
  return given


def infos(fitted: Fitted, x, y, settings: dict, named: dict, extra: dict) -> list[Info]:
  """Each member's `Info`: the training ranges and data digest, its validation spread, the
  cross-validation's interval fields `extra`."""
  base = dict(input_lo=x.min(axis=0), input_hi=x.max(axis=0), output_lo=y.min(axis=0),
              output_hi=y.max(axis=0), samples=len(x), data_sha256=data_digest(x, y),
              settings=settings, **named)
  return [Info(residual_sd=sd, **base, **extra) for sd in fitted.sds]


def interval_fields(residual, only, stats, groups, outputs, distance=None, near=None) -> dict:
  """`Info`'s interval and validation fields from a cross-validation (`distance`: each
  held-out sample's beyond its training fold's box, `info.fold_distance`; `near`: each one's
  distance to its fold's nearest training row and the reference rows, `info.held_out`)."""
  return held_out(residual, groups, {**stats, "ls_only": [outputs[j]
                                                          for j in np.flatnonzero(only)]},
                  distance, near)


def check(kind, counts, forces, *, seed, ensemble, net_inputs, degree, groups, folds):
  """The fit's data and options, checked; raises SettingError naming the one out of range."""
  if kind is Kind.AUTO:
    raise errors.SettingError("method AUTO chooses among the others on held-out groups: call "
                              "fit_auto(counts, forces, groups, folds)")
  if kind is Kind.GRU:
    raise errors.SettingError("method GRU reads recordings in time order: call fit_temporal("
                              "'GRU', counts, forces, dt, segments=...)")
  counts, forces = linear.check_pair(counts, forces)
  if not (isinstance(ensemble, (int, np.integer)) and 1 <= ensemble <= 100):
    raise errors.SettingError(f"ensemble={ensemble!r} is out of range: allowed integers 1..100")
  if ensemble > 1 and not seeded(kind.value):
    raise errors.SettingError(f"ensemble={ensemble}: {kind.value} has no random start, so its "
                              f"seeds would agree; an ensemble is for LSANN and NN")
  if net_inputs is not None and not (isinstance(net_inputs, (int, np.integer))
                                     and 1 <= net_inputs <= counts.shape[1]):
    raise errors.SettingError(f"net_inputs={net_inputs!r} is out of range: allowed integers "
                              f"1..{counts.shape[1]} (the input columns)")
  if not (isinstance(seed, (int, np.integer)) and 0 <= seed < 2 ** 63):
    raise errors.SettingError(f"seed={seed!r} is out of range: allowed integers >= 0")
  if kind is Kind.POLY and not (isinstance(degree, (int, np.integer)) and 1 <= degree <= 5):
    raise errors.SettingError(f"degree={degree!r} is out of range: allowed integers 1..5")
  if folds and groups is None:
    raise errors.SettingError("folds need groups (calibrate.splits.groups): cross-validation "
                              "over single samples would flatter every method")
  if groups is not None and len(groups.labels) != len(counts):
    raise errors.SettingError(f"groups: {len(groups.labels)} labels for {len(counts)} samples")
  return counts, forces


# each method's recipe, built from the fit's options
RECIPES = {
    "LS": LinearRecipe,
    "POLY": LinearRecipe,  # with cross=True: PolyRecipe
    "LSANN": NetworkRecipe,
    "NN": NetworkRecipe,
    "LSGP": ResidualRecipe,
    "MLP": DeepRecipe,
}
# the methods that are LS plus a family fitted on its residual, and that family
RESIDUAL_FAMILIES = {"LSGP": "gp"}


def seeded(kind: str) -> bool:
  """Whether the method starts from a random draw (an ensemble of seeds means something)."""
  return RECIPES[kind].SEEDED


def recipe(kind: str, options: dict, settings: dict, x, y, cv_folds):
  """The recipe of `kind` with the fit's `options`, its choices recorded in `settings`; a
  POLY with cross terms and no ridge given chooses degree and ridge on the folds `cv_folds`."""
  if kind == "POLY" and options["cross"]:
    ridge, degree = options["ridge"], options["degree"]
    if ridge is None and cv_folds:
      degree, lam, table = choose_poly(x, y, cv_folds, tuple(range(1, degree + 1)))
      ridge = lam / len(x)
      settings["poly_cv_mse"] = table
    ridge = 0.0 if ridge is None else float(ridge)
    settings.update(cross=True, ridge_per_sample=ridge, degree=degree)
    return PolyRecipe(degree, ridge)
  if kind in RESIDUAL_FAMILIES:
    return ResidualRecipe(RESIDUAL_FAMILIES[kind], options["gp"])
  if kind == "MLP":
    settings["ensemble"] = options["ensemble"]
    return DeepRecipe(options["deep"], options["ensemble"])
  if kind in ("LS", "POLY"):
    degree = options["degree"] if kind == "POLY" else 1
    if kind == "POLY":
      settings["degree"] = degree
    return LinearRecipe(degree)
  settings.update(config=dataclasses.asdict(options["config"]), ensemble=options["ensemble"])
  return NetworkRecipe(options["config"], kind == "LSANN", options["ensemble"],
                       options["net_inputs"], tuple(options["snapshots"]))


def fit(kind, counts, forces, *, linear_fit=None, config=mlp.LMConfig(), val_fraction=0.15,
        seed=0, progress=None, degree=3, snapshots=(), val_block=None, ensemble=1, inputs=None,
        outputs=None, input_units=None, output_units=None, groups=None, folds=0, cross=False,
        ridge=None, widths=(), net_inputs=None, gp=None, deep=None, layers=None,
        activation=None, box_columns=None, plane=False):
  """`calibrate.estimators.fit` (its docstring says what each option does). `plane`
  (`fit_auto`'s): the estimator's `plane_info` holds the interval and held-out error of its
  predictions continued along an LS plane beyond the training box, as `compose.PerOutput`
  may continue it."""
  counts, forces = check(kind, counts, forces, seed=seed, ensemble=ensemble,
                         net_inputs=net_inputs, degree=degree, groups=groups, folds=folds)
  named = names(counts.shape[1], forces.shape[1], inputs, outputs, input_units, output_units)
  settings = {"method": kind.value, "val_fraction": val_fraction, "seed": seed,
              "val_block": None if groups is not None else val_block,
              "integer_inputs": integer_counts(counts)}
  if groups is not None:
    settings.update(split=groups.how, groups=groups.count, block=groups.block)
  parts = splits.folds(groups, folds, seed) if folds else []
  how = recipe(kind.value, dict(cross=cross, ridge=ridge, degree=degree, config=config,
                                ensemble=ensemble, net_inputs=net_inputs, snapshots=snapshots,
                                gp=gp, deep=deep),
               settings, counts, forces, parts)
  val = Validation(val_fraction, val_block)
  cv = None
  if isinstance(how, NetworkRecipe):
    warn_few_states(counts.shape[1], forces, how.config)
    if widths and folds:
      how, cv, table = choose(width_grid(how, widths), counts, forces, groups, folds, val,
                              seed, plane)
      settings.update(config=dataclasses.asdict(how.config), width_cv=table)
  if isinstance(how, DeepRecipe):
    how, cv = _deep_layers(how, layers, counts, forces, groups, folds, val, seed, settings,
                           plane, activation)
  where = groups if groups is not None else len(counts)
  fitted = how.fit(counts, forces, where, val, seed, linear_fit, progress)
  extra, beyond = {}, None
  if folds:
    residual, only, stats, beyond = cv or cross_validate(how, counts, forces, groups, folds,
                                                         val, seed, plane)
    if np.isnan(fitted.sds).any():  # its networks held nothing out: the folds' spread
      fitted = dataclasses.replace(fitted, sds=(np.std(residual, axis=0),) * len(fitted.sds))
    if only.any():
      fitted = dataclasses.replace(fitted, parts=tuple(
          compose.Residual(p.base, p.residual.without_outputs(only)) for p in fitted.parts))
    # the distances over the raw counts (a front end's first columns)
    raw = counts[:, :box_columns]
    distance = fold_distance(raw, parts)
    near = (fold_nearest(raw, parts), reference(raw))
    extra = interval_fields(residual, only, stats, groups, named["outputs"], distance, near)
  out = [Estimator(kind, p, i, training=t) for p, i, t in
         zip(fitted.parts, infos(fitted, counts, forces, settings, named, extra),
             fitted.trainings)]
  est = out[0] if len(out) == 1 else combine(out)
  if beyond is None:
    return est
  fields = interval_fields(beyond, only, select.stats(beyond, parts, groups), groups,
                           named["outputs"], distance, near)
  return dataclasses.replace(est, plane_info=dataclasses.replace(est.info, **fields))


def _deep_layers(how: DeepRecipe, layers, x, y, groups, folds, val, seed, settings,
                 plane=False, activation=None):
  """(the perceptron's recipe at its layers, units and length, their cross-validation or
  None): `layers` None chooses among `deep.GRID` on the held-out groups (when there are
  folds), `activation` None then the units at those layers among `deep.ACTIVATIONS`: tanh
  units bend smoothly and saturate, ReLU ones (scikit-learn's `MLPRegressor` default) are
  planes by region and continue as planes past the data. With folds, each option trains
  for the checks its folds' mean held-out curve calls for (`_deep_curve`), unless
  `config.checks` is given. Measured, each at its own layers, NRMSE % of range held out /
  tested: shell_static's 48 static loads, ReLU Mx 2.95 / 1.95 against tanh's 5.14 / 2.71; a
  printed F/T sensor's recordings mixed (Fx 9.3 / 6.8 against 11.0 / 7.8, Fy 9.3 / 14.4
  against 8.4 / 14.8), the summed score keeping tanh; the footpad alike (stopped early on a
  validation hold-out, before the curve)."""
  from calibrate.parts import deep
  how = dataclasses.replace(how, config=how.config or deep.DeepConfig())
  given = {k: v for k, v in (("layers", None if layers is None else
                                        tuple(int(w) for w in layers)),
                             ("activation", activation)) if v is not None}
  how = dataclasses.replace(how, config=dataclasses.replace(how.config, **given))
  if how.config.checks and not folds:
    raise errors.SettingError(f"checks={how.config.checks} trains on every sample, holding "
                              f"nothing out: it needs folds >= 2 for the held-out spread")
  cv = None
  if folds:
    one = dataclasses.replace(how, ensemble=1)

    def run(cand):  # (the option at its length, its cross-validation)
      if cand.config.checks:
        return cand, cross_validate(cand, x, y, groups, folds, val, seed, plane)
      return _deep_curve(cand, x, y, groups, folds, val, seed, plane)

    if layers is None:
      chosen, cv, settings["layers_cv"] = choose(
          {}, x, y, groups, folds, val, seed, plane,
          done={k: run(c) for k, c in layer_grid(one, deep.GRID).items()})
    elif activation is None or not one.config.checks:
      chosen, cv = run(one)
    else:  # every choice given (an ensemble of the single's): its own cross-validation follows
      chosen = one
    if activation is None:  # then the units at the layers kept (a tie keeps the first's)
      kept = chosen.config.activation
      done = {kept: (chosen, cv)}
      done.update({a: run(dataclasses.replace(one, config=dataclasses.replace(
          one.config, layers=chosen.config.layers, activation=a)))
          for a in deep.ACTIVATIONS if a != kept})
      chosen, cv, scores = choose({}, x, y, groups, folds, val, seed, plane, done=done)
      settings["activation_cv"] = {a: scores[a] for a in deep.ACTIVATIONS}
    how = dataclasses.replace(chosen, ensemble=how.ensemble)
    cv = cv if how.ensemble == 1 else None
  how.config.validate()
  settings["deep"] = dataclasses.asdict(how.config)
  return how, cv


def _deep_curve(how: DeepRecipe, x, y, groups, folds, val, seed, plane) -> tuple:
  """(`how` one network trained for the checks its folds' mean held-out curve calls for, its
  cross-validation): one network per fold on that fold's LS residual, in step
  (`deep.fold_curve`), each output's held-out MSE over its variance summed, an output that
  never beats LS counting at LS's. The folds' networks at the curve's lowest are the
  cross-validation's, with nothing held out of their training folds; the final network
  trains that long on every sample. Measured on a printed F/T sensor's 42 training
  recordings (10 folds, 64x64 ReLU trained to 200 checks): the held-out Mx error falls from
  5.00 % of range at check 1 to 3.79 at 20, where an early stop on 6 recordings of each
  fold stopped at check 1 in 9 folds of 10."""
  from calibrate.parts import deep
  parts = splits.folds(groups, folds, seed)
  lins = [linear.fit_linear(x[tr], y[tr]) for tr, _ in parts]
  curve = deep.fold_curve(
      [(x[tr], y[tr] - lin.predict(x[tr]), x[va], y[va] - lin.predict(x[va]))
       for lin, (tr, va) in zip(lins, parts)], how.config, seed, 1.0 / output_variance(y))
  how = dataclasses.replace(how, config=dataclasses.replace(how.config, checks=curve.checks))
  prefit = [Fitted((compose.Residual(lin, run.net),), (np.full(y.shape[1], np.nan),), (run,))
            for lin, run in zip(lins, curve.runs)]
  return how, cross_validate(how, x, y, groups, folds, val, seed, plane, prefit)


def combine(members):
  """Fitted estimators of one kind (networks from several seeds) as one ensemble: it predicts
  their mean, and its residual spread is the root mean square of theirs. Each member needs
  its `info` (every `fit` gives one)."""
  members = tuple(members)
  first = members[0].info
  spread = np.sqrt(np.mean([m.info.residual_sd ** 2 for m in members], axis=0))
  info = dataclasses.replace(first, residual_sd=spread,
                             settings={**first.settings, "ensemble": len(members)})
  return Estimator(members[0].kind, compose.Mean(tuple(m.root for m in members)), info,
                   trainings=tuple(m.training for m in members))


# the candidates `fit_auto` chooses among by name, simplest first: each a method and the fit
# options that make it this candidate. Where several hold out within a standard error the
# first is kept, so the order decides ties, and past the folds' box it decides how the pick
# extrapolates: each channel's cube fades to LS's plane there, POLY with cross terms
# continues along its own tangent plane. Measured (`real_recordings --quick`, auto / best
# baseline), POLY before POLY-CH: the footpad's Y 0.81 to 0.51 (seeds 0-4; its 1.5 mm test
# presses follow POLY's degree 2, at seed 0 NRMSE past the box 3.0 % against the faded
# cube's 6.7 %), but the printed F/T sensor's Fy 1.13 to 1.18 (3 draws, its default split),
# shell_static's the same (seeds 1-4); the one-standard-error rule itself against the
# lowest held-out error (footpad Z 0.92 to 2.12, the F/T sensor's Fz 1.13 to 2.34) or a
# 1 % tie (its Fy 1.47)
AUTO = {
    "LS": (Kind.LS, {}),
    "POLY-CH": (Kind.POLY, {"cross": False}),  # each channel's powers: the shell paper's
    "POLY": (Kind.POLY, {"cross": True}),
    "LSANN": (Kind.LSANN, {}),
    "NN": (Kind.NN, {}),
    "LSGP": (Kind.LSGP, {}),
    "MLP": (Kind.MLP, {}),
    # behind a memory front end (`temporal_fit.fit_auto_temporal`): they read its features,
    # the others its first columns (the counts); last, so kept only where their held-out
    # gain beats every static candidate's by more than a standard error
    "LS+MEM": (Kind.LS, {}),
    "POLY+MEM": (Kind.POLY, {"cross": True}),
}
AUTO_CANDIDATES = ("LS", "POLY-CH", "POLY", "LSANN", "NN", "MLP")
MEMORY_CANDIDATES = ("LS+MEM", "POLY+MEM")


def candidate_name(candidate) -> str:
  """A candidate's name in `AUTO` from its name or its method (a `Kind`: its plain fit);
  a network's name may end in xN, the mean of N networks (`ENSEMBLE_MARK`)."""
  name = candidate.value if isinstance(candidate, Kind) else str(candidate)
  base, n = split_ensemble(name)
  if base not in AUTO or (n > 1 and not seeded(AUTO[base][0].value)):
    raise errors.unknown("candidate", name, tuple(AUTO) + tuple(
        f"{k}{ENSEMBLE_MARK}5" for k, (kind, _) in AUTO.items() if seeded(kind.value)))
  return name


ENSEMBLE_MARK = "x"  # "NNx5": the mean of five NN networks


def split_ensemble(name: str) -> tuple[str, int]:
  """("NN", 5) from "NNx5"; (name, 1) for a name without the mark."""
  base, mark, n = name.rpartition(ENSEMBLE_MARK)
  if mark and base and n.isdigit() and int(n) > 1:
    return base, int(n)
  return name, 1


def with_ensembles(names: list, ensemble: int) -> list:
  """`names` with each network's mean of `ensemble` networks right after it (`ensemble` > 1):
  the single network first, so one-SE keeps the mean only where its gain shows."""
  out = []
  for name in names:
    out.append(name)
    if ensemble > 1 and split_ensemble(name)[1] == 1 and seeded(AUTO[name][0].value):
      out.append(f"{name}{ENSEMBLE_MARK}{ensemble}")
  return list(dict.fromkeys(out))


def _candidate_options(name: str, fitted: dict, config) -> tuple[Kind, dict]:
  """(candidate `name`'s method, the options that set it apart from the fit's): its
  family's fixed ones, its ensemble size; a mean of networks takes the width (into
  `config`, the fit's LM settings) or layers its single network chose (in `fitted` {name:
  estimator}) rather than choosing them again."""
  base, n = split_ensemble(name)
  kind, fixed = AUTO[base]
  out = {**fixed, "ensemble": n}
  single = fitted.get(base)
  if n > 1 and single is not None:
    chosen = single.info.settings
    if kind is Kind.MLP and "deep" in chosen:  # its layers, units and length
      from calibrate.parts import deep
      out["deep"] = deep.DeepConfig(**{**chosen["deep"],
                                       "layers": tuple(chosen["deep"]["layers"])})
      out["layers"], out["activation"] = out["deep"].layers, out["deep"].activation
    elif "config" in chosen:
      out["widths"] = ()
      out["config"] = dataclasses.replace(config, hidden=chosen["config"]["hidden"])
  return kind, out


def fit_auto(counts, forces, groups, folds=5, candidates=None, progress=None,
             static_columns=None, **kwargs):
  """`calibrate.estimators.fit_auto` (its docstring says what it returns). With
  `static_columns`, the candidates but `MEMORY_CANDIDATES` read only the first that many
  columns of `counts` (a front end's counts, before its history features)."""
  import time
  if groups is None or folds < 2:
    raise errors.SettingError("method auto chooses on held-out groups: it needs groups and "
                              "folds >= 2")
  fitted, table = [], {}
  ensemble = kwargs.pop("ensemble", 1)
  names = with_ensembles([candidate_name(c) for c in (
      AUTO_CANDIDATES if candidates is None else candidates)], ensemble)
  names_in = None if kwargs.get("inputs") is None else list(kwargs["inputs"])
  plane = "LS" in names  # its plane continues the others beyond the box
  with warnings.catch_warnings(record=True) as heard:
    warnings.simplefilter("always", FewStatesWarning)
    for name in names:
      t0 = time.perf_counter()
      kind, own = _candidate_options(name, {k: v["estimator"] for k, v in table.items()},
                                     kwargs.get("config", mlp.LMConfig()))
      reads = counts if static_columns is None or name in MEMORY_CANDIDATES else \
          counts[:, :static_columns]
      est = fit(kind, reads, forces, groups=groups, folds=folds, progress=progress,
                box_columns=static_columns, plane=plane,
                **{**kwargs, **own,
                   "inputs": None if names_in is None else names_in[:reads.shape[1]]})
      table[name] = {"cv_rmse": est.info.validation["cv_rmse"],
                     "seconds": time.perf_counter() - t0, "estimator": est}
      fitted.append(est)
  _say_once(heard, ensemble)
  rows = _continuations(fitted, names)
  share = select.between_share(forces, groups.labels)
  scored = [select.model_error(i.validation, share) for _, _, i, _ in rows]
  best = select.one_standard_error(np.array([r for r, _ in scored]),
                                   np.array([f for _, f in scored]),
                                   np.abs(np.asarray(forces, float)).max(axis=0))
  chosen = [rows[b] for b in best]
  # LS stays a part even where no output keeps it: its plane continues the networks beyond
  # the training box (`compose.PerOutput`)
  ls = [k for k, e in enumerate(fitted) if e.kind is Kind.LS]
  used = sorted({k for k, _, _, _ in chosen} | set(ls))
  pick = tuple(used.index(k) for k, _, _, _ in chosen)
  info = _auto_info([i for _, _, i, _ in chosen], [n for _, _, _, n in chosen],
                    fitted[used[0]].info, {n: i.validation["cv_rmse"] for _, _, i, n in rows},
                    share)
  # the box of every column: the parts reading fewer take its first ones
  width = max(fitted[k].root.n_inputs for k in used)
  root = compose.PerOutput(tuple(fitted[k].root for k in used), pick,
                           np.min(counts[:, :width], axis=0), np.max(counts[:, :width], axis=0),
                           plane=tuple(bool(on) for _, on, _, _ in chosen),
                           reach=_reach(fitted))
  return Estimator(Kind.AUTO, root, info), table


def _reach(fitted) -> Optional[float]:
  """How far past their fold's box the held-out samples lay, the farthest (training ranges;
  every candidate is held out on the same folds), or None without folds."""
  reach = [r for e in fitted if (r := e.info.validation.get("held_out_reach")) is not None]
  return max(reach) if reach else None


OWN = " unguarded"  # the name of a candidate continued beyond the box as it extrapolates


def _continuations(fitted, names) -> list[tuple]:
  """The rows `fit_auto` chooses among, simplest first, each (candidate index, continued
  along the LS plane beyond the box, its `Info`, its name): every candidate as
  `compose.PerOutput` continues it by default (along the plane where it is not tame), then
  each one that is not tame again as it extrapolates itself (named with `OWN`), last, so
  kept only where its held-out error beyond the folds' boxes is lower by more than a
  standard error, and only with `info.GROWTH_MIN` such samples or more. The plane is the tamer guess (measured on the footpad's 1.5 mm presses,
  NN-only Fz NRMSE 6.6 % alone, 0.9 % along the plane), but not always the better one
  (the shell under 48 static loads, a quarter of the test past the box: NNx5 Fx 6.7 %
  alone, 7.4 % along the plane)."""
  rows = [(k, e.plane_info is not None, e.plane_info or e.info, n)
          for k, (e, n) in enumerate(zip(fitted, names))]
  # with fewer held-out samples beyond their fold's box the two differ by noise alone
  return rows + [(k, False, e.info, n + OWN) for k, (e, n) in enumerate(zip(fitted, names))
                 if e.plane_info is not None
                 and e.info.validation.get("held_out_beyond_box", 0) >= GROWTH_MIN]


def _say_once(heard, ensemble: int) -> None:
  """Warns again what the candidates' fits warned, each message once (both networks would
  say the same of the same targets), a network's advice on few states as what `auto` does
  (it weighs LS and POLY already; each network's mean of `ensemble` where over 1)."""
  instead = "; auto weighs LS and POLY beside the networks" + (
      f" and each one's mean of {ensemble}" if ensemble > 1 else
      ", and with --ensemble 5 each network's mean of five")
  for message in dict.fromkeys(str(w.message) for w in heard):
    category = next(w.category for w in heard if str(w.message) == message)
    warnings.warn(message.replace(FEW_STATES_ADVICE, instead), category, stacklevel=3)


def _auto_info(infos, chosen_names, first: Info, candidates: dict, share) -> Info:
  """AUTO's `Info`: each output's spread, interval and held-out RMSE from its candidate's
  (`infos`, one per output); `candidates` {name: held-out RMSE per output}; `share` (A,)
  the loads' share between the groups the choice weighed (`select.between_share`)."""
  cols = range(len(infos))
  return dataclasses.replace(
      first, residual_sd=np.array([i.residual_sd[j] for j, i in zip(cols, infos)]),
      interval_abs=np.column_stack([i.interval_abs[:, j] for j, i in zip(cols, infos)]),
      interval_offsets=None if infos[0].interval_offsets is None else np.column_stack(
          [i.interval_offsets[:, j] for j, i in zip(cols, infos)]),
      interval_growth=None if infos[0].interval_growth is None else np.array(
          [i.interval_growth[j] for j, i in zip(cols, infos)]),
      # every candidate measures to the same reference rows: the same training data
      interval_local=None if infos[0].interval_local is None else np.array(
          [i.interval_local[j] for j, i in zip(cols, infos)]),
      interval_reference=infos[0].interval_reference,
      settings={"method": "AUTO", "candidates": [n for n in candidates if not n.endswith(OWN)],
                "seed": first.settings.get("seed"),
                "integer_inputs": first.settings.get("integer_inputs")},
      validation={**{k: v for k, v in first.validation.items()
                     if k in ("split", "groups", "block", "folds")},
                  "cv_rmse": [i.validation["cv_rmse"][j] for j, i in zip(cols, infos)],
                  "chosen": list(chosen_names), "between_share": share.tolist(),
                  "held_out_beyond_box": min(i.validation.get("held_out_beyond_box", 0)
                                             for i in infos),
                  "candidates": candidates,
                  "ls_only": [n for j, n in enumerate(first.outputs)
                              if n in infos[j].validation.get("ls_only", [])]})
