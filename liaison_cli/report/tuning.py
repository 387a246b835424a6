"""The consistency table `liaison tune` writes: per scenario and estimated spacecraft, the shipped process
noise's error RMS, sigma RMS, their ratio and NEES-in-band share after the settle time, beside the same for
the rung the rule chose (campaign.studies.tuning states the rule). Formats only."""

import math
from importlib.resources import files

import pandas as pd
import yaml


def paper_tuned_notes() -> dict:
    """{scenario: note} of the scenarios kept tuned to a paper (data/paper_tuned.yaml says why, measured)."""
    return yaml.safe_load(files("liaison_cli.report").joinpath("data/paper_tuned.yaml").read_text())


def _ratio(value: float, half_width: float = math.nan) -> str:
    if not math.isfinite(value):
        return "-"
    return f"{value:.2f}" + (f"±{half_width:.2f}" if math.isfinite(half_width) else "")


def _untuned(table: pd.DataFrame) -> set:
    """The scenarios tried on no rung: their estimator has no process noise (a batch), so no SNC to show."""
    return set(table.scenario) - set(table.scenario[table.setting == "rung"])


def _snc(row, untuned: set) -> str:
    """The rung's sigma_a; '-' for a batch (none); 'default' for a shipped row whose process noise is the
    default derived for the scenario (scenario.default_noise: the run prints its value)."""
    if row["scenario"] in untuned:
        return "-"
    value = row["snc_m_s2"]
    return "default" if value is None or value != value else f"{value:.0e}"


def _cells(row, untuned: set) -> list[str]:
    """SNC ('-' for a batch: it has none), position error RMS, sigma RMS, position and velocity error/sigma,
    NEES in band, runs ok."""
    if row is None:
        return ["-"] * 7
    share = row["nees_in_band_share"]
    mark = "" if row.get("consistent", True) else " !"
    return [_snc(row, untuned), f"{row['error_rms_position_m']:.1f}", f"{row['sigma_rms_position_m']:.1f}",
            _ratio(row["position_error_to_sigma"], row.get("position_error_to_sigma_halfwidth", math.nan)),
            _ratio(row["velocity_error_to_sigma"], row.get("velocity_error_to_sigma_halfwidth", math.nan)),
            _share(share, row.get("nees_in_band_halfwidth", math.nan)) + mark, f"{row['runs_ok']}/{row['runs']}"]


def _share(share: float, half_width: float) -> str:
    """A whole-state NEES share in %, with its interval's half-width when known."""
    if not math.isfinite(share):
        return "-"
    shown = math.isfinite(half_width) and half_width > 0.0  # runs that all agree have no spread to show
    return f"{100 * share:.1f}" + (f"±{100 * half_width:.1f}" if shown else "") + " %"


def _verdict(rows: pd.DataFrame, chosen, notes: dict) -> str:
    first = rows.iloc[0]
    verdict = first["verdict"]
    if chosen is not None and bool(chosen.iloc[0]["lowest_rung"]):
        verdict += " (lowest rung: smaller not tried)"
    if chosen is not None:
        verdict += "; shipped = chosen" if _same_as_chosen(rows, chosen) else ""
    note = notes.get(first["scenario"])
    return verdict + (f"; {note}" if note else "")


def _same_as_chosen(rows: pd.DataFrame, chosen: pd.DataFrame) -> bool:
    shipped = rows[rows.setting == "shipped"].set_index("spacecraft").snc_m_s2
    value = float(chosen.iloc[0]["snc_m_s2"])
    return bool((shipped == value).all())


