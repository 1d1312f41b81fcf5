"""The rig's mechanics against closed-form references."""

import ctypes
import dataclasses

import mujoco
import numpy as np
import pytest

from models import footpad as model_lib
from sim.footpad import layer

P = model_lib.FootpadParams()


def _press(model, data, z, x=0.0, y=0.0, steps=300):
  data.ctrl[:] = [x, y, -z]
  for _ in range(steps):
    mujoco.mj_step(model, data)


@pytest.fixture(scope="module")
def rig():
  """The default pad: element rates from the bonded finite-element block."""
  model = model_lib.build_spec(P, stiffness=layer.element_stiffness(P)).compile()
  return model, mujoco.MjData(model)


def test_normal_force_matches_EA_over_h():
  """A flat pad of free rubber columns ("uniform") presses with E*A/h."""
  model = model_lib.build_spec(P).compile()
  data = mujoco.MjData(model)
  for z in (0.0005, 0.001, 0.0015):
    _press(model, data, z)
    indentation = -data.qpos[model_lib.cnc_qpos_index(model)[2]]
    expected = P.youngs_modulus * P.footprint[0] * P.footprint[1] / P.thickness * indentation
    assert data.sensordata[2] == pytest.approx(expected, rel=0.05)


def test_normal_range_near_paper(rig):
  model, data = rig
  mujoco.mj_resetData(model, data)
  _press(model, data, 0.0015)
  assert 200 < data.sensordata[2] < 245  # paper: 221 N Z range


def test_plate_sensor_equals_element_forces_quasistatically(rig):
  model, data = rig
  mujoco.mj_resetData(model, data)
  _press(model, data, 0.001)
  for x in np.linspace(0, 0.0015, 600):  # 2.5 mm/s, then hold
    data.ctrl[0] = x
    mujoco.mj_step(model, data)
  _press(model, data, 0.001, x=0.0015, steps=500)
  fsum = model_lib.element_forces(model, P, data.qpos).sum(axis=0)
  np.testing.assert_allclose(data.sensordata[:3], fsum, rtol=0.01, atol=0.01)
  assert abs(data.sensordata[0]) > 20  # a real shear load, not a trivial zero


@pytest.mark.parametrize("axis", [0, 1])
def test_full_slip_shear_is_mu_times_normal(rig, axis):
  model, data = rig
  mujoco.mj_resetData(model, data)
  _press(model, data, 0.0005)
  ratios = []
  for s in np.linspace(0, 0.006, 1201):
    data.ctrl[axis] = s
    mujoco.mj_step(model, data)
    ratios.append(-data.sensordata[axis] / data.sensordata[2])
  assert np.mean(ratios[-300:]) == pytest.approx(P.friction, rel=0.02)
  assert np.std(ratios[-300:]) < 0.02 * P.friction  # steady sliding, no stick-slip collapse


def test_shear_range_of_order_200N(rig):
  """Paper: 219 N (X), 233 N (Y). The 13 mm bonded block's shear rate (0.92 G A/h) gives
  ~130 N over a +-3 mm stroke while stuck: the same order, below the paper (see thickness)."""
  model, data = rig
  mujoco.mj_resetData(model, data)
  _press(model, data, 0.0015)
  fx = []
  for s in np.concatenate([np.linspace(0, 0.003, 600), np.linspace(0.003, -0.003, 1200)]):
    data.ctrl[0] = s
    mujoco.mj_step(model, data)
    fx.append(data.sensordata[0])
  assert 100 < np.ptp(fx) < 400


def test_element_stiffness_sums_to_EA_over_h():
  k = P.element_stiffness()
  area = P.footprint[0] * P.footprint[1]
  assert k[:, 2].sum() == pytest.approx(P.youngs_modulus * area / P.thickness, rel=1e-12)
  assert k[:, 0].sum() == pytest.approx(P.shear_modulus * area / P.thickness, rel=1e-12)


def _arms(kind):
  if kind == "native" and model_lib.arm_dynamics()[0] != "native":
    pytest.skip(f"native Maxwell arms unavailable: {model_lib.arm_dynamics()[1]}")
  return kind


