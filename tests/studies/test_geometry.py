"""Formation geometry (001 §6.5): halo pairs with longer periods are less observable."""


from liaison_cli.campaign.studies.geometry import geometry_study


def test_longer_periods_give_less_observable_halo_pairs():
    table = geometry_study("l1_halo_south", "l2_halo_south", count=3, interval_s=900.0)
    assert len(table) == 9
    longest = table.loc[(table.first_period_days + table.second_period_days).idxmax()]
    shortest = table.loc[(table.first_period_days + table.second_period_days).idxmin()]
    for observable in ("range", "range_rate"):
        column = f"{observable}_condition_number"
        assert longest[column] > 100 * shortest[column], observable
    assert (table.duration_days >= table[["first_period_days", "second_period_days"]].max(axis=1) - 1e-9).all()
    assert table.mean_distance_km.between(50_000, 200_000).all()
