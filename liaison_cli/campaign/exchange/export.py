"""`liaison export`: one run of a result folder as CCSDS files. Per estimated spacecraft an OEM of the truth and
one of the estimate with its 6x6 covariance at every epoch (km, km/s; the estimator's covariance_record: the EKF's
after each update, a batch's solution propagated), and a TDM of the run's observed measurements; KVN, XML or both.

The result folder keeps error norms, not states, so the run is recomputed from the scenario the folder
records (summary.parquet's provenance), its seed and the run index: runs are reproducible by design, and the
recomputed run's position errors are checked against the stored ones before anything is written.

Frames and time tags (docs/exchange.md): a dated scenario is written in geocentric ICRF (REF_FRAME ICRF,
CENTER_NAME EARTH) with TDB tags, the time of its ephemeris grid; a CRTBP scenario in its Earth-Moon rotating
frame (REF_FRAME EARTH_MOON_ROTATING, barycentre-centred, km and km/s) with MET tags from t0, or, given t0's
date (`--frame icrf --epoch`), in ICRF about the Earth or the Moon with TDB tags (export_frame; an approximation
stated in the files and in docs/exchange.md).
"""

import re
from dataclasses import dataclass, replace
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from liaison_cli.campaign.engine.noise_check import prepare_checked_problem
from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.dynamics.constants import LU_KM, M_PER_LU, MU, TU_S, VU_KM_S
from liaison_cli.errors import ExchangeFileError, UnreadableFileError
from liaison_cli.exchange import library
from liaison_cli.exchange.frames import CRTBP_CENTRE, CRTBP_FRAME, crtbp_anchor_axes, crtbp_icrf_jacobians
from liaison_cli.exchange.oem import Ephemeris, oem_message
from liaison_cli.exchange.tdm import Track, data_convention, tdm_message
from liaison_cli.exchange.timetags import met_tags, tags_to_seconds, tdb_tags
from liaison_cli.scenario.observed import channel_track
from liaison_cli.scenario.loading import validate_scenario
from liaison_cli.scenario.scenario_model import Scenario
from liaison_cli.scenario.setup import Problem
from liaison_cli.storage import read_metadata, write_text_atomic

KM_PER_SCALED = np.array([LU_KM] * 3 + [VU_KM_S] * 3)  # scaled state -> km, km/s (both dynamics)
STORED_ERROR_TOLERANCE_M = 1e-3  # the recomputation's own reach: the same arithmetic, to 1 mm
# On top, the storage's rounding: float32 (the default) keeps 24 bits, so a stored error of 16 km is known
# only to 1 mm and one of 300 km to 2 cm; four half-units of its last place are allowed.
STORED_ROUNDING = {"float": 4 * 2.0**-24, "double": 4 * 2.0**-53}
CRTBP_COMMENTS = (
    f"Earth-Moon CRTBP rotating frame: origin the barycentre, x from the Earth to the Moon, z along the Moon's "
    f"orbit normal; mu = {MU:.10f}",
    f"km and km/s from the CRTBP units: 1 LU = {LU_KM:.1f} km, 1 TU = {TU_S:.6f} s; velocity relative to the "
    "rotating axes",
    "MET: elapsed time from the scenario's t0, 0000-001T00:00:00 = t0 (the CRTBP has no date)",
)


@dataclass(frozen=True, eq=False)
class RecomputedRun:
    """One run again: truth and estimate (m, 6 n_sc) and covariance (m, 6 n_sc, 6 n_sc) in scaled units, the
    observed measurements (m, C) in filter units; healthy_steps: epochs 0 .. healthy_steps - 1 are before any
    failure."""

    problem: Problem
    run: int
    truth: np.ndarray
    estimate: np.ndarray
    covariance: np.ndarray
    y_obs: np.ndarray
    healthy_steps: int
    position_error_m: np.ndarray  # (m, n_sc)


