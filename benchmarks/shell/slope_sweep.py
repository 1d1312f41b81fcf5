"""reflector_slope_sweep: which reflector slopes (and springs, gap...) make the best shell.

A grid of designs (default slope_x x slope_y, 0 to 1.5 in 12 steps each; any ShellParams
number is a further axis: `--set sweep.spring_rate=100,150,300`). For each design, on the
static path (poses from the mount's stiffness, `sim.shell.design`):
  - rank, condition number and lost directions of the height map (closed form);
  - the wrench resolution per axis: 1 count rms of noise per sensor (the paper's bench
    figure, Sec. II-B) through the count map, in N and mN m;
  - the in-window range per axis (the load along that axis alone at which the first sensor
    leaves its 2-4 mm window) and the shares of the paper's load box (Table II ranges) that
    keep every sensor in the window and that drive a reflector into the PCB;
  - the calibrated median and worst-case error per axis: the shell's cubic calibration
    (paper Eqns 4-9) on static-path calibration and test loads of the paper's sizes (a tenth
    with --quick), with the board's effects; every design its own seeds from the run's seed.
The figure of merit is the mean over the six axes of the calibrated median % error (lower is
better); designs the sensors cannot fully see (rank < 6) sort last. The `confirm` best
designs also run the full MuJoCo scene (hand loads through the dynamics), and the rank
correlation of the two paths over them is printed, with their ray-cast height maps against
the closed form. With `search`, a gradient search (L-BFGS-B in JAX) minimises the design
objective (`sim.shell.design.objective`: resolution against the paper's, plus a hinge on an
in-window range short of the paper's loads) over the swept slopes and gap, from the board's
design, and is checked against the same objective on the grid. The board's own design (the
project's assumed 0.3 / 0.3) is placed in the table. Heat-map data: DIR/sweep.npz; finished
designs are kept in DIR/points/, so an interrupted sweep resumes.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Optional

import numpy as np

from benchmarks import shell
from benchmarks.registry import register
from util import errors, files

FIXED = {"board.frames": "the static path runs the paper's frame counts (a tenth with --quick)",
         "board.seed": "every design draws its own seed from --seed"}
SHOWN = 12  # rows of the sorted table


def sweep_settings(quick: bool, seed: int):
  """The sweep's settings (`sim.shell.design.SlopeSweep`), the root of --set keys."""
  from sim.shell import design
  return design.SlopeSweep()


def evaluate(point: dict) -> dict:
  """One design on the static path (runs in a worker: everything comes from the point)."""
  from calibrate import metrics  # not estimators: the workers need no JAX
  from calibrate.parts import linear
  from util import fields
  from sim.shell import design, geometry, scene as scene_lib
  board = fields.build(scene_lib.ShellScene, point["board"])
  params = dataclasses.replace(board.params, **point["design"])
  board = dataclasses.replace(board, params=params)
  quality = geometry.map_quality(geometry.height_jacobian(params))
  sd = design.resolution(params, board.sensor)
  window = design.window_range(params, board.sensor)
  inside, bottomed = design.window_shares(params, board.sensor,
                                          design.box_loads(point["box_samples"], point["seed"]))
  cal, test = (scene_lib.simulate_static(dataclasses.replace(board, frames=n, seed=s))
               for n, s in zip(point["frames"], point["seeds"]))
  pred = linear.fit_linear(cal.counts, cal.wrench, degree=3).predict(test.counts)
  median = metrics.wrench_median_pct(pred, test.wrench)
  worst = metrics.worst_pct_of_range(pred, test.wrench)
  return {"rank": quality.rank, "condition": quality.condition, "lost": list(quality.lost),
          "resolution": sd.tolist(), "window_range": window.tolist(),
          "box_inside": inside, "box_bottomed": bottomed,
          "objective": design.objective(params, board.sensor),
          "median_pct": median.tolist(), "worst_pct": worst.tolist(),
          "fom": float(np.mean(median)) if quality.rank == 6 else float("inf"),
          "out_of_window": [cal.meta["out_of_window"], test.meta["out_of_window"]]}


