"""Every code block of README.md, run as a user would paste it, in order, in an empty folder:
csv blocks are written to the file their first comment names, python blocks run in one
namespace, `python -m calibrate` lines run, `python -m benchmarks.run` lines are checked
(`--check`: name, settings and folder, without the run's minutes) except an identification
of a user's own table (`--set targets=...`), which runs, and no inline command is broken
over two lines."""

import pathlib
import re
import shlex

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
BLOCK = re.compile(r"^( *)```(\w+)\n(.*?)^\1```", re.S | re.M)


def _blocks():
  for indent, lang, body in BLOCK.findall(README):
    yield lang, "\n".join(line[len(indent):] for line in body.splitlines())


def _commands(body: str):
  for line in body.splitlines():
    line = line.split("  #")[0].strip()
    for part in (p.strip() for p in line.split("&&")):
      if part.startswith(("python -m", "python3 -m")):
        yield shlex.split(part)


def test_readme_opens_with_the_two_commands():
  first = [body for lang, body in _blocks()][:2]
  assert first[0].strip() == "pip install -e . && python -m benchmarks.run asterisk_path"
  assert first[1].strip() == "pip install -e '.[test]' && python3 -m pytest -q -n auto tests"


@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_every_block_runs_in_order(tmp_path, monkeypatch, capsys):
  from benchmarks import run
  from calibrate import __main__ as calibrate_cli
  monkeypatch.chdir(tmp_path)
  namespace: dict = {}
  ran = {"python": 0, "csv": 0, "calibrate": 0, "benchmarks": 0, "render": 0,
         "identification": 0}
  for lang, body in _blocks():
    if lang == "csv":
      name = re.match(r"#\s*([\w.-]+\.csv)", body).group(1)
      (tmp_path / name).write_text(body + "\n")
      ran["csv"] += 1
    elif lang == "python":
      exec(compile(body, "README.md", "exec"), namespace)
      ran["python"] += 1
    elif lang == "bash":
      for argv in _commands(body):
        module, args = argv[2], argv[3:]
        if module == "calibrate":
          assert calibrate_cli.main(args) == 0, argv
          said = capsys.readouterr().out
          # the README's tares take windows at rest: no command of it warns of a false tare
          assert "not at rest" not in said, (argv, said)
          ran["calibrate"] += 1
        elif module == "benchmarks.run" and any(a.startswith("targets=") for a in args):
          # the identification of a user's own table: run for real (a small table, seconds)
          assert run.main(args + ["--no-progress"]) == 0, (argv, capsys.readouterr().err)
          ran["identification"] += 1
        elif module == "benchmarks.run":
          assert run.main(args + ["--check"]) == 0, (argv, capsys.readouterr().err)
          ran["benchmarks"] += 1
        elif module == "sim.render":
          from sim import render
          code = render.main(args)
          err = capsys.readouterr().err
          if code == 2 and "offscreen context" in err:
            continue  # no GL library here: test_render says so
          assert code == 0, (argv, err)
          ran["render"] += 1
  assert all(v for k, v in ran.items() if k != "render"), ran
  assert ran["render"] == 0 or (tmp_path / "footpad.png").exists()
  assert (tmp_path / "my_pad_c" / "estimator.c").exists()
  assert (tmp_path / "my_identification" / "preset.json").exists()
  assert namespace["forces"].shape[1] == 3 and (namespace["sd"] > 0).all()


def test_no_inline_command_is_broken_over_lines():
  prose = BLOCK.sub("", README)
  broken = [m for m in re.findall(r"(?<!`)`([^`]+)`(?!`)", prose)
            if "\n" in m and m.lstrip().startswith(("--", "python"))]
  assert not broken, broken
