"""docs/architecture.md's recipes ("How to add an observable, an estimator or a force") against the code: each
recipe's `Files:` line must name exactly the files where the code keeps what a new one of its kind needs (found by
introspection of the registries, descriptors and term table, not typed here), and the claims each step makes
about those files must hold for every observable, estimator and force term registered today."""

import ast
import inspect
import re
from pathlib import Path

import numpy as np
import pytest

import liaison_cli
from tests.conftest import REPO

PACKAGE = Path(liaison_cli.__file__).parent
DOC = REPO / "docs" / "architecture.md"


def _recipe_files(title: str) -> list[str]:
    """The `Files:` line of the doc's recipe section `### <title>`, as package-relative paths."""
    section = DOC.read_text().split(f"### {title}\n")[1].split("\n## ")[0].split("\n### ")[0]
    line = re.search(r"^Files: (.*?)\.\n\n", section, flags=re.S | re.M).group(1)
    return re.findall(r"`([^`]+)`", line)


def _where(obj) -> str:
    """The package-relative file that defines obj."""
    obj = getattr(obj, "py_func", obj)  # a compiled function: its Python source
    return Path(inspect.getsourcefile(obj)).relative_to(PACKAGE).as_posix()


def _module_of(name: str, module) -> str:
    return Path(module.__file__).relative_to(PACKAGE).as_posix()


# --- an observable ---------------------------------------------------------------------------------------------------

def test_the_observable_recipe_names_the_files_the_code_uses():
    from liaison_cli.measurements import registry
    from liaison_cli.scenario import observed
    from liaison_cli.scenario.links import LinkNoiseSpec
    from liaison_cli.scenario.radio_settings import NoiseSpec

    derived = ["measurements/<name>.py", _where(registry.get_observable), _where(NoiseSpec), _where(LinkNoiseSpec),
               _module_of("CHANNEL_TRACKS", observed)]
    assert _where(registry.residual) == derived[1]  # the dispatch lives beside the table
    assert _recipe_files("Adding an observable") == derived


def _observable_module(observable):
    from liaison_cli.measurements import registry

    for name in dir(registry):
        module = getattr(registry, name)
        if inspect.ismodule(module) and module.__name__.startswith("liaison_cli.measurements.") and any(
                getattr(module, attr, None) is observable for attr in dir(module)):
            return module
    raise AssertionError(f"{observable.name}: no measurements module of the registry defines it")


def test_every_observable_follows_the_recipe():
    """Step 1: each registered observable lives in a module of its own under measurements/ that defines its kind
    codes as KIND_ constants and a compiled predict_ function; step 2: predict dispatches every code (a kind it
    does not know gives NaN); step 3: every noise key its description names is a NoiseSpec field, and every
    LinkNoiseSpec field is one too; step 4: every TDM channel of scenario/observed.py is a registered channel."""
    from liaison_cli.measurements.registry import CHANNEL_KINDS, OBSERVABLES, predict
    from liaison_cli.scenario.links import LinkNoiseSpec
    from liaison_cli.scenario.observed import CHANNEL_TRACKS
    from liaison_cli.scenario.radio_settings import NoiseSpec

    rng = np.random.default_rng(3)
    ends = [np.concatenate([rng.normal(size=3), 0.1 * rng.normal(size=3)]) for _ in range(3)]
    for observable in OBSERVABLES.values():
        module = _observable_module(observable)
        assert Path(module.__file__).parent == PACKAGE / "measurements"
        codes = {value for name, value in vars(module).items() if name.startswith("KIND_")}
        assert {kind.code for kind in observable.channels} <= codes, observable.name
        assert any(name.startswith("predict") for name in vars(module)), observable.name
        for kind in observable.channels:
            value = predict(kind.code, *ends, 0, np.empty(6), np.empty(6), np.empty(6))
            assert np.isfinite(value), (observable.name, kind.label)
        for key in re.findall(r"noise\.(\w+)", observable.description):
            assert key in NoiseSpec.model_fields, (observable.name, key)
    assert np.isnan(predict(max(CHANNEL_KINDS) + 1, *ends, 0, np.empty(6), np.empty(6), np.empty(6)))
    assert set(LinkNoiseSpec.model_fields) <= set(NoiseSpec.model_fields)
    assert set(CHANNEL_TRACKS) <= {kind.label for kind in CHANNEL_KINDS.values()}


# --- an estimator ----------------------------------------------------------------------------------------------------

