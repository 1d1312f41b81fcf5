"""The perceptron trained by AdamW (`calibrate.parts.deep`): its forward pass against numpy,
what it learns that LS cannot, the layers grouped cross-validation keeps, and its file."""

from __future__ import annotations

import numpy as np
import pytest

from calibrate import estimators, splits
from calibrate.parts import deep


def _smooth(n=3000, seed=0):
  """Six channels and three outputs no plane reaches: a product, a square, a saturation."""
  rng = np.random.default_rng(seed)
  z = rng.uniform(-1, 1, (n, 6))
  y = np.column_stack([np.sin(3 * z[:, 0]) * z[:, 1], z[:, 2] ** 2 - z[:, 3],
                       np.tanh(2 * z[:, 4] + z[:, 5])])
  return z * 1000 + 2000, y


UNITS = {"tanh": np.tanh, "relu": lambda v: np.maximum(v, 0.0)}


@pytest.mark.parametrize("activation", sorted(UNITS))
def test_the_forward_pass_is_its_units_layers_of_its_weights(activation):
  rng = np.random.default_rng(1)
  w = (rng.normal(size=(5, 3)), rng.normal(size=(4, 5)), rng.normal(size=(2, 4)))
  b = tuple(rng.normal(size=len(m)) for m in w)
  net = deep.Deep(w, b, np.array([1.0, 2, 3]), np.array([2.0, 1, 4]), np.array([5.0, -1]),
                  np.array([3.0, 0.5]), activation)
  x = rng.normal(size=(20, 3))
  unit = UNITS[activation]
  h = unit(((x - [1, 2, 3]) / [2, 1, 4]) @ w[0].T + b[0])
  h = unit(h @ w[1].T + b[1])
  want = (h @ w[2].T + b[2]) * [3.0, 0.5] + [5.0, -1]
  np.testing.assert_allclose(net.predict(x), want, rtol=1e-12)


def test_a_file_without_an_activation_holds_tanh_units_and_an_unknown_one_is_refused():
  """Files written before the choice of units hold tanh networks; their spec names none."""
  rng = np.random.default_rng(2)
  arrays = {"w0": rng.normal(size=(4, 3)), "b0": rng.normal(size=4),
            "w1": rng.normal(size=(2, 4)), "b1": rng.normal(size=2),
            "x_mean": np.zeros(3), "x_sd": np.ones(3), "y_mean": np.zeros(2), "y_sd": np.ones(2)}
  old = deep.Deep.from_leaves({"layers": 2}, arrays)
  assert old.activation == "tanh"
  x = rng.normal(size=(7, 3))
  np.testing.assert_allclose(old.predict(x), np.tanh(x @ arrays["w0"].T + arrays["b0"])
                             @ arrays["w1"].T + arrays["b1"], rtol=1e-12)
  assert deep.Deep.from_leaves(*old.leaves()[::-1]).activation == "tanh"
  with pytest.raises(ValueError, match="activation 'sigmoid'"):
    deep.Deep.from_leaves({"layers": 2, "activation": "sigmoid"}, arrays)


def test_adamw_learns_what_ls_cannot_on_held_out_data():
  x, y = _smooth()
  cfg = deep.DeepConfig(layers=(32,), epochs=60)
  est = estimators.fit("MLP", x[:2500], y[:2500], deep=cfg, seed=3)
  ls = estimators.fit("LS", x[:2500], y[:2500])
  err = np.sqrt(np.mean((est.predict(x[2500:]) - y[2500:]) ** 2, axis=0))
  err_ls = np.sqrt(np.mean((ls.predict(x[2500:]) - y[2500:]) ** 2, axis=0))
  assert (err < 0.2 * err_ls).all(), (err, err_ls)
  assert tuple(est.info.settings["deep"]["layers"]) == (32,)


