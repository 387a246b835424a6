"""Build hooks (pyproject.toml, [tool.setuptools.cmdclass]): the checkout's commit, written into the package built.

liaison reads its commit from the .git beside the package (liaison_cli.provenance.git_commit), which an
editable install has and an installed copy does not: `pip install .` builds a wheel from the checkout and
unpacks it into site-packages. So the build writes the commit into the package, as
liaison_cli/<provenance.BUILD_COMMIT_FILE>, and the record reads it there (provenance.recorded_commit):
- build_py (every wheel): the commit of the checkout being built or, built from an sdist (no .git), the
  commit the sdist carries;
- sdist: the commit, written into the sdist's tree, so a wheel built from the sdist later still has it.
Built without a checkout and without a recorded commit (a source archive without .git), there is no file, and
the record says None. The file goes into the build's output only, never into the checkout, so an editable
install and the tests read the live .git.
"""

import importlib.util
from pathlib import Path

from setuptools.command.build_py import build_py
from setuptools.command.sdist import sdist

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = "liaison_cli"


def _provenance():
    """liaison_cli/provenance.py, loaded from its file: importing the package would import numpy and the rest,
    which an isolated build environment does not have (provenance.py itself imports only the standard library)."""
    spec = importlib.util.spec_from_file_location("_liaison_build_provenance", ROOT / PACKAGE / "provenance.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _write_commit(package_dir: Path) -> None:
    """Write the source's commit into package_dir; without one, leave no file there (not one from an earlier
    build into the same build folder either)."""
    provenance = _provenance()
    commit = provenance.git_commit(ROOT) or provenance.recorded_commit(ROOT / PACKAGE)
    target = package_dir / provenance.BUILD_COMMIT_FILE
    if target.is_file():  # unlinked, not overwritten: sdist hard-links the tree it archives to the source's files
        target.unlink()
    if commit is not None:
        package_dir.mkdir(parents=True, exist_ok=True)
        target.write_text(commit + "\n", encoding="ascii")


class BuildPyWithCommit(build_py):
    """build_py, then the commit written into the built package."""

    def run(self):
        super().run()
        if not getattr(self, "editable_mode", False):  # an editable install runs from the checkout and reads its .git
            _write_commit(Path(self.build_lib) / PACKAGE)


class SdistWithCommit(sdist):
    """sdist, with the commit written into the tree it archives."""

    def make_release_tree(self, base_dir, files):
        super().make_release_tree(base_dir, files)
        _write_commit(Path(base_dir) / PACKAGE)
