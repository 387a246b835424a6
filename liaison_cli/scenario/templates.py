"""Starting scenarios for `liaison new NAME.yaml --from KIND`: commented YAML files in templates/, each small
enough to run in seconds as written, each saying in its comments what to change for a real study."""

import re
from pathlib import Path

from liaison_cli.errors import LiaisonError, OutputExistsError
from liaison_cli.scenario.spec_base import NAME_PATTERN
from liaison_cli.storage import write_text_atomic

TEMPLATE_DIR = Path(__file__).with_name("templates")
TEMPLATES = {
    "crosslink-pair": "EML2 halo + lunar orbiter, crosslink range, CRTBP (EKF)",
    "network": "star of three spacecraft around an EML2 hub, CRTBP (EKF; one word to a mesh)",
    "nrho-batch": "NRHO Gateway + 2 anchors, dual one-way range + range-rate and clocks, batch least squares",
    "dated-dsn": "dated DE421 + SRP EML1 / EML2 halos, crosslink + Goldstone range / range-rate (EKF)",
    "tdoa-pair": "EML2 halo transmitter located by TDoA + FDoA at a GEO receiver pair, dated (EKF)",
    "lunar-relay": "NRHO relay + 100 km polar orbiter, range + range-rate, GRGM1200A lunar field (EKF)",
}
_NAME_LINE = re.compile(r"^name: .*$", re.MULTILINE)


def template_text(kind: str) -> str:
    if kind not in TEMPLATES:
        raise LiaisonError(f"--from {kind!r}: no such template; allowed: {', '.join(TEMPLATES)}")
    return (TEMPLATE_DIR / f"{kind}.yaml").read_text(encoding="utf-8")


def new_scenario(path: Path, kind: str) -> str:
    """Write template `kind` to `path` (never over an existing file), named after the file's stem when that
    is a valid scenario name; returns the scenario's name."""
    text = template_text(kind)
    path = Path(path)
    if path.exists() or path.is_symlink():
        raise OutputExistsError(f"{path}: already exists; allowed: a new file name (liaison new never "
                                "overwrites a file)")
    if path.suffix not in (".yaml", ".yml"):
        raise LiaisonError(f"{path}: a scenario file name ends in .yaml or .yml")
    name = _NAME_LINE.search(text).group(0)[len("name: "):]
    if re.fullmatch(NAME_PATTERN, path.stem):
        name = path.stem
        text = _NAME_LINE.sub(f"name: {name}", text, count=1)
    write_text_atomic(text, path)
    return name