def result_scenario(result_dir) -> Scenario:
    """The scenario a result folder ran (summary.parquet's scenario_effective: file paths already absolute)."""
    summary = Path(result_dir) / "summary.parquet"
    if not summary.is_file():
        raise ExchangeFileError(f"{result_dir}: not a liaison result folder (no summary.parquet)")
    try:
        meta = read_metadata(summary)
    except Exception as exc:  # noqa: BLE001 - a damaged table
        raise UnreadableFileError(f"{summary}: cannot read its provenance ({type(exc).__name__})") from None
    effective = meta.get("scenario_effective") if isinstance(meta, dict) else None
    if not isinstance(effective, dict):  # a study's or compare's folder, or tampered provenance (issue 35)
        raise ExchangeFileError(f"{result_dir}: not the folder of one `liaison run` (its summary.parquet carries "
                                "no scenario_effective); allowed: a run's result folder")
    return validate_scenario({k: v for k, v in effective.items() if k != "topology"},
                             f"{summary} (scenario_effective)")


def recompute_run(problem: Problem, run: int) -> RecomputedRun:
    """Run `run` of the problem again with the estimator's estimate and covariance kept at every epoch
    (Estimator.covariance_record)."""
    from liaison_cli.estimation.estimators import ESTIMATORS

    descriptor = problem.scenario.estimator_descriptor()
    if descriptor.covariance_record is None:  # an OEM carries P at every epoch
        keeps = ", ".join(e.name for e in ESTIMATORS.values() if e.covariance_record)
        raise ExchangeFileError(f"{problem.scenario.name}: export needs an estimator that keeps its covariance at "
                                f"every epoch (estimator: {keeps}); this result used {problem.scenario.estimator}")
    if problem.scenario.filter.initial_batch_hours is not None:
        raise ExchangeFileError(f"{problem.scenario.name}: export of an EKF started from an initial batch "
                                "(filter.initial_batch_hours) is not supported: its first hours are a batch solution")
    inputs = draw_run_inputs(problem, run)
    arrays = problem.filter if inputs.filter_params is None else replace(problem.filter,
                                                                         model_params=inputs.filter_params)
    history, estimates, covariances = descriptor.covariance_record(arrays, inputs.x0_hat, inputs.y_obs, inputs.truth)
    n_dyn = 6 * problem.n_spacecraft
    healthy = len(problem.times_s) if history.ok else history.fail_step
    error_m = np.linalg.norm(history.err[:, :n_dyn].reshape(len(problem.times_s), -1, 6)[:, :, :3], axis=2) * M_PER_LU
    return RecomputedRun(problem, run, inputs.truth[:, :n_dyn], estimates[:, :n_dyn],
                         covariances[:, :n_dyn, :n_dyn], inputs.y_obs, healthy, error_m)


def check_against_stored(result_dir, recomputed: RecomputedRun) -> tuple[float, bool]:
    """(the largest difference (m) between the recomputed run's position errors and timeseries.parquet's,
    whether every one is within STORED_ERROR_TOLERANCE_M plus the stored type's rounding of its value)."""
    import pyarrow.parquet as pq

    path = Path(result_dir) / "timeseries.parquet"
    try:
        table = pq.read_table(path, columns=["run", "position_error_m"], filters=[("run", "=", recomputed.run)])
    except (OSError, ValueError, KeyError) as exc:  # missing, truncated, or not a run's table (ArrowInvalid)
        raise UnreadableFileError(f"{path}: cannot read the stored run ({type(exc).__name__}: "
                                  f"{str(exc).splitlines()[0][:120] if str(exc) else ''})") from None
    column = table.column("position_error_m")
    stored = column.to_numpy().astype(float)
    if len(stored) != recomputed.position_error_m.size:
        raise ExchangeFileError(f"{result_dir}: run {recomputed.run} is not in timeseries.parquet")
    steps = recomputed.healthy_steps
    n_sc = recomputed.position_error_m.shape[1]
    here = recomputed.position_error_m.reshape(-1)[: steps * n_sc]
    difference = np.abs(stored[: steps * n_sc] - here)
    rounding = STORED_ROUNDING.get(str(column.type), STORED_ROUNDING["float"])
    within = bool(np.all(difference <= STORED_ERROR_TOLERANCE_M + rounding * np.abs(here)))
    return (float(np.max(difference)) if difference.size else 0.0), within