@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_the_layers_kept_are_those_of_the_lowest_held_out_error(tmp_path):
  x, y = _smooth(1200)
  groups = splits.groups(len(x), "recordings", np.repeat(np.arange(6), 200))
  est = estimators.fit("MLP", x, y, groups=groups, folds=2, seed=0,
                       deep=deep.DeepConfig(epochs=8))
  table = est.info.settings["layers_cv"]
  assert set(table) == {"x".join(map(str, g)) for g in deep.GRID}
  assert "x".join(map(str, est.info.settings["deep"]["layers"])) == min(table, key=table.get)
  # then the units at those layers: the lower held-out error of the two, the layers' own
  # score for the units they were chosen with
  units = est.info.settings["activation_cv"]
  assert set(units) == set(deep.ACTIVATIONS)
  assert units[deep.DeepConfig().activation] == min(table.values())
  assert est.info.settings["deep"]["activation"] == min(units, key=units.get)
  est.save(tmp_path / "m.npz")
  back = estimators.Estimator.load(tmp_path / "m.npz")
  assert back.kind is estimators.Kind.MLP
  np.testing.assert_array_equal(back.predict(x), est.predict(x))
  for activation in deep.ACTIVATIONS:  # given, nothing is chosen
    given = estimators.fit("MLP", x, y, groups=groups, folds=2, seed=0, layers=(16,),
                           activation=activation, deep=deep.DeepConfig(epochs=2))
    assert given.info.settings["deep"]["activation"] == activation
    assert "activation_cv" not in given.info.settings and "layers_cv" not in given.info.settings


def test_the_folds_curve_is_their_held_out_error_and_its_lowest_what_training_that_long_gives():
  """Each fold's network at the curve's lowest is the one trained exactly that many checks
  from the same seed; the curve is the folds' held-out MSE, recomputed from predictions."""
  import dataclasses
  x, y = _smooth(1200)
  folds = [(x[:800], y[:800], x[800:], y[800:]), (x[400:], y[400:], x[:400], y[:400])]
  cfg = deep.DeepConfig(layers=(16,), epochs=25, patience=4)
  scale = 1.0 / np.var(y, axis=0)
  curve = deep.fold_curve(folds, cfg, seed=2, scale=scale)
  n = curve.checks
  np.testing.assert_allclose(curve.floor, np.mean(np.vstack([f[3] for f in folds]) ** 2, axis=0))
  np.testing.assert_allclose(curve.score, np.sum(np.minimum(curve.mse, curve.floor) * scale,
                                                 axis=1))
  assert n == 1 + int(np.argmin(curve.score[1:]))
  ran = len(curve.score) - 1
  assert ran == cfg.epochs or ran - n == cfg.patience
  sse = 0.0
  for (xt, yt, xv, yv), run in zip(folds, curve.runs):
    again = deep.train(xt, yt, xv[:0], yv[:0], dataclasses.replace(cfg, checks=n), seed=2)
    np.testing.assert_array_equal(again.net.predict(xv), run.net.predict(xv))
    sse = sse + np.sum((run.net.predict(xv) - yv) ** 2, axis=0)
  np.testing.assert_allclose(curve.mse[n], sse / 800, rtol=1e-9)


@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_with_folds_the_final_network_trains_the_curves_length_on_every_sample():
  """Nothing held out of the final fit: it is the network trained `checks` on all of LS's
  residual, and its spread is the folds' held-out one (finite)."""
  import dataclasses
  from calibrate.parts import linear
  x, y = _smooth(1200)
  groups = splits.groups(len(x), "recordings", np.repeat(np.arange(6), 200))
  cfg = deep.DeepConfig(epochs=12, patience=4)
  est = estimators.fit("MLP", x, y, groups=groups, folds=3, seed=0, layers=(16,),
                       activation="tanh", deep=cfg)
  n = est.info.settings["deep"]["checks"]
  assert 1 <= n <= cfg.epochs
  assert est.info.validation["ls_only"] == []
  lin = linear.fit_linear(x, y)
  net = deep.train(x, y - lin.predict(x), x[:0], y[:0], dataclasses.replace(
      cfg, layers=(16,), activation="tanh", checks=n), seed=0).net
  np.testing.assert_allclose(est.predict(x), lin.predict(x) + net.predict(x), rtol=1e-12)
  assert np.isfinite(est.info.residual_sd).all() and (est.info.residual_sd > 0).all()


