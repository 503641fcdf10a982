"""Golden baselines: the results of every command, pinned bit for bit (as pymoo's ``tests/golden``).

Each case runs ``tdcr`` commands in a fresh interpreter (as a user's run is), reads what they printed and wrote,
drops what legitimately changes from run to run (times, dates, versions, paths) and compares the rest with
``tests/golden/NAME.json``.
A reshape of the code must leave every case identical. A change that is meant to move results (a better
solver, a fixed bug) regenerates them, and its commit says which moved and why::

    python tests/test_golden.py            # rewrite every baseline
    python tests/test_golden.py solve_pcc  # or only some

Another CPU or another version of NumPy, Numba or LLVM may compute other last bits (docs/conventions.md, "Repeatable
runs"). Each baseline records the installation it was made on; on the same one
the comparison is exact. On another, floats are compared to 1e-9 relative and arrays by their values rather than
their hashes, and the test says so in its output. The chaotic cases (:data:`CHAOTIC`: a genetic algorithm, a
boundary search, a design study) amplify a last bit into another trajectory: on another CPU they reach other
samples and another optimum, so there only their structure is compared (every key of the baseline's records, at
every depth, and no other key), and the test says so.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import math
import platform
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = Path(__file__).resolve().parent / "golden"
EXAMPLES = ROOT / "examples"

PAPER_WRENCH = ["--tip-force=0.1,0.1,-0.1", "--tip-moment=-0.1,0.1,0.1"]
#: keys that change between runs of the same inputs: times, dates, machine, versions, paths
VOLATILE = re.compile(r"(second|^ms_|_ms(_|$)|time|^started$|^finished$|^ended$|^host$|^pid$|version|^python$|"
                      r"^pytdcr$|^numpy$|^numba$|^command$|^argv$|^cwd$|^executor$|^study_file$)")
#: relative tolerance of floats on another installation (its compiled code may round otherwise)
OTHER_INSTALLATION_RTOL = 1e-9


def installation() -> dict[str, str]:
    """What the compiled results depend on: the CPU and the numeric stack's versions."""
    import llvmlite
    import numba
    import scipy

    cpu = ""
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith(("model name", "flags")):
                cpu += line.split(":", 1)[1].strip() + ";"
            if line.startswith("flags"):
                break
    return {"machine": platform.machine(), "python": platform.python_version(), "numpy": np.__version__,
            "scipy": scipy.__version__, "numba": numba.__version__, "llvmlite": llvmlite.__version__,
            "cpu": hashlib.sha256(cpu.encode()).hexdigest()[:16]}


# ---------------------------------------------------------------- reading what a command produced
def scrub(data: Any) -> Any:
    """``data`` without its volatile keys, recursively."""
    if isinstance(data, dict):
        return {k: scrub(v) for k, v in data.items() if not VOLATILE.search(str(k))}
    if isinstance(data, list):
        return [scrub(v) for v in data]
    return data


def read_csv(path: Path) -> dict[str, Any]:
    """A CSV's columns (volatile ones dropped), as text: the files' own digits are what is pinned."""
    rows = list(csv.reader(path.read_text().splitlines()))
    keep = [k for k, name in enumerate(rows[0]) if not VOLATILE.search(name)]
    return {"columns": [rows[0][k] for k in keep], "rows": [[r[k] for k in keep] for r in rows[1:]]}


def read_npz(path: Path) -> dict[str, Any]:
    """Every array of an NPZ file: shape, dtype, a hash of its bytes and its values (for another installation)."""
    out = {}
    with np.load(path) as z:
        for key in sorted(z.files):
            a = z[key]
            out[key] = {"shape": list(a.shape), "dtype": str(a.dtype),
                        "sha256": hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest(),
                        "values": _values(a)}
    return out