def format_table(table: pd.DataFrame, rule: str, command: str, settle_note: str, notes: dict | None = None) -> str:
    """Markdown: the header (what wrote it, the rule, the columns) and one row per scenario and spacecraft.
    notes: {scenario: text} appended to its verdict (e.g. a scenario kept tuned to a paper)."""
    notes = notes or {}
    lines = ["# Consistency of the shipped scenarios, and process noise chosen by a rule", "",
             f"Written by `{command}`; do not edit by hand.", "", rule, "",
             f"Statistics after the settle time ({settle_note}), over the runs that finished: error RMS and sigma "
             "RMS of the 3-D position error (m; sigma of the norm, sqrt(sx^2 + sy^2 + sz^2)), their ratio for "
             "position and velocity with its 95 % interval from the run count, and the mean share of epochs whose "
             "whole-state NEES lies in its single-run 95 % chi-square band with its 95 % interval from the runs' "
             "spread (the same for every spacecraft of a scenario); ! marks a spacecraft that fails the consistency verdict (the ladder text says which test). "
             "SNC in m/s^2; a shipped value per spacecraft where they differ.", ""]
    kept = [label for label in table.scenario.unique() if label in notes]
    if kept:
        lines += [f"Kept tuned to a paper, not to the rule: {', '.join(kept)} (why, and the rule's value: their "
                  "verdicts).", ""]
    lines += ["| scenario | S/C | shipped SNC | err RMS m | σ RMS m | pos err/σ | vel err/σ | NEES in band | runs ok "
              "| chosen SNC | err RMS m | σ RMS m | pos err/σ | vel err/σ | NEES in band | runs ok | verdict |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    untuned = _untuned(table)
    for label, rows in table.groupby("scenario", sort=False):
        chosen = rows[rows.chosen]
        verdict = _verdict(rows, chosen if len(chosen) else None, notes)
        for i, shipped in enumerate(rows[rows.setting == "shipped"].to_dict("records")):
            mine = chosen[chosen.spacecraft == shipped["spacecraft"]]
            rule_row = mine.iloc[0].to_dict() if len(mine) else None
            lines.append(f"| {label} | {shipped['spacecraft']} | " + " | ".join(_cells(shipped, untuned)) + " | "
                         + " | ".join(_cells(rule_row, untuned)) + f" | {verdict if i == 0 else ''} |")
    return "\n".join(lines) + "\n"


def format_ladder(table: pd.DataFrame) -> str:
    """Plain text for the terminal: every rung's ratios and NEES share, per scenario and spacecraft."""
    lines = [f"{'scenario':<32}{'S/C':<12}{'SNC m/s^2':>10}{'pos err/σ':>13}{'vel err/σ':>13}{'NEES in band':>14}"
             f"{'runs ok':>9}  why the rung fails the rule"]
    untuned = _untuned(table)
    for row in table.to_dict("records"):
        value = _snc(row, untuned)
        snc = value + ("*" if row["chosen"] else (" s" if row["setting"] == "shipped" else ""))
        share = row["nees_in_band_share"]
        position = _ratio(row["position_error_to_sigma"], row.get("position_error_to_sigma_halfwidth", math.nan))
        velocity = _ratio(row["velocity_error_to_sigma"], row.get("velocity_error_to_sigma_halfwidth", math.nan))
        lines.append(f"{row['scenario']:<32}{row['spacecraft']:<12}{snc:>10}{position:>13}{velocity:>13}"
                     f"{_share(share, row.get('nees_in_band_halfwidth', math.nan)):>14}"
                     f"{str(row['runs_ok']) + '/' + str(row['runs']):>9}  "
                     f"{row.get('rule_failed') or row.get('consistency_failed') or ''}")
    lines.append("s: shipped settings; *: the rung the rule chose")
    for row in table[table.chosen & (table.get("ladder_key", "") == "filter.process_noise_psd_m2_s3")].drop_duplicates(
            "scenario").to_dict("records"):  # a PSD scenario: the value to give, in its own key
        lines.append(f"{row['scenario']}: its process noise is a PSD; the chosen rung is "
                     f"filter.process_noise_psd_m2_s3: {row['psd_m2_s3']:.3g} (m^2/s^3, the same Q as sigma_a "
                     f"{row['snc_m_s2']:g} m/s^2 under the continuous white-acceleration model)")
    for row in table[table.chosen & (table.get("ladder_key", "") == "filter.process_noise_psd_ric_m2_s3")
                     ].drop_duplicates("scenario").to_dict("records"):  # RIC densities: the triple to give
        lines.append(f"{row['scenario']}: its process noise is a PSD per RIC axis; the chosen rung is "
                     f"filter.process_noise_psd_ric_m2_s3: [{', '.join(f'{q:.3g}' for q in row['ric_m2_s3'])}] "
                     f"(m^2/s^3, in the scenario's proportions; the largest {row['psd_m2_s3']:.3g})")
    return "\n".join(lines)