def _points(ctx, designs: list[dict]) -> list[dict]:
  """One point per design; its seeds come from the run's seed and the design's values, so a
  design gets the same numbers wherever it stands in the grid (and as the board's row)."""
  import zlib
  from sim.shell import scene as scene_lib
  frames = [n // 10 if ctx.quick else n for n in scene_lib.PAPER_FRAMES.values()]
  board = scene_lib.config(ctx.settings.board)
  out = []
  for d in designs:
    tag = zlib.crc32(repr(sorted(d.items())).encode())
    seeds = np.random.SeedSequence(ctx.seed, spawn_key=(tag,)).generate_state(2)
    out.append({"design": d, "board": board, "frames": frames, "seeds": [int(s) for s in seeds],
                "seed": int(seeds[0]), "box_samples": ctx.settings.box_samples})
  return out


def _fmt(v: float, scale: float = 1.0, width: int = 6, digits: int = 2) -> str:
  return f"{v * scale:{width}.{digits}f}" if np.isfinite(v) else f"{'inf':>{width}s}"


def _search(ctx, axes: dict, best: dict) -> dict:
  """L-BFGS-B over the swept search axes from the board's design, the other axes at `best`."""
  import jax
  import jaxopt
  from sim.shell import design
  names = tuple(n for n in design.SEARCH_FIELDS if n in axes and len(axes[n]) > 1)
  if not names:
    return {"skipped": "no continuous axis (slope_x, slope_y, gap) swept"}
  board = ctx.settings.board
  others = {k: v for k, v in best.items() if k not in names}
  board = dataclasses.replace(board, params=dataclasses.replace(board.params, **others))
  lo = np.array([min(axes[n]) for n in names])
  hi = np.array([max(axes[n]) for n in names])
  start = np.clip([getattr(board.params, n) for n in names], lo, hi)
  with jax.enable_x64(True):
    fn = jax.jit(design.objective_fn(board, names))
    t = time.perf_counter()
    solver = jaxopt.LBFGSB(fun=fn, maxiter=200, tol=1e-9)
    res = solver.run(np.asarray(start, float), bounds=(lo, hi))
    found = np.asarray(res.params)
    seconds = time.perf_counter() - t
    value = float(fn(found))
  return {"axes": list(names), "start": start.tolist(), "found": found.tolist(),
          "objective": value, "iterations": int(res.state.iter_num), "seconds": seconds}


def _heatmap(ctx, axes: dict, fom: np.ndarray, board_design: dict) -> None:
  """figures/slope_sweep.png: the figure of merit over the first two swept axes (the best
  over any further axes), the board's design marked."""
  from benchmarks import figures
  names = list(axes)
  if len(names) < 2:
    return
  order = [np.argsort(axes[n]) for n in names[:2]]
  values = fom if fom.ndim == 2 else np.nanmin(fom.reshape(fom.shape[:2] + (-1,)), axis=2)
  values = values[np.ix_(*order)]
  if not np.isfinite(values).any():
    return
  x, y = (np.sort(np.asarray(axes[n], float)) for n in names[:2])
  further = f" (best over {', '.join(names[2:])})" if len(names) > 2 else ""
  figures.save(figures.heatmap(x, y, values.T, xlabel=names[0], ylabel=names[1],
                               label="mean calibrated median error (%)", benchmark=ctx.name,
                               seed=ctx.seed, what="reflector slope sweep, static path" + further,
                               mark=(board_design[names[0]], board_design[names[1]], "board")),
               ctx.out, "slope_sweep")


PER_AXIS = ("median_pct", "worst_pct", "resolution", "window_range")


def _axis_rows(group: str, r: dict) -> list:
  """metrics.csv rows of one design's per-axis lists (the cubic calibration's errors and the
  count map's resolution and in-window range), each naming its axis."""
  from calibrate import metrics
  from sim.shell.paper import AXES
  return metrics.scored(group, {"cubic": {ax: {k: r[k][i] for k in PER_AXIS}
                                          for i, ax in enumerate(AXES)}})


@register("reflector_slope_sweep", "shell design grid over reflector slopes (and any ShellParams "
          "number): rank, resolution, window, calibrated error; best design, gradient search",
          settings=sweep_settings, fixed=FIXED, tags=("shell", "design", "sweep"))
def run(ctx):
  from benchmarks import executors, outputs
  settings = ctx.settings
  axes = settings.axes()
  designs = settings.designs()
  board_design = {name: getattr(settings.board.params, name) for name in axes}
  points = _points(ctx, designs + [board_design])
  ctx.print(f"{len(designs)} designs over {', '.join(f'{n} ({len(v)})' for n, v in axes.items())}"
            f"; static path, {points[0]['frames'][0]} + {points[0]['frames'][1]} frames each; "
            f"executor {ctx.executor.kind}")
  results, failures, grid_seconds = executors.run_designs(ctx, evaluate, points,
                                                          lambda p: p["design"])
  _all_failed(failures, len(points))
  if results[-1] is None:  # its error was printed above; finished designs stay in DIR/points
    raise errors.SettingError(f"the board's own design {board_design} failed: the sweep "
                              f"cannot place it (the designs that finished are kept)")
  board_row = dict(results[-1], design=board_design)
  rows = [dict(r, design=p["design"]) for r, p in zip(results[:-1], points) if r]
  grid_rows = [r for r in rows if _unranked(r) is None]
  unranked = [dict(r, reason=_unranked(r)) for r in rows if _unranked(r) is not None]
  if not grid_rows:
    raise errors.SettingError(
        f"no design of the grid can be ranked: {len(unranked)} unranked ("
        + "; ".join(sorted({r['reason'] for r in unranked}))
        + f"), {len(failures)} failed: widen the swept ranges (--set sweep.NAME=...)")
  for r in unranked:
    ctx.print(f"design {r['design']} not ranked: {r['reason']}")
  order = sorted(range(len(grid_rows)), key=lambda k: (grid_rows[k]["fom"],
                                                       grid_rows[k]["objective"]))
  ranked = [grid_rows[k] for k in order]
  best = ranked[0]
  place = 1 + sum(r["fom"] < board_row["fom"] for r in grid_rows) \
      if _unranked(board_row) is None else None
  _print_table(ctx, list(axes), ranked, board_row, place)
  confirmed, refused, spearman = _confirm(ctx, ranked)
  search = _search_against_grid(ctx, axes, grid_rows, best["design"]) if settings.search \
      else {"skipped": "search off"}
  _save_grid(ctx, axes, results[:-1], board_design)
  speed = _speed(ctx, len(points), grid_seconds)
  data = {"axes": {n: list(v) for n, v in axes.items()},
          "table": ranked, "unranked": unranked, "board": board_row,
          "board_place": place, "best": best,
          "figure_of_merit": "mean over axes of calibrated median % error, static path",
          "confirmed": confirmed, "refused_by_full_scene": refused,
          "spearman_static_vs_full": spearman, "search": search,
          "failures": [dataclasses.asdict(f) for f in failures], "speed": speed}
  rows = [r for i, g in enumerate(data["table"]) for r in _axis_rows(
      f"design {i + 1} " + ", ".join(f"{n}={v:g}" for n, v in g["design"].items()), g)]
  rows += [r for i, g in enumerate(unranked) for r in _axis_rows(
      f"unranked {i + 1} " + ", ".join(f"{n}={v:g}" for n, v in g["design"].items()), g)]
  rows += _axis_rows("board", board_row) + _axis_rows("best", best)
  skip = tuple(path + (k,) for path in (("table", "*"), ("unranked", "*"), ("board",),
                                        ("best",)) for k in PER_AXIS)
  return outputs.Result(data, tuple(rows + outputs.plain(data, skip=skip)))


def _unranked(r: dict) -> Optional[str]:
  """Why a design cannot be ranked (None if it can): a map of rank < 6, or a figure of merit
  or objective that is not a finite number."""
  if r["rank"] < 6:
    return f"rank {r['rank']} < 6 (lost: {', '.join(r['lost']) or 'a direction'})"
  if not (np.isfinite(r["fom"]) and np.isfinite(r["objective"])):
    return "its calibrated error or objective is not a finite number"
  return None


def _all_failed(failures: list, designs: int) -> None:
  """One line when every design failed (the same settings fail them all)."""
  if failures and len(failures) == designs:
    last = failures[0].error.strip().splitlines()[-1] if failures[0].error.strip() else "?"
    raise errors.SettingError(f"every design of the sweep failed ({designs}); the first: "
                              f"{last}")


def _print_table(ctx, names: list[str], ranked: list[dict], board: dict, place: int) -> None:
  """The best `SHOWN` designs and the board's, then why the best one wins."""
  from sim.shell import design
  ctx.print(f"\n{'':3s} " + " ".join(f"{n:>9s}" for n in names) +
            f" {'rank':>4s} {'cond':>6s} {'res Fx':>6s} {'Fz mN':>6s} {'My uNm':>6s}"
            f" {'box in':>6s} {'PCB':>5s} {'obj':>6s} {'median %':>8s} {'worst %':>7s}")

  def line(tag, r):
    res = np.array(r["resolution"])
    return (f"{tag:>3s} " + " ".join(f"{r['design'][n]:9.4g}" for n in names) +
            f" {r['rank']:4d} {_fmt(r['condition'], 1, 6, 1)} {_fmt(res[0], 1e3)} "
            f"{_fmt(res[2], 1e3)} {_fmt(res[4], 1e6, 6, 1)} {r['box_inside']:6.1%} "
            f"{r['box_bottomed']:5.1%} {_fmt(r['objective'], 1, 6, 3)} {_fmt(r['fom'], 1, 8)} "
            f"{_fmt(float(np.mean(r['worst_pct'])), 1, 7)}")
  for i, r in enumerate(ranked[:SHOWN]):
    ctx.print(line(str(i + 1), r))
  ctx.print(line("brd", board) + (f"   <- the board's design: {place} of {len(ranked)}"
                                   if place else f"   <- the board's design: not ranked "
                                                 f"({_unranked(board)})"))
  best = ranked[0]
  ctx.print(f"\nfigure of merit: mean over the six axes of the calibrated median % error "
            f"(static path); best {best['design']}: {best['fom']:.2f} % against the board's "
            f"{board['fom']:.2f} %")

  def pair(key, scale, count, fmt):
    return ("/".join(f"{v * scale:{fmt}}" for v in best[key][:count]) + " (board " +
            "/".join(f"{v * scale:{fmt}}" for v in board[key][:count]) + ")")
  why = [f"rank {best['rank']}, condition {best['condition']:.1f} (board rank "
         f"{board['rank']}, {board['condition']:.1f})",
         "resolution Fx/Fy/Fz " + pair("resolution", 1e3, 3, ".2f").replace(" (", " mN (", 1),
         "in-window range Fx/Fy " + pair("window_range", 1, 2, ".2f").replace(" (", " N (", 1)
         + f"; paper's half ranges {design.PAPER_RANGE[0] / 2:.2f}/"
           f"{design.PAPER_RANGE[1] / 2:.2f}",
         "median % per axis " + " ".join(f"{v:.1f}" for v in best["median_pct"]) + " (board " +
         " ".join(f"{v:.1f}" for v in board["median_pct"]) + ")"]
  ctx.print("why it wins: " + "; ".join(why))


def _confirm(ctx, ranked: list[dict]) -> tuple[list, list, Optional[float]]:
  """The full MuJoCo scene for the best three and designs spread over the rest of the table:
  does it rank them alike? (confirmed, refused, Spearman's rank correlation or None)."""
  from calibrate import metrics
  from sim.shell import geometry
  settings = ctx.settings
  seen = [r for r in ranked if np.isfinite(r["fom"])]
  picks = sorted(set(list(range(min(3, settings.confirm, len(seen)))) + np.round(np.linspace(
      0, len(seen) - 1, max(settings.confirm - 3, 0))).astype(int).tolist()))
  confirmed, refused = [], []
  for r in (seen[i] for i in picks):
    board = dataclasses.replace(settings.board, params=dataclasses.replace(
        settings.board.params, **r["design"]))
    try:
      fit = shell.calibrated(ctx, board)
    except errors.SimulationError as err:  # e.g. springs too stiff for the dynamic scene's step
      refused.append({"design": r["design"], "static_fom": r["fom"], "refused": str(err)})
      continue
    test = fit.runs["test"]
    median = metrics.wrench_median_pct(fit.estimator.predict(test.counts), test.wrench)
    rays = geometry.ray_jacobian(board.params)
    closed = geometry.height_jacobian(board.params)
    confirmed.append({"design": r["design"], "static_fom": r["fom"],
                      "full_fom": float(np.mean(median)),
                      "ray_vs_closed": float(np.max(np.abs(rays - closed)) /
                                             np.max(np.abs(closed)))})
  spearman = None
  if len(confirmed) >= 3:
    a = np.argsort(np.argsort([c["static_fom"] for c in confirmed]))
    b = np.argsort(np.argsort([c["full_fom"] for c in confirmed]))
    spearman = float(np.corrcoef(a, b)[0, 1])
  if confirmed:
    ctx.print(f"\nthe full MuJoCo scene (hand loads through the dynamics, the protocol's frame "
              f"counts) for {len(confirmed)} designs, the best three and the rest spread over "
              f"the table:")
    for c in confirmed:
      ctx.print(f"  {c['design']}: static {c['static_fom']:.2f} %, full {c['full_fom']:.2f} %; "
                f"rays vs closed form {c['ray_vs_closed']:.1e}")
    if spearman is not None:
      ctx.print(f"rank correlation (Spearman) static vs full: {spearman:+.2f}")
  for c in refused:
    ctx.print(f"  {c['design']}: static {c['static_fom']:.2f} %, the full scene refused it: "
              f"{c['refused']}")
  return confirmed, refused, spearman


def _search_against_grid(ctx, axes: dict, grid_rows: list[dict], start: dict) -> dict:
  """The gradient search from `start`, and how far (in grid cells) it lands from the grid's
  best design by the same objective."""
  search = _search(ctx, axes, start)
  if "found" not in search:
    return search
  objs = np.array([r["objective"] for r in grid_rows])  # ranked rows: finite objectives
  grid_best = grid_rows[int(np.argmin(objs))]["design"]
  # distance in cells: the found value's fractional index along each (sorted) axis
  cells = {n: abs(float(np.interp(search["found"][i], sorted(axes[n]), range(len(axes[n]))))
                  - sorted(axes[n]).index(grid_best[n]))
           for i, n in enumerate(search["axes"])}
  search.update(grid_best=grid_best, grid_best_objective=float(objs.min()),
                cells_from_grid_best=cells)
  ctx.print(f"\ngradient search (L-BFGS-B, JAX) from {search['start']}: "
            f"{dict(zip(search['axes'], np.round(search['found'], 4).tolist()))} objective "
            f"{search['objective']:.4f} in {search['iterations']} iterations "
            f"({search['seconds']:.2f} s); the grid's best by the same objective "
            f"{grid_best}: {objs.min():.4f}; distance in grid cells "
            + ", ".join(f"{n} {v:.2f}" for n, v in cells.items()))
  return search


def _save_grid(ctx, axes: dict, results: list, board_design: dict) -> None:
  """DIR/sweep.npz (every grid quantity shaped like the grid, NaN where a design failed) and
  the heat map."""
  shape = tuple(len(v) for v in axes.values())
  ctx.out.mkdir(parents=True, exist_ok=True)
  grid = {key: np.array([r[key] if r else np.nan for r in results], float).reshape(shape)
          for key in ("fom", "objective", "condition", "box_inside", "box_bottomed")}
  res = np.array([r["resolution"] if r else [np.nan] * 6 for r in results]).reshape(
      shape + (6,))
  rank = np.array([r["rank"] if r else -1 for r in results]).reshape(shape)
  files.atomic_write(ctx.out / "sweep.npz", lambda f: np.savez(
      f, **{f"axis_{n}": np.array(v) for n, v in axes.items()}, **grid, resolution=res,
      rank=rank))
  _heatmap(ctx, axes, grid["fom"], board_design)


def _speed(ctx, designs: int, grid_seconds: float) -> dict:
  """The grid's wall time and the closed-form heights' rate (frames/s, best of three)."""
  from sim.shell import geometry
  frames = 200_000
  poses = np.random.default_rng(ctx.seed).uniform(-1e-3, 1e-3, (frames, 6))
  times = []
  for _ in range(3):  # the best of three: the first pays for the arrays' pages
    t = time.perf_counter()
    geometry.pose_heights(ctx.settings.board.params, poses)
    times.append(time.perf_counter() - t)
  rate = frames / min(times)
  ctx.print(f"\n{designs} designs in {grid_seconds:.1f} s on {ctx.executor.kind} "
            f"({ctx.executor.count() if ctx.executor.kind != 'serial' else 1} workers); "
            f"closed-form heights {rate:,.0f} frames/s; heat-map data {ctx.out / 'sweep.npz'}")
  return {"grid_seconds": grid_seconds, "designs": designs, "executor": ctx.executor.kind,
          "closed_form_frames_per_s": rate}
