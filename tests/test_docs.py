"""The documentation site (issue 27): it builds with `mkdocs build --strict`, its generated references cover
the code, its output tables list exactly the columns that real runs write, and every number a page shows
from a reference output is that output's (the tables themselves are included verbatim from
results/reference/ by pymdownx.snippets, which the strict build checks)."""

import json
import re
import subprocess
import sys
import time

import pyarrow.parquet as pq
import pytest

from tests.conftest import REPO, SCENARIOS, run_cli_in_process

DOCS = REPO / "docs"
REFERENCE = REPO / "results" / "reference"


# --- the site builds --------------------------------------------------------------------------------------


def test_the_site_builds_strict(tmp_path):
    """Broken links, missing anchors, missing snippet files and pages outside the nav all fail the build.
    Measured: 4.4–5.9 s on the shared 2-core development machine (docs/performance.md); printed with -s."""
    started = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file",
                           str(REPO / "mkdocs.yml"), "--site-dir", str(tmp_path / "site")],
                          capture_output=True, text=True, cwd=REPO, timeout=300)
    print(f"mkdocs build --strict: {time.perf_counter() - started:.1f} s")
    assert proc.returncode == 0, proc.stderr
    table3 = (tmp_path / "site" / "reproductions" / "000-table3" / "index.html").read_text()
    assert "<td>eml1_eml2</td>" in table3  # the snippet was included, not left as text
    assert (tmp_path / "site" / "results" / "reference" / "fig15.png").is_file()
    site = tmp_path / "site"
    assert "liaison orbits generate" in (site / "cli" / "index.html").read_text()  # the generated parts are in
    assert "SpacecraftSpec" in (site / "scenario-reference" / "index.html").read_text()
    assert "dual_one_way_derived" in (site / "model" / "index.html").read_text()


