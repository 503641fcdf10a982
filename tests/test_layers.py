"""House rules, checked in the source: layers, imports (at module level: no private module of another package),
function length and parameters, one registry, one atomic write, no import side effects."""

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
    {"validate", "limits", "runtime", "records", "_core"},  # shared: numbers, files, records, threads; compiled core
    {"robot", "loads", "bounds", "paper", "kinematics", "contact", "results", "io"},
    {"statics"},
    {"workspace", "optimize", "compare", "accuracy", "calibrate"},
    {"plotting", "palette"},  # presentation: figures and their shared colours
    {"runs", "designs"},
    {"explore"},  # the local web page (Dash, imported when the app is built)
    {"cli"},
]


def _layer_of(module: str) -> int:
    first = module.split(".")[0]
    for k, names in enumerate(LAYERS):
        if first in names:
            return k
    raise AssertionError(f"module {module} has no layer: add it to LAYERS")


def _name(path: Path) -> str:
    rel = path.relative_to(SRC).with_suffix("")
    parts = [p for p in rel.parts if p != "__init__"]
    return ".".join(parts) or "__init__"


def _is_module(name: str) -> bool:
    rel = Path(*name.split("."))
    return (SRC / rel).with_suffix(".py").exists() or (SRC / rel / "__init__.py").exists()


def _from_imports(path: Path):
    """(module, node) of every ``from <pytdcr module> import ...`` in ``path`` at any depth, the module relative to
    the package and relative imports resolved."""
    pkg = [] if _name(path) == "__init__" else _name(path).split(".")
    if path.name != "__init__.py":
        pkg = pkg[:-1]
    for node in ast.walk(ast.parse(path.read_text())):
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level:
            base = pkg[: len(pkg) - node.level + 1]
            mod = ".".join([*base, node.module] if node.module else base)
        elif node.module and node.module.startswith("pytdcr"):
            mod = node.module.removeprefix("pytdcr").lstrip(".")
        else:
            continue
        yield mod, node


def _imports(path: Path) -> set[str]:
    """pytdcr modules imported by ``path`` (relative imports resolved; ``from pkg import module`` counts the
    module), at any depth of the file."""
    out = set()
    for mod, node in _from_imports(path):
        if mod:
            out.add(mod)
            out |= {f"{mod}.{a.name}" for a in node.names if _is_module(f"{mod}.{a.name}")}
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name.removeprefix("pytdcr.") for a in node.names if a.name.startswith("pytdcr.")}
    return out


@pytest.mark.parametrize("path", MODULES, ids=[_name(p) for p in MODULES])
def test_imports_flow_one_way(path):
    me = _name(path)
    if me in ("__init__", "_version"):
        return
    mine = _layer_of(me)
    for mod in _imports(path):
        if mod in ("__init__", "_version", "", "pytdcr"):
            continue
        theirs = _layer_of(mod)
        assert theirs <= mine, f"{me} (layer {mine}) imports {mod} (layer {theirs})"


def _package_of(module: str, is_package: bool) -> tuple[str, ...]:
    parts = tuple(module.split("."))
    return parts if is_package else parts[:-1]


@pytest.mark.parametrize("path", MODULES, ids=[_name(p) for p in MODULES])
def test_no_module_imports_a_private_module_of_another_package(path):
    """A private module (a part of its name starts with one underscore) is imported only from inside the package
    that holds it: other packages use that package's public names."""
    me = _name(path)
    mine = _package_of(me, path.name == "__init__.py") if me != "__init__" else ()
    for mod in _imports(path):
        parts = mod.split(".")
        for k, part in enumerate(parts):
            if part.startswith("_") and not part.startswith("__"):
                owner = tuple(parts[:k])
                assert mine[: len(owner)] == owner, f"{me} imports the private module {mod} of package {owner}"


def _public_names(package: str) -> set[str] | None:
    """The names a package's ``__init__.py`` lists in ``__all__`` (read from the source), or None without one."""
    init = SRC / Path(*package.split(".")) / "__init__.py"
    if not init.exists():
        return None
    for node in ast.parse(init.read_text()).body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets):
            return {e.value for e in node.value.elts if isinstance(e, ast.Constant)}
    return None


def _imported_names(path: Path):
    """(package, name, line) of every ``from <pytdcr package> import name`` in ``path``, relative ones resolved."""
    for mod, node in _from_imports(path):
        for alias in node.names:
            yield mod, alias.name, node.lineno


@pytest.mark.parametrize("path", MODULES, ids=[_name(p) for p in MODULES])
def test_no_module_imports_a_name_another_package_keeps_private(path):
    """From another package a module takes only the names that package lists in ``__all__`` (or its public
    submodules): the workspace package's dozen public names, not its internals, are what the rest of the code and
    users build on."""
    me = _name(path)
    mine = _package_of(me, path.name == "__init__.py") if me != "__init__" else ()
    for mod, name, line in _imported_names(path):
        if not mod or tuple(mod.split(".")) == mine[: len(mod.split("."))]:
            continue  # the module's own package or one that holds it
        public = _public_names(mod)
        if public is None or _is_module(f"{mod}.{name}") or name == "__version__":
            continue
        assert name in public, f"{me} line {line} imports {name} from {mod}, which does not list it in __all__"


