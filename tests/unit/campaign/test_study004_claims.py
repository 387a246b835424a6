"""004's claims as data (report/data/study004_claims.yaml) and their checker (campaign.studies.study004.check_claims)
on small synthetic summary tables: a claim holds, fails, the EKF and LinCov disagree, or it cannot be told."""

import json

import numpy as np
import pandas as pd
import pytest

from liaison_cli.campaign.studies.study004 import check_claims, claims_004, rankings
from liaison_cli.report.study004 import format_claims

GROUND, GEO, L1 = "MaunaKea+OwensValley", "GEO130W+GEO170W", "L1A+L1B"
PAIRS = {"ground": GROUND, "geo": GEO, "l1": L1}


def summary(transmitter="eml2_halo", **columns) -> pd.DataFrame:
    """One transmitter's three pairs; each column given as (ground, geo, l1)."""
    base = {"ekf_error_rms_position_settled_m": (400.0, 60.0, 80.0),
            "ekf_error_rms_velocity_settled_m_s": (2e-3, 5e-4, 6e-4),
            "steady_3sigma_position_m": (1200.0, 300.0, 350.0),
            "steady_3sigma_velocity_m_s": (6e-3, 1.6e-3, 2e-3),
            "ekf_converged_days_median": (8.0, 1.0, 9.0),
            "convergence_days_position": (9.0, 2.0, 10.0),
            "median_dop": (125.0, 21.0, 3.0)}
    base.update(columns)
    return pd.DataFrame({"transmitter": transmitter, "pair": [GROUND, GEO, L1],
                         **{k: list(v) for k, v in base.items()}})


def one(claim_id: str, check: dict, table: pd.DataFrame, grid_keys=None) -> pd.DataFrame:
    claims = {"pairs": PAIRS, "claims": [{"id": claim_id, "source": "§6", "claim": "a claim", "check": check}]}
    return check_claims(table, grid_keys, claims)


BEST_GEO = {"quantity": "accuracy", "transmitters": ["eml2_halo"], "kind": "best_pair", "pair": "geo"}


def test_a_claim_that_holds_on_both_metrics():
    row = one("best", BEST_GEO, summary()).iloc[0]
    assert (row.ekf_holds, row.lincov_holds, row.geometry_holds) == ("yes", "yes", "n/a")
    assert not row.metrics_disagree and row.note == ""
    assert row.ekf_metric == "ekf_error_rms_position_settled_m" and row.lincov_metric == "steady_3sigma_position_m"
    assert json.loads(row.ekf_values) == {"eml2_halo": {"ground": 400.0, "geo": 60.0, "l1": 80.0}}


def test_a_claim_that_fails_on_both_metrics():
    row = one("best", {**BEST_GEO, "pair": "l1"}, summary()).iloc[0]
    assert (row.ekf_holds, row.lincov_holds) == ("no", "no") and not row.metrics_disagree


def test_the_metrics_disagree_where_the_ekf_and_lincov_rank_differently():
    """LinCov's σ puts the EML1 pair first, the EKF's settled error the GEO pair (004's transfer, measured)."""
    row = one("best", BEST_GEO, summary(steady_3sigma_position_m=(12e3, 2e3, 0.8e3))).iloc[0]
    assert (row.ekf_holds, row.lincov_holds) == ("yes", "no") and row.metrics_disagree
    assert "**disagree**" in format_claims(one("best", BEST_GEO, summary(steady_3sigma_position_m=(12e3, 2e3, 800))))


def test_not_computable_without_converged_runs_or_the_transmitter():
    no_runs = one("best", BEST_GEO, summary(ekf_error_rms_position_settled_m=(400.0, np.nan, 80.0))).iloc[0]
    assert (no_runs.ekf_holds, no_runs.lincov_holds) == ("not computable", "yes") and not no_runs.metrics_disagree
    assert "no converged EKF run" in no_runs.note
    elsewhere = one("best", {**BEST_GEO, "transmitters": ["dro"]}, summary()).iloc[0]
    assert elsewhere.ekf_holds == elsewhere.lincov_holds == "not computable"
    assert "dro: not in the study" in elsewhere.note
    missing_pair = one("best", BEST_GEO, summary().iloc[:2]).iloc[0]  # no EML1 row: a ranking of two is no ranking
    assert missing_pair.ekf_holds == "not computable" and "no l1 pair" in missing_pair.note