def test_every_page_is_in_the_nav():
    nav = (REPO / "mkdocs.yml").read_text()
    pages = {p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md")}
    assert pages and all(page in nav for page in pages), pages


# --- generated references -----------------------------------------------------------------------------


def test_cli_reference_has_every_command_and_option():
    import typer.main

    from liaison_cli.cli import app
    from tools.docs_hooks import cli_reference_markdown

    text = cli_reference_markdown()
    root = typer.main.get_command(app)
    ctx = root.context_class(root, info_name="liaison")
    for name in root.list_commands(ctx):
        command = root.get_command(ctx, name)
        assert f"`liaison {name}`" in text, name
        sub_ctx = command.context_class(command, info_name=name, parent=ctx)
        for param in command.get_params(sub_ctx):
            for opt in param.opts:
                if opt.startswith("--") and opt != "--help":  # a row names it, after its short form if any
                    assert re.search(rf"`(-\w, )?{re.escape(opt)}[ `]", text), (name, opt)
    assert "`liaison plot fig15`" in text and "`liaison orbits generate`" in text


def test_scenario_reference_has_every_schema_key():
    from liaison_cli.scenario.json_schema import scenario_json_schema
    from tools.docs_hooks import scenario_reference_markdown

    text = scenario_reference_markdown()
    schema = scenario_json_schema()
    for model in [schema, *schema["$defs"].values()]:
        for key in model.get("properties", {}):
            assert f"| `{key}` |" in text, key
    for name in schema["$defs"]:
        assert f"### {name}" in text, name


def test_observables_table_is_the_registry():
    from liaison_cli.measurements.registry import OBSERVABLES
    from tools.docs_hooks import observables_markdown

    rows = [line for line in observables_markdown().splitlines() if line.startswith("| `")]
    assert len(rows) == len(OBSERVABLES) == 8
    assert "<!-- liaison:observables -->" in (DOCS / "model.md").read_text()


def test_dynamics_table_is_the_registry():
    from liaison_cli.dynamics.registry import DYNAMICS
    from tools.docs_hooks import dynamics_markdown

    rows = [line for line in dynamics_markdown().splitlines() if line.startswith("| `")]
    assert len(rows) == len(DYNAMICS) == 2
    assert all(p.summary in dynamics_markdown() for d in DYNAMICS.values() for p in d.parameters)
    assert "<!-- liaison:dynamics -->" in (DOCS / "filter.md").read_text()


def test_rule_text_reads_the_schema_shapes():
    from tools.docs_hooks import rule_text

    rule = {"if": {"properties": {"bias": {"enum": ["estimate", "consider"]}}, "required": ["bias"]},
            "then": {"properties": {"bias_apriori_sigma_m": {"not": {"type": "null"}}},
                     "required": ["bias_apriori_sigma_m"]}}
    assert rule_text(rule) == "if `bias` is one of `estimate`, `consider`, then `bias_apriori_sigma_m` is given"


# --- numbers the pages show from reference outputs -----------------------------------------------------------


def _table_rows(path) -> list[list[str]]:
    return [[c.strip() for c in line.strip().strip("|").split("|")] for line in path.read_text().splitlines()
            if line.startswith("| ") and not line.startswith("|---")]


def _span(values, digits: int) -> str:
    return f"{min(values):.{digits}f}–{max(values):.{digits}f}"


def test_table3_page_ranges_are_the_reference_tables():
    """The prose of the Table 3 page quotes ranges over results/reference/table3.md's columns."""
    rows = [r for r in _table_rows(REFERENCE / "table3.md") if r[0] in ("eml2_lunar", "eml1_lunar", "eml1_eml2")]
    rows = [r for r in rows if len(r) > 11]  # the comparison table (the cost table after it is narrower)
    assert len(rows) == 12
    ratios = [re.findall(r"\d+\.\d+", r[11]) for r in rows]
    nees = [int(re.search(r"(\d+) %", r[11]).group(1)) for r in rows]
    halo_lunar = [r for r in rows if r[0] != "eml1_eml2"]
    inside = [re.findall(r"\d+\.\d+", r[10]) for r in halo_lunar]
    page = " ".join((DOCS / "reproductions" / "000-table3.md").read_text().split())
    assert '--8<-- "results/reference/table3.md"' in page
    assert f"position error {_span([float(p) for p, _ in ratios], 2)} of σ" in page
    assert f"velocity {_span([float(v) for _, v in ratios], 2)}" in page
    assert f"{min(nees)}–{max(nees)} % of the time" in page
    three = [float(t) for _, t in inside]
    two = [float(t) for t, _ in inside]
    assert f"inside 3σ {min(three):.1f}–{max(three):.0f} %" in page
    assert f"(inside 2σ: {min(two):.1f}–{max(two):.0f} %)" in page


# (page, reference file, [(number as the page shows it, the reference's value)])
QUOTED = [
    ("reproductions/001.md", "networks.md", [("9.16 mm/s", "9.16"), ("9.31 mm/s", "9.31"), ("at 88–", "88 %"),
                                              ("–99 % of the epochs", "99 %")]),
    ("reproductions/001.md", "measurement_types.md",
     [("359 against", "359.2"), ("426 m", "426.3"), ("2,452", "2451.7"), ("3,450", "3449.7"), ("323 and", "323.2"),
      ("2,291", "2291.1"), ("91–94 %", "91 %"), ("94 %.", "94 %")]),
    ("reproductions/000-fig15.md", "fig15_study.md",
     [("0.66–2.07", "0.66-2.07"), ("0.56–1.75", "0.56-1.75"), ("35 %", "35 %"), ("33 %", "33 %"),
      ("1.14", "1.14")]),
    ("reproductions/002.md", "nrho002_readings.md",
     [("to 0.52–0.77", "0.52"), ("–0.77 of the", "0.77"), ("0.56–0.76 with", "0.56"), ("–0.76 with", "0.76"),
      ("–0.68)", "0.68"), ("ratios 0.99–1.01", "0.99"), ("prediction 0.87–1.16", "0.87"),
      ("–1.16, sampling", "1.16")]),
    ("filter.md", "cr_estimation.md", [("7–19 %", "7 %"), ("–19 % of each", "19 %"), ("band (94 % and", "94 %"),
                                        ("and 91 %)", "91 %"), ("0.24 % after", "0.24 %"), ("is 1.5 σ", "1.52"), ("is 77 %", "77 %"), ("only 54 %", "54 %"),
                                        ("3.2 σ at", "3.23"), ("in band 93 %", "93 %"), ("is 1.19 σ", "1.19")]),
    ("reproductions/003.md", "study003.md", [("44 m", "44.4"), ("26 m per axis", "[25.6]")]),
    ("reproductions/004.md", "study004.md",
     [("0.186 against 0.294", "0.186"), ("0.294 km; EKF", "0.294"), ("0.845 against", "0.845"),
      ("1.985 km", "1.985"), ("0.19 against", "0.189"), ("0.61 km", "0.610"),
      ("GEO 0.95", "0.95 / 1.69"), ("1.93", "1.93 / 17.70"), ("5.03 / 22.28", "5.03 / 5.08"),
      ("22.28", "22.28 / 22.96"), ("5.65 d", "5.65 / 6.55"), ("day 0.89", "0.89"), ("0.95 d (EKF)", "0.95"),
      ("1.76 d (LinCov)", "1.76"), ("DOP 113", "112.66"), ("377", "376.75")]),
    ("reproductions/004.md", "study004_snc.md", [("1.9–4.8", "1.94"), ("–4.8,", "4.76"), ("(81–82 %", "81 %"),
                                                  ("48–58 %", "48 %"), ("28–60 %", "28 %")]),
    ("reproductions/004.md", "study004_plain_ekf.md", [("10, 7, 0", "10/10"), ("7, 0 /", "7/10"),
                                                        ("6, 6 (", "6/10")]),
    ("reproductions/004.md", "study004_cr_state.md", [("(0.059 km) < GEO", "0.059 / 0.081"),
                                                       ("(0.079 km)", "0.079 / 0.088"), ("(0.483 km", "0.483 / 0.487"),
                                                       ("error/σ 0.73", "0.73, 0.78"), ("band 73 %", "73 %"),
                                                       ("(51–54 %)", "51 %"), ("–54 %)", "54 %")]),
]


@pytest.mark.parametrize("page, reference, quotes", QUOTED)
def test_numbers_quoted_from_reference_outputs(page, reference, quotes):
    text = " ".join((DOCS / page).read_text().split())  # a quote may wrap across lines
    ref = (REFERENCE / reference).read_text()
    assert f'--8<-- "results/reference/{reference}"' in text, "the page includes the reference file"
    for shown, value in quotes:
        assert shown in text, shown
        assert value in ref, value
        shown_number, value_number = (re.search(r"\d[\d,.]*", s).group(0).replace(",", "") for s in (shown, value))
        decimals = len(shown_number.split(".")[1]) if "." in shown_number else 0
        assert abs(float(shown_number) - float(value_number)) <= 0.5 * 10**-decimals + 1e-9, (shown, value)


# --- output tables: the documented columns are the written ones ---------------------------------------------


def documented_columns(stem: str) -> dict[str, str]:
    """outputs.md's `### \\`stem.parquet\\`` table: column -> its 'when' cell."""
    text = (DOCS / "outputs.md").read_text()
    start = text.index(f"### `{stem}.parquet`")
    columns = {}
    for line in text[start:].splitlines()[1:]:
        if line.startswith("### ") or line.startswith("## "):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("| `") and len(cells) == 4:
            for name in re.findall(r"`([^`]+)`", cells[0]):
                columns[name] = cells[2]
    return columns


def expected_columns(stem: str, active: set[str], grid_keys=()) -> set[str]:
    documented = documented_columns(stem)
    expected = {name for name, when in documented.items() if when in active and not name.startswith("<")}
    if "<grid key>" in documented:
        expected |= set(grid_keys)
    if stem == "curve":  # one row stands for four statistics of each always-present metric
        for stat in ("mean", "median", "p10", "p90"):
            expected |= {f"{metric}_{stat}" for metric in ("rms_position_m", "rms_velocity_m_s",
                                                         "rms_position_after_day1_m", "rms_velocity_after_day1_m_s")}
    if stem == "runs":  # "every other summary.parquet column"
        expected |= expected_columns("summary", active)
    return expected


ALWAYS = {"always"}
RUN_TABLES = ("summary", "timeseries", "residuals", "links", "consistency", "bias")


def _schema(path) -> set[str]:
    return set(pq.read_schema(path).names)


def test_run_tables_have_the_documented_columns(tmp_path):
    proc = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "2", "--jobs", "1", "--quiet", "--output",
                              tmp_path / "run", "--epoch-states", "1")
    assert proc.returncode == 0, proc.stderr
    for stem in (*RUN_TABLES, "states"):
        assert _schema(tmp_path / "run" / f"{stem}.parquet") == expected_columns(stem, ALWAYS), stem
    assert _schema(tmp_path / "run" / "clocks.parquet") == set()  # no estimated clocks: no columns