@pytest.mark.parametrize("checks", [0, 3])
def test_training_whose_weights_blow_up_stops_with_a_message_not_numbers(checks, monkeypatch):
  """Early stopped or trained a fixed length, a network whose weights became NaN is refused."""
  import jax
  real = deep._epoch_fn

  def blows_up(config):
    step = real(config)

    def epoch(state, *args):
      params, m, v, t = step(state, *args)
      return jax.tree_util.tree_map(lambda a: a * np.nan, params), m, v, t
    return epoch
  monkeypatch.setattr(deep, "_epoch_fn", blows_up)
  x, y = _smooth(400)
  with pytest.raises(Exception, match="training diverged .* lower its learning rate"):
    deep.train(x[:300], y[:300], x[300:], y[300:], deep.DeepConfig(layers=(8,), epochs=5,
                                                                   checks=checks))


def test_a_layer_setting_out_of_range_is_named():
  with pytest.raises(Exception, match="layers=.* one or two hidden layers"):
    deep.DeepConfig(layers=(8, 8, 8)).validate()
  with pytest.raises(Exception, match="learning_rate"):
    deep.DeepConfig(learning_rate=2.0).validate()
  with pytest.raises(Exception, match="activation='sigmoid' is unknown: allowed 'relu', 'tanh'"):
    deep.DeepConfig(activation="sigmoid").validate()
  with pytest.raises(Exception, match=r"checks=400 is out of range: allowed integers 0 to "
                                      r"epochs \(300\)"):
    deep.DeepConfig(checks=400).validate()
  x, y = _smooth(300)
  with pytest.raises(Exception, match="checks=3 trains on every sample.*needs folds >= 2"):
    estimators.fit("MLP", x, y, deep=deep.DeepConfig(checks=3, epochs=5))


def test_fit_says_when_the_size_kept_is_the_largest_tried():
  from calibrate.cli import fit
  table = {"16": 0.3, "64x64": 0.2, "128x128": 0.1}
  assert "largest size tried" in fit.grid_line("perceptron layers", "128x128", table)
  assert "largest" not in fit.grid_line("perceptron layers", "64x64", table)


@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_the_command_chooses_the_units_or_takes_them_given(tmp_path, capsys):
  from calibrate import __main__ as cli, csvfile
  x, y = _smooth(600)
  names = [f"s{k}" for k in range(6)] + ["Fx", "Fy", "Fz"]
  for g in range(4):
    rows = slice(150 * g, 150 * (g + 1))
    csvfile.write(tmp_path / f"run{g}.csv", names, np.column_stack([x[rows], y[rows]]))
  data = ["fit", "--csv", str(tmp_path / "run*.csv"), "--inputs", "s*", "--targets",
          "Fx,Fy,Fz", "--method", "mlp", "--layers", "8", "--epochs", "3", "--folds", "2",
          "--no-progress"]
  assert cli.main(data + ["--out", str(tmp_path / "a.npz")]) == 0
  said = capsys.readouterr().out
  chosen = estimators.Estimator.load(tmp_path / "a.npz").info.settings
  assert f"perceptron units {chosen['deep']['activation']} at those layers" in said
  assert all(f"{a}: " in said for a in deep.ACTIVATIONS)
  assert cli.main(data + ["--activation", "relu", "--out", str(tmp_path / "b.npz")]) == 0
  assert "perceptron units" not in capsys.readouterr().out
  given = estimators.Estimator.load(tmp_path / "b.npz")
  assert given.info.settings["deep"]["activation"] == "relu"
  assert given.root.residual.activation == "relu"
