"""The commit of an installed copy (tools/build_commit.py, liaison_cli.provenance.recorded_commit): a package built
from a checkout carries the checkout's commit, directly or through an sdist, and `liaison --version --verbose`
prints it from the installed package; built without a checkout it carries none, and says None."""

import os
import shutil
import subprocess
import sys
import tarfile

import pytest

from liaison_cli.provenance import BUILD_COMMIT_FILE, recorded_commit
from tests.conftest import REPO

COMMIT = "fedcba9876543210fedcba9876543210fedcba98"
# What a build reads from the checkout: the build configuration, the hook and the package.
SOURCES = ("pyproject.toml", "MANIFEST.in", "README.md", "tools/build_commit.py")

setuptools = pytest.importorskip("setuptools")


def _setuptools(source, *command):
    """Run a setuptools command in `source` as the PEP 517 backend would (pyproject.toml's configuration)."""
    proc = subprocess.run([sys.executable, "-c", "from setuptools import setup; setup()", "-q", *command],
                          cwd=source, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr


@pytest.fixture
def checkout(tmp_path):
    """A copy of this project's sources with a .git whose branch is at COMMIT (git itself not needed)."""
    source = tmp_path / "checkout"
    for name in SOURCES:
        (source / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(REPO / name, source / name)
    shutil.copytree(REPO / "liaison_cli", source / "liaison_cli",
                    ignore=shutil.ignore_patterns("__pycache__", BUILD_COMMIT_FILE))
    (source / ".git" / "refs" / "heads").mkdir(parents=True)
    (source / ".git" / "HEAD").write_text("ref: refs/heads/main\n")
    (source / ".git" / "refs" / "heads" / "main").write_text(COMMIT + "\n")
    return source


def _version_verbose(package_root):
    """`liaison --version --verbose` run from the package under package_root (an installed copy's layout)."""
    env = {**os.environ, "PYTHONPATH": str(package_root)}
    proc = subprocess.run([sys.executable, "-m", "liaison_cli", "--version", "--verbose"], cwd=package_root,
                          env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    lines = dict(line.split(": ", 1) for line in proc.stdout.splitlines() if ": " in line)
    return lines["git_commit"]


def test_a_package_built_from_a_checkout_carries_its_commit(checkout, tmp_path):
    built = tmp_path / "built"
    _setuptools(checkout, "build_py", "--build-lib", str(built))
    assert recorded_commit(built / "liaison_cli") == COMMIT
    assert not (checkout / "liaison_cli" / BUILD_COMMIT_FILE).exists()  # the checkout itself is left alone
    assert _version_verbose(built) == COMMIT
    shutil.rmtree(checkout / ".git")  # the same build folder, built again without a checkout: no commit
    _setuptools(checkout, "build_py", "--build-lib", str(built))
    assert not (built / "liaison_cli" / BUILD_COMMIT_FILE).exists()
    assert _version_verbose(built) == "None"


def test_a_package_built_from_an_sdist_of_a_checkout_carries_its_commit(checkout, tmp_path):
    _setuptools(checkout, "sdist", "--dist-dir", str(tmp_path / "dist"))
    with tarfile.open(next((tmp_path / "dist").glob("*.tar.gz"))) as archive:
        archive.extractall(tmp_path / "unpacked", filter="data")
    unpacked = next((tmp_path / "unpacked").iterdir())
    assert not (unpacked / ".git").exists()
    _setuptools(unpacked, "build_py", "--build-lib", str(tmp_path / "built"))
    assert recorded_commit(tmp_path / "built" / "liaison_cli") == COMMIT
