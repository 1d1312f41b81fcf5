"""The footpad scene end to end: reproducibility, cache, bad input, instability."""

import dataclasses

import mujoco
import numpy as np
import pytest

from benchmarks import run as cli
from models import footpad as model_lib
from sim.footpad import layer, scene as footpad, trajectories
from sim.footpad.effects import EFFECTS as FOOTPAD_EFFECTS

SMALL = footpad.FootpadScene(paths=("x_stroke",), z_levels=(0.001,), feed=0.005,
                             effects=("friction", "sensor_noise", "ft_noise"), seed=5)


@pytest.fixture(scope="module")
def recording():
  return footpad.simulate(SMALL)[0]


def test_same_seed_same_bytes(recording):
  again, _ = footpad.simulate(SMALL)
  for name in ("counts", "pressure", "wrench", "element_force", "cnc", "time"):
    assert getattr(recording, name).tobytes() == getattr(again, name).tobytes()


def test_other_seed_changes_noise_only(recording):
  other, _ = footpad.simulate(dataclasses.replace(SMALL, seed=6))
  assert other.pressure.tobytes() == recording.pressure.tobytes()
  assert other.element_force.tobytes() == recording.element_force.tobytes()
  assert not np.array_equal(other.counts, recording.counts)
  assert not np.array_equal(other.wrench, recording.wrench)


def test_signal_effect_off_is_identical_to_not_listing_it(recording):
  clean, _ = footpad.simulate(dataclasses.replace(SMALL, effects=("friction",)))
  assert clean.pressure.tobytes() == recording.pressure.tobytes()
  noisy_off, _ = footpad.simulate(dataclasses.replace(SMALL, effects=("friction", "ft_noise")))
  assert noisy_off.counts.tobytes() == clean.counts.tobytes()


def test_truth_and_summed_element_forces_are_both_recorded(recording):
  on = recording.phase == 1
  fz = recording.element_force[on, 2]
  assert np.median(np.abs(recording.wrench[on, 2] - fz) / fz) < 0.01
  assert recording.meta["effects"] == ["friction", "ft_noise", "sensor_noise"]
  assert recording.meta["seed"] == 5 and "mujoco" in recording.meta["versions"]


@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_cache_round_trip(tmp_path, monkeypatch):
  from util import files
  # the recordings in a cache of their own; what the other tests share stays shared (the
  # finite-element kernels, stiffness and native arms: solving and compiling them again was
  # 20 of this test's 26 s)
  for kind in ("kernels", "stiffness", "native"):
    shared = files.cache_dir() / kind
    shared.mkdir(parents=True, exist_ok=True)
    (tmp_path / kind).symlink_to(shared, target_is_directory=True)
  monkeypatch.setenv("TESTBENCH_CACHE", str(tmp_path))
  first, timing = footpad.generate(SMALL)
  assert timing is not None
  second, timing2 = footpad.generate(SMALL)
  assert timing2 is None
  assert second.counts.tobytes() == first.counts.tobytes()
  assert second.meta == first.meta
  assert not list((tmp_path / "recordings").rglob("*.tmp"))


def test_middle_row_carries_less_signal_under_y_shear():
  scene = dataclasses.replace(SMALL, paths=("x_stroke", "y_stroke"), effects=("friction",))
  rec, _ = footpad.simulate(scene)
  middle = [i for i, (_, y, _) in enumerate(scene.params.die_positions()) if y == 0]

  def swing(path):
    r = rec.paths(path)
    on = r.phase == 1
    return np.ptp(r.pressure[on][:, middle], axis=0)
  assert np.all(swing("y_stroke") < 0.2 * swing("x_stroke"))


@pytest.mark.parametrize("change, message", [
    (dict(z_levels=(-0.001,)), r"z_levels=\(-0.001,\) is out of range: allowed \[0, 0.02\] m"),
    (dict(z_levels=(0.01,)), r"z_levels=\(0.01,\) is out of range: allowed \[0, 0.0052\] m"),
    (dict(paths=("helix",)), r"paths=\('helix',\) is out of range: allowed any of 'z_press'"),
    (dict(effects=("glitter",)), r"effects=\('glitter',\) is out of range: allowed any of"),
    (dict(params=model_lib.FootpadParams(friction=0.0)), "params.friction=0.0 is out of range"),
    (dict(params=model_lib.FootpadParams(friction=-1.0)), "params.friction=-1.0 is out of range"),
])
def test_bad_input_is_named(change, message):
  with pytest.raises(ValueError, match=message):
    footpad.simulate(dataclasses.replace(SMALL, **change))


