"""A sweep's plan: scenarios x a full-factorial grid of overrides x Monte Carlo runs, as grid points and
tasks with stable ids (the hash of the point's effective scenario plus the run index), and the manifest
header that names them (manifest checks it on resume)."""

import hashlib
import itertools
import json
from dataclasses import dataclass, field

from liaison_cli import RESULT_PACKAGES, core_source_hash
from liaison_cli.errors import LiaisonError
from liaison_cli.scenario.loading import apply_overrides
from liaison_cli.scenario.scenario_model import Scenario

MANIFEST_FORMAT = 2  # the header's "format": see manifest's docstring for how older ones are read
SIGMA_KEY = "noise.sigma_m"


class SweepError(LiaisonError):
    """The output folder holds a different sweep, or the sweep definition is inconsistent."""


class SweepInterrupted(LiaisonError):
    """Ctrl-C: what finished is in the manifest; the same command resumes."""

    exit_code = 130


def scenario_hash(scenario: Scenario) -> str:
    """Hash of the effective (validated, defaults filled) configuration, not of the YAML text, and of the
    contents of every file it names (an orbit's OEM / OPM, the measurements' TDM): a scenario whose OEM was
    edited is another scenario, and a sweep must not reuse its old runs (issue 35)."""
    files = referenced_files(scenario)
    content = scenario.model_dump(mode="json") if not files else {"scenario": scenario.model_dump(mode="json"),
                                                                  "files": files}  # unchanged without files
    canonical = json.dumps(content, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]


def referenced_files(scenario: Scenario) -> dict:
    """{path: sha256 of its bytes} of the files the scenario reads (missing or unreadable: the OS error's name,
    so the set-up's own one-line error comes later)."""
    paths = [path for sc in scenario.spacecraft if sc.orbit_file is not None
             for path in (sc.orbit_file.oem, sc.orbit_file.opm) if path]
    if scenario.measurements is not None:
        paths.append(scenario.measurements.tdm)
    return {str(path): _file_digest(str(path)) for path in paths}


def _file_digest(path: str) -> str:
    """sha256 of the file's first MAX_MESSAGE_BYTES + 1 bytes (a file beyond the cap is refused when read)."""
    from liaison_cli.exchange.library import MAX_MESSAGE_BYTES

    digest, left = hashlib.sha256(), MAX_MESSAGE_BYTES + 1
    try:
        with open(path, "rb") as handle:
            while left > 0 and (block := handle.read(min(2**20, left))):
                digest.update(block)
                left -= len(block)
    except OSError as exc:
        return type(exc).__name__
    return digest.hexdigest()


@dataclass(frozen=True)
class SweepPoint:
    index: int
    scenario_name: str
    base_hash: str
    overrides: tuple[tuple[str, object], ...]
    point_hash: str
    sigma_m: float
    spacecraft: tuple[str, ...]
    scenario: Scenario = field(compare=False, repr=False)

    def header_entry(self) -> dict:
        return {
            "point": self.index,
            "scenario": self.scenario_name,
            "base_hash": self.base_hash,
            "overrides": [[k, v] for k, v in self.overrides],
            "point_hash": self.point_hash,
        }


@dataclass(frozen=True)
class SweepTask:
    task_id: str
    point: int
    run: int


@dataclass(frozen=True, eq=False)
class SweepPlan:
    name: str
    grid: tuple[tuple[str, tuple], ...]
    runs: int
    points: tuple[SweepPoint, ...]
    base_texts: dict

    @property
    def tasks(self) -> list[SweepTask]:
        return [SweepTask(f"{p.point_hash}/{r}", p.index, r) for p in self.points for r in range(self.runs)]

    def key(self) -> str:
        """A short digest of the header: the same sweep definition (any run count) has the same key."""
        return hashlib.sha256(json.dumps(self.header(), sort_keys=True).encode()).hexdigest()[:12]

    def header(self) -> dict:
        return {
            "kind": "header",
            "format": MANIFEST_FORMAT,
            "sweep": self.name,
            "core_hash": core_source_hash(RESULT_PACKAGES),  # the code that shapes its numbers
            "points": [p.header_entry() for p in self.points],
        }


def plan_sweep(bases: list[tuple[Scenario, str, str]], grid: list[tuple[str, list]], runs: int,
               name: str) -> SweepPlan:
    """bases: (scenario, yaml text, source path); grid: [(dotted key, values)] -> full factorial plan.

    Setting `noise.sigma_m` on a scenario whose sigma comes from a link budget replaces that budget.
    """
    keys = [key for key, _ in grid]
    repeated = sorted({k for k in keys if keys.count(k) > 1})
    if repeated:
        raise SweepError(f"--grid {repeated[0]}: given more than once (also by --sigma for {SIGMA_KEY})")
    names = [scenario.name for scenario, _, _ in bases]
    if len(set(names)) != len(names):
        raise SweepError(f"scenario name {max(names, key=names.count)!r} given more than once")
    points, seen = [], {}
    for scenario, _, source in bases:
        base_hash = scenario_hash(scenario)
        for values in itertools.product(*[vals for _, vals in grid]):
            overrides = tuple(zip(keys, values))
            effective = dict(overrides)
            if SIGMA_KEY in effective:
                # The budget stays when the carrier still derives range-rate / LOS sigmas from it.
                dropped = {"noise.ranging_method": None}
                if scenario.noise.carrier is None:
                    dropped["noise.link_budget"] = None
                effective = {**dropped, **effective}
            shown = ", ".join(f"{k}={v}" for k, v in overrides)
            point = apply_overrides(scenario, effective, f"{source} with --grid {shown}") if overrides else scenario
            point_hash = scenario_hash(point)
            if point_hash in seen:
                raise SweepError(f"{source}: grid point {shown} gives the same scenario as {seen[point_hash]}")
            seen[point_hash] = shown or source
            points.append(
                SweepPoint(len(points), scenario.name, base_hash, overrides, point_hash,
                           point.noise.resolved_sigma_m(), tuple(point.spacecraft_names()), point)
            )
    return SweepPlan(name, tuple((k, tuple(v)) for k, v in grid), runs, tuple(points),
                     {scenario.name: text for scenario, text, _ in bases})
