"""The API reference's docstrings: numpydoc's Sphinx roles become cross-references, none is left raw.

``docs/_hooks/griffe_sphinx_roles.py`` is the griffe extension mkdocstrings loads (see mkdocs.yml); these tests
load the package with griffe as the docs build does (static analysis, about a second) and apply it. They are
skipped where the docs extra is not installed.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

# griffe comes with the docs extra (`pip install -e '.[docs]'`, which `make docs` installs)
griffe = pytest.importorskip("griffe")

ROOT = Path(__file__).resolve().parents[1]
HOOK = ROOT / "docs" / "_hooks" / "griffe_sphinx_roles.py"

spec = importlib.util.spec_from_file_location("griffe_sphinx_roles", HOOK)
roles = importlib.util.module_from_spec(spec)
spec.loader.exec_module(roles)


def _load(*, convert: bool) -> griffe.Module:
    extensions = griffe.load_extensions(f"{HOOK}:SphinxRoles") if convert else None
    return griffe.load("pytdcr", search_paths=[str(ROOT / "src")], extensions=extensions,
                       docstring_parser="numpy")


@pytest.fixture(scope="module")
def converted() -> griffe.Module:
    return _load(convert=True)


@pytest.fixture(scope="module")
def original() -> griffe.Module:
    return _load(convert=False)


def _docstrings(pkg: griffe.Module) -> dict[str, str]:
    return {obj.path: obj.docstring.value for obj in roles._objects(pkg) if obj.docstring is not None}


def _convert(obj: griffe.Object, text: str) -> str:
    return roles.convert(text, obj, obj.modules_collection)


def test_the_docstrings_do_use_roles(original):
    # what the extension is for: without it, the reference would show these as raw text
    count = sum(len(roles.ROLE.findall(text)) for text in _docstrings(original).values())
    assert count > 100


def test_no_raw_role_left_in_any_docstring(converted):
    left = {path: roles.RAW_ROLE.findall(text) for path, text in _docstrings(converted).items()}
    assert {path: found for path, found in left.items() if found} == {}


def test_every_reference_names_an_object_of_the_package(converted):
    targets = set()
    for text in _docstrings(converted).values():
        targets.update(re.findall(r'<autoref identifier="([^"]+)" optional>', text))
    assert len(targets) > 100
    missing = [path for path in targets if roles._lookup(converted.modules_collection, path) is None]
    assert missing == []


def test_full_path_with_tilde_shows_the_last_name(original):
    solve = original["statics.equilibrium.solve"]
    assert _convert(solve, "see :data:`~pytdcr.statics.MODELS`.") == (
        'see <autoref identifier="pytdcr.statics.registry.MODELS" optional>`MODELS`</autoref>.'
    )
    # without the tilde the full name is shown, and the link goes to where the object is defined
    assert _convert(solve, ":func:`pytdcr.solve`") == (
        '<autoref identifier="pytdcr.statics.equilibrium.solve" optional>`pytdcr.solve`</autoref>'
    )


def test_names_resolve_from_the_docstrings_scope(original):
    # a name the module imports
    statics = original["statics"]
    assert _convert(statics, ":data:`MODELS`") == (
        '<autoref identifier="pytdcr.statics.registry.MODELS" optional>`MODELS`</autoref>'
    )
    # a sibling method, from a method's docstring, and Class.method from the module
    robot = original["robot"]
    method = next(m for m in robot["Robot"].members.values() if m.is_function and not m.name.startswith("_"))
    assert _convert(method, f":meth:`{method.name}`") == (
        f'<autoref identifier="{method.path}" optional>`{method.name}`</autoref>'
    )
    assert _convert(robot, f":meth:`Robot.{method.name}`") == (
        f'<autoref identifier="{method.path}" optional>`Robot.{method.name}`</autoref>'
    )
    # a leading dot: relative to the enclosing module, then to the packages above
    workspace_module = original["workspace._study"]
    assert _convert(workspace_module, ":func:`._study.workspace_study`") == (
        '<autoref identifier="pytdcr.workspace._study.workspace_study" optional>`._study.workspace_study`</autoref>'
    )


def test_title_target_wrapped_target_and_no_link(original):
    robot = original["robot"]
    assert _convert(robot, ":class:`the robot <Robot>`") == (
        '<autoref identifier="pytdcr.robot.Robot" optional>`the robot`</autoref>'
    )
    assert _convert(robot, ":class:`~pytdcr.robot.\n    Robot`") == (
        '<autoref identifier="pytdcr.robot.Robot" optional>`Robot`</autoref>'
    )
    assert _convert(robot, ":class:`!Robot`") == "`Robot`"


@pytest.mark.parametrize("role", [
    ":func:`numpy.linalg.solve`",  # another package's: not on the site
    ":class:`ValueError`",  # a builtin
    ":func:`no_such_function`",  # a name nobody defines
    ":py:meth:`Robot.no_such_method`",
])
def test_unresolvable_names_become_plain_code(original, role):
    shown = role.split("`")[1]
    assert _convert(original["robot"], f"as {role} does") == f"as `{shown}` does"