def test_cli_errors_are_one_line(capsys):
  assert cli.main(["footpad_dataset", "--quick", "--set", "nope=1", "--no-progress"]) == 2
  err = capsys.readouterr().err.strip()
  assert err.startswith("error: unknown setting 'nope'") and "\n" not in err
  assert cli.main(["no_such_benchmark"]) == 2
  err = capsys.readouterr().err.strip()
  assert err.startswith("error: unknown benchmark 'no_such_benchmark'") and "\n" not in err
  assert cli.main(["asterisk_pth"]) == 2  # a typo gets the name, not the list of 17
  assert capsys.readouterr().err.strip() == \
      "error: unknown benchmark 'asterisk_pth': did you mean asterisk_path?"
  assert cli.main(["--list"]) == 0


def test_mujoco_instability_becomes_an_error(tmp_path, monkeypatch):
  monkeypatch.chdir(tmp_path)  # MuJoCo writes MUJOCO_LOG.TXT beside the process
  model = model_lib.build_spec(model_lib.FootpadParams()).compile()
  model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER  # explicit springs at 1 ms: diverge
  model.actuator_gainprm[:, 0] = 1e11
  model.actuator_biasprm[:, 1] = -1e11
  ep = trajectories.episode("x_stroke", 0.001, 0.005, 0.001, repeats=1)
  with pytest.raises(footpad.SimulationError, match="MuJoCo warning|non-finite"):
    footpad._run_episode(model, mujoco.MjData(model), ep)


def test_every_effect_is_documented():
  for e in FOOTPAD_EFFECTS.values():
    assert len(e.doc) > 40


def test_kernel_choice_changes_only_die_stress():
  a, _ = footpad.simulate(dataclasses.replace(SMALL, effects=("friction",)))
  b, _ = footpad.simulate(dataclasses.replace(SMALL, effects=("friction",),
                                              kernel=layer.Kernel.HALFSPACE))
  assert a.element_force.tobytes() == b.element_force.tobytes()
  assert not np.array_equal(a.pressure, b.pressure)


def test_p_delta_changes_only_die_stress_and_amplifies_the_shear_moment():
  """The couples act after the physics; a normal force carried sideways by the shear adds to
  the shear's own overturning moment (same sign), so the X column difference per newton of
  Fx grows."""
  scene = dataclasses.replace(SMALL, effects=("friction",))
  a, _ = footpad.simulate(scene)
  b, _ = footpad.simulate(dataclasses.replace(scene, effects=("friction", "p_delta")))
  assert a.element_force.tobytes() == b.element_force.tobytes()
  assert a.wrench.tobytes() == b.wrench.tobytes()
  on = a.phase == 1
  fx = a.wrench[on, 0]
  x_pos = [i for i, d in enumerate(scene.params.die_positions()) if d[0] > 0]
  x_neg = [i for i, d in enumerate(scene.params.die_positions()) if d[0] < 0]

  def slope(rec):
    diff = rec.pressure[on][:, x_pos].sum(axis=1) - rec.pressure[on][:, x_neg].sum(axis=1)
    return np.polyfit(fx, diff, 1)[0]
  assert abs(slope(b)) > 1.1 * abs(slope(a))
  assert np.sign(slope(b)) == np.sign(slope(a))


def test_slip_share_counts_elements_at_their_friction_limit():
  f = np.array([[[0.0, 0.9, 1.0], [0.5, 0.0, 1.0], [0.0, 0.0, 0.0], [0.89, 0.0, 1.0]]])
  # loaded: 0, 1, 3; at the limit 0.9 * 1.0 (x 0.98): 0 and 3
  assert footpad.slip_share(f, 0.9)[0] == pytest.approx(2 / 3)


