"""Every path a new user walks from a wheel in an empty folder; writes results/reference/wheel_walk.md.

    python -m benchmarks.wheel_walk [--output results/reference/wheel_walk.md] [--jobs 2] [--timeout 300] [--keep]

1. The committed tree (`git archive HEAD`, so uncommitted edits do not leak in) is unpacked into a temporary
   folder, its commit written where a checkout's build would write it (liaison_cli/build_commit.txt), and
   built into a wheel with `python -m pip wheel --no-deps` (an isolated build: setuptools>=77 from the index).
2. A fresh virtual environment gets `pip install -c constraints.txt 'WHEEL[ccsds]'` (the ccsds extra because
   `liaison export` needs ccsds-ndm; dask, docs and test are not installed).
3. Three groups of cases run that environment's `liaison` (through `bash -c`, so `&&` and pipes work as
   written), each in a new empty working folder, all sharing one fresh LIAISON_CACHE_DIR (numba compiles once;
   LIAISON_TRUTH_CACHE is left unset, i.e. on), each with a timeout after which its process group is killed:
   a. every shipped scenario by name: `liaison validate NAME` (and each shipped link file), `liaison run NAME
      --runs 1 --jobs 1 --quiet --output OUT/NAME`, and the studies by their default scenarios;
   b. every `Example:` / `Examples:` of every command's help (read from the installed package's Typer app),
      one case per `;`-separated example, in one folder: examples that read a `results/...` folder run after
      the others;
   c. every distinct `liaison ...` command of docs/*.md (fenced lines and inline code spans), one folder per page,
      in the page's order; placeholders, bare mentions and commands writing outside the temporary folders are
      listed as skipped.
   In b and c, `--runs N` becomes the smallest value the command accepts (1; 2 for `design`), except that
   every `liaison run` of a group keeps up to K+1 runs, K the largest `liaison export --run K` of the group
   (so the export examples find their run).
4. The tables (exit code, wall seconds, pass/fail with the last stderr line) go to the Markdown output.

--jobs N runs N lanes of cases side by side (group a: every case its own lane; b: one lane; c: one per page).
Measured on the shared 2-core machine with --jobs 2: about 12 minutes in all (build and install 52 s;
groups a, b, c 301, 174 and 179 s); the per-case seconds are in the table.
"""

import argparse
import datetime
import json
import os
import platform
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tarfile
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUTPUT = ROOT / "results" / "reference" / "wheel_walk.md"
EXTRAS = "ccsds"
STUDIES = ("study004", "table3", "study003")
PLACEHOLDER_WORD = re.compile(r"(?<![A-Za-z0-9])[A-Z][A-Z_-]*(?![A-Za-z0-9_-])")

# Run inside the new virtual environment: the command tree of the installed app, and the shipped folder.
INTROSPECT = r"""
import json, typer
from liaison_cli.cli import app
from liaison_cli.scenario.shipped import shipped_dir
def walk(cmd, path):
    subs = getattr(cmd, "commands", None) or {}
    yield {"path": path, "group": bool(subs), "help": cmd.help or "",
           "required": [p.name for p in cmd.params if p.param_type_name == "argument" and p.required],
           "runs_min": next((getattr(p, "min", None) for p in cmd.params if "--runs" in p.opts), None),
           "valued": [o for p in cmd.params if p.param_type_name == "option" and not p.is_flag
                      and not p.count for o in p.opts]}
    for name, sub in subs.items():
        yield from walk(sub, path + [name])
print(json.dumps({"commands": list(walk(typer.main.get_command(app), [])), "shipped": str(shipped_dir())}))
"""


@dataclass
class Case:
    group: str
    label: str
    command: str
    cwd: Path
    lane: str
    skip: str | None = None
    exit: str = "-"
    seconds: float | None = None
    result: str = ""
    notes: list = field(default_factory=list)


# ---------------------------------------------------------------------------------------------- set-up


def sh(args, **kw) -> subprocess.CompletedProcess:
    """A set-up step; its failure stops the benchmark with the step's output."""
    proc = subprocess.run([str(a) for a in args], capture_output=True, text=True, **kw)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, args))} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
    return proc