@dataclass(frozen=True, eq=False)
class ExportFrame:
    """How a run's epochs and states are written: the time tags, REF_FRAME, CENTER_NAME, TIME_SYSTEM and COMMENT
    lines, and jacobians (m, 6, 6) with offset (6,): a scaled state x at epoch k is written as
    jacobians[k] (x + offset) (km, km/s), its covariance as jacobians[k] P jacobians[k]^T; jacobians None: the
    frame is the run's own, scaled to km and km/s (KM_PER_SCALED)."""

    tags: list
    frame: str
    centre: str
    time_system: str
    comments: tuple
    jacobians: np.ndarray | None = None
    offset: np.ndarray | None = None

    def states_km(self, states_scaled: np.ndarray) -> np.ndarray:
        if self.jacobians is None:
            return states_scaled * KM_PER_SCALED
        return np.einsum("kij,kj->ki", self.jacobians[: len(states_scaled)], states_scaled + self.offset)

    def covariance_km(self, covariance_scaled: np.ndarray, k: int) -> np.ndarray:
        if self.jacobians is None:
            return covariance_scaled * np.outer(KM_PER_SCALED, KM_PER_SCALED)
        return self.jacobians[k] @ covariance_scaled @ self.jacobians[k].T


@dataclass(frozen=True)
class FrameRequest:
    """What `liaison export --frame --epoch --centre` asked for: frame None (the run's own), "rotating" or "icrf";
    a CRTBP run's t0 as TDB seconds past J2000 and as given (None: not given); the centre, EARTH or MOON."""

    frame: str | None = None
    epoch_tdb_s: float | None = None
    epoch_text: str | None = None
    centre: str = "EARTH"


def export_frame(problem: Problem, request: FrameRequest = FrameRequest()) -> ExportFrame:
    """The frame a run is written in: a dated scenario in geocentric ICRF with TDB tags; a CRTBP scenario in its
    rotating frame with MET tags or, given t0's date, in ICRF about the Earth or the Moon with TDB tags
    (exchange.frames.crtbp_to_icrf). A request the run cannot take is refused in one line."""
    scenario = problem.scenario
    if scenario.dynamics_descriptor().dated:  # dated epochs: TDB dates in ICRF
        if request.epoch_tdb_s is not None or request.frame == "rotating" or request.centre != "EARTH":
            raise ExchangeFileError(f"{scenario.name}: a dated run is written in geocentric ICRF at its own dates; "
                                    "allowed: --frame icrf (or none), no --epoch, --centre earth")
        epoch_s = problem.dynamics.epoch_tdb_s
        return ExportFrame(tdb_tags(epoch_s + problem.times_s), "ICRF", "EARTH", "TDB",
                           (f"liaison scenario {scenario.name}: geocentric ICRF, TDB (the ephemeris time of the run)",))
    if request.epoch_tdb_s is None:
        if request.frame == "icrf" or request.centre != "EARTH":
            raise ExchangeFileError(f"{scenario.name}: a CRTBP run has no date; --frame icrf and --centre moon need "
                                    "its t0 as --epoch YYYY-MM-DDThh:mm:ss (TDB)")
        return ExportFrame(met_tags(problem.times_s), CRTBP_FRAME, CRTBP_CENTRE, "MET", CRTBP_COMMENTS)
    if request.frame == "rotating":
        raise ExchangeFileError(f"{scenario.name}: --epoch: only with --frame icrf (the rotating frame has no date)")
    axes0 = crtbp_anchor_axes(moon_state_km(request.epoch_tdb_s))
    offset = np.array([MU if request.centre == "EARTH" else MU - 1.0, 0, 0, 0, 0, 0])
    comments = (f"CRTBP run carried into ICRF axes about the {request.centre.title()} with t0 = {request.epoch_text} "
                "TDB: the CRTBP's rotating frame turning uniformly at its mean motion from the axes of DE421's Moon at "
                f"t0 (x towards the Moon, z along its orbit normal), lengths in the CRTBP's 1 LU = {LU_KM:.1f} km",
                "An approximation: distances and range rates are the run's own, but the real Moon departs from the "
                "CRTBP's circular one, which turns at the mean motion: by up to about 22,000 km in distance and 12 degrees "
                "in longitude within a month (10.5 degrees within 10 days)"
                + ("; the centre is the CRTBP's Moon" if request.centre == "MOON" else ""))
    return ExportFrame(tdb_tags(request.epoch_tdb_s + problem.times_s), "ICRF", request.centre, "TDB", comments,
                       crtbp_icrf_jacobians(axes0, problem.times_s), offset)


