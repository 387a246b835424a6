"""004's study as tables and figures: per transmitter, the 3σ position and velocity histories of each
receiver pair (the analogue of 004 Figs. 6-9) and the pairs' DOP (the analogue of Fig. 2); the LinCov
table with the EKF Monte Carlo beside it, the rankings per grid point, and 004's claims with their verdicts on
the EKF's settled error and on LinCov's σ."""

from pathlib import Path

import numpy as np
import pandas as pd

from liaison_cli.report.study003 import pyplot, save_png


def _day(value) -> str:
    return "never" if not np.isfinite(value) else f"{value:.2f}"


def _number(value, scale: float = 1.0, digits: int = 3) -> str:
    return "—" if not np.isfinite(value) else f"{value * scale:.{digits}f}"


def format_table(summary: pd.DataFrame, grid_keys: list[str] | None = None) -> str:
    """Two tables: LinCov (steady 3σ, convergence, DOP) and the EKF Monte Carlo (converged share, time to
    converge, error and σ after the settle time and over the last quarter, NEES in band, consistent)."""
    keys = grid_keys or []
    head = "".join(f"{k} | " for k in keys)
    rule = "---|" * len(keys)
    lincov = [f"| {head}transmitter | pair | steady 3σ pos km | steady 3σ vel cm/s | converged pos (d) | "
              "< 1 km from (d) | < 1 cm/s from (d) | epochs measured | median DOP |",
              f"|{rule}---|---|---|---|---|---|---|---|---|"]
    ekf = [f"| {head}transmitter | pair | EKF converged | converged at, median / max (d) | < 1 km at, median (d) | "
           "batch window (d) | error / σ RMS pos settled km | error/σ pos, vel settled | "
           "error / σ RMS pos last quarter km | error/σ pos last quarter | NEES in 95 % band | consistent |",
           f"|{rule}---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in summary.to_dict("records"):
        point = "".join(f"{r[k]:g} | " if isinstance(r[k], float) else f"{r[k]} | " for k in keys)
        lincov.append(f"| {point}{r['transmitter']} | {r['pair']} | {r['steady_3sigma_position_m'] / 1e3:.3f} | "
                      f"{r['steady_3sigma_velocity_m_s'] * 1e2:.3f} | {_day(r['convergence_days_position'])} | "
                      f"{_day(r['days_below_1km'])} | {_day(r['days_below_1cm_s'])} | "
                      f"{100 * r['measured_share']:.0f} % | {r['median_dop']:.2f} |")
        converged = f"{round(r['ekf_converged_share'] * r['runs'])}/{r['runs']}"
        consistent = "—" if not np.isfinite(r["ekf_error_to_sigma_position_settled"]) else (
            "yes" if r["ekf_consistent_settled"] else "**no**")
        ekf.append(
            f"| {point}{r['transmitter']} | {r['pair']} | {converged} | "
            f"{_day(r['ekf_converged_days_median'])} / {_day(r['ekf_converged_days_max'])} | "
            f"{_day(r['ekf_below_1km_days_median'])} | {_day(r['ekf_initial_batch_window_days_median'])} | "
            f"{_number(r['ekf_error_rms_position_settled_m'], 1e-3)} / "
            f"{_number(r['ekf_sigma_rms_position_settled_m'], 1e-3)} | "
            f"{_number(r['ekf_error_to_sigma_position_settled'], 1, 2)}, "
            f"{_number(r['ekf_error_to_sigma_velocity_settled'], 1, 2)} | "
            f"{_number(r['ekf_error_rms_position_last_quarter_m'], 1e-3)} / "
            f"{_number(r['ekf_sigma_rms_position_last_quarter_m'], 1e-3)} | "
            f"{_number(r['ekf_error_to_sigma_position_last_quarter'], 1, 2)} | "
            f"{_number(r['ekf_frac_nees_in_band_settled'], 100, 0)} % | {consistent} |")
    return "\n".join(lincov) + "\n\n" + "\n".join(ekf) + "\n"


def format_rankings(rankings: pd.DataFrame, grid_keys: list[str]) -> str:
    """The pairs best first per grid point and transmitter, by LinCov and by the EKF."""
    head = "".join(f"{k} | " for k in grid_keys)
    lines = [f"| {head}transmitter | best first, LinCov steady 3σ | best first, EKF settled error RMS (converged runs; a pair "
             "not all of whose runs converged is unrankable) |",
             f"|{'---|' * len(grid_keys)}---|---|---|"]
    for r in rankings.to_dict("records"):
        point = "".join(f"{r[k]:g} | " if isinstance(r[k], float) else f"{r[k]} | " for k in grid_keys)
        lines.append(f"| {point}{r['transmitter']} | {r['best_first_lincov']} | {r['best_first_ekf']} |")
    return "\n".join(lines) + "\n"


def draw_histories(history: pd.DataFrame, transmitter: str, out_dir: Path) -> Path:
    """LinCov 3σ (lines), the EKF's error RMS over converged runs (dotted) and the DOP, per pair."""
    plt = pyplot()
    data = history[history.transmitter == transmitter]
    fig, axes = plt.subplots(3, 1, figsize=(9, 10), sharex=True)
    for pair, part in data.groupby("pair", sort=False):
        line, = axes[0].semilogy(part.t_days, part.position_3sigma_m / 1e3, lw=1, label=f"{pair} LinCov 3σ")
        axes[1].semilogy(part.t_days, part.velocity_3sigma_m_s * 1e2, lw=1, color=line.get_color())
        if np.isfinite(part.position_ekf_error_rms_m).any():
            axes[0].semilogy(part.t_days, part.position_ekf_error_rms_m / 1e3, ":", lw=1, color=line.get_color(),
                             label=f"{pair} EKF error RMS")
            axes[1].semilogy(part.t_days, part.velocity_ekf_error_rms_m_s * 1e2, ":", lw=1, color=line.get_color())
        axes[2].semilogy(part.t_days[part.measured], part.dop[part.measured], ".", ms=1.5, color=line.get_color())
    axes[0].set_ylabel("position (km)")
    axes[1].set_ylabel("velocity (cm/s)")
    axes[2].set_ylabel("DOP (m per m of path)")
    axes[2].set_xlabel("days")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{transmitter}: TDoA + FDoA, LinCov 3σ along the truth, the EKF's error RMS, and the pair's DOP")
    fig.tight_layout()
    path = save_png(fig, out_dir / f"{transmitter}_3sigma.png")
    plt.close(fig)
    return path


# --- 004's claims (campaign.studies.study004.check_claims) -------------------------------------------------------------

CLAIMS_LEGEND = (
    "004's claims, each checked on one metric (report/data/study004_claims.yaml holds the statements and their "
    "checks; claims.parquet the values). Accuracy claims: EKF = its position error RMS after the settle time over "
    "the converged runs (the primary reading; for the transfer this window runs through the burn), LinCov = its "
    "steady 3σ (median over the last quarter before any burn); a 3σ threshold is compared with 3 × the EKF's "
    "error RMS. Convergence claims: EKF = the median day its runs converged, LinCov = the day its 3σ converged "
    "(\"never\" counts as slower than any day). The DOP claim is geometry alone (no filter). \"not computable\": "
    "the study lacks the transmitter, the pair, a converged run, or any statistic for the claim (note).")


def _claim_number(value, quantity: str, part: str = "") -> str:
    if value is None:
        return "—"
    if value == "never":
        return "never"
    if quantity == "convergence":
        return f"{value:.2f} d"
    if quantity == "geometry":
        return f"{value:.1f}"
    return f"{value * 1e2:.3f} cm/s" if part == "velocity" else f"{value / 1e3:.3f} km"


def _ratio_text(check: dict, numbers: dict) -> str:
    """The ratio a ratio check judged, e.g. "ground/geo 6.2×"."""
    kind = check["kind"]
    if kind == "similar":
        pairs = [(check["pairs"][0], check["pairs"][1])]
    elif kind in ("ratio_at_least", "ratio_between"):
        worse = check["worse"] if isinstance(check["worse"], list) else [check["worse"]]
        pairs = [(w, check["better"]) for w in worse]
    else:
        return ""
    texts = []
    for top, bottom in pairs:
        a, b = numbers.get(top), numbers.get(bottom)
        if isinstance(a, (int, float)) and isinstance(b, (int, float)) and b > 0:
            ratio = a / b
            texts.append(f"{top}/{bottom} {ratio:.{2 if ratio < 1 else 1 if ratio < 10 else 0}f}×")
    return f" ({', '.join(texts)})" if texts else ""


def _claim_values(values_json: str, check: dict) -> str:
    import json

    values = json.loads(values_json)
    parts = []
    for transmitter, numbers in values.items():
        shown = ", ".join(f"{alias} {_claim_number(v, check['quantity'], alias)}" for alias, v in numbers.items())
        parts.append(f"{transmitter}: {shown}{_ratio_text(check, numbers)}")
    return "; ".join(parts)


def _verdict_cell(status: str) -> str:
    return "**no**" if status == "no" else status


def format_claims(claims: pd.DataFrame, grid_keys: list[str] | None = None) -> str:
    """004's claims: id, 004's statement and where, whether it holds on the EKF's settled error (primary) and on
    LinCov's σ (or their convergence times), a mark where the two disagree, and the values they were judged on
    (or why a claim cannot be checked)."""
    import json

    keys = grid_keys or []
    head = "".join(f"{k} | " for k in keys)
    lines = [CLAIMS_LEGEND, "",
             f"| {head}id | 004 says (where) | EKF: holds? | LinCov: holds? | metrics disagree | measured / note |",
             f"|{'---|' * len(keys)}---|---|---|---|---|---|"]
    for r in claims.to_dict("records"):
        point = "".join(f"{r[k]:g} | " if isinstance(r[k], float) else f"{r[k]} | " for k in keys)
        check = json.loads(r["check"])
        if r["quantity"] == "geometry":
            measured = "; ".join(t for t in (f"DOP (geometry, no filter) holds: {_verdict_cell(r['geometry_holds'])}",
                                             _claim_values(r["geometry_values"], check)) if t)
        else:
            measured = "; ".join(f"{label} {text}" for label, text in (
                ("EKF", _claim_values(r["ekf_values"], check)), ("LinCov", _claim_values(r["lincov_values"], check)))
                if text)
        cell = " — ".join(t for t in (measured, r["note"]) if t) or "—"
        disagree = "**disagree**" if r["metrics_disagree"] else ""
        lines.append(f"| {point}`{r['id']}` | {r['claim']} ({r['source']}) | {_verdict_cell(r['ekf_holds'])} | "
                     f"{_verdict_cell(r['lincov_holds'])} | {disagree} | {cell.replace('|', '/')} |")
    return "\n".join(lines) + "\n"


def initial_batch_text(scenario) -> str:
    """The header's note on a scenario's initial batch (how the EKF starts)."""
    flt = scenario.filter
    if flt.initial_batch_hours is None:
        return "; no initial batch (the EKF starts from the a priori)"
    longest = flt.initial_batch_max_hours or flt.initial_batch_hours
    return (f"; initial batch {flt.initial_batch_hours:g} h, doubling up to {longest:g} h until the hand-over "
            f"position 1σ < {flt.initial_batch_handover_sigma_km:g} km")
