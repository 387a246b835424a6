"""Issue 47's faults, replayed: each as a new user would meet it, in an empty folder, with what the issue saw
beside what liaison says now. Writes results/reference/issue47_faults.md.

    python -m benchmarks.issue47_faults [--output results/reference/issue47_faults.md]

Each case runs the installed `liaison` (this tree's, `python -m liaison_cli`) in a fresh temporary folder and
records its exit code and the last line it printed on stderr (or the check the case makes). The "before" column is
the issue's own account (data, quoted). Faults that need a signal, a lock held by another process or a cluster are
covered by the tests named in the table's last column instead of a replay.
"""

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
OUTPUT = ROOT / "results" / "reference" / "issue47_faults.md"
SMOKE = yaml.safe_load((ROOT / "scenarios" / "smoke.yaml").read_text())


def liaison(folder: Path, *args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "liaison_cli", *map(str, args)], cwd=folder, capture_output=True,
                          text=True, timeout=600, env={**__import__("os").environ, "PYTHONPATH": str(ROOT)})


def last_line(proc) -> str:
    lines = [line for line in proc.stderr.strip().splitlines() if line.strip()]
    return lines[-1] if lines else (proc.stdout.strip().splitlines() or [""])[-1]


def scenario_with(folder: Path, edit) -> Path:
    data = yaml.safe_load(yaml.safe_dump(SMOKE))
    edit(data)
    path = folder / "s.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def by_name(folder):
    proc = liaison(folder, "run", "eml2_lunar", "--runs", "1", "--jobs", "1", "--quiet")
    return proc.returncode, f"{last_line(proc)}; results/eml2_lunar written: {(folder / 'results/eml2_lunar').is_dir()}"


def rerun_keeps_plots(folder):
    liaison(folder, "run", "smoke", "--runs", "1", "--jobs", "1", "--quiet")
    liaison(folder, "plot", "run", "results/smoke")
    proc = liaison(folder, "run", "smoke", "--runs", "1", "--jobs", "1", "--quiet")
    kept = (folder / "results/smoke/plots/errors.png").is_file()
    return proc.returncode, f"plots/ kept: {kept}; {last_line(proc)}"


def nested_yaml(folder):
    path = folder / "deep.yaml"
    path.write_text("name: " + "[" * 5000 + "]" * 5000 + "\n")
    proc = liaison(folder, "validate", path)
    return proc.returncode, last_line(proc)


def tiny_empirical_sigma(folder):
    path = scenario_with(folder, lambda d: d.setdefault("filter", {}).update(
        empirical_acceleration={"sigma_m_s2": 1e-300, "time_constant_s": 3600}))
    proc = liaison(folder, "validate", path)
    return proc.returncode, last_line(proc)


def plot_other_summary(folder):
    import pandas as pd

    (folder / "r").mkdir()
    for name in ("summary", "timeseries", "consistency", "residuals"):
        pd.DataFrame({"a": [1.0]}).to_parquet(folder / "r" / f"{name}.parquet")
    proc = liaison(folder, "plot", "run", "r")
    return proc.returncode, last_line(proc)


def long_name(folder):
    proc = liaison(folder, "validate", scenario_with(folder, lambda d: d.update(name="x" * 300)))
    line = last_line(proc)
    return proc.returncode, f"{line[:60]}...{line[line.index(chr(39), 70) + 1:]}" if "'" in line[70:] else line


def names_by_case(folder):
    def edit(d):
        d["spacecraft"][1]["name"] = "eml2"
        d["links"][0]["transponder"] = "eml2"
    proc = liaison(folder, "validate", scenario_with(folder, edit))
    return proc.returncode, last_line(proc)


def boolean_sigma(folder):
    proc = liaison(folder, "validate", scenario_with(folder, lambda d: d["noise"].update(sigma_m=True)))
    return proc.returncode, last_line(proc)


def api_negative_runs(folder):
    code = ("from liaison_cli import api\ntry:\n    api.run('smoke', runs=-1)\nexcept api.ArgumentError as e:\n"
            "    print(type(e).__name__ + ': ' + str(e))\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=folder, capture_output=True, text=True,
                          env={**__import__("os").environ, "PYTHONPATH": str(ROOT)})
    return proc.returncode, proc.stdout.strip()


