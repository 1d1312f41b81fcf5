"""The figures any calibration draws, headless (matplotlib's Agg), into a `figures/` folder:
used by `python -m calibrate evaluate` and by the benchmarks (`benchmarks.figures` adds the
papers' other figures). Each function takes plain arrays, returns the matplotlib Figure (so
tests read its axes back) and states units, what made it and the seed in its title.

* `over_time`: predicted against measured force over time, one panel per axis (LSANN Fig. 7).
* `scatter`: predicted against true, one panel per axis, with the 1:1 line (shell Fig. 7).
"""

from __future__ import annotations

import pathlib
from typing import Sequence

import numpy as np

from util import files

MAX_POINTS = 20000  # per line: a figure of 400 k samples shows no more and draws in seconds


def _pyplot():
  import matplotlib
  matplotlib.use("Agg", force=True)  # no display here, none needed
  import matplotlib.pyplot as plt
  return plt


def _title(fig, what: str, benchmark: str, seed: int) -> None:
  fig.suptitle(f"{what}\n{benchmark}, seed {seed}", fontsize=10)


def _thin(n: int) -> np.ndarray:
  """Indices of at most MAX_POINTS of n samples, evenly spread, first and last kept."""
  return np.unique(np.linspace(0, n - 1, min(n, MAX_POINTS)).round().astype(int))


def save(fig, out: pathlib.Path, name: str) -> pathlib.Path:
  """Writes `fig` to out/figures/name.png (atomically) and closes it."""
  plt = _pyplot()
  path = pathlib.Path(out) / "figures" / f"{name}.png"
  path.parent.mkdir(parents=True, exist_ok=True)
  files.atomic_write(path, lambda f: fig.savefig(f, format="png", dpi=110))
  plt.close(fig)
  return path


def over_time(time: np.ndarray, truth: np.ndarray, predictions: dict[str, np.ndarray],
              axes: Sequence[str], unit: str, *, benchmark: str, seed: int,
              what: str = "predicted and measured force on the test paths"):
  """One panel per axis: truth (N, A) and each method's prediction (N, A) against time (N,)
  s."""
  plt = _pyplot()
  keep = _thin(len(time))
  fig, panels = plt.subplots(len(axes), 1, figsize=(9, 2.2 * len(axes) + 0.8), sharex=True,
                             squeeze=False)
  for i, (ax, name) in enumerate(zip(panels[:, 0], axes)):
    ax.plot(time[keep], truth[keep, i], color="k", lw=1.0, label="measured (F/T)")
    for method, pred in predictions.items():
      ax.plot(time[keep], pred[keep, i], lw=0.8, alpha=0.8, label=method)
    ax.set_ylabel(f"{name} ({unit})")
    ax.grid(alpha=0.3)
  panels[0, 0].legend(loc="upper right", fontsize=8, ncol=len(predictions) + 1)
  panels[-1, 0].set_xlabel("time (s)")
  _title(fig, what, benchmark, seed)
  fig.tight_layout()
  return fig


def scatter(truth: np.ndarray, predictions: dict[str, np.ndarray], axes: Sequence[str],
            units: Sequence[str], *, benchmark: str, seed: int,
            what: str = "predicted against true on the test data"):
  """One panel per axis: each method's prediction (N, A) against the truth (N, A), with the
  1:1 line over the truth's range."""
  plt = _pyplot()
  cols = min(3, len(axes))
  rows = -(-len(axes) // cols)
  fig, panels = plt.subplots(rows, cols, figsize=(3.6 * cols, 3.4 * rows + 0.6), squeeze=False)
  keep = _thin(len(truth))
  for i, (name, unit) in enumerate(zip(axes, units)):
    ax = panels.flat[i]
    for method, pred in predictions.items():
      ax.plot(truth[keep, i], pred[keep, i], ".", ms=1.5, alpha=0.4, label=method)
    lo, hi = float(truth[:, i].min()), float(truth[:, i].max())
    ax.plot([lo, hi], [lo, hi], "k--", lw=1, label="1:1")
    ax.set_xlabel(f"true {name} ({unit})")
    ax.set_ylabel(f"predicted {name} ({unit})")
    ax.grid(alpha=0.3)
  for ax in panels.flat[len(axes):]:
    ax.set_visible(False)
  panels.flat[0].legend(fontsize=7, markerscale=4)
  _title(fig, what, benchmark, seed)
  fig.tight_layout()
  return fig
