"""The shell scene: hand loads, F/T truth, reproducibility, bad input."""

import dataclasses

import mujoco
import numpy as np
import pytest

from models import shell as model_lib
from sim.shell import geometry as shell_geometry, scene as shell

SMALL = shell.ShellScene(frames=3000, force_range=0.5, torque_range=0.02, knot_interval=2.0,
                         seed=3)


@pytest.fixture(scope="module")
def run():
  return shell.simulate(SMALL)[0]


def test_tared_ft_equals_the_applied_wrench_under_slow_loading(run):
  """The hand's wrench acts at the shell's centre of mass as it moves; about the F/T site it
  is M + (com - site) x F. Under slow loading the tared F/T reading equals it within 1 %."""
  model = model_lib.build_spec(SMALL.params).compile()
  data = mujoco.MjData(model)
  adr = model_lib.mount_qpos_index(model)
  mujoco.mj_kinematics(model, data)
  com0 = data.body("shell").xipos.copy()
  site = data.site("ft").xpos.copy()
  moved = []
  for q in run.pose:
    data.qpos[adr] = q
    mujoco.mj_kinematics(model, data)
    moved.append(data.body("shell").xipos - com0)
  force = run.applied[:, :3]
  torque = run.applied[:, 3:] + np.cross(np.array(moved), force)
  expected = np.column_stack([force, torque])
  err = np.sqrt(np.mean((run.wrench - expected) ** 2, axis=0))
  scale = np.sqrt(np.mean(expected**2, axis=0))
  assert np.all(err < 0.01 * scale), err / scale
  assert site[2] < com0[2]


def test_heights_from_joints_equal_rays(run):
  model = model_lib.build_spec(SMALL.params).compile()
  data = mujoco.MjData(model)
  for i in range(0, len(run.pose), 300):
    np.testing.assert_allclose(shell_geometry.rays_at(model, data, run.pose[i]),
                               run.height[i], atol=1e-9)


def test_same_seed_same_bytes_other_seed_other_loads(run):
  again, _ = shell.simulate(SMALL)
  assert again.pose.tobytes() == run.pose.tobytes()
  assert again.wrench.tobytes() == run.wrench.tobytes()
  other, _ = shell.simulate(dataclasses.replace(SMALL, seed=4))
  assert not np.allclose(other.applied, run.applied)


def test_loads_stay_in_range_and_bias_pushes_down():
  rng = np.random.default_rng(0)
  loads = shell.hand_loads(dataclasses.replace(SMALL, downward_bias=1.0), 20000, rng)
  # blends of targets drawn in the box never leave it
  assert np.all(loads[:, 2] <= 1e-12)
  assert np.mean(loads[:, 2]) < -0.2 * SMALL.force_range
  assert np.max(np.abs(loads[:, :3])) <= SMALL.force_range
  assert np.max(np.abs(loads[:, 3:])) <= SMALL.torque_range


def test_hand_loads_keep_the_static_heights_in_the_window():
  scene = dataclasses.replace(SMALL, force_range=1.0, torque_range=0.06)
  loads = shell.hand_loads(scene, 50000, np.random.default_rng(1))
  h = shell.heights_from_pose(scene.params, shell.static_pose(scene.params, loads))
  lo, hi = scene.sensor.window
  # between two in-window targets only the heights' small nonlinearity in the pose strays
  assert h.min() > lo - 2e-5 and h.max() < hi + 2e-5, (h.min(), h.max())


def test_bottoming_out_is_reported():
  with pytest.warns(UserWarning, match="into the PCB"):
    r, _ = shell.simulate(dataclasses.replace(SMALL, frames=2000, force_range=4.0,
                                              in_window=False))
  assert 0 < r.meta["bottomed"] <= r.meta["out_of_window"] <= 1


@pytest.mark.parametrize("change, message", [
    (dict(frames=0), "frames"), (dict(torque_range=-1.0), "torque_range"),
    (dict(downward_bias=2.0), "downward_bias"), (dict(steps_per_frame=3), "100 Hz"),
])
def test_bad_scene_is_named(change, message):
  with pytest.raises(ValueError, match=message):
    shell.simulate(dataclasses.replace(SMALL, **change))


def test_in_window_targets_keep_static_heights_inside():
  rng = np.random.default_rng(1)
  scene = dataclasses.replace(SMALL, force_range=1.0, torque_range=0.06)
  box = rng.uniform(-1, 1, (500, 6)) * np.array([1, 1, 1, 0.06, 0.06, 0.06])
  scaled = box * shell.window_scale(scene.params, box, scene.sensor)[:, None]
  h = shell.heights_from_pose(scene.params, shell.static_pose(scene.params, scaled))
  lo, hi = scene.sensor.window
  assert np.all((h >= lo - 1e-9) & (h <= hi + 1e-9))
  # and the scaling is tight: 1 % more leaves the window for the scaled-down targets
  cut = np.abs(np.linalg.norm(scaled, axis=1) - np.linalg.norm(box, axis=1)) > 1e-12
  h2 = shell.heights_from_pose(scene.params, shell.static_pose(scene.params, 1.01 * scaled[cut]))
  assert np.all(np.any((h2 < lo) | (h2 > hi), axis=1))