@pytest.mark.parametrize("arms", ["native", pytest.param("dcmotor", marks=pytest.mark.slow)])
@pytest.mark.parametrize("axis", [2, 0])
def test_viscoelastic_relaxes_as_its_prony_series(axis, arms):
  """Held at a fixed press (axis 2) or a press plus a sideways hold (axis 0), the plate force
  along that axis per unit of the elements' deflection follows the Prony series
  k0 (1 - g1 - g2 + g1 exp(-t/tau1) + g2 exp(-t/tau2)) after the hold starts, with either
  integration of the Maxwell arms."""
  params = dataclasses.replace(P, prony=(0.15, 0.3, 0.1, 3.0))  # short, to test in seconds
  g1, tau1, g2, tau2 = params.prony
  model = model_lib.build_spec(params, viscoelastic=True, arms=_arms(arms)).compile()
  data = mujoco.MjData(model)
  data.ctrl[:] = [0, 0, -0.001]
  if axis == 0:
    for _ in range(20000):  # let the press relax first (7 tau2)
      mujoco.mj_step(model, data)
    data.ctrl[0] = 0.0003  # well inside sticking: 0.3 mm x 23 kN/m << 0.9 x 110 N
  modulus = params.youngs_modulus if axis == 2 else params.shear_modulus
  k0 = modulus * params.footprint[0] * params.footprint[1] / params.thickness
  rate = []
  for _ in range(9000):
    mujoco.mj_step(model, data)
    # the deflection, not the CNC's travel: over seconds the soft friction rows let stuck
    # tips creep by ~4 % of a sideways hold (measured)
    deflection = model_lib.element_state(model, params, data.qpos, data.act)[1][:, axis].mean()
    rate.append(abs(data.sensordata[axis]) / abs(deflection))
  # the hold is reached over ~40 ms (servo and ramp): compare from 0.1 s on, the series
  # started at the hold's middle
  t = (np.arange(len(rate)) + 1) * params.timestep - 0.02
  series = k0 * (1 - g1 - g2 + g1 * np.exp(-t / tau1) + g2 * np.exp(-t / tau2))
  late = t > 0.1
  np.testing.assert_allclose(np.array(rate)[late], series[late], rtol=0.03)
  assert rate[-1] < 0.8 * rate[100]  # it did relax


def _press_and_drag(t):
  """CNC command at t s: press 1 mm over 0.1 s, drag 4 mm in x over 0.4 s (it slides), hold."""
  return [0.004 * min(max(t - 0.15, 0.0) / 0.4, 1.0), 0.0, -0.001 * min(t / 0.1, 1.0)]


def test_native_arms_integrate_the_motors_equation():
  """The compiled arms and MuJoCo's implicitly coupled DC motors are two integrations of one
  equation: pressed, dragged into sliding and held over 1 s, the plate's force agrees to 1 %
  of its largest value at every millisecond, and each stays within 3 % of the motors
  stepped at a fifth of the time step (measured: 0.5 %; 2.0 and 1.5 %)."""
  _arms("native")
  k = layer.element_stiffness(P)
  runs = {}
  for arms, dt in (("native", 0.001), ("dcmotor", 0.001), ("dcmotor", 0.0002)):
    # fast arms, the hard case for an explicit step
    params = dataclasses.replace(P, prony=(0.15, 0.05, 0.1, 0.5), timestep=dt)
    model = model_lib.build_spec(params, viscoelastic=True, stiffness=k, arms=arms).compile()
    data = mujoco.MjData(model)
    every = round(0.001 / dt)
    force, arm_load = [], 0.0
    for step in range(1000 * every):
      data.ctrl[:] = _press_and_drag((step + 1) * dt)
      mujoco.mj_step(model, data)
      if step % every == every - 1:
        force.append(data.sensordata[:3].copy())
        arm_load = max(arm_load, np.abs(data.act).sum())
    runs[arms, dt] = np.array(force)
    assert arm_load > 10.0  # N: the arms carried load
  native, motor, fine = runs["native", 0.001], runs["dcmotor", 0.001], runs["dcmotor", 0.0002]
  scale = np.abs(fine).max()
  assert np.abs(native - motor).max() < 0.01 * scale
  assert np.abs(native - fine).max() < 0.03 * scale
  assert np.abs(motor - fine).max() < 0.03 * scale