def _values(a: np.ndarray) -> Any:
    """An array's values for the comparison on another installation: all of them when small, else a summary."""
    if a.dtype.kind not in "fiub":
        return [str(x) for x in a.ravel()]
    if a.size <= 400:
        return a.tolist()
    f = a.astype(float)
    return {"sum": float(np.nansum(f)), "min": float(np.nanmin(f)), "max": float(np.nanmax(f)),
            "finite": int(np.isfinite(f).sum())}


def read_folder(folder: Path, skip: tuple[str, ...] = ()) -> dict[str, Any]:
    """Every data file of a run's folder, recursively: JSON, CSV, NPZ, TOML and meshes (figures, HTML and the
    Markdown reports, which only word the JSON's numbers next to times, aside)."""
    out: dict[str, Any] = {}
    for path in sorted(folder.rglob("*")):
        rel = path.relative_to(folder).as_posix()
        if not path.is_file() or rel.endswith(skip) or path.name.startswith("."):
            continue
        if path.suffix == ".json":
            out[rel] = scrub(json.loads(path.read_text()))
        elif path.suffix == ".csv":
            out[rel] = read_csv(path)
        elif path.suffix == ".npz":
            out[rel] = read_npz(path)
        elif path.suffix == ".toml":
            out[rel] = path.read_text()
        elif path.suffix == ".ply":
            out[rel] = {"sha256": hashlib.sha256(path.read_bytes()).hexdigest()}
    return out


def run_tdcr(args: list[str]) -> tuple[int, str]:
    """``tdcr ARGS`` in this process: exit status and standard output."""
    from pytdcr.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
        code = main(args)
    return code, buf.getvalue()


# ---------------------------------------------------------------- the cases
SOLVE_CASES = {
    "tendons only": ["--tensions", "3,0,0,0,2,0,0,0"],
    "paper wrench": ["--tensions", "4,0,0,0,2,0,0,0", *PAPER_WRENCH],
    "paper wrench, other tendons": ["--tensions", "0,7.5,0,1.25,0,0,12,3", *PAPER_WRENCH],
    "heavy": ["--tensions", "18,2,0,9,0,14,1,6", *PAPER_WRENCH],
    "snap-through": ["--tensions", "11.4,6.4,11.9,6.8,7.8,17.8,4.5,12.5", *PAPER_WRENCH],
    "fallback": ["--tensions", "8.8,19.1,10,8.5,12.4,19.9,19,9.2", *PAPER_WRENCH],
    "not converged": ["--tensions", "6.8,0,9.7,12.2,1.9,4.8,16.1,16.8", *PAPER_WRENCH],
    "constant friction, releasing": ["--tensions", "5,0,2,0,6,1,0,0", "--friction", "0.1", "--release"],
    "no gravity, tip force": ["--tensions", "2,2,0,0,1,0,3,0", "--no-gravity", "--tip-force=0.2,0,0"],
    "rao": ["--robot", "rao", "--tensions", "4,0,0,0,2,0"],
}


def _solve_case(model: str) -> Callable[[Path], dict[str, Any]]:
    def run(_tmp: Path) -> dict[str, Any]:
        out = {}
        for name, args in SOLVE_CASES.items():
            extra = ["--friction", "none"] if model == "cosserat" and "--friction" not in args else []
            if model == "cosserat" and "--friction" in args:
                args = [a for a in args if a not in ("--friction", "0.1", "--release")]
                extra = ["--friction", "none"]
            code, text = run_tdcr(["solve", "--model", model, *args, *extra, "--json"])
            out[name] = {"exit": code, "result": scrub(json.loads(text))}
        return out
    return run


def _sample(tmp: Path) -> dict[str, Any]:
    code, _ = run_tdcr(["sample", "--n", "40", "--seed", "3", *PAPER_WRENCH, "--out", str(tmp / "s")])
    return {"exit": code, "files": read_folder(tmp / "s")}


def _sample_sscr(tmp: Path) -> dict[str, Any]:
    code, _ = run_tdcr(["sample", "--n", "6", "--seed", "2", "--model", "sscr", "--out", str(tmp / "s")])
    return {"exit": code, "files": read_folder(tmp / "s")}