def build_wheel(work: Path) -> tuple[Path, str]:
    """(the wheel built from HEAD's tree, HEAD's commit)."""
    commit = sh(["git", "-C", ROOT, "rev-parse", "HEAD"]).stdout.strip()
    archive = work / "head.tar"
    sh(["git", "-C", ROOT, "archive", "--format=tar", "-o", archive, "HEAD"])
    snapshot = work / "snapshot"
    with tarfile.open(archive) as tar:
        tar.extractall(snapshot, filter="tar")
    (snapshot / "liaison_cli" / "build_commit.txt").write_text(commit + "\n", encoding="ascii")
    dist = work / "dist"
    sh([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", dist, snapshot], timeout=900)
    (wheel,) = dist.glob("liaison-*.whl")
    return wheel, commit


def make_venv(work: Path, wheel: Path) -> Path:
    """A fresh virtual environment with the wheel (and its ccsds extra) installed under the constraints."""
    venv = work / "venv"
    sh([sys.executable, "-m", "venv", venv])
    sh([venv / "bin" / "python", "-m", "pip", "install", "-q", "-c", ROOT / "constraints.txt",
        f"{wheel}[{EXTRAS}]"], timeout=1800)
    return venv


def user_env(venv: Path, cache: Path) -> dict:
    """The environment of a new user who activated the venv, with the shared fresh cache."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("LIAISON_TRUTH_CACHE", "NUMBA_CACHE_DIR", "PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env.update(PATH=f"{venv / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}", VIRTUAL_ENV=str(venv),
               LIAISON_CACHE_DIR=str(cache))
    return env


def introspect(venv: Path, cwd: Path) -> tuple[dict, Path]:
    """({command path tuple: info}, the installed shipped folder), read from the installed package."""
    proc = sh([venv / "bin" / "python", "-c", INTROSPECT], cwd=cwd)
    data = json.loads(proc.stdout.strip().splitlines()[-1])
    return {tuple(c["path"]): c for c in data["commands"]}, Path(data["shipped"])


# ------------------------------------------------------------------------------- reading a command


def tokens_of(command: str) -> list[str]:
    try:
        return shlex.split(command, comments=True)
    except ValueError:
        return command.split()


def pieces(command: str) -> list[str]:
    """The simple commands of a shell line (split at &&, ||, ;, |), the non-liaison ones included."""
    return [p.strip() for p in re.split(r"&&|\|\||;|\|", command.split(" #")[0]) if p.strip()]


def resolve(tokens: list[str], tree: dict) -> tuple[dict, list[str]]:
    """(the info of the (sub)command a `liaison ...` token list names, the tokens after it)."""
    path, rest = [], []
    for tok in tokens[1:]:
        if all(t.startswith("-") for t in rest) and tuple(path + [tok]) in tree:
            path.append(tok)
        else:
            rest.append(tok)
    return tree[tuple(path)], rest


def positional_and_missing(info: dict, rest: list[str]) -> tuple[list[str], bool]:
    """(the positional arguments among `rest`, whether an option that takes a value lacks it)."""
    positional, missing, i = [], False, 0
    while i < len(rest):
        tok = rest[i]
        if tok in info["valued"]:
            missing |= i + 1 >= len(rest) or rest[i + 1].startswith("--")
            i += 2
            continue
        if not tok.startswith("-"):
            positional.append(tok)
        i += 1
    return positional, missing


def liaison_pieces(command: str, tree: dict):
    """(info, rest) of each `liaison ...` piece of a shell line."""
    for piece in pieces(command):
        toks = tokens_of(piece)
        if toks and toks[0] == "liaison":
            yield resolve(toks, tree)


def not_run_because(command: str, tree: dict, work: Path) -> str | None:
    """Why a command is listed but not run (a placeholder, a bare mention, a write outside the sandbox)."""
    toks = tokens_of(command)
    if any(PLACEHOLDER_WORD.search(t) or t.startswith(("[", "<")) or "..." in t or "…" in t for t in toks):
        return "skipped: placeholder"
    if "--install-completion" in toks:
        return "skipped: would change the shell's profile"
    outside = [t for t in toks if t.startswith("/") and not t.startswith(str(work))]
    if outside:
        return f"skipped: writes outside the temporary folders ({outside[0]})"
    for info, rest in liaison_pieces(command, tree):
        positional, missing = positional_and_missing(info, rest)
        name = " ".join(["liaison", *info["path"]])
        if info["group"] and not rest:
            return f"skipped: mention (`{name}` names a command group)"
        if (info["required"] and not positional) or missing:
            return f"skipped: mention (`{name}` without its {'value' if missing else 'arguments'})"
    return None


def shorten(command: str, tree: dict, run_floor: int) -> str:
    """`--runs N` replaced by the command's smallest accepted value (a `liaison run`: at least run_floor)."""
    out = command
    for piece in pieces(command):
        toks = tokens_of(piece)
        if not toks or toks[0] != "liaison" or not re.search(r"--runs[ =]\d+", piece):
            continue
        info, _ = resolve(toks, tree)
        least = max(info["runs_min"] or 1, run_floor if info["path"] == ["run"] else 1)
        new = re.sub(r"--runs([ =])(\d+)", lambda m: f"--runs{m[1]}{min(int(m[2]), least)}", piece)
        out = out.replace(piece, new, 1)
    return out


def run_floor(commands) -> int:
    """K+1 for the largest `liaison export ... --run K` among the commands (1 without one)."""
    ks = [int(m) for c in commands if "liaison export" in c for m in re.findall(r"--run[ =](\d+)", c)]
    return max(ks, default=0) + 1


def reads_results(command: str, tree: dict) -> bool:
    """The command reads a `results/...` folder an earlier one must have written (not its --output)."""
    for info, rest in liaison_pieces(command, tree):
        values = {rest[i + 1] for i, t in enumerate(rest[:-1]) if t == "--output"}
        if any(t.startswith("results/") and t not in values for t in rest):
            return True
    return False


# --------------------------------------------------------------------------------------------- cases


def group_a(shipped: Path, work: Path) -> list[Case]:
    """validate and run every shipped scenario by name, validate every link file, the studies by default."""
    cwd, out = work / "a-empty", work / "a-out"
    names = sorted(p.relative_to(shipped).with_suffix("").as_posix() for p in shipped.rglob("*.yaml"))
    scenarios = [n for n in names if not n.startswith("links/")]
    cases = [Case("a", f"validate {n}", f"liaison validate {n}", cwd, f"v {n}") for n in names]
    cases += [Case("a", f"run {n}", f"liaison run {n} --runs 1 --jobs 1 --quiet --output {out}/{n.replace('/', '_')}",
                   cwd, f"r {n}") for n in scenarios]
    cases += [Case("a", s, f"liaison {s} --runs 1 --jobs 1 --quiet --output {out}/{s}", cwd, s) for s in STUDIES]
    return cases


def help_examples(help_text: str) -> list[str]:
    """The commands of the `Example:`/`Examples:` paragraph, one per `;`, trailing (comments) dropped."""
    match = re.search(r"(?:^|\n)\s*Examples?:\s*(.*?)(?:\n\s*\n|$)", help_text, re.S)
    if not match:
        return []
    text = " ".join(match[1].split())
    out = []
    for part in re.split(r";\s*(?=liaison\b)", text):
        part = re.sub(r"\s*\([^()]*\)\s*$", "", part.strip().rstrip(";")).strip()
        if part.startswith("liaison "):
            out.append(part)
    return out


def group_b(tree: dict, work: Path) -> list[Case]:
    """Every help example, in one folder; the ones reading a results/ folder after all others."""
    cwd, raw = work / "b-empty", []
    for path, info in tree.items():
        for i, example in enumerate(help_examples(info["help"]), 1):
            raw.append((" ".join(path) or "liaison", i, example))
    floor, seen, first, later = run_floor(c for _, _, c in raw), {}, [], []
    for name, i, example in raw:
        case = Case("b", f"{name} #{i}", example, cwd, "b")
        case.skip = not_run_because(example, tree, work)
        if case.skip is None:
            case.command = shorten(example, tree, floor)
            if case.command in seen:
                case.skip = f"skipped: same command as case {seen[case.command]}"
            seen.setdefault(case.command, case.label)
        if case.skip is None and reads_results(case.command, tree):
            case.notes.append("after the others: reads a results/ folder")
            later.append(case)
        else:
            first.append(case)
    return first + later


def docs_commands(docs: Path) -> list[tuple[str, int, str]]:
    """(page, line, command) of every `liaison ...` line of a fenced block (`$ ` dropped, `\\` lines joined) and
    every inline code span starting with `liaison `, in page order."""
    found = []
    for page in sorted(docs.glob("*.md")):
        fenced, pending = False, None
        for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
            text = line.strip()
            if text.startswith("```"):
                fenced, pending = not fenced, None
                continue
            if not fenced:  # an inline span; one in a heading is marked: it names a section, it is not a step
                mark = INLINE if text.startswith("#") else ""
                found += [(page.name, number, mark + span) for span in re.findall(r"`(liaison [^`]*)`", line)]
                continue
            if pending is not None:
                pending = (pending[0], pending[1], pending[2] + " " + text.rstrip("\\").strip())
            elif text.removeprefix("$ ").startswith("liaison "):
                pending = (page.name, number, text.removeprefix("$ ").rstrip("\\").strip())
            if pending is not None and not text.endswith("\\"):
                found.append(pending)
                pending = None
    return found


INLINE = "\0heading "  # marks a command found in a Markdown heading's code span (docs_commands)


def inline_mention(command: str, heading: bool) -> str | None:
    """Why an inline span is a mention, not a step: it names a section (a Markdown heading: `## \`liaison sweep
    --json\``), or the page names the command in prose with a word after it that says so (\`liaison sweep\` still
    opens ...)."""
    return "skipped: mention (a section's name, or a command named in prose and shown with its arguments elsewhere)" \
        if heading else None


def page_file_missing(command: str, tree: dict, written: set) -> str | None:
    """A scenario file the command names that ships under no such name and no earlier step of the page writes:
    the page shows its YAML for the reader to save (e.g. getting-started's relay.yaml)."""
    for _, rest in liaison_pieces(command, tree):
        for tok in rest:
            if tok.endswith(".yaml") and tok not in written and not (ROOT / "scenarios" / tok.removeprefix(
                    "scenarios/")).is_file():
                return f"skipped: {tok} is the page's own YAML, shown for the reader to save"
    return None


def group_c(tree: dict, work: Path) -> list[Case]:
    """Every distinct docs command (at its first occurrence), one empty folder per page, in the page's order."""
    found, seen, cases, written = docs_commands(ROOT / "docs"), set(), [], set()
    floor = run_floor(c.removeprefix(INLINE) for _, _, c in found)
    # A command the docs also show with arguments: its bare name in prose (`liaison sweep`) is a mention.
    with_arguments = {tuple(info["path"]) for _, _, c in found
                      for info, rest in liaison_pieces(c.removeprefix(INLINE), tree) if rest}
    for page, number, command in found:
        inline = command.startswith(INLINE)
        key = " ".join(command.removeprefix(INLINE).split())
        if key in seen:
            continue
        seen.add(key)
        written |= {tok for tok in tokens_of(key) if tok.endswith(".yaml") and " new " in f" {key} "}
        stem = page.removesuffix(".md")
        case = Case("c", f"{page}:{number}", key, work / f"c-empty-{stem}", f"c {stem}")
        bare = [tuple(info["path"]) for info, rest in liaison_pieces(key, tree) if not rest]
        if len(pieces(key)) == 1 and bare and bare[0] in with_arguments:
            inline = True  # named in prose; shown in full elsewhere
        case.skip = (inline_mention(key, inline) or not_run_because(key, tree, work)
                     or page_file_missing(key, tree, written))
        if case.skip is None:
            case.command = shorten(key, tree, floor)
        cases.append(case)
    return cases


# ------------------------------------------------------------------------------------------ running


def last_line(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1] if lines else ""


def execute(case: Case, env: dict, timeout: float, logs: Path) -> None:
    """Run the case's command with bash in its folder; record exit, seconds and result. Never raises."""
    started = time.perf_counter()
    try:
        case.cwd.mkdir(parents=True, exist_ok=True)
        proc = subprocess.Popen(["bash", "-o", "pipefail", "-c", case.command], cwd=case.cwd, env=env, text=True,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
        try:
            out, err = proc.communicate(timeout=timeout)
            case.exit = str(proc.returncode)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            out, err = proc.communicate()
            case.exit, err = "timeout", (err or "") + f"\ntimeout ({timeout:g} s)"
        case.seconds = time.perf_counter() - started
        slug = re.sub(r"[^A-Za-z0-9.-]+", "_", f"{case.group}-{case.label}")
        (logs / f"{slug}.out").write_text(out or "")
        (logs / f"{slug}.err").write_text(err or "")
        if case.exit == "0":
            case.result = "pass"
        elif case.exit == "timeout":
            case.result = f"fail: timeout after {timeout:g} s"
        else:
            case.result = "fail: " + (last_line(err) or f"(stdout) {last_line(out)}")
    except Exception as exc:  # noqa: BLE001 - a case that cannot even start is a failure, not a crash
        case.seconds = time.perf_counter() - started
        case.exit, case.result = "-", f"fail: {type(exc).__name__}: {exc}"
    print(f"[{case.group}] {case.label}: {case.exit} {case.seconds or 0:.1f} s {case.result[:150]}", flush=True)


def run_group(cases: list[Case], env: dict, timeout: float, jobs: int, logs: Path) -> float:
    """Run the cases (not skipped), each lane in order, `jobs` lanes side by side; the group's wall seconds."""
    lanes: dict[str, list[Case]] = {}
    for case in cases:
        if case.skip is None:
            lanes.setdefault(case.lane, []).append(case)
    for case in cases:
        case.cwd.mkdir(parents=True, exist_ok=True)  # every folder exists, empty, before any case runs
    started = time.perf_counter()
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        for _ in pool.map(lambda lane: [execute(c, env, timeout, logs) for c in lane], lanes.values()):
            pass
    return time.perf_counter() - started


# ------------------------------------------------------------------------------------------ writing

TITLES = {
    "a": ("a. Every shipped scenario by name", "`liaison validate NAME` for every shipped scenario and link file, "
          "`liaison run NAME --runs 1 --jobs 1 --quiet --output OUT/NAME` for every shipped scenario, and the "
          "studies by their default scenarios (`--runs 1 --jobs 1 --quiet --output OUT/STUDY`); NAME as "
          "`liaison warm-up --list` names them (`eml2_lunar`, `004/dro`, `lunar/elfo_pair`), OUT outside the "
          "working folder."),
    "b": ("b. Every `--help` example", "Each `;`-separated command of the `Example:`/`Examples:` paragraph of "
          "every command's help (the installed package's Typer app, subcommands of `orbits` and `plot` "
          "included), run as written in one empty folder shared by the group, in help order, except: `--runs N` "
          "becomes the smallest value the command accepts (1; 2 for `design`), except that every `liaison run` "
          "keeps up to K+1 runs, K the largest `export --run K` of the group (so the export examples find their "
          "run); a trailing `(comment)` is dropped; examples "
          "that read a `results/...` folder run after all others (noted in the case column)."),
    "c": ("c. Every docs command", "Each distinct `liaison ...` command of docs/*.md (lines of fenced blocks, "
          "`$ ` dropped and `\\` continuations joined, and inline code spans), at its first occurrence "
          "(page:line), run as written in one empty folder per page, in the page's order, with the same "
          "`--runs` rule as b. Not run: placeholders (an upper-case word such as RESULT_DIR, or `...`, `…`, "
          "`[`, `<`), mentions (a command without the argument it requires, or an option without its value), "
          "and commands that would write outside the temporary folders or into the shell's profile."),
}


def cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def table(group: str, cases: list[Case], wall: float, work: Path) -> list[str]:
    """The group's Markdown table and totals (the temporary folder shown as OUT/TMP)."""
    title, rule = TITLES[group]
    lines = [f"## {title}", "", rule, "", "| case | command | exit | seconds | result |", "|---|---|---|---|---|"]
    for c in cases:
        label = c.label + "".join(f" ({n})" for n in c.notes)
        seconds = "-" if c.seconds is None else f"{c.seconds:.1f}"
        command = c.command.replace(f"{work}/a-out", "OUT").replace(str(work), "TMP")
        lines.append(f"| {cell(label)} | `{cell(command)}` | {c.exit} | {seconds} | {cell(c.skip or c.result)} |")
    passed = sum(c.result == "pass" for c in cases)
    failed = sum(c.result.startswith("fail") for c in cases)
    skipped = sum(c.skip is not None for c in cases)
    lines += ["", f"Totals ({group}): {passed} passed, {failed} failed, {skipped} skipped of {len(cases)} cases; "
              f"{wall:.0f} s wall for the group.", ""]
    return lines


def header(args, commit: str, venv: Path, setup_s: float, total_s: float) -> list[str]:
    py = subprocess.run([venv / "bin" / "python", "-c", "import platform; print(platform.python_version())"],
                        capture_output=True, text=True).stdout.strip()
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return ["# Wheel walk: every path a new user walks from a wheel in an empty folder", "",
            f"Written by `python -m benchmarks.wheel_walk --jobs {args.jobs} --timeout {args.timeout:g}`; do not "
            f"edit by hand. Measured {when} on {platform.machine()}, {os.cpu_count()} cores (a machine shared with "
            f"other work), Linux {platform.release()}, python {py}. Code: the committed tree of HEAD "
            f"(commit {commit[:12]}, `git archive HEAD`, no uncommitted change), built with `pip wheel --no-deps` "
            f"and installed into a fresh venv with `pip install -c constraints.txt 'liaison-*.whl[{EXTRAS}]'` "
            f"(extras installed: {EXTRAS} only, for `liaison export`; not dask, docs, test). Every case runs that "
            "venv's `liaison` through `bash -o pipefail -c` in new empty working folders (one for group a, one for b, "
            "one per docs page for c; OUT and TMP are temporary folders outside them), with one fresh "
            "LIAISON_CACHE_DIR shared by all cases (so numba compiles once: the first cases carry the compilation) "
            f"and LIAISON_TRUTH_CACHE unset; {args.jobs} case(s) side by side; a case is killed after "
            f"{args.timeout:g} s (\"timeout\"). A case passes on exit 0; for a failure the result is the last line "
            f"on stderr. Build and install: {setup_s:.0f} s; everything: {total_s / 60:.0f} min.", ""]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=OUTPUT)
    parser.add_argument("--jobs", type=int, default=2, help="lanes of cases side by side")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds before a case is killed")
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder (logs/ has every output)")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="wheel_walk-"))
    print(f"work folder: {work}", flush=True)
    try:
        wheel, commit = build_wheel(work)
        venv = make_venv(work, wheel)
        setup_s = time.perf_counter() - started
        env, logs = user_env(venv, work / "cache"), work / "logs"
        logs.mkdir()
        tree, shipped = introspect(venv, work)
        groups = {"a": group_a(shipped, work), "b": group_b(tree, work), "c": group_c(tree, work)}
        walls = {g: run_group(cases, env, args.timeout, args.jobs if g != "b" else 1, logs)
                 for g, cases in groups.items()}
        lines = header(args, commit, venv, setup_s, time.perf_counter() - started)
        for g, cases in groups.items():
            lines += table(g, cases, walls[g], work)
        args.output.parent.mkdir(parents=True, exist_ok=True)
        args.output.write_text("\n".join(lines), encoding="utf-8")
        print(f"wrote {args.output}", flush=True)
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