def test_the_estimator_recipe_names_the_files_the_code_uses():
    from liaison_cli.estimation import estimators
    from liaison_cli.scenario.scenario_model import Scenario

    sections = {e.settings_section for e in estimators.ESTIMATORS.values() if e.settings_section}
    setting_models = {_where(_annotation_class(Scenario, section)) for section in sections}
    assert len(setting_models) == 1, setting_models
    derived = ["estimation/<name>.py", _where(estimators.get_estimator), *setting_models, _where(Scenario)]
    assert _recipe_files("Adding an estimator") == derived


def _annotation_class(model, field: str):
    annotation = model.model_fields[field].annotation
    return next(arg for arg in getattr(annotation, "__args__", (annotation,)) if isinstance(arg, type))


def test_every_estimator_follows_the_recipe():
    """Each registered estimator's entry point and descriptor are in estimation/estimators.py, its numerics in a
    module of estimation/; its settings section is a Scenario field; no module outside estimation/ compares with
    an estimator's name (the rules ask the descriptor)."""
    from liaison_cli.estimation.estimator import Estimator
    from liaison_cli.estimation.estimators import ESTIMATORS
    from liaison_cli.scenario.scenario_model import Scenario

    for name, estimator in ESTIMATORS.items():
        assert isinstance(estimator, Estimator) and _where(estimator.run) == "estimation/estimators.py", name
        if estimator.settings_section:
            assert estimator.settings_section in Scenario.model_fields, name
        if estimator.covariance_record is not None:
            assert _where(estimator.covariance_record) == "estimation/estimators.py", name
    names = set(ESTIMATORS)
    found = []
    for path in PACKAGE.rglob("*.py"):
        relative = path.relative_to(PACKAGE).as_posix()
        if relative.startswith("estimation/"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Compare):
                found += [f"{relative}: compares with {operand.value!r}" for operand in [node.left, *node.comparators]
                          if isinstance(operand, ast.Constant) and operand.value in names]
    assert found == []


# --- a force term ----------------------------------------------------------------------------------------------------

def test_the_force_recipe_names_the_files_the_code_uses():
    from liaison_cli.dynamics import crtbp_field
    from liaison_cli.dynamics.model import crtbp_model
    from liaison_cli.scenario.moon_gravity import MoonGravitySpec
    from liaison_cli.scenario.truth import MODEL_BUILDERS

    callers = [relative for relative in _files_calling("crtbp_model") if relative != "dynamics/model.py"]
    assert callers == [_where(next(iter(MODEL_BUILDERS.values())))], callers  # the truth's builder calls it
    derived = ["dynamics/<term>.py", _where(crtbp_field.added_terms_into), _where(MoonGravitySpec),
               _where(crtbp_model), *callers]
    assert _recipe_files("Adding a force (CRTBP)") == derived


def _files_calling(function: str) -> list[str]:
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text())
        if any(isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", None)) == function
               for node in ast.walk(tree)):
            out.append(path.relative_to(PACKAGE).as_posix())
    return out


@pytest.mark.parametrize("builder", ["j2_term", "harmonics_term"])
def test_every_force_term_has_its_builder_its_branch_and_its_own_module(builder):
    """Each TERM_ kind of dynamics/crtbp_field.py: its `..._term` builder returns it, `added_terms_into` evaluates
    it (2,000 km from the Moon's centre a term's acceleration is finite and not zero: the branch exists), and
    its evaluator lives in a module of its own under dynamics/."""
    from liaison_cli.dynamics import crtbp_field
    from liaison_cli.dynamics.constants import LU_KM, MU
    from liaison_cli.dynamics.lunar_gravity import lunar_field, lunar_j2

    kinds = {value for name, value in vars(crtbp_field).items() if name.startswith("TERM_")}
    assert {name for name in vars(crtbp_field) if name.endswith("_term")} == {"j2_term", "harmonics_term"}
    term = crtbp_field.j2_term(*lunar_j2()) if builder == "j2_term" else crtbp_field.harmonics_term(lunar_field(4))
    assert term[0] in kinds
    params = crtbp_field.crtbp_params(MU, term)
    acc, grad = np.empty(3), np.empty(6)
    crtbp_field.added_terms_into(params, 1.0 - MU + 1200.0 / LU_KM, 1600.0 / LU_KM, 0.0, True, acc, grad)
    assert np.all(np.isfinite(acc)) and np.linalg.norm(acc) > 0.0
    evaluators = {"j2_term": "dynamics/zonal_j2.py", "harmonics_term": "dynamics/spherical_harmonics.py"}
    assert (PACKAGE / evaluators[builder]).is_file()
    source = inspect.getsource(crtbp_field)
    assert evaluators[builder].split("/")[1].removesuffix(".py") in source