def test_shallow_strokes_slide_within_coulomb_and_deep_ones_stick():
  scene = footpad.FootpadScene(paths=("x_stroke",), z_levels=(0.0005, 0.0015),
                               effects=("friction",))
  rec, _ = footpad.simulate(scene)
  mu = scene.params.friction
  for z, slides in ((0.0005, True), (0.0015, False)):
    m = (rec.z_level == z) & (rec.phase == 1)
    ratio = np.hypot(rec.wrench[m, 0], rec.wrench[m, 1]) / rec.wrench[m, 2]
    assert ratio.max() <= mu * 1.01  # the plate's shear never beats the pad's friction
    assert (rec.slip[m].max() > 0.1) == slides


def test_thirion_friction_is_coulomb_at_low_pressure_and_capped_at_high():
  mu0, tau_s = 1.85, 0.3e6
  assert footpad.thirion_friction(mu0, tau_s, np.array([1.0]))[0] == pytest.approx(mu0, rel=1e-5)
  p = np.array([1e9, 1e10])
  np.testing.assert_allclose(footpad.thirion_friction(mu0, tau_s, p) * p, tau_s, rtol=2e-3)
  # in between, the law itself: tau = mu0 p / (1 + mu0 p / tau_s)
  assert footpad.thirion_friction(mu0, tau_s, np.array([0.1e6]))[0] == pytest.approx(
      mu0 / (1 + mu0 * 0.1e6 / tau_s))


def test_pressure_friction_sets_each_element_and_bounds_the_shear():
  params = model_lib.FootpadParams(friction_mu0=1.2, friction_shear_strength=0.15e6)
  scene = footpad.FootpadScene(paths=("x_stroke",), z_levels=(0.0003,), params=params,
                               effects=("friction", "pressure_friction"))
  mu = footpad.episode_friction(scene, 0.0003)
  assert np.ptp(mu) > 0.01  # by element, not one coefficient
  rec, _ = footpad.simulate(scene)
  held = rec.phase == 1
  ratio = np.hypot(rec.wrench[held, 0], rec.wrench[held, 1]) / rec.wrench[held, 2]
  assert ratio.max() <= mu.max() * 1.01 and rec.slip[held].max() > 0.1
  assert ratio.max() > params.friction  # the Coulomb coefficient is not the one in force
  with pytest.raises(ValueError, match="pressure_friction together with friction"):
    footpad.simulate(dataclasses.replace(scene, effects=("pressure_friction",)))


# a flat 2 x 2 pad dragged 0.3 mm deep: every element slides at the Coulomb limit
SLIDER = footpad.FootpadScene(
    paths=("x_stroke",), z_levels=(0.0003,), effects=("friction", "stick_slip"),
    params=model_lib.FootpadParams(grid=(2, 2), crown_radius=float("inf")))


def slider(ratio):
  params = dataclasses.replace(SLIDER.params, static_friction_ratio=ratio)
  rec, _ = footpad.simulate(dataclasses.replace(SLIDER, params=params))
  f = rec.element_force
  held = (rec.phase == 1) & (f[:, 2] > 0.5 * f[rec.phase == 1, 2].max())
  return rec, np.max(np.abs(f[held, 0]) / f[held, 2])


def test_stick_slip_breaks_away_at_the_static_limit_and_slides_at_the_kinetic():
  mu = SLIDER.params.friction
  plain, peak1 = slider(1.0)
  assert peak1 == pytest.approx(mu, rel=2e-3)  # equal coefficients: Coulomb, slides at mu
  for ratio in (1.15, 1.3):
    rec, peak = slider(ratio)
    # a stuck element holds up to the static limit (broken away at SLIDING of it), not past
    assert footpad.SLIDING * ratio * mu * 0.995 <= peak <= ratio * mu
    assert rec.slip[rec.phase == 1].mean() < 0.5 * plain.slip[plain.phase == 1].mean()


def test_stick_slip_at_ratio_one_is_identical_to_plain_friction():
  for effects in (("friction",), ("friction", "pressure_friction", "viscoelastic")):
    scene = dataclasses.replace(SLIDER, effects=effects, params=SLIDER.params)
    with_state = dataclasses.replace(scene, effects=effects + ("stick_slip",),
                                     params=dataclasses.replace(scene.params,
                                                                static_friction_ratio=1.0))
    a, _ = footpad.simulate(scene)
    b, _ = footpad.simulate(with_state)
    assert a.pressure.tobytes() == b.pressure.tobytes()
    assert a.wrench.tobytes() == b.wrench.tobytes()
  with pytest.raises(ValueError, match="stick_slip together with friction"):
    footpad.simulate(dataclasses.replace(SLIDER, effects=("stick_slip",)))