def test_native_arms_refuse_to_step_without_their_callback():
  """A model with native arms, stepped where their callback is not installed, would never
  relax: the episode runner refuses it and names the fix."""
  _arms("native")
  from util import errors
  model = model_lib.build_spec(P, viscoelastic=True, arms="native").compile()
  installed = mujoco.get_mjcb_act_dyn()
  try:
    mujoco.set_mjcb_act_dyn(None)
    with pytest.raises(errors.SimulationError, match="mjcb_act_dyn was replaced"):
      model_lib.require_arm_dynamics(model)
  finally:
    mujoco.set_mjcb_act_dyn(installed)
  model_lib.require_arm_dynamics(model)  # restored
  model_lib.require_arm_dynamics(model_lib.build_spec(P, viscoelastic=True,
                                                      arms="dcmotor").compile())


def test_bonded_plate_rates_soften_edges_and_set_the_press():
  k = layer.element_stiffness(P)
  kz = k[:, 2].reshape(P.grid)
  mean = kz.mean()
  assert kz.min() < 0.9 * mean and kz[0, 0] < 0.95 * mean  # soft free edges and corners
  assert kz[P.grid[0] // 2, P.grid[1] // 2] > 1.2 * mean  # stiff, confined centre
  model = model_lib.build_spec(P, stiffness=k).compile()
  data = mujoco.MjData(model)
  _press(model, data, 0.001)
  indentation = -data.qpos[model_lib.cnc_qpos_index(model)[2]]
  assert data.sensordata[2] == pytest.approx(k[:, 2].sum() * indentation, rel=0.05)


def test_plate_wrench_is_what_mujocos_force_torque_sensor_reads():
  """The plate's wrench from its net contact force (`plate_wrench`) equals MuJoCo's own
  force and torque sensors at the F/T site, pressed and dragged off centre."""
  spec = model_lib.build_spec(P, viscoelastic=True, stiffness=layer.element_stiffness(P))
  for kind in (mujoco.mjtSensor.mjSENS_FORCE, mujoco.mjtSensor.mjSENS_TORQUE):
    spec.add_sensor(type=kind, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="ft")
  model = spec.compile()
  data = mujoco.MjData(model)
  n = model_lib.PLATE_SENSOR
  worst, peak = 0.0, np.zeros(6)
  for i in range(600):
    data.ctrl[:] = [0.003 * np.sin(i / 90), 0.002 * np.cos(i / 60), -0.0012]
    mujoco.mj_step(model, data)
    ours, theirs = model_lib.plate_wrench(data.sensordata), data.sensordata[n:n + 6]
    worst = max(worst, np.abs(ours - theirs).max())
    peak = np.maximum(peak, np.abs(theirs))
  assert peak[2] > 100 and peak[0] > 10 and peak[3] > 0.05  # a real press, drag and couple
  assert worst < 1e-9 * peak[2]


def test_native_build_says_why_it_could_not(tmp_path, monkeypatch):
  """Without a compiler, or with a source that does not compile, `shared_library` returns no
  library and the reason (the arms then fall back to MuJoCo's motors); a good source loads."""
  from util import native
  monkeypatch.setenv("TESTBENCH_CACHE", str(tmp_path / "cache"))
  good, bad = tmp_path / "good.c", tmp_path / "bad.c"
  good.write_text("double twice(double x) { return 2 * x; }\n")
  bad.write_text("double twice(double x) { return 2 * ; }\n")
  monkeypatch.setenv("CC", "")
  assert native.shared_library(good) == (None, "no C compiler found (set CC, or install gcc)")
  monkeypatch.delenv("CC")
  if native.compiler() is None:
    pytest.skip("no C compiler here")
  lib, why = native.shared_library(bad)
  assert lib is None and "could not compile bad.c" in why
  lib, why = native.shared_library(good)
  lib.twice.restype, lib.twice.argtypes = ctypes.c_double, [ctypes.c_double]
  assert why == "" and lib.twice(1.5) == 3.0
  assert [p.name.split("-")[0] for p in (tmp_path / "cache" / "native").iterdir()] == ["good"]