def test_a_claim_over_several_transmitters_fails_when_one_fails():
    both = pd.concat([summary(), summary("dro", ekf_error_rms_position_settled_m=(400.0, 90.0, 80.0))])
    row = one("best", {**BEST_GEO, "transmitters": ["eml2_halo", "dro"]}, both).iloc[0]
    assert (row.ekf_holds, row.lincov_holds) == ("no", "yes") and row.metrics_disagree
    partly = one("best", {**BEST_GEO, "transmitters": ["eml2_halo", "dro"]}, summary()).iloc[0]
    assert partly.ekf_holds == "not computable"  # holds where it can be told, the DRO is missing


@pytest.mark.parametrize("check, columns, expected", [
    # a convergence that never came is slower than any time
    ({"kind": "better", "better": "geo", "worse": ["l1"]}, {"convergence_days_position": (9.0, 2.0, np.nan)}, "yes"),
    ({"kind": "better", "better": "l1", "worse": ["geo"]}, {"convergence_days_position": (9.0, 2.0, np.nan)}, "no"),
    ({"kind": "best_pair", "pair": "geo"}, {"convergence_days_position": (np.nan, np.nan, np.nan)},
     "not computable"),
    ({"kind": "ratio_at_least", "better": "geo", "worse": ["ground", "l1"], "factor": 2.0}, {}, "yes"),
    ({"kind": "ratio_at_least", "better": "geo", "worse": ["ground", "l1"], "factor": 5.0}, {}, "no"),
    ({"kind": "similar", "pairs": ["l1", "ground"], "factor": 1.5}, {}, "yes"),
    ({"kind": "about", "pair": "geo", "value": 2.5, "factor": 2.0}, {}, "yes"),
    ({"kind": "about", "pair": "geo", "value": 2.5, "factor": 2.0}, {"convergence_days_position": (9, np.nan, 10)},
     "no"),
    ({"kind": "within", "pairs": ["ground", "l1"], "low": 7.5, "high": 15.1}, {}, "yes"),
    ({"kind": "worst_pair", "pair": "l1"}, {}, "yes"),
    ({"kind": "worst_pair", "pair": "ground"}, {}, "no"),
])
def test_convergence_checks_on_lincov(check, columns, expected):
    check = {"quantity": "convergence", "transmitters": ["eml2_halo"], **check}
    assert one("c", check, summary(**columns)).iloc[0].lincov_holds == expected


def test_ratio_between_and_the_3_sigma_threshold():
    slightly = {"quantity": "accuracy", "transmitters": ["eml2_halo"], "kind": "ratio_between", "better": "ground",
                "worse": "l1", "low": 1.0, "high": 2.0}
    assert one("s", slightly, summary()).iloc[0].ekf_holds == "no"  # the EML1 pair is 5x better, not a bit worse
    assert one("s", slightly, summary(ekf_error_rms_position_settled_m=(400, 60, 600))).iloc[0].ekf_holds == "yes"
    below = {"quantity": "accuracy", "transmitters": ["eml2_halo"], "kind": "below", "pair": "geo",
             "position_m": 1000.0, "velocity_m_s": 0.01}
    row = one("b", below, summary(ekf_error_rms_position_settled_m=(400, 340, 80))).iloc[0]  # 3 x 340 m > 1 km
    assert (row.ekf_holds, row.lincov_holds) == ("no", "yes") and row.metrics_disagree
    assert json.loads(row.ekf_values)["eml2_halo"] == {"position": 1020.0, "velocity": 0.0015}


def test_geometry_claims_read_the_dop_only():
    dop = {"quantity": "geometry", "transmitters": ["eml2_halo"], "kind": "ratio_at_least", "better": "geo",
           "worse": "ground", "factor": 3.16}
    row = one("d", dop, summary()).iloc[0]
    assert (row.ekf_holds, row.lincov_holds, row.geometry_holds) == ("n/a", "n/a", "yes")
    assert not row.metrics_disagree and row.geometry_metric == "median_dop"


def test_claims_the_study_cannot_check_are_listed_with_their_reason():
    check = {"quantity": "accuracy", "transmitters": ["dro"], "kind": "not_checked", "reason": "a history feature"}
    row = one("n", check, summary()).iloc[0]
    assert row.ekf_holds == row.lincov_holds == "not computable" and row.note == "a history feature"