def moon_state_km(epoch_tdb_s: float) -> np.ndarray:
    """The Moon's geocentric ICRF state (km, km/s) at a TDB epoch (DE421); refused in one line outside DE421."""
    from liaison_cli.dynamics.ephemeris import BODY_MOON, geocentric_state, load_window

    try:
        window = load_window(epoch_tdb_s, epoch_tdb_s)
    except ValueError as exc:
        raise ExchangeFileError(f"--epoch: {exc}") from None
    return geocentric_state(window.coeffs, window.start_s, window.interval_s, window.n_records, BODY_MOON,
                            float(epoch_tdb_s))


def ephemerides(recomputed: RecomputedRun, frame: ExportFrame | None = None) -> dict[str, Ephemeris]:
    """{file stem: Ephemeris}: '<spacecraft>_truth' and '<spacecraft>_estimate' (with covariance), in `frame`
    (export_frame; None: the run's own)."""
    problem = recomputed.problem
    frame = frame or export_frame(problem)
    meaning = problem.scenario.estimator_descriptor().record_meaning
    steps = recomputed.healthy_steps
    seconds = problem.times_s[:steps]
    out = {}
    for i, name in enumerate(problem.spacecraft):
        block = slice(6 * i, 6 * i + 6)
        note = f"run {recomputed.run} of seed {problem.scenario.monte_carlo.seed}"
        out[f"{name}_truth"] = Ephemeris(name, name, frame.centre, frame.frame, frame.time_system, frame.tags[:steps],
                                         seconds, frame.states_km(recomputed.truth[:steps, block]),
                                         comments=(*frame.comments, f"truth, {note}"))
        covariances = {k: frame.covariance_km(recomputed.covariance[k, block, block], k) for k in range(steps)}
        out[f"{name}_estimate"] = Ephemeris(name, name, frame.centre, frame.frame, frame.time_system,
                                            frame.tags[:steps], seconds,
                                            frame.states_km(recomputed.estimate[:steps, block]),
                                            covariances=covariances,
                                            comments=(*frame.comments, f"{meaning}, {note}"))
    return out


def tracks(recomputed: RecomputedRun, frame: ExportFrame | None = None) -> tuple[list[Track], list[str]]:
    """The run's observed measurements as TDM tracks (tagged as `frame` tags the run: export_frame; None: the run's
    own), and the channels that have no TDM keyword."""
    problem = recomputed.problem
    frame = frame or export_frame(problem)
    tags, time_system = frame.tags, frame.time_system
    out, skipped = [], []
    for c, channel in enumerate(problem.channels):
        form = channel_track(problem.scenario, channel)
        if form is None:
            skipped.append(f"{channel.label} on {channel.link_label}")
            continue
        keyword, factor, participants, paths = form
        seen = np.flatnonzero(np.isfinite(recomputed.y_obs[: recomputed.healthy_steps, c]))
        if not len(seen):
            continue
        values = recomputed.y_obs[seen, c] * channel.scale_si * factor
        comments = (f"liaison {channel.label} on {channel.link_label}", *data_convention(keyword, paths))
        out.append(Track(participants, paths, keyword, time_system, [tags[k] for k in seen],
                         problem.times_s[seen], values, comments))
    return out, skipped