def test_static_pose_matches_the_simulated_rest_under_a_steady_wrench():
  model = model_lib.build_spec(SMALL.params).compile()
  data = mujoco.MjData(model)
  w = np.array([[0.3, -0.2, -0.4, 0.004, -0.006, 0.005]])
  data.xfrc_applied[:] = shell._xfrc(model, data, w)[0].reshape(model.nbody, 6)
  for _ in range(6000):
    mujoco.mj_step(model, data)
  adr = model_lib.mount_qpos_index(model)
  np.testing.assert_allclose(data.qpos[adr], shell.static_pose(SMALL.params, w)[0],
                             rtol=0.03, atol=2e-6)


def test_rank_deficient_slopes_run_with_a_warning_naming_the_lost_direction():
  flat_x = dataclasses.replace(SMALL.params, slope_x=0.0)
  with pytest.warns(UserWarning, match=r"rank 5: the sensors cannot see 1 x"):
    r, _ = shell.simulate(dataclasses.replace(SMALL, params=flat_x, frames=500))
  assert np.isfinite(r.counts).all()


def test_run_saves_and_loads_as_a_recording(run, tmp_path):
  from sim import recording
  run.save(tmp_path / "cal")
  back = recording.Recording.load(tmp_path / "cal")
  assert back.counts.tobytes() == run.counts.tobytes()
  assert back.height.tobytes() == run.height.tobytes()
  assert back.applied.tobytes() == run.applied.tobytes()
  assert back.pressure is None and back.meta == run.meta and back.meta["scene"] == "shell"
  half = back.select(back.episode == 0)
  assert len(half) == int(np.sum(run.episode == 0))
  with pytest.raises(ValueError, match="no paths"):
    back.on_path("asterisk")


def test_spring_hysteresis_opens_a_loop_of_twice_the_friction():
  """Loaded slowly up and down in z, the shell lags by the mount's Coulomb friction: at the
  same force the loading and unloading displacements differ by 2 f / k."""
  p = SMALL.params
  model = model_lib.build_spec(p, hysteresis=True).compile()
  data = mujoco.MjData(model)
  z = model_lib.mount_qpos_index(model)[2]
  load = np.concatenate([np.linspace(0, -0.5, 4000), np.linspace(-0.5, 0, 4000)])
  trace = []
  for f in load:
    data.xfrc_applied[:] = shell._xfrc(model, data, np.array([[0, 0, f, 0, 0, 0]]))[0].reshape(
        model.nbody, 6)
    mujoco.mj_step(model, data)
    trace.append(data.qpos[z])
  trace = np.array(trace)
  up, down = trace[2000], trace[6000]  # both at -0.25 N
  width = abs(up - down)
  expected = 2 * p.mount_friction[0] / model_lib.mount_stiffness(p)[2]
  assert width == pytest.approx(expected, rel=0.15)


def test_cubic_calibration_is_exact_on_noiseless_in_window_counts():
  """The paper's cubic pseudoinverse (Eqns 4-9) on the scene's own noiseless counts: a wrench
  that is an exact cubic of them is recovered to 1e-8."""
  from calibrate import estimators
  r, _ = shell.simulate(dataclasses.replace(SMALL, effects=()))
  lo, hi = SMALL.sensor.window
  counts = r.counts[np.all((r.height >= lo) & (r.height <= hi), axis=1)]
  assert len(counts) > 1000
  rng = np.random.default_rng(7)
  x = (counts - 2900.0) / 1000.0  # counts scaled to ~[-1, 1] to draw the known cubic
  wrench = (x @ rng.normal(size=(8, 6)) + x**2 @ rng.normal(size=(8, 6)) * 0.3
            + x**3 @ rng.normal(size=(8, 6)) * 0.1 + rng.normal(size=6))
  est = estimators.fit(estimators.Kind.POLY, counts, wrench)
  err = np.max(np.abs(est.predict(counts) - wrench)) / np.max(np.abs(wrench))
  assert err < 1e-8, err


def test_cache_round_trip_gives_the_same_recording(tmp_path, monkeypatch):
  monkeypatch.setenv("TESTBENCH_CACHE", str(tmp_path))
  scene = dataclasses.replace(SMALL, frames=500)
  first, timing = shell.generate(scene)
  second, timing2 = shell.generate(scene)
  assert timing is not None and timing2 is None
  for name in ("counts", "wrench", "height", "pose", "applied", "time", "episode"):
    assert getattr(second, name).tobytes() == getattr(first, name).tobytes()
  assert second.meta == first.meta
  other, timing3 = shell.generate(dataclasses.replace(scene, seed=4))
  assert timing3 is not None and not np.array_equal(other.counts, first.counts)
