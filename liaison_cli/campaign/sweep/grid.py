"""Sweep grids from the command line: `--sigma 50:700[:50]` or `50,150,300`, and `--grid key=v1,v2`.

Values are read as a scenario file reads them (scenario.loading.read_yaml_value): `60` is an int, `187.5`
and `6e-5` floats (YAML 1.2's rule: PyYAML's YAML 1.1 rule read `6e-5` as text, and a sweep then failed after
computing every run), `true` a bool and `null` removes a key (restoring its default).
"""

import math

import yaml

from liaison_cli.errors import LiaisonError
from liaison_cli.scenario.loading import read_yaml_value

# A sweep's plan validates every grid point's scenario and keeps it (measured: ~1.3 ms and ~10 kB per point
# on smoke.yaml), then holds a task per point and run: 10,000 points plan in ~15 s and ~100 MB; the task
# count shares the runs cap (1,000,000).
MAX_GRID_POINTS = 10_000
MAX_SWEEP_TASKS = 1_000_000
RANGE_HELP = "start:stop[:step] with numbers (e.g. 50:700 or 50:700:25) or a comma list (e.g. 50,150,300)"


class GridError(LiaisonError):
    """A --sigma or --grid option cannot be parsed."""


def _number(text: str, option: str, whole: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise GridError(f"{option} {whole!r}: {text!r} is not a number; expected {RANGE_HELP}") from None
    if not math.isfinite(value):
        raise GridError(f"{option} {whole!r}: {text!r} is not finite; expected {RANGE_HELP}")
    return value


def _tidy(value: float):
    """Whole numbers become ints, so a grid value prints and hashes as the user typed it."""
    return int(value) if float(value).is_integer() else value


def parse_range(text: str, option: str = "--sigma", default_step: float = 50.0) -> list:
    """'50:700' -> [50, 100, ..., 700] (stop included when on the grid); '50,150' -> [50, 150]."""
    text = text.strip()
    if not text:
        raise GridError(f"{option} is empty; expected {RANGE_HELP}")
    if ":" in text:
        parts = text.split(":")
        if len(parts) not in (2, 3):
            raise GridError(f"{option} {text!r}: too many ':'; expected {RANGE_HELP}")
        start, stop = _number(parts[0], option, text), _number(parts[1], option, text)
        step = _number(parts[2], option, text) if len(parts) == 3 else default_step
        if step <= 0:
            raise GridError(f"{option} {text!r}: step must be > 0; expected {RANGE_HELP}")
        if stop < start:
            raise GridError(f"{option} {text!r}: stop {parts[1]} is below start {parts[0]}; expected {RANGE_HELP}")
        count = int(math.floor((stop - start) / step + 1e-9)) + 1
        if count > 10_000:
            raise GridError(f"{option} {text!r}: {count} points is more than the 10000 allowed")
        return [_tidy(round(start + i * step, 12)) for i in range(count)]
    values = [_number(part.strip(), option, text) for part in text.split(",")]
    return [_tidy(v) for v in values]


def parse_grid(text: str) -> tuple[str, list]:
    """'measurement.interval_s=60,187.5,600' -> ('measurement.interval_s', [60, 187.5, 600]).

    A single numeric value with ':' is a range ('noise.sigma_m=50:300:50').
    """
    key, sep, values_text = text.partition("=")
    key = key.strip()
    if not sep or not key or not values_text.strip():
        raise GridError(f"--grid {text!r}: expected key=value[,value...] (e.g. measurement.interval_s=60,187.5,600)")
    if ":" in values_text and "," not in values_text:
        return key, parse_range(values_text, f"--grid {key}=")
    values = []
    for part in values_text.split(","):
        part = part.strip()
        if not part:
            raise GridError(f"--grid {text!r}: empty value in the list")
        try:
            values.append(read_yaml_value(part))  # as the scenario file reads it: 6e-5 is a number
        except yaml.YAMLError:
            raise GridError(f"--grid {text!r}: cannot read value {part!r}") from None
    if len({repr(float(v)) if isinstance(v, (int, float)) and not isinstance(v, bool) else repr(v)
            for v in values}) != len(values):  # 1e2 and 100.0 are one value
        raise GridError(f"--grid {text!r}: repeated value")
    return key, values


def check_grid_size(axes: list[tuple[str, list]], n_scenarios: int, runs: int) -> None:
    """Bounded work, before any scenario is read or any point built: at most MAX_GRID_POINTS grid points
    (scenarios x the product of the axes' lengths) and MAX_SWEEP_TASKS tasks (points x runs)."""
    points = n_scenarios * math.prod(len(values) for _, values in axes)
    shape = " x ".join([f"{n_scenarios} scenario(s)", *(f"{len(v):,} {k}" for k, v in axes)])
    if points > MAX_GRID_POINTS:
        raise GridError(f"--grid/--sigma: {shape} = {points:,} grid points; allowed: at most {MAX_GRID_POINTS:,} "
                        "(split the sweep, or use fewer values per axis)")
    if points * runs > MAX_SWEEP_TASKS:
        raise GridError(f"--runs {runs}: {points:,} grid points x {runs:,} runs = {points * runs:,} tasks; allowed: "
                        f"at most {MAX_SWEEP_TASKS:,} (the runs cap)")