def test_the_workspace_package_keeps_its_public_list_short():
    """The workspace package offers the study, its settings, its result and the result's first parts: about a
    dozen names, where the region alone offered 63; deeper parts are in ``workspace.parts``, the paper's random
    sampling in ``workspace.sampling``."""
    public = _public_names("workspace")
    assert public is not None and len(public) <= 13, sorted(public or ())
    assert not any(n.startswith("_") for n in public)


@pytest.mark.parametrize("path", MODULES, ids=[_name(p) for p in MODULES])
def test_no_function_outside_the_kernels_takes_more_than_8_parameters(path):
    if _is_kernel_module(path):
        return
    for fn in _functions(ast.parse(path.read_text())):
        a = fn.args
        names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
        names += [x.arg for x in (a.vararg, a.kwarg) if x is not None]
        names = [n for n in names if n not in ("self", "cls")]
        assert len(names) <= 8, f"{_name(path)}.{fn.name} takes {len(names)} parameters: {', '.join(names)}"


def test_the_atomic_write_is_written_once():
    """Files are replaced by a rename in one place (:mod:`pytdcr.runtime`), which every writer calls."""
    for path in MODULES:
        if "runtime" in path.relative_to(SRC).parts:
            continue
        text = path.read_text()
        for needle in ("os.replace(", ".replace(out /", "os.rename("):
            assert needle not in text, f"{_name(path)} renames a file itself ({needle}): use pytdcr.runtime"


def test_the_command_line_is_a_package_of_short_modules():
    cli = SRC / "cli"
    assert (cli / "__init__.py").exists(), "the command line is a package"
    for path in sorted(cli.rglob("*.py")):
        lines = len(path.read_text().splitlines())
        assert lines <= 300, f"{path.relative_to(SRC)} has {lines} lines"


def test_core_never_imports_plotting_or_the_command_line():
    for path in MODULES:
        me = _name(path)
        if me.split(".")[0] in ("runs", "designs", "explore", "cli", "plotting"):  # the layers that write results
            continue
        for mod in _imports(path):
            assert mod.split(".")[0] not in ("plotting", "cli", "runs"), f"{me} imports {mod}"
        text = path.read_text()
        assert "import matplotlib" not in text and "from matplotlib" not in text, me


def _functions(tree: ast.AST):
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield node


def _is_kernel_module(path: Path) -> bool:
    """The compiled kernels: ``statics/kernels/*.py``."""
    return "kernels" in path.relative_to(SRC).parts[:-1] or "kernel" in path.name


@pytest.mark.parametrize("path", MODULES, ids=[_name(p) for p in MODULES])
def test_no_function_over_120_lines_outside_kernel_modules(path):
    if _is_kernel_module(path):
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
        "import pytdcr, pytdcr.runs, pytdcr.plotting, pytdcr.workspace, pytdcr.optimize, pytdcr.compare\n"
        "bad = [m for m in ('matplotlib', 'pytdcr.cli') if m in sys.modules]\n"
        "import numba\n"
        "from pytdcr.statics.kernels import loading_path, pcc\n"
        "loaded = [k for k, f in (('solve_range', loading_path.solve_range), ('evaluate', pcc.evaluate))\n"
        "          if f.signatures]\n"
        "print(','.join(bad + loaded))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == ""


def test_importing_the_study_leaves_the_matplotlib_backend_alone():
    code = (
        "import matplotlib\n"
        "matplotlib.use('svg')\n"
        "import pytdcr.runs, pytdcr.plotting\n"
        "from pytdcr.plotting import plot_convergence\n"
        "plot_convergence([1.0], [2.0])\n"
        "print(matplotlib.get_backend())\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "svg"


def test_the_specification_is_in_the_project_and_nothing_points_outside_it():
    """docs/MODEL.md is the specification every "MODEL.md" in the code and docs means; no tracked file points
    to a folder beside the checkout (a user's clone has none)."""
    root = SRC.parents[1]
    if not (root / ".git").exists():
        pytest.skip("not a git checkout: the tracked files are unknown")
    spec = root / "docs" / "MODEL.md"
    assert spec.exists() and "## Appendix" in spec.read_text(encoding="utf-8")
    tracked = subprocess.run(["git", "ls-files"], cwd=root, capture_output=True, text=True, check=True).stdout.split()
    outside = "../" + "shared"
    pointing = [f for f in tracked if (root / f).is_file()
                and outside in (root / f).read_text(encoding="utf-8", errors="ignore")]
    assert not pointing, f"these tracked files point outside the project: {pointing}"
