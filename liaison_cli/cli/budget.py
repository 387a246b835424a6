"""`liaison budget`: ranging and carrier sigmas from a link budget, and the OD errors a sweep expects."""

import math
from pathlib import Path

import typer

from liaison_cli.cli.common import echo_json, json_option, user_errors
from liaison_cli.cli.root import app


def _print_dual_one_way(spec) -> None:
    receiver = spec.receiver()
    sig = receiver.sigmas()
    typer.echo(f"dual one-way receiver (002 Eq. 8-12): carrier {spec.carrier_frequency_hz / 1e9:g} GHz, "
               f"C/N0 {spec.c_n0_db_hz:g} dB-Hz, code {spec.chip_rate_hz / 1e6:g} Mcps in {spec.front_end_bandwidth_hz / 1e6:g} MHz, "
               f"early-late spacing {receiver.spacing_chips:.3f} chips")
    typer.echo(f"  {'TOA Cramér-Rao bound (Eq. 8), range':<44}{sig['toa_crb_range_m']:10.3f} m"
               f"   (Gabor bandwidth {sig['gabor_bandwidth_hz'] / 1e3:.0f} kHz, T {spec.code_integration_s:g} s)")
    typer.echo(f"  {'DLL code tracking (Eq. 11), range':<44}{sig['dll_range_m']:10.3f} m"
               f"   ({sig['dll_regime']}, B_n {spec.code_loop_bandwidth_hz:g} Hz)")
    typer.echo(f"  {'FOA Cramér-Rao bound (Eq. 10), range-rate':<44}{1e3 * sig['foa_crb_range_rate_m_s']:10.4f} mm/s"
               f" (T {spec.carrier_integration_s:g} s)")
    typer.echo(f"  {'PLL Doppler (Eq. 12), range-rate':<44}{1e3 * sig['pll_range_rate_m_s']:10.4f} mm/s"
               f" (B_d {spec.doppler_bandwidth_hz:g} Hz)")


@app.command()
@user_errors
def budget(
    link_file: Path = typer.Argument(..., help="link YAML: link_budget {uplink, downlink} + ranging parameters"),
    sweep_dir: Path = typer.Option(None, "--sweep", help="a 'liaison sweep --sigma' folder to read errors from"),
    as_json: bool = json_option(),
):
    """Ranging sigma of each method from a link budget; with --sweep, the expected OD errors (Fig. 15 read-off).

    Example: liaison budget links/turan2022_table2.yaml --json"""
    from liaison_cli.scenario.loading import load_link_file

    link = load_link_file(link_file)
    if as_json:
        from liaison_cli.report.json_summary import budget_document

        echo_json(budget_document(link_file, link, _expected_errors(link, sweep_dir), sweep_dir))
    else:
        _print_budget(link, sweep_dir)


def _print_budget(link, sweep_dir) -> None:
    from liaison_cli.report.budget import METHOD_LABELS

    if link.dual_one_way is not None:
        _print_dual_one_way(link.dual_one_way)
    if link.link_budget is None:
        return
    for leg_name in ("uplink", "downlink"):
        leg = getattr(link.link_budget, leg_name).leg()
        typer.echo(f"{leg_name:<9} {leg.distance_km:,.0f} km, {leg.data_rate_bps:,.0f} bps: free-space loss "
                   f"{leg.free_space_loss_db:.2f} dB, C/N0 {leg.c_over_n0_dbhz:.2f} dB-Hz, "
                   f"Es/N0 {leg.es_over_n0_db:.2f} dB (margin {leg.margin_db:g} dB held back)")
    sigmas = link.sigma_by_method()
    typer.echo(f"ranging sigma (1σ, correlator integration {link.correlator_integration_s:g} s):")
    for method, sigma in sigmas.items():
        shown = f"{sigma:10.1f} m" if sigma is not None else (
            "   not computed: needs ranging_clock_hz, loop_bandwidth_hz, ranging_power_fraction_db")
        typer.echo(f"  {METHOD_LABELS[method]:<22}{shown}")
    if link.carrier is not None:
        carrier = link.carrier.sigmas(link.link_budget)
        count_s = link.carrier.doppler_count_s
        typer.echo(f"carrier ({link.carrier.power_fraction_db:g} dB of each leg, {link.carrier.loop_bandwidth_hz:g} Hz "
                   f"loops): loop SNR up {10 * math.log10(carrier['uplink_loop_snr']):.1f} dB, down "
                   f"{10 * math.log10(carrier['downlink_loop_snr']):.1f} dB")
        doppler = f"two-way Doppler (Eq. 5), {count_s:g} s count"
        typer.echo(f"  {doppler:<40}{1e3 * carrier['range_rate_sigma_m_s']:10.4f} mm/s")
        typer.echo(f"  {'LOS interferometer path (Eq. 9)':<40}{1e3 * carrier['los_path_sigma_m']:10.3f} mm")
        typer.echo("range / range-rate sigma ratio (Eq. 65):")
        for method, sigma in sigmas.items():
            if sigma is not None:
                typer.echo(f"  {METHOD_LABELS[method]:<22}{sigma / carrier['range_rate_sigma_m_s']:10.0f} s")
    if sweep_dir is None:
        return
    table = _expected_errors(link, sweep_dir)
    typer.echo(f"expected OD error from {sweep_dir} (mean of run RMS [90th percentile], interpolated in sigma):")
    typer.echo(f"  {'method':<14}{'sigma m':>9}  {'scenario':<12}{'spacecraft':<11}{'position m':>20}"
               f"{'velocity mm/s':>22}")
    for row in table.itertuples():
        if row.inside_swept_range:
            pos = f"{row.rms_position_m_mean:.0f} [{row.rms_position_m_p90:.0f}]"
            vel = f"{1e3 * row.rms_velocity_m_s_mean:.2f} [{1e3 * row.rms_velocity_m_s_p90:.2f}]"
        else:
            pos, vel = f"outside swept {row.swept_min_m:g}-{row.swept_max_m:g} m", ""
        typer.echo(f"  {row.method:<14}{row.sigma_m:>9.1f}  {row.scenario:<12}{row.spacecraft:<11}{pos:>20}{vel:>22}")


def _expected_errors(link, sweep_dir):
    """The OD errors a sweep's curve gives at each method's sigma; None without --sweep or a link budget."""
    if sweep_dir is None or link.link_budget is None:
        return None
    from liaison_cli.report.budget import expected_errors
    from liaison_cli.report.fig15 import load_curve

    return expected_errors(load_curve(sweep_dir), link.sigma_by_method())