def _step_one_at_a_time(stick, model, data, target):
  """The stick-slip state machine stepped singly, reading MuJoCo's constraint forces and
  velocities after each step: the reference for the chunked `StickSlip.roll`."""
  n, nt = len(target), len(stick.tips)
  element_of = np.full(model.ngeom, -1)
  element_of[stick.tips] = np.arange(nt)
  slip, sens = np.zeros(n), np.empty((n, model.nsensordata))
  stuck, velocity = np.ones(nt, bool), np.zeros((nt, 2))
  static = stick.ratio * stick.kinetic
  model.geom_friction[stick.tips, 0] = static
  for t in range(n):
    data.ctrl[:] = target[t]
    mujoco.mj_step(model, data)
    sens[t] = data.sensordata
    nc = data.ncon
    el = element_of[data.contact.geom[:nc].max(axis=1)]
    adr = data.contact.efc_address[:nc]
    fn = data.efc_force[adr]
    on = (el >= 0) & (fn > footpad.LOADED)
    el, adr, fn = el[on], adr[on], fn[on]
    ft = np.hypot(data.efc_force[adr + 1], data.efc_force[adr + 2])
    vx, vy = data.efc_vel[adr + 1], data.efc_vel[adr + 2]
    touching = np.zeros(nt, bool)
    touching[el] = True
    was = stuck[el]
    breaks = was & (ft >= footpad.SLIDING * static[el] * fn)
    halts = ~was & ((np.hypot(vx, vy) < footpad.STICK_SPEED)
                    | (vx * velocity[el, 0] + vy * velocity[el, 1] < 0))
    stuck[el[breaks]] = False
    stuck[el[halts]] = True
    velocity[el, 0], velocity[el, 1] = vx, vy
    slip[t] = np.count_nonzero(~stuck[el]) / len(el) if len(el) else 0.0
    stuck |= ~touching
    model.geom_friction[stick.tips, 0] = np.where(stuck, static, stick.kinetic)
  return sens, slip


@pytest.mark.parametrize("effects", [("friction", "stick_slip"),
                                     ("friction", "stick_slip", "viscoelastic")])
def test_chunked_stick_slip_equals_stepping_one_at_a_time(effects):
  """Rolled in chunks, re-rolled from each change of coefficient, the state machine gives
  the slip of every step and the plate's force that single steps give (up to the solver's
  tolerance: a re-rolled chunk starts from another warm start)."""
  params = dataclasses.replace(SLIDER.params, static_friction_ratio=1.3)
  scene = dataclasses.replace(SLIDER, params=params, effects=effects)
  model = footpad.compile_model(scene)
  model.geom_friction[model.geom("plate").id, 0] = 0.0
  stick = footpad.StickSlip.of(model, params, np.full(params.num_elements, params.friction))
  ep = footpad.episodes(scene, layer.die_kernel(params, scene.kernel))[0]
  runs = []
  for roll in (lambda m, d: stick.roll(m, d, ep.target)[3:],
               lambda m, d: _step_one_at_a_time(stick, m, d, ep.target)):
    data = mujoco.MjData(model)
    data.qpos[model_lib.cnc_qpos_index(model)] = ep.target[0]
    data.ctrl[:] = ep.target[0]
    mujoco.mj_forward(model, data)
    runs.append(roll(model, data))
  (sens, slip), (ref_sens, ref_slip) = runs
  assert 0.2 < ref_slip.max() and (np.diff(ref_slip) != 0).sum() > 4  # it slid, and stuck
  np.testing.assert_array_equal(slip, ref_slip)
  scale = np.abs(ref_sens[:, :3]).max()
  np.testing.assert_allclose(model_lib.plate_wrench(sens), model_lib.plate_wrench(ref_sens),
                             rtol=0, atol=1e-6 * scale)
