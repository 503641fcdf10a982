"""House rules, checked in the source: layers, imports, function length, one registry, no import side effects."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from pytdcr.statics import MODELS

SRC = Path(__file__).resolve().parents[1] / "src" / "pytdcr"
MODULES = sorted(p for p in SRC.rglob("*.py"))

#: layers, lowest first: a module may import only from its own layer or lower ones
LAYERS = [
    {"__init__", "_version"},  # the top-level package re-exports; checked apart below
    {"validate", "design", "loads", "bounds", "paper", "kinematics", "contact", "results", "io", "limits"},
    {"statics"},
    {"workspace", "region", "optimize", "compare", "accuracy"},
    {"plotting"},
    {"study", "designs"},
    {"cli"},
]


def _layer_of(module: str) -> int:
    first = module.split(".")[0]
    for k, names in enumerate(LAYERS[1:], start=1):
        if first in names:
            return k
    raise AssertionError(f"module {module} has no layer: add it to LAYERS")


def _name(path: Path) -> str:
    rel = path.relative_to(SRC).with_suffix("")
    parts = [p for p in rel.parts if p != "__init__"]
    return ".".join(parts) or "__init__"


def _imports(path: Path) -> set[str]:
    """pytdcr modules imported by ``path`` (relative imports resolved), at any depth of the file."""
    tree = ast.parse(path.read_text())
    pkg = _name(path).split(".")
    if path.name != "__init__.py":
        pkg = pkg[:-1]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg[: len(pkg) - node.level + 1]
                mod = ".".join([*base, node.module] if node.module else base)
            elif node.module and node.module.startswith("pytdcr"):
                mod = node.module.removeprefix("pytdcr").lstrip(".")
            else:
                continue
            if mod:
                out.add(mod)
        elif isinstance(node, ast.Import):
            out |= {a.name.removeprefix("pytdcr.") for a in node.names if a.name.startswith("pytdcr.")}
    return out


@pytest.mark.parametrize("path", MODULES, ids=[_name(p) for p in MODULES])
def test_imports_flow_one_way(path):
    me = _name(path)
    if me == "__init__":
        return
    mine = _layer_of(me)
    for mod in _imports(path):
        if mod == "__init__" or mod in ("", "pytdcr"):
            continue
        theirs = _layer_of(mod)
        assert theirs <= mine, f"{me} (layer {mine}) imports {mod} (layer {theirs})"


def test_core_never_imports_plotting_or_the_command_line():
    for path in MODULES:
        me = _name(path)
        if me.split(".")[0] in ("study", "designs", "cli", "plotting"):  # the layer that writes results
            continue
        for mod in _imports(path):
            assert mod.split(".")[0] not in ("plotting", "cli", "study"), f"{me} imports {mod}"
        text = path.read_text()
        assert "import matplotlib" not in text and "from matplotlib" not in text, me


def _functions(tree: ast.AST):
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield node


@pytest.mark.parametrize("path", MODULES, ids=[_name(p) for p in MODULES])
def test_no_function_over_120_lines_outside_kernel_modules(path):
    if "kernel" in path.name:
        return
    for fn in _functions(ast.parse(path.read_text())):
        length = fn.end_lineno - fn.lineno + 1
        assert length <= 120, f"{_name(path)}.{fn.name} has {length} lines"


def test_no_module_but_the_registry_compares_a_model_name():
    names = set(MODELS)
    for path in MODULES:
        if path.name == "registry.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Compare):
                parts = [node.left, *node.comparators]
                consts = [p.value for p in parts if isinstance(p, ast.Constant) and isinstance(p.value, str)]
                for p in parts:
                    if isinstance(p, (ast.Tuple, ast.List, ast.Set)):
                        consts += [e.value for e in p.elts if isinstance(e, ast.Constant)]
                assert not names & set(consts), f"{_name(path)} line {node.lineno} compares a model name"


def test_the_paper_case_is_defined_in_one_module():
    # the paper's tip load appears as numbers only in pytdcr/paper.py
    for path in MODULES:
        if path.name == "paper.py":
            continue
        text = path.read_text().replace(" ", "")
        assert "(0.1,0.1,-0.1)" not in text and "[0.1,0.1,-0.1]" not in text, _name(path)
        assert "def paper_robot" not in text, _name(path)


def test_import_has_no_side_effects():
    code = (
        "import sys, os\n"
        "os.environ.pop('MPLBACKEND', None)\n"
        "import pytdcr, pytdcr.study, pytdcr.plotting, pytdcr.workspace, pytdcr.optimize, pytdcr.compare\n"
        "bad = [m for m in ('matplotlib', 'pytdcr.cli') if m in sys.modules]\n"
        "import numba\n"
        "from pytdcr.statics import _kernels, _solver_kernels\n"
        "loaded = [k for k, f in (('solve_range', _solver_kernels.solve_range), ('evaluate', _kernels.evaluate))\n"
        "          if f.signatures]\n"
        "print(','.join(bad + loaded))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == ""


def test_importing_the_study_leaves_the_matplotlib_backend_alone():
    code = (
        "import matplotlib\n"
        "matplotlib.use('svg')\n"
        "import pytdcr.study, pytdcr.plotting\n"
        "from pytdcr.plotting import plot_convergence\n"
        "plot_convergence([1.0], [2.0])\n"
        "print(matplotlib.get_backend())\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "svg"