def test_one_row_per_claim_and_grid_point():
    grid = pd.concat([summary().assign(**{"filter.process_noise_accel_m_s2": s}) for s in (1e-8, 1e-7)])
    table = one("best", BEST_GEO, grid, ["filter.process_noise_accel_m_s2"])
    assert list(table["filter.process_noise_accel_m_s2"]) == [1e-8, 1e-7]
    assert "| filter.process_noise_accel_m_s2 | id |" in format_claims(table, ["filter.process_noise_accel_m_s2"])


def test_a_null_grid_value_is_a_grid_point():
    """`--grid filter.initial_batch_hours=null,12`: the null point keeps its claims and its rankings."""
    key = "filter.initial_batch_hours"
    grid = pd.concat([summary().assign(**{key: None}), summary().assign(**{key: 12.0})], ignore_index=True)
    table = one("best", BEST_GEO, grid, [key])
    assert len(table) == 2 and pd.isna(table[key].iloc[0]) and table[key].iloc[1] == 12.0
    ranked = rankings(grid, [key])
    assert len(ranked) == 2 and pd.isna(ranked[key].iloc[0])
    assert ranked.best_first_ekf.iloc[0] == f"{GEO} < {L1} < {GROUND}"


def test_the_shipped_claims_are_complete_and_well_formed():
    """Every claim has an id, a source and a check of a known kind naming known pairs and 004's transmitters; the
    claims 004 makes and the study cannot check are listed too. On a study where every ordering is 004's, each
    checkable claim gets a verdict."""
    data = claims_004()
    ids = [c["id"] for c in data["claims"]]
    assert len(ids) == len(set(ids)) >= 20 and set(data["pairs"]) == {"ground", "geo", "l1"}
    assert {c["check"]["kind"] for c in data["claims"]} >= {"best_pair", "ratio_at_least", "ratio_between",
                                                              "not_checked"}
    for claim in data["claims"]:
        check = claim["check"]
        assert claim["source"] and claim["claim"] and check["quantity"] in ("accuracy", "convergence", "geometry")
        assert set(check["transmitters"]) <= {"eml2_halo", "dro", "low_energy_transfer"}, claim["id"]
    for required in ("halo_l1_slightly_worse_than_ground", "halo_l1_slower_than_geo", "transfer_l1_beats_ground",
                     "ground_about_ten_times_less_accurate", "halo_geo_converges_in_2_5_days"):
        assert required in ids
    study = pd.concat([summary(t) for t in ("eml2_halo", "dro", "low_energy_transfer")])
    table = check_claims(study, [])
    assert len(table) == len(ids)
    checkable = table[table.kind != "not_checked"]
    filtered = checkable[checkable.quantity != "geometry"]
    assert filtered.ekf_holds.isin(["yes", "no"]).all() and filtered.lincov_holds.isin(["yes", "no"]).all()
    text = format_claims(table)
    assert all(f"`{i}`" in text for i in ids)


def test_the_reproduction_page_lists_every_claim():
    from tests.conftest import REPO

    page = (REPO / "docs" / "reproductions" / "004.md").read_text()
    missing = [c["id"] for c in claims_004()["claims"] if f"| `{c['id']}` |" not in page]
    assert not missing, missing


def test_a_pair_some_of_whose_runs_diverge_is_unrankable_not_ranked_on_its_survivors():
    """004's transfer with a C_R error: GEO converges in 2 of 6 runs. Its settled error over the 2 survivors is
    the best of the three, but the EKF's order leaves it out as unrankable (naming 2/6), the claim that GEO is the
    best pair cannot be told on the EKF's reading, and LinCov's reading still judges it."""
    table = summary(runs=(6, 6, 6), ekf_converged_share=(1.0, 2 / 6, 1.0))
    ranked = rankings(table, [])
    assert ranked.best_first_ekf.iloc[0] == f"{L1} (6/6) < {GROUND} (6/6); unrankable: {GEO} (2/6 converged)"
    assert not ranked.ekf_all_converged.iloc[0]
    row = one("best", BEST_GEO, table).iloc[0]
    assert row.ekf_holds == "not computable" and "geo converged in 2/6 runs" in row.note
    assert row.lincov_holds == "yes"
    full = rankings(summary(runs=(6, 6, 6), ekf_converged_share=(1.0, 1.0, 1.0)), [])
    assert full.best_first_ekf.iloc[0] == f"{GEO} (6/6) < {L1} (6/6) < {GROUND} (6/6)"