def test_smoother_and_gate_columns_are_documented(tmp_path):
    scenario = tmp_path / "smoothed.yaml"
    text = (SCENARIOS / "smoke.yaml").read_text()
    scenario.write_text(text + "filter: {smoother: rts, residual_gate_sigma: 5, empirical_acceleration: "
                        "{sigma_m_s2: 1.0e-8, time_constant_s: 86400}}\n")
    proc = run_cli_in_process("run", scenario, "--runs", "2", "--jobs", "1", "--quiet", "--output", tmp_path / "run")
    assert proc.returncode == 0, proc.stderr
    active = ALWAYS | {"`filter.smoother: rts`", "`filter.residual_gate_sigma` > 0", "`filter.empirical_acceleration`"}
    for stem in ("summary", "timeseries"):
        assert _schema(tmp_path / "run" / f"{stem}.parquet") == expected_columns(stem, active), stem


def test_sweep_tables_have_the_documented_columns(tmp_path):
    proc = run_cli_in_process("sweep", SCENARIOS / "smoke.yaml", "--sigma", "100,200", "--runs", "2", "--jobs", "1",
                   "--quiet", "--output", tmp_path / "sweep")
    assert proc.returncode == 0, proc.stderr
    for stem in ("runs", "curve"):
        expected = expected_columns(stem, ALWAYS, grid_keys=("noise.sigma_m",))
        assert _schema(tmp_path / "sweep" / f"{stem}.parquet") == expected, stem