def export_run(result_dir, run: int, formats: tuple, out_dir, request: FrameRequest = FrameRequest()) -> dict:
    """Write the run's OEMs and TDM into out_dir (in the frame `request` asks for, export_frame); returns what was written and
    checked."""
    scenario = result_scenario(result_dir)
    if scenario.measurements is not None:
        run = 0
    problem = prepare_checked_problem(scenario)
    frame = export_frame(problem, request)  # a request the run cannot take is refused before the run is redone
    recomputed = recompute_run(problem, run)
    difference_m, within = check_against_stored(result_dir, recomputed)
    if not within:
        raise ExchangeFileError(f"{result_dir}: run {run} recomputed differs from the stored run by "
                                f"{difference_m:.3g} m in position error, more than 1 mm plus the stored values' "
                                "rounding; the folder's scenario or its files changed")
    created = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S")
    messages = {f"{stem}.oem": oem_message(eph, created) for stem, eph in ephemerides(recomputed, frame).items()}
    track_list, skipped = tracks(recomputed, frame)
    comments = [f"liaison scenario {scenario.name}, run {run}, seed {scenario.monte_carlo.seed}"]
    comments += [f"not written (no TDM keyword): {s}" for s in skipped]
    comments += sorted({line for track in track_list for line in data_convention(track.keyword, track.paths)})
    if track_list:
        messages["measurements.tdm"] = tdm_message(track_list, created, comments)
    written = []
    for name, message in messages.items():
        for data_format in formats:
            path = Path(out_dir) / (name if data_format == "kvn" else f"{name}.xml")
            write_text_atomic(library.message_text(message, data_format), path)
            written.append(path.name)
    return {"scenario": scenario.name, "run": run, "files": written, "skipped": skipped,
            "stored_difference_m": difference_m, "epochs": recomputed.healthy_steps, "ref_frame": frame.frame,
            "center_name": frame.centre, "time_system": frame.time_system}


def check_export_request(result_dir, out_dir) -> None:
    """Before any work or any folder is made: `result_dir` is a `liaison run` result (result_scenario's one line
    otherwise), and `out_dir` is neither it nor a folder holding it (a replaced export would take the result
    with it)."""
    result_scenario(result_dir)
    if Path(out_dir).resolve() in (Path(result_dir).resolve(), *Path(result_dir).resolve().parents):
        raise ExchangeFileError(f"output {out_dir}: the result folder being exported, or a folder holding it; allowed: "
                                "a folder beside or inside it (default: RESULT/ccsds-run<K>)")


_EPOCH = re.compile(r"^(\d{4})-(\d{2})-(\d{2})T(\d{2}):(\d{2}):(\d{2}(?:\.\d+)?)$")


def parse_epoch(text) -> tuple[float, str]:
    """A CRTBP run's t0 given as a TDB date 'YYYY-MM-DDThh:mm:ss[.d]' (no zone: TDB is not UTC): (seconds past J2000,
    the date as the files will print it); one line for anything else, a 25th hour or a 61st second included."""
    match = _EPOCH.match(text.strip()) if isinstance(text, str) else None
    try:
        if match is None:
            raise ValueError
        year, month, day, hour, minute = (int(g) for g in match.groups()[:5])
        second = float(match.group(6))
        datetime(year, month, day, hour, minute, int(second))  # a real calendar date and time of day
        if second >= 60.0:
            raise ValueError
    except ValueError:
        raise ExchangeFileError(f"epoch {text!r}: allowed a TDB date and time YYYY-MM-DDThh:mm:ss[.d] (hours 0-23, "
                                "seconds below 60, no time zone)") from None
    seconds = float(tags_to_seconds([text.strip()], "TDB")[0])
    return seconds, tdb_tags(np.array([seconds]))[0]
