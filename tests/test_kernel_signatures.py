"""Each compiled function is compiled once per argument types, not once per constant it is called with.

numba types an ``int`` or ``bool`` constant passed from one compiled function to another as a literal
(``Literal[bool](False)``, ``Literal[int](2)``) and compiles the callee again for each such constant: the solver's
Newton iteration was compiled three times per packed model type, about 8 s each, for ``reuse=False`` and two
Jacobian limits. The checks below read the kernels' sources: a call between compiled functions passes no bare
``int`` or ``bool`` constant (a module constant of that kind included); a NumPy scalar (``np.int64(2)``,
``np.bool_(False)``) or a variable computed at run time is typed by its kind alone. Calls to functions inlined
by numba (``inline="always"``) are inlined before typing and may pass constants.
"""

from __future__ import annotations

import ast
import operator
from pathlib import Path

import pytest

from pytdcr.runtime import KERNEL_SOURCES

SRC = Path(__file__).resolve().parents[1] / "src" / "pytdcr"
FILES = sorted({p for pattern in KERNEL_SOURCES for p in SRC.glob(pattern)})


def _decorator(fn: ast.FunctionDef) -> ast.expr | None:
    """The ``njit`` decorator of ``fn`` (bare or called), or None."""
    for dec in fn.decorator_list:
        target = dec.func if isinstance(dec, ast.Call) else dec
        if isinstance(target, ast.Name) and target.id == "njit":
            return dec
    return None


def _inlined(dec: ast.expr) -> bool:
    return isinstance(dec, ast.Call) and any(
        k.arg == "inline" and isinstance(k.value, ast.Constant) and k.value.value == "always" for k in dec.keywords)


def _compiled_functions() -> tuple[set[str], set[str]]:
    """Names of the compiled functions of every kernel source: (called as separate functions, inlined)."""
    separate: set[str] = set()
    inlined: set[str] = set()
    for path in FILES:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and (dec := _decorator(node)) is not None:
                (inlined if _inlined(dec) else separate).add(node.name)
    return separate - inlined, inlined


_OPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Pow: operator.pow,
        ast.LShift: operator.lshift, ast.USub: operator.neg, ast.Invert: operator.invert}


def _constant(node: ast.expr) -> object:
    """The value of a constant expression of plain numbers (``1 << 30``, ``-2``); LookupError for anything else
    (a name, a call such as ``np.int64(2)``)."""
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.UnaryOp):
        return _OPS[type(node.op)](_constant(node.operand))
    if isinstance(node, ast.BinOp):
        return _OPS[type(node.op)](_constant(node.left), _constant(node.right))
    raise LookupError(ast.dump(node))


def _literal_constants() -> set[str]:
    """Module-level names bound to an ``int`` or ``bool`` (numba types them as literals when passed on)."""
    names: set[str] = set()
    for path in FILES:
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.Assign | ast.AnnAssign) and node.value is not None:
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                try:
                    value = _constant(node.value)
                except LookupError:
                    continue
                if isinstance(value, bool | int):
                    names.update(t.id for t in targets if isinstance(t, ast.Name))
    return names


def _is_literal(arg: ast.expr, constants: set[str]) -> bool:
    if isinstance(arg, ast.UnaryOp):
        arg = arg.operand
    if isinstance(arg, ast.Constant):
        return isinstance(arg.value, bool | int)
    return isinstance(arg, ast.Name) and arg.id in constants


def _literal_calls() -> list[str]:
    separate, _ = _compiled_functions()
    constants = _literal_constants()
    found = []
    for path in FILES:
        for fn in ast.walk(ast.parse(path.read_text())):
            if not (isinstance(fn, ast.FunctionDef) and _decorator(fn) is not None):
                continue
            for call in ast.walk(fn):
                if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name) and call.func.id in separate):
                    continue
                args = [*call.args, *(k.value for k in call.keywords)]
                if any(_is_literal(a, constants) for a in args):
                    found.append(f"{path.relative_to(SRC)}:{call.lineno} {fn.name} -> {call.func.id}")
    return found


def test_the_check_finds_compiled_functions_and_constants() -> None:
    separate, inlined = _compiled_functions()
    assert {"newton", "solve_one", "evaluate"} <= separate and "_maxabs" in inlined
    assert "_FOLD_H" not in _literal_constants() and "_ARC_STEPS" in _literal_constants()


@pytest.mark.parametrize("source", ["f(x, False, 2)", "f(x, -1)", "f(x, N)"])
def test_the_check_catches_a_literal(source: str) -> None:
    call = ast.parse(source).body[0].value
    assert any(_is_literal(a, {"N"}) for a in call.args)


def test_no_compiled_call_passes_a_literal() -> None:
    found = _literal_calls()
    assert not found, "calls compiling a copy per constant (pass np.int64(...) / np.bool_(...)):\n" + "\n".join(found)