def jobs_cap(folder):
    proc = liaison(folder, "run", "eml2_lunar", "--runs", "160", "--jobs", "16", "--quiet", "--output", "j")
    notes = [line for line in proc.stderr.splitlines() if "--jobs 16" in line]
    return proc.returncode, notes[0] if notes else f"(on this machine's cores no cap applies) {last_line(proc)}"


def dask_nothing_answers(folder):
    proc = liaison(folder, "run", "smoke", "--runs", "2", "--backend", "dask", "--scheduler", "tcp://127.0.0.1:9",
                   "--scheduler-timeout", "2")
    return proc.returncode, last_line(proc)


CASES = [
    ("shipped scenario by name in an empty folder", "exit 2, 'no such scenario file'", by_name,
     "tests/cli/test_cli_root.py"),
    ("a rerun and the plots another command made", "plots/ and exports silently deleted", rerun_keeps_plots,
     "tests/cli/test_reliability.py"),
    ("a deeply nested YAML file", "RecursionError traceback", nested_yaml, "tests/cli/test_bad_input.py"),
    ("filter.empirical_acceleration.sigma_m_s2: 1e-300", "allowed; every run diverged", tiny_empirical_sigma,
     "tests/cli/test_bad_input.py"),
    ("plot run on a folder whose tables are another table", "traceback", plot_other_summary,
     "tests/cli/test_cli_plot_run.py"),
    ("a 300-character name", "passed validation, failed after setup", long_name, "tests/cli/test_bad_input.py"),
    ("spacecraft EML2 and eml2", "export files collide on case-insensitive file systems", names_by_case,
     "tests/cli/test_bad_input.py"),
    ("noise.sigma_m: true", "read as 1", boolean_sigma, "tests/cli/test_bad_input.py"),
    ("Python API runs=-1", "an empty result", api_negative_runs, "tests/test_python_api.py"),
    ("--jobs 16 on 2 cores", "17 processes, 3.4 GB", jobs_cap, "tests/unit/campaign/test_fanout.py"),
    ("a dask scheduler address where nothing listens", "'answered, but not as a dask scheduler'",
     dask_nothing_answers, "tests/cli/test_faults.py"),
]
COVERED_BY_TESTS = [
    ("run --overwrite while a sweep writes the folder", "the sweep died with a KeyError traceback",
     "tests/cli/test_reliability.py, tests/unit/storage/test_durability.py"),
    ("a TDM with TIMETAG_REF = TRANSMIT", "read as receive time, exit 0", "tests/cli/test_exchange.py"),
    ("SIGTERM during a campaign; SIGKILL of the parent", "exit 143, no message, pool alive 120 s later",
     "tests/cli/test_interrupts.py"),
    ("ric.png's error RMS against the run text's", "2-5 % apart under one label", "tests/cli/test_cli_plot_run.py"),
    ("NaN / inf values in a TDM", "dropped without a word", "tests/cli/test_exchange.py"),
    ("a 600 MB OEM", "refused only after it was read", "tests/cli/test_exchange.py"),
]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=OUTPUT)
    args = parser.parse_args(argv)
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    lines = [f"Written by `python -m benchmarks.issue47_faults` at commit {commit}; do not edit by hand. Each case in a "
             "new empty folder; 'now' is the exit code and the last line liaison printed on stderr (or the check "
             "named).", "", "| fault | before (issue 47) | exit now | now | test |", "|---|---|---|---|---|"]
    for label, before, case, test in CASES:
        with tempfile.TemporaryDirectory() as folder:
            try:
                code, text = case(Path(folder))
            except Exception as exc:  # noqa: BLE001 - a replay that breaks is itself a finding
                code, text = "-", f"the replay failed: {type(exc).__name__}: {exc}"
        lines.append(f"| {label} | {before} | {code} | {text.replace('|', '/')} | {test} |")
        print(lines[-1], flush=True)
    lines += ["", "Not replayed here (a signal, a lock held by another process): their tests.", "",
              "| fault | before (issue 47) | test |", "|---|---|---|",
              *[f"| {label} | {before} | {test} |" for label, before, test in COVERED_BY_TESTS]]
    args.output.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