def _workspace(tmp: Path) -> dict[str, Any]:
    code, _ = run_tdcr(["workspace", "--n", "200", "--seed", "5", "--directions", "4", "--budget", "1500",
                        *PAPER_WRENCH,
                        "--out", str(tmp / "w")])
    return {"exit": code, "files": read_folder(tmp / "w")}


def _optimize(tmp: Path) -> dict[str, Any]:
    code, text = run_tdcr(["optimize", "--pop", "12", "--max-gen", "4", "--seed", "1", *PAPER_WRENCH, "--json"])
    return {"exit": code, "result": scrub(json.loads(text))}


def _compare(tmp: Path) -> dict[str, Any]:
    code, _ = run_tdcr(["compare", "--n", "6", "--seed", "2", "--models", "pcc,pcc2,cosserat", "--out",
                        str(tmp / "c")])
    return {"exit": code, "files": read_folder(tmp / "c")}


def _designs(tmp: Path) -> dict[str, Any]:
    code, _ = run_tdcr(["designs", str(EXAMPLES / "design_study_small.toml"), "--workers", "2", "--no-figures",
                        "--out", str(tmp / "d")])
    return {"exit": code, "files": read_folder(tmp / "d", skip=("timings.csv", ".parquet"))}


def _reproduce(tmp: Path) -> dict[str, Any]:
    """The paper's study at reduced settings (the demo's own run is ``tdcr reproduce``; its numbers, at full
    settings, are compared by the slow case below)."""
    from pytdcr import paper_robot
    from pytdcr.runs import ReproduceSettings, run_reproduce

    settings = ReproduceSettings(pops=(8, 10), n_samples=12, max_gen=3, bound_uppers=(5.0,), side_max_gen=2,
                                 workspace_n=32, workspace_budget=200)
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        run_reproduce(paper_robot(), tmp / "r", seed=0, settings=settings)
    return {"files": read_folder(tmp / "r")}


def _reproduce_demo(tmp: Path) -> dict[str, Any]:
    code, _ = run_tdcr(["reproduce", "--out", str(tmp / "r")])
    return {"exit": code, "files": read_folder(tmp / "r")}


CASES: dict[str, Callable[[Path], dict[str, Any]]] = {
    **{f"solve_{m}": _solve_case(m) for m in ("pcc", "pcc2", "sscr", "cosserat")},
    "sample": _sample, "sample_sscr": _sample_sscr, "workspace": _workspace, "optimize": _optimize,
    "compare": _compare, "designs": _designs, "reproduce": _reproduce, "reproduce_demo": _reproduce_demo,
}
SLOW = {"reproduce_demo", "reproduce", "designs", "workspace", "optimize"}
#: cases whose results depend on the last bits of every solve (seen: another CPU's flags move all five)
CHAOTIC = {"workspace", "optimize", "designs", "reproduce", "reproduce_demo"}


def _keys(data: Any, where: str, out: set[str]) -> set[str]:
    """Every dictionary key path in ``data`` (list items merged: their count may differ)."""
    if isinstance(data, dict):
        for k, v in data.items():
            out.add(f"{where}.{k}")
            _keys(v, f"{where}.{k}", out)
    elif isinstance(data, list):
        for v in data:
            _keys(v, f"{where}[]", out)
    return out


