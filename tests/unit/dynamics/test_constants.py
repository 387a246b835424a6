"""Physical constants live in dynamics/constants.py only: no other module gives a number to a name of a
physical constant (the speed of light, a GM, a body's radius, an epoch), so two values of one constant
cannot drift apart; where two values are meant (the CRTBP's and DE421's Earth GM), constants.py names both."""

import ast
import re
from pathlib import Path

import pytest

import liaison_cli
from liaison_cli.dynamics import constants

PACKAGE = Path(liaison_cli.__file__).parent
PHYSICAL_NAME = re.compile(r"SPEED_OF_LIGHT|(^|_)C_M_S$|(^|_)GM(_|$)|RADIUS|^R_[A-Z]+_KM$|J2000|^AU_KM$|OBLIQUITY|"
                           r"SOLAR_FLUX|GEOSTATIONARY_ALTITUDE|SECONDS_PER_DAY")


def _is_number(node) -> bool:
    """A numeric literal, or arithmetic of numeric literals only (e.g. 35786.03e3, 1.0 / 298.257)."""
    if isinstance(node, ast.Constant):
        return isinstance(node.value, (int, float)) and not isinstance(node.value, bool)
    if isinstance(node, ast.UnaryOp):
        return _is_number(node.operand)
    if isinstance(node, ast.BinOp):
        return _is_number(node.left) and _is_number(node.right)
    if isinstance(node, ast.Dict):
        return bool(node.values) and all(_is_number(v) for v in node.values)
    return False


def constants_defined_outside(package_root: Path) -> list[str]:
    found = []
    for path in sorted(package_root.rglob("*.py")):
        if path.relative_to(package_root).as_posix() == "dynamics/constants.py":
            continue
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.Assign) and _is_number(node.value):
                found += [f"{path.relative_to(package_root)}: {t.id}" for t in node.targets
                          if isinstance(t, ast.Name) and PHYSICAL_NAME.search(t.id)]
    return found


def test_physical_constants_are_defined_in_constants_only():
    assert constants_defined_outside(PACKAGE) == []


@pytest.mark.parametrize("text", ["SPEED_OF_LIGHT_M_S = 299792458.0\n", "R_EARTH_KM = 6378.1366\n",
                                  "GM_KM3_S2 = {399: 398600.436233}\n", "EARTH_RADIUS_M = 6371.0 * 1e3\n"])
def test_the_check_catches_a_second_definition(tmp_path, text):
    (tmp_path / "radio").mkdir()
    (tmp_path / "radio" / "link.py").write_text(text)
    assert len(constants_defined_outside(tmp_path)) == 1


def test_the_two_earth_gms_are_the_intended_ones():
    """The CRTBP's pair fixes mu and TU; the dated model uses DE421's own Earth (2.1e-9 apart)."""
    assert constants.GM_EARTH_KM3_S2 == 398600.4354
    assert constants.DE421_GM_KM3_S2[399] == 398600.436233
    assert constants.DE421_GM_KM3_S2[399] / constants.GM_EARTH_KM3_S2 - 1.0 == pytest.approx(2.09e-9, abs=0.01e-9)
    assert constants.SPEED_OF_LIGHT_KM_S * 1e3 == constants.SPEED_OF_LIGHT_M_S == 299792458.0