@pytest.mark.slow
def test_batch_clock_and_study_columns_are_documented(tmp_path):
    """The columns that need slower scenarios: a batch with clock synchronisation, estimated clocks, table3
    and compare."""
    proc = run_cli_in_process("run", SCENARIOS / "nrho_gateway_anchors.yaml", "--runs", "1", "--jobs", "1", "--quiet",
                   "--output", tmp_path / "batch")
    assert proc.returncode == 0, proc.stderr
    active = ALWAYS | {"`estimator: batch`", "`clock_sync`"}
    assert _schema(tmp_path / "batch" / "summary.parquet") == expected_columns("summary", active)
    proc = run_cli_in_process("run", SCENARIOS / "clock_one_way_eml2_lunar.yaml", "--runs", "1", "--jobs", "1", "--quiet",
                   "--output", tmp_path / "clock")
    assert proc.returncode == 0, proc.stderr
    assert _schema(tmp_path / "clock" / "clocks.parquet") == expected_columns("clocks", {"estimated clocks"})
    proc = run_cli_in_process("table3", "--runs", "1", "--jobs", "1", "--quiet", "--output", tmp_path / "table3",
                              "--json")
    assert proc.returncode == 0, proc.stderr
    assert _schema(tmp_path / "table3" / "table3.parquet") == expected_columns("table3", ALWAYS)
    from tests.cli.test_cli_json import _study_rows_are_the_parquets

    printed = _study_rows_are_the_parquets(json.loads(proc.stdout), tmp_path / "table3", "table3")  # docs/json-output.md
    assert printed["runs_per_case"] == 1 and set(printed["ordering_checks"]) and set(printed["tables"]) == {"table3"}
    proc = run_cli_in_process("compare", SCENARIOS / "smoke.yaml", "--runs", "1", "--jobs", "1", "--output", tmp_path / "compare")
    assert proc.returncode == 0, proc.stderr
    assert _schema(tmp_path / "compare" / "compare.parquet") == expected_columns("compare", ALWAYS)


# --- the README stays a newcomer's page --------------------------------------------------------------------


def test_readme_points_to_the_docs_and_keeps_the_two_commands():
    readme = (REPO / "README.md").read_text()
    blocks = re.findall(r"```\n(.*?)```", readme, flags=re.S)
    assert blocks[0].strip() == ("python3 -m venv .venv && . .venv/bin/activate && pip install . && "
                                 "liaison run scenarios/eml2_lunar.yaml")
    assert blocks[1].strip() == "pip install '.[test]' && pytest"
    assert "mkdocs serve" in readme and "docs/" in readme
    for image in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", readme):
        assert (REPO / image).is_file(), image
    assert len(readme.splitlines()) < 120


def test_every_test_file_named_in_prose_exists():
    """README, docs/, the package's docstrings and tools/ cite tests by path (`tests/unit/.../test_x.py`): each
    cited file exists, so a moved or renamed test cannot leave a sentence pointing nowhere."""
    cited = {}
    for path in [REPO / "README.md", REPO / "mkdocs.yml", *DOCS.rglob("*.md"), *(REPO / "liaison_cli").rglob("*.py"),
                 *(REPO / "tools").glob("*.py"), *(REPO / "benchmarks").glob("*.py")]:
        for name in re.findall(r"(?<![\w/])(tests/[\w/]*test_\w+\.py)", path.read_text()):
            cited.setdefault(name, path.relative_to(REPO))
    assert len(cited) >= 15, cited  # the scan itself finds the citations
    missing = {name: str(where) for name, where in cited.items() if not (REPO / name).is_file()}
    assert not missing, missing