# ---------------------------------------------------------------- comparing
def _differences(got: Any, want: Any, where: str, exact: bool, out: list[str]) -> None:
    if len(out) > 20:
        return
    if isinstance(want, dict) and isinstance(got, dict):
        if exact and "sha256" in want and "values" in want:
            if got.get("sha256") != want["sha256"]:
                out.append(f"{where}: array bytes differ")
            return
        for k in sorted(set(want) | set(got)):
            if k not in got or k not in want:
                out.append(f"{where}.{k}: {'missing' if k not in got else 'not in the baseline'}")
            elif not exact and k == "sha256":
                continue
            else:
                _differences(got[k], want[k], f"{where}.{k}", exact, out)
    elif isinstance(want, list) and isinstance(got, list):
        if len(got) != len(want):
            out.append(f"{where}: length {len(got)}, baseline {len(want)}")
            return
        for k, (g, w) in enumerate(zip(got, want, strict=True)):
            _differences(g, w, f"{where}[{k}]", exact, out)
    elif isinstance(want, float) and isinstance(got, (int, float)) and not isinstance(got, bool):
        same = got == want or (math.isnan(got) and math.isnan(want)) if exact else (
            math.isclose(got, want, rel_tol=OTHER_INSTALLATION_RTOL, abs_tol=1e-12))
        if not same:
            out.append(f"{where}: {got!r}, baseline {want!r}")
    elif got != want:
        if not exact and isinstance(want, str) and isinstance(got, str) and _close_numbers(got, want):
            return
        out.append(f"{where}: {str(got)[:120]!r}, baseline {str(want)[:120]!r}")


def _close_numbers(a: str, b: str) -> bool:
    """Two texts equal but for numbers within the other installation's tolerance."""
    pat = r"[-+]?\d*\.?\d+(?:[eE][-+]?\d+)?"
    if re.sub(pat, "#", a) != re.sub(pat, "#", b):
        return False
    return all(math.isclose(float(x), float(y), rel_tol=1e-6, abs_tol=1e-9)
               for x, y in zip(re.findall(pat, a), re.findall(pat, b), strict=True))


def _normalise(data: Any) -> Any:
    """What a baseline holds once written and read back as JSON (tuples as lists, NaN as null)."""
    return json.loads(json.dumps(data, allow_nan=True))


def compute(name: str) -> Any:
    """Run case ``name`` in a fresh interpreter (as a user's ``tdcr`` run is) and return its data."""
    import subprocess

    out = subprocess.run([sys.executable, __file__, "--emit", name], capture_output=True, text=True, check=False)
    assert out.returncode == 0, f"case {name} failed:\n{out.stderr[-3000:]}"
    return json.loads(out.stdout)


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n for n in CASES])
def test_golden(name):
    path = GOLDEN / f"{name}.json"
    assert path.exists(), f"no baseline {path.name}: run python tests/test_golden.py {name}"
    baseline = json.loads(path.read_text())
    got = compute(name)
    exact = baseline["installation"] == installation()
    problems: list[str] = []
    if not exact and name in CHAOTIC:
        got_keys, want_keys = _keys(got, name, set()), _keys(baseline["data"], name, set())
        problems = [f"{k}: missing" for k in sorted(want_keys - got_keys)][:20]
        problems += [f"{k}: not in the baseline" for k in sorted(got_keys - want_keys)][:20]
        assert not problems, f"{name}'s records differ in structure from its baseline:\n" + "\n".join(problems)
        pytest.skip(f"{name} is chaotic and its baseline was made on another installation ({installation()}): "
                    "its structure matches; its values are compared on the baseline's installation only")
    _differences(got, baseline["data"], name, exact, problems)
    how = "bit for bit" if exact else f"to {OTHER_INSTALLATION_RTOL:g} (another installation: {installation()})"
    assert not problems, f"{name} differs from its baseline ({how}):\n" + "\n".join(problems)


def _emit(name: str) -> None:
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        data = _normalise(CASES[name](Path(tmp)))
    sys.stdout.write(json.dumps(data, allow_nan=True))


def write_baselines(names: list[str]) -> None:
    """Run the cases, each in a fresh interpreter, and write their baselines."""
    GOLDEN.mkdir(exist_ok=True)
    for name in names or list(CASES):
        record = {"case": name, "installation": installation(), "data": compute(name)}
        (GOLDEN / f"{name}.json").write_text(json.dumps(record, indent=1, allow_nan=True) + "\n")
        print(f"wrote {name}.json")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--emit"]:
        _emit(sys.argv[2])
    else:
        write_baselines(sys.argv[1:])
