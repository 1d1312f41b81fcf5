"""The shell benchmarks end to end through the command, on --quick settings."""

import json

import numpy as np

from benchmarks import run as cli


def test_shell_geometry_command(tmp_path):
  assert cli.main(["shell_geometry", "--quick", "--out", str(tmp_path), "--no-progress"]) == 0
  m = json.loads((tmp_path / "metrics.json").read_text())
  assert m["rank"] == 6 and m["max_rel_difference"] < 1e-3
  ranks = {(s["slope_x"], s["slope_y"]): s["rank"] for s in m["sweep"]}
  assert ranks[(0.0, 0.0)] == 3 and ranks[(0.0, 0.3)] == 5 and ranks[(0.3, 0.0)] == 4


def test_shell_table1_command(tmp_path):
  args = ["shell_table1", "--quick", "--out", str(tmp_path), "--no-progress",
          "--set", "force_range=0.5", "--set", "torque_range=0.02"]
  assert cli.main(args) == 0
  m = json.loads((tmp_path / "metrics.json").read_text())
  assert m["frames"] == {"calibration": 9752, "test": 4231}
  med = np.array([m["results"][a]["median_pct"] for a in ("Fx", "Fy", "Fz", "Mx", "My", "Mz")])
  assert np.all(np.isfinite(med)) and np.all(med < 50)
  assert m["bottomed"]["calibration"] == 0.0


def test_shell_table2_command(tmp_path):
  args = ["shell_table2", "--quick", "--out", str(tmp_path), "--no-progress"]
  assert cli.main(args) == 0
  m = json.loads((tmp_path / "metrics.json").read_text())
  for a in ("Fx", "Fy", "Fz", "Mx", "My", "Mz"):
    r = m["results"][a]
    # the resolution at rest is a small fraction of the loaded range
    assert 0 < r["resolution"] < 0.02 * r["range"], (a, r)


def test_step_response_rings_at_the_spring_mass_frequency(tmp_path):
  args = ["step_response", "--quick", "--out", str(tmp_path), "--no-progress"]
  assert cli.main(args) == 0
  m = json.loads((tmp_path / "metrics.json").read_text())
  assert abs(m["ringing_hz"] / m["spring_mass_hz"] - 1) < 0.05
  # the calibrated step reads the mass's weight with the right sign and order
  assert -0.7 < m["fz_step"] < -0.3


def test_gravity_vectors_reads_the_mass_and_the_tared_shell(tmp_path):
  from models import shell
  from sim.shell import turn
  args = ["gravity_vectors", "--quick", "--out", str(tmp_path), "--no-progress"]
  assert cli.main(args) == 0
  m = json.loads((tmp_path / "metrics.json").read_text())["results"]["every direction"]
  # statics: the mass's weight plus the change of the shell's own weight since the tare
  p = shell.ShellParams()
  m_shell = p.shell_mass + p.reflector_mass + 8e-5
  g = turn.gravity_sequence(2000)
  g0 = g[0]
  expected = np.mean(np.linalg.norm(turn.PAYLOAD * g + m_shell * (g - g0), axis=1)
                     / np.linalg.norm(g, axis=1)) * 1e3
  assert abs(m["mean_mass_g"] / expected - 1) < 0.05, (m["mean_mass_g"], expected)
  assert m["mean_angle_deg"] < 20


def test_collisions_course_matches_fig11_signs(tmp_path):
  args = ["collisions", "--quick", "--out", str(tmp_path), "--no-progress"]
  assert cli.main(args) == 0
  r = json.loads((tmp_path / "metrics.json").read_text())["results"]
  # [II] the front-left corner is pushed back and to the right, and the robot turns right
  assert r["corner_min"][0] < -0.1 and r["corner_min"][1] < -0.1
  assert r["turn_deg"] < -5
  assert r["along_contact_mean"][1] < 0 and r["along_mean"][1] < 0  # [III] wall on the left
  # [IV] the feet's friction limits the push: at most mu_s x weight, near it when they slip
  limit = r["feet_friction_limit"]
  assert 0.8 * limit < -r["pushing_contact_mean"][0] < 1.05 * limit
  assert abs(r["pushing_mean"][0] - r["pushing_contact_mean"][0]) < 0.05  # the shell reads it
  # walking jolts: the paper's +-0.15 N within a factor of 3, read as the springs feel them
  amp, spring = np.array(r["walking_amplitude"]), np.array(r["walking_spring_amplitude"])
  assert 0.05 < amp.max() < 0.45
  assert np.all(np.abs(amp - spring) < 0.2 * spring.max())
