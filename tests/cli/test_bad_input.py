"""Bad input: one line on stderr naming the file and key, exit code 2, no traceback."""

import pytest

from tests.conftest import SCENARIOS, run_cli_in_process

GOOD = (SCENARIOS / "smoke.yaml").read_text()


def _case(tmp_path, text):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    return path


CASES = {
    "malformed_yaml": (GOOD.replace("links:", "links: [oops"), ["malformed YAML", "line"]),
    "unknown_orbit": (GOOD.replace("orbit: eml2_halo", "orbit: eml3_halo"),
                      ["spacecraft[0].orbit", "'eml3_halo'", "eml2_halo", "lunar_keplerian"]),
    "missing_key": (GOOD.replace("  seed: 7\n", ""), ["monte_carlo.seed", "missing"]),
    "empty_section": (GOOD.replace("  interval_s: 187.5\n", ""), ["measurement", "mapping"]),
    "extra_key": (GOOD.replace("noise:\n", "noise:\n  colour: pink\n"), ["noise", "'colour'", "sigma_m"]),
    "negative_sigma": (GOOD.replace("sigma_m: 150", "sigma_m: -150"), ["noise.sigma_m", "-150", "greater than 0"]),
    "zero_interval": (GOOD.replace("interval_s: 187.5", "interval_s: 0"),
                      ["measurement.interval_s", "= 0", "greater than 0"]),
    "unknown_link_spacecraft": (GOOD.replace("transponder: Lunar", "transponder: Gateway"),
                                ["links[0].transponder", "'Gateway'", "EML2, Lunar"]),
    "not_a_mapping": ("- just\n- a list\n", ["YAML mapping"]),
    "bad_type": (GOOD.replace("runs: 2", "runs: many"), ["monte_carlo.runs", "'many'", "integer"]),
    "infinite_sigma": (GOOD.replace("sigma_m: 150", "sigma_m: .inf"), ["noise.sigma_m", "inf", "finite number"]),
    "nan_interval": (GOOD.replace("interval_s: 187.5", "interval_s: .nan"), ["measurement.interval_s", "finite"]),
    "infinite_snc": (GOOD.replace("process_noise_accel_m_s2: 1.0e-10   # per spacecraft",
                                  "process_noise_accel_m_s2: .inf   # per spacecraft"),
                     ["spacecraft[1].process_noise_accel_m_s2", "finite"]),
    # YAML's booleans are no numbers (pydantic alone took true as 1): issue 47.
    "boolean_sigma": (GOOD.replace("sigma_m: 150", "sigma_m: true"), ["noise", "sigma_m: true is a boolean",
                                                                      "allowed: a number"]),
    "boolean_runs": (GOOD.replace("runs: 2", "runs: yes"), ["monte_carlo", "runs: true is a boolean"]),
    # Names become file names (issue 47): a 300-character one failed only after the setup ...
    "long_name": (GOOD.replace("name: smoke", "name: " + "s" * 300), ["name", "at most 64 characters"]),
    # ... and two participants differing only by case wrote colliding export files on macOS and Windows.
    # Issue 47: a deeply nested file (well under the size cap) was a RecursionError traceback.
    "nested_too_deep_to_read": ("a: " + "[" * 3000 + "]" * 3000 + "\n", ["nested too deeply to read",
                                                                        "at most 64 levels"]),
    "nested_deeper_than_allowed": ("a: " + "[" * 80 + "]" * 80 + "\n", ["nested deeper than 64 levels"]),
    # Issue 47: a vanishing empirical-acceleration sigma underflowed in filter units and every run diverged.
    "tiny_empirical_sigma": (GOOD + "filter:\n  empirical_acceleration: {sigma_m_s2: 1.0e-300, "
                             "time_constant_s: 21600}\n",
                             ["empirical_acceleration.sigma_m_s2", "= 1e-300", "greater than or equal to"]),
    "case_duplicates": (GOOD.replace("name: Lunar", "name: eml2").replace("transponder: Lunar", "transponder: eml2"),
                        ["unique, ignoring case", "EML2, eml2"]),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_scenario_gives_one_line_and_exit_2(tmp_path, case):
    """In this process (the loader's message and user_errors' exit are the behaviour), as the tests below."""
    text, expected = CASES[case]
    path = _case(tmp_path, text)
    proc = run_cli_in_process("run", path, "--output", tmp_path / "out")
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("error: ") and str(path) in lines[0]
    for fragment in expected:
        assert fragment in lines[0], (fragment, lines[0])
    assert not (tmp_path / "out").exists()


def test_missing_file(tmp_path):
    proc = run_cli_in_process("run", tmp_path / "nope.yaml")
    assert proc.returncode == 2 and "no such scenario file" in proc.stderr and "Traceback" not in proc.stderr


def test_existing_output_needs_overwrite(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.parquet").write_text("old")
    proc = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--output", out)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1
    assert str(out) in proc.stderr and "--overwrite" in proc.stderr
    assert (out / "summary.parquet").read_text() == "old"
    # --overwrite replaces only what liaison wrote: this folder is not a liaison result.
    proc = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--output", out, "--overwrite", "--runs", "1")
    assert proc.returncode == 2 and "not a liaison result" in proc.stderr
    assert (out / "summary.parquet").read_text() == "old"
    mine = tmp_path / "mine"
    assert run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--output", mine, "--runs", "1").returncode == 0
    proc = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--output", mine, "--overwrite", "--runs", "2")
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine", "out"]  # no staging folder left behind


def test_the_readme_command_runs_twice_and_a_foreign_default_folder_is_kept(tmp_path):
    """Issue 35: `liaison run X` again replaces results/<name> when liaison wrote it (an edit-and-rerun cycle),
    with one note; a folder of that name liaison did not write is refused and kept."""
    import contextlib
    import json
    from types import SimpleNamespace

    from typer.testing import CliRunner

    from liaison_cli.cli import app

    def here(*args):  # the CLI with the working folder in tmp_path (run_cli_in_process works from the repository)
        with contextlib.chdir(tmp_path):
            result = CliRunner().invoke(app, [str(a) for a in args])
        return SimpleNamespace(returncode=result.exit_code, stderr=result.stderr, stdout=result.stdout)

    first = here("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--json")
    second = here("run", SCENARIOS / "smoke.yaml", "--runs", "2", "--json")
    assert first.returncode == 0 and second.returncode == 0, second.stderr
    assert "replacing results/smoke" in second.stderr and "Traceback" not in second.stderr
    assert json.loads(second.stdout)["runs"] == 2
    assert sorted(p.name for p in (tmp_path / "results").iterdir()) == ["smoke"]  # nothing staged left behind
    # Another scenario's run in that folder is not an earlier run of this one: kept, one line.
    other = tmp_path / "other.yaml"
    other.write_text((SCENARIOS / "smoke.yaml").read_text().replace("name: smoke", "name: other_smoke", 1))
    import shutil

    shutil.rmtree(tmp_path / "results" / "smoke")
    assert here("run", other, "--runs", "1", "--output", tmp_path / "results" / "smoke").returncode == 0
    proc = here("run", SCENARIOS / "smoke.yaml", "--runs", "1")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    foreign = tmp_path / "results" / "smoke"

    shutil.rmtree(foreign)
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    proc = here("run", SCENARIOS / "smoke.yaml", "--runs", "1")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert (foreign / "notes.txt").read_text() == "mine"


def test_yaml_tags_are_not_executed(tmp_path):
    """A Python tag in the YAML is refused, not run: the command it names would leave a file behind."""
    marker = tmp_path / "pwned"
    path = _case(tmp_path, f"!!python/object/apply:os.system ['touch {marker}']\n")
    proc = run_cli_in_process("run", path)
    assert proc.returncode == 2 and "malformed YAML" in proc.stderr
    assert not marker.exists()


def test_overwrite_never_deletes_a_folder_whose_files_only_look_like_ours(tmp_path):
    """Issue 35 fault 1: a user's folder with a file named manifest.jsonl was taken for a sweep's and replaced."""
    mine = tmp_path / "mydata"
    mine.mkdir()
    (mine / "thesis.tex").write_text("hi")
    (mine / "manifest.jsonl").write_text("{}\n")
    proc = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "2", "--output", mine, "--overwrite")
    assert proc.returncode == 2 and "not a liaison result" in proc.stderr
    assert (mine / "thesis.tex").read_text() == "hi"
