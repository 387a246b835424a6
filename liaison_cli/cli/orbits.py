"""`liaison orbits ...`: periodic-orbit families of the Earth-Moon CRTBP (generate, list, show, plot)."""

from pathlib import Path

import typer

from liaison_cli.cli.common import FamilyArgument, FamilyCountOption, echo_json, json_option, user_errors
from liaison_cli.cli.root import app
from liaison_cli.errors import LiaisonError

orbits_app = typer.Typer(no_args_is_help=True, help="Periodic-orbit families of the Earth-Moon CRTBP.")
app.add_typer(orbits_app, name="orbits")


def _family_table(name: str, count: int, regenerate: bool = False):
    from liaison_cli.orbits.family_store import load_or_generate
    from liaison_cli.orbits.families import FamilyError

    try:
        return load_or_generate(name, count, regenerate)
    except FamilyError as exc:
        raise LiaisonError(str(exc)) from None


def _format_family(frame) -> str:
    from liaison_cli.dynamics.constants import LU_KM

    lines = [f"{'#':>3}{'x0 LU':>12}{'z0 LU':>11}{'vy0 LU/TU':>12}{'period d':>10}{'Jacobi':>9}"
             f"{'stab. index':>13}{'Az km':>9}{'perilune km':>13}{'closure LU':>12}"]
    for row in frame.itertuples():
        lines.append(f"{row.member:>3}{row.x0:>12.7f}{row.z0:>11.7f}{row.vy0:>12.7f}{row.period_days:>10.4f}"
                     f"{row.jacobi:>9.5f}{row.stability_index:>13.2f}{row.z_amplitude_lu * LU_KM:>9.0f}"
                     f"{row.perilune_km:>13.0f}{row.closure_lu:>12.1e}")
    return "\n".join(lines)


@orbits_app.command("generate")
@user_errors
def orbits_generate(
    family: FamilyArgument,
    count: FamilyCountOption = 30,
    regenerate: bool = typer.Option(False, "--regenerate", help="ignore the cache"),
):
    """Correct and continue a family; store its table (Parquet) in the user cache.

    Example: liaison orbits generate l2_halo_south --count 30"""
    import time

    from liaison_cli.orbits.family_store import family_path

    start = time.perf_counter()
    frame, cached = _family_table(family, count, regenerate)
    typer.echo(_format_family(frame))
    how = "read from the cache" if cached else "generated"
    typer.echo(f"{family}: {len(frame)} members, periods {frame.period_days.min():.3f}-"
               f"{frame.period_days.max():.3f} d, {how} in {time.perf_counter() - start:.1f} s: "
               f"{family_path(family, count)}")


@orbits_app.command("catalogue")
@user_errors
def orbits_catalogue(
    output: Path = typer.Option(None, "--output", help="where to write the catalogue (default: the package's own "
                                "orbits/data/family_catalogue.json, which a checkout commits)"),
):
    """Regenerate the shipped orbit catalogue (every family's 30-member table) and say how far it moved.

    Example: liaison orbits catalogue --output family_catalogue.json"""
    import time

    from liaison_cli.orbits.family_catalogue import CATALOGUE_PATH, build_catalogue, largest_change, write_catalogue

    start = time.perf_counter()
    catalogue = build_catalogue()
    for name, change in largest_change(catalogue).items():
        typer.echo(f"{name:<16}largest change of an initial state against the shipped catalogue: {change:.3g} LU")
    path = write_catalogue(catalogue, output or CATALOGUE_PATH)
    typer.echo(f"wrote {path} in {time.perf_counter() - start:.1f} s")


@orbits_app.command("list")
def orbits_list(as_json: bool = json_option()):
    """The known families and the tables already in the cache.

    Example: liaison orbits list"""
    from liaison_cli.orbits.family_store import cached_families
    from liaison_cli.orbits.families import FAMILIES

    if as_json:
        from liaison_cli.report.json_summary import orbit_families_document

        echo_json(orbit_families_document({name: FAMILIES[name].description for name in sorted(FAMILIES)},
                                          [str(path) for path in cached_families()]))
        return
    for name in sorted(FAMILIES):
        typer.echo(f"{name:<16}{FAMILIES[name].description}")
    tables = cached_families()
    typer.echo(f"cached tables ({len(tables)}):" if tables else "no cached tables yet")
    for path in tables:
        typer.echo(f"  {path}")


@orbits_app.command("show")
@user_errors
def orbits_show(
    family: FamilyArgument,
    count: FamilyCountOption = 30,
    as_json: bool = json_option(),
):
    """Print a family table (generating it first if needed).

    Example: liaison orbits show dro --count 10"""
    frame, _ = _family_table(family, count)
    if as_json:
        from liaison_cli.report.json_summary import orbit_family_document

        echo_json(orbit_family_document(family, frame))
        return
    typer.echo(_format_family(frame))


@orbits_app.command("plot")
@user_errors
def orbits_plot(
    family: FamilyArgument,
    count: FamilyCountOption = 30,
    output: Path = typer.Option(None, "--output", help="PNG path (default: results/orbits/<family>.png)"),
):
    """Draw a family in the x-y, x-z and y-z planes, coloured by period (PNG).

    Example: liaison orbits plot l1_halo_north --output l1_halo_north.png"""
    from liaison_cli.orbits.family_store import from_table
    from liaison_cli.report.orbit_plots import draw_family

    frame, _ = _family_table(family, count)
    path = draw_family(family, from_table(frame), output or Path("results") / "orbits" / f"{family}.png")
    typer.echo(f"wrote {path}")
