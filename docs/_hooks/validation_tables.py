"""mkdocs hook: the tables of ``validation.md`` rendered from the benchmark results in ``docs/validation/``.

A marker ``<!-- table: NAME -->`` (or ``<!-- table: NAME:VIEW -->`` for one of several tables from the same file)
is replaced by a markdown table built from ``docs/validation/NAME.json``, followed by a line giving the command
that wrote the file, the machine it was measured on (cores, CPU model, load average) and the date. A file
marked ``"carried"`` holds figures documented before and not re-measured; its line says so and where they come
from. A marker naming a missing file, or a view no renderer knows, fails the build with a message naming both.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

try:
    from mkdocs.exceptions import PluginError as _BuildError
except ImportError:  # pragma: no cover - the hook is only run by mkdocs, the tests import it directly
    _BuildError = RuntimeError  # type: ignore[misc,assignment]

DATA = Path(__file__).resolve().parent.parent / "validation"
"""The folder of the JSON files (``docs/validation/``)."""

MARKER = re.compile(r"<!--\s*table:\s*([A-Za-z0-9_-]+)(?::([A-Za-z0-9_-]+))?\s*-->")
"""``<!-- table: NAME -->`` or ``<!-- table: NAME:VIEW -->``."""

Rows = list[list[str]]
NA = "\u2013"
"""What a cell holds without a number (an en dash)."""


class ValidationTableError(_BuildError):  # type: ignore[misc,valid-type]
    """A marker of ``validation.md`` that cannot be rendered (missing file, unknown view, bad content)."""


def _num(x: Any, digits: int = 3) -> str:
    """``x`` to ``digits`` significant digits with thousands separators (NA for None or NaN)."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return NA
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return f"{x:,}"
    x = float(x)
    if abs(x) >= 10 ** (digits - 1):
        return f"{x:,.0f}"
    return f"{x:.{digits}g}"


def _table(header: list[str], rows: Rows) -> str:
    """A markdown table: numbers right-aligned is left to the theme; every column left as written."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def _of(part: int, whole: int) -> str:
    return f"{part:,} of {whole:,}"


# ----------------------------------------------------------------------------------------------- renderers


def _cm3(value: float, error: float) -> str:
    """A volume [cm³] with its error, or, when the error is larger than the value, no value: the run did not
    measure it."""
    if not error < value:
        return f"not measured (error ± {_num(error)} cm³ exceeds the estimate)"
    return f"{_num(value)} ± {_num(error)} cm³"


def _solve_speed(d: dict, view: str | None) -> str:
    c = d["converged_fraction"]
    det = d["detail"]
    if view == "throughput":
        rows = [["friction and gravity, along the loading path", _num(d["throughput_per_s"]), _num(100 * c["d"], 4)],
                ["... with `load_stepping=\"auto\"`", _num(d["throughput_auto_per_s"]), NA],
                ["friction, gravity and the paper's tip load", _num(d["throughput_paper_load_per_s"]),
                 _num(100 * c["d_load"], 4)]]
        return _table([f"`solve_batch`, {d['config']['batch']:,} random tension vectors in [0, 20] N",
                       "solves/s (median of 3)", "converged %"], rows)
    rows = [["start-up: import and load the cached kernels", f"{_num(d['startup_s'])} s", NA, NA]]
    for key, label, conv in (("cold_tendons_ms", "cold solve, tendons only", "a"),
                             ("cold_full_ms", "cold solve, paper friction, gravity and tip load", "b"),
                             ("warm_ms", "warm start from a solved neighbour (tensions moved 2 %)", "c")):
        s = det[key]
        rows.append([label, f"{_num(s['median'])} ms", f"{_num(s['min'])} to {_num(s['max'])} ms",
                     _num(100 * c[conv], 4)])
    return _table(["case (paper robot, `pcc`, one call)", "median", "range", "converged %"], rows)


def _models(d: dict, view: str | None) -> str:
    rows = []
    for case, label in (("friction", "paper's"), ("no friction", "none")):
        for model, r in d.get(case, {}).items():
            if "unsupported" in r:
                reason = r["unsupported"].split(";")[0].strip()
                rows.append([f"`{model}`", label, f"unsupported ({reason})", NA, NA, NA, NA])
                continue
            rows.append([f"`{model}`", label, _num(r["median_ms"]), _num(r["mean_ms"]), _num(r["p90_ms"]),
                         _of(r["converged"], r["cases"]), _num(r["batch_per_s"])])
    return _table(["model", "friction", "median ms", "mean ms", "p90 ms", "converged", "batch solves/s"], rows)


def _convergence(d: dict, view: str | None) -> str:
    rows = []
    for model, laws in d.items():
        if model in ("config", "command", "machine"):
            continue
        for law, r in laws.items():
            contact = r.get("self_contact_rows")
            rows.append([f"`{model}`", law, _of(r["converged"], r["cases"]),
                         "not counted" if contact is None else str(len(contact)),
                         _of(len(r["failed_rows"]), r["cases"]), _num(r["median_ms"]), _num(r["mean_ms"]),
                         _num(r["mean_iterations"]), str(r["converged_out_of_tolerance"])])
    return _table(["model", "friction", "converged", "converged, refused for self-contact", "did not converge",
                   "median ms", "mean ms", "mean iterations", "converged out of tolerance"], rows)


def _continuation(d: dict, view: str | None) -> str:
    s, b = d["single"], d["batch"]
    rows = [["continued from the solved state (`start=`)", _num(s["continued_median_ms"]), _num(s["continued_mean_ms"]),
             _of(s["continued_converged"], s["steps"]), _num(b["continued_per_s"])],
            ["cold, from rest", _num(s["cold_median_ms"]), _num(s["cold_mean_ms"]),
             _of(s["cold_converged"], s["steps"]), _num(b["cold_per_s"])]]
    return (_table([f"`{d['model']}`, each of {s['steps']:,} solved states moved {_num(d['step_N'])} N",
                    "median ms", "mean ms", "converged", f"batch solves/s ({b['threads']} threads)"], rows)
            + f"\n\nContinued / cold (medians): {_num(s['median_ratio'])}; {_of(s['same_as_cold'], s['steps'])} "
              f"continued steps end where the cold solve does; {s['snapped']:,} snap through.")


def _batch_derivatives(d: dict, view: str | None) -> str:
    ms = d["ms_per_row"]
    rows = [["stability test (stiffness eigenvalues)", _num(ms["stability_1_threads"]),
             _num(ms["stability_2_threads"]), _num(ms["stability_python_reference"])],
            ["tip gradient by the tensions", _num(ms["gradients_1_threads"]), _num(ms["gradients_2_threads"]),
             _num(ms["gradients_python_reference"])]]
    if "solve_1_threads" in ms:
        rows.append(["for scale: the batch's solves", _num(ms["solve_1_threads"]), _num(ms["solve_2_threads"]), ""])
    return _table([f"`{d['model']}`, {d['rows']:,} converged rows, ms a row (median of {d['repeat']})",
                   "compiled, 1 thread", "compiled, 2 threads", "Python, row by row"], rows)


def _inverse(d: dict, view: str | None) -> str:
    rows = []
    for obj, r in d["objectives"].items():
        rows.append([f"reachable targets, objective `{obj}`", _of(r["reached"], d["n"]), _num(r["median_ms"]),
                     _num(r["p90_ms"]), _num(r["median_solves"])])
    out = _table([f"`inverse_statics`, `{d['model']}`, paper load", "reached", "median ms", "p90 ms",
                  "median solves"], rows)
    extra = [f"First call (builds the start pool): {_num(d['first_call_s'])} s."]
    if "path" in d:
        p = d["path"]
        extra.append(f"`inverse_path` over {p['points']:,} targets ({_num(p['length_m'] * 1e3)} mm): "
                     f"{_num(p['seconds'])} s, {_of(p['reached'], p['points'])} reached, {p['continued']:,} "
                     f"continued, largest tension change {_num(p['largest_tension_change_N'])} N.")
    if "far" in d:
        f = d["far"]
        extra.append(f"{f['n']:,} targets 0.45 m out (beyond reach): {f['reached']:,} reported reachable, median "
                     f"{_num(f['median_s'])} s; nearest points "
                     f"{', '.join(_num(x * 1e3) for x in f['distances_m'])} mm away.")
    return out + "\n\n" + " ".join(extra)


def _cosserat(d: dict, view: str | None) -> str:
    labels = {"a_tendons_gravity": "cold, tendons and gravity",
              "b_paper_tip_load": "cold, with the paper's tip load",
              "c_auto_stepping": "cold, `load_stepping=\"auto\"`",
              "d_warm_start": "warm start from a neighbour (tensions 2 % lower)"}
    rows = [[lab, _num(d[k]["median_ms"]), _num(d[k]["p90_ms"]), _of(d[k]["converged"], d[k]["cases"])]
            for k, lab in labels.items() if k in d]
    out = _table(["`cosserat` solve, paper robot without friction", "median ms", "p90 ms", "converged"], rows)
    e = d.get("e_compare_100")
    if e:
        out += (f"\n\n`compare_models` on 100 tension vectors (no tip load): {_num(e['seconds'])} s; both converged on "
                f"{e['all_converged']:,}; Cosserat against `pcc` tip difference median "
                f"{_num(e['cosserat_difference_median_mm'])} mm, largest {_num(e['cosserat_difference_max_mm'])} mm.")
    return out


def _volume(d: dict, view: str | None) -> str:
    rows = [[r["shape"], r["voxel"], _num(r["true_cm3"]), f"{r['outer_pct']:+.1f}", f"{r['inner_pct']:+.1f}",
             f"{r['mean_pct']:+.1f}", f"±{r['claimed_pct']:.1f}", "yes" if r["misses"] else "no"] for r in d["rows"]]
    return _table(["shape", "voxel edge", "true cm³", "outer %", "inner %", "reported %", "claimed error %",
                   "error bar misses"], rows)


def _workspace(d: dict, view: str | None) -> str:
    rows = []
    if "sampling" in d:
        s = d["sampling"]
        rows.append([f"sampling: `solve_plan`, {s['samples']:,} Sobol samples", _num(s["seconds"]),
                     f"{s['solves']:,} solves, {_num(s['solves_per_s'])} solves/s"])
    if "support" in d:
        s = d["support"]
        rows.append([f"h(d) on {s['directions']:,} directions ({s['searches']})", _num(s["seconds"]),
                     f"median {_num(s['evaluations_median'])} evaluations a direction"])
    if "region" in d:
        r = d["region"]
        rows.append([f"region at n = {r['n']:,} (boundary search, folds: {r['folds']})", _num(r["seconds"]),
                     f"{r['solves']:,} sampling + {r['search_solves']:,} search solves ("
                     + ("stopped at its budget: the volume is not converged; " if r["search_stop"] == "budget"
                        else f"{r['search_stop']}; ")
                     + f"FSW {_cm3(r['volume_cm3'], r['error_cm3'])}, realisable "
                     f"{_cm3(r['realisable_cm3'], r['realisable_error_cm3'])})"])
    return _table(["step (paper robot, paper load, tensions in [0, 20] N)", "seconds", "what"], rows)


def _designs(d: dict, view: str | None) -> str:
    small, large = (str(n) for n in d["designs"])
    labels = {"local_1": "1 local process", "local_2": "2 local processes", "dask_2": "Dask LocalCluster, 2 workers"}
    rows = [[lab, _num(d[k]["wall_s"][small]), _num(d[k]["wall_s"][large]), _num(d[k]["designs_per_min"]),
             _num(d[k]["startup_s"]), _num(d[k]["design_s_inside"])] for k, lab in labels.items() if k in d]
    out = _table([f"`run_designs`, {d['samples']:,} samples a design", f"s for {small} designs",
                  f"s for {large} designs", "designs/min", "start-up s", "s a design in its worker"], rows)
    est = d.get("estimate_1000_designs", {})
    if est:
        erows = [[f"{_num(e['design_s'])} s a design ({label})", _num(e["2_processes_h"])]
                 + [_num(e[f"{n}_dask_workers_h"]) for n in (2, 8, 32, 128)] for label, e in est.items()]
        out += "\n\nEstimated hours for 1,000 designs:\n\n" + _table(
            ["design cost", "2 local processes", "2 Dask workers", "8", "32", "128"], erows)
    return out


def _accuracy(d: dict, view: str | None) -> str:
    s = d["summary"]
    if view == "order":
        rows = []
        for o in s["orders"]:
            for model, errs in o["errors_mm"].items():
                rows.append([o["group"], f"`{model}`", " / ".join(_num(e) for e in errs), _num(o["order"][model])])
        if not rows:
            return "_No order study in this run._"
        disks = " / ".join(str(n) for n in s["orders"][0]["disks"])
        return _table(["load group", "model", f"median tip error mm at {disks} disks a segment",
                       "order in the spacing"], rows)
    rows = []
    for r in s["rows"]:
        if r["unsupported"]:
            reason = r["unsupported"].split(";")[0].strip()
            rows.append([r["group"], f"`{r['model']}`", f"unsupported ({reason})", NA, NA, NA, NA])
            continue
        rows.append([r["group"], f"`{r['model']}`", _of(r["converged"], r["reference_converged"]),
                     _num(r["median_error_mm"]), _num(r["p95_error_mm"]), _num(r["max_error_mm"]),
                     _num(r["median_ms"])])
    return _table(["load group", "model", "converged (of the reference's)", "median error mm", "p95 mm", "max mm",
                   "median ms"], rows)


def _compile_profile(d: dict, view: str | None) -> str:
    if view == "functions":
        top = sorted(d["cold_all"]["functions"], key=lambda f: -f["exclusive_s"])[:8]
        return _table(["compiled function (all models, one process, empty cache)", "own s", "with callees s",
                       "signatures"],
                      [[f"`{f['function'].removeprefix('pytdcr.statics.kernels.')}`", _num(f["exclusive_s"]),
                        _num(f["inclusive_s"]), str(f["signatures"])] for f in top])
    rows = []
    for name, run in d["cold_by_model"].items():
        m = run["models"][name]
        c = m["calls_s"]
        rows.append([f"`{name}` alone, empty cache", _num(run["import_s"]), _num(c.get("first solve")),
                     _num(c.get("continuation")), _num(c.get("tip gradient")), _num(c.get("stability")),
                     _num(m["total_s"])])
    for key, label in (("cold_all", "all models, empty cache"), ("cached_all", "all models, from the cache")):
        if key in d:
            run = d[key]
            rows.append([label, _num(run["import_s"]), NA, NA, NA, NA,
                         _num(sum(m["total_s"] for m in run["models"].values()))])
    return _table(["first use", "import s", "first solve s", "continuation s", "tip gradient s", "stability s",
                   "total s"], rows)


def _first_use(d: dict, view: str | None) -> str:
    rows = [["install into a new environment (`pip install`, packages from pip's cache)", _num(d["install_s"]),
             NA]] if "install_s" in d else []
    for name, c in d["calls"].items():
        said = "; ".join(c["compile_notices"]) or "nothing"
        rows.append([name, _num(c["seconds"]) if c["ok"] else "failed", said])
    return _table(["first use (a fresh process, an empty cache)", "s", "said on stderr"], rows)


def _solve_phases(d: dict, view: str | None) -> str:
    rows = []
    for name, kinds in d["models"].items():
        for kind, r in kinds.items():
            c, share, unit = r["median_count"], r.get("share") or {}, r.get("unit_us") or {}
            rows.append([f"`{name}`", kind, _num(r["median_ms"]), _num(r["mean_ms"]),
                         *(_num(c[k], 2) for k in ("residuals", "jacobians", "factorisations", "load_steps")),
                         *(f"{100 * share[k]:.0f} %" if k in share else NA
                           for k in ("residual", "jacobian", "factorisation", "other")),
                         *(_num(unit.get(k)) for k in ("residual", "jacobian", "factorisation"))])
    return _table(["model", "solve", "median ms", "mean ms", "residuals", "Jacobians", "factorisations",
                   "load steps", "time in residuals", "in Jacobians", "in factorisations", "elsewhere",
                   "us per residual", "per Jacobian", "per factorisation"], rows)


def _branch_agreement(d: dict, view: str | None) -> str:
    rows = []
    for name, r in d["models"].items():
        b, a = r["before"], r["after"]
        differ = r["differ"]
        rows.append([f"`{name}`", f"{_of(r['same_equilibrium'], r['cases'])} ({100 * r['same_share']:.1f} %)",
                     f"{_num(1e3 * r['same_tip_m'])} mm", _num(1e3 * r["largest_same_tip_distance_m"]),
                     f"{r['converged_before']:,} / {r['converged_after']:,}",
                     f"{r['differ_one_stable_one_not']} of {len(differ)}",
                     f"{_num(b['median_ms'])} / {_num(a['median_ms'])}", f"{_num(b['mean_ms'])} / {_num(a['mean_ms'])}",
                     f"{_num(b['jacobians'], 2)} / {_num(a['jacobians'], 2)}",
                     f"{_num(b['factorisations'], 2)} / {_num(a['factorisations'], 2)}"])
    return (f"Change: {d['change']}.\n\n" if d.get("change") else "") + _table(
        ["model", "same equilibrium", "same: tips within", "largest distance of the same, mm",
         "converged before / after", "differing: one stable, one not", "median ms before / after",
         "mean ms before / after", "Jacobians before / after", "factorisations before / after"], rows)


def _generic(d: dict, view: str | None) -> str:
    """A file holding its own table: ``{"table": {"columns": [...], "rows": [[...], ...]}}`` (or under ``view``)."""
    t = d["tables"][view] if view else d["table"]
    return _table(list(t["columns"]), [[c if isinstance(c, str) else _num(c) for c in r] for r in t["rows"]])


RENDERERS: dict[str, Callable[[dict, str | None], str]] = {
    "solve_speed": _solve_speed, "models": _models, "convergence": _convergence, "continuation": _continuation,
    "batch_derivatives": _batch_derivatives, "batch_derivatives_sscr": _batch_derivatives, "inverse": _inverse,
    "cosserat": _cosserat, "volume": _volume,
    "workspace": _workspace, "designs": _designs, "accuracy": _accuracy, "compile_profile": _compile_profile,
    "first_use": _first_use, "solve_phases": _solve_phases, "branch_agreement": _branch_agreement,
}
"""File name (without ``.json``) -> its renderer; a file not listed must hold a ``table`` (or ``tables``)."""


def provenance(d: dict) -> str:
    """The line under a table: the command, the machine, the load average and the date (or what was carried)."""
    m = d.get("machine", {})
    where = [f"{m['cores']} cores" if m.get("cores") else None, m.get("cpu"),
             (f"load average {m['load_average_start'][0]:.2f} at start, {m['load_average_end'][0]:.2f} at end"
              if m.get("load_average_start") and m.get("load_average_end") else None)]
    machine = ", ".join(w for w in where if w) or "machine not recorded"
    command = f"`{d['command']}`" if d.get("command") else "command not recorded"
    if d.get("carried"):
        c = d["carried"]
        measured = f"; measured on {machine}" if m else ""
        return (f"*Carried, not re-measured:* from {c['source']}; made by {command}{measured}"
                f"{', ' + c['date'] if c.get('date') else ''}.")
    return f"*Made by* {command}; *measured on* {machine}, {m.get('date', 'date not recorded')}."


def render(name: str, view: str | None = None, data_dir: Path = DATA) -> str:
    """The markdown (table and provenance line) for the marker ``NAME[:VIEW]``.

    Raises
    ------
    ValidationTableError
        The file ``data_dir/NAME.json`` is missing or unreadable, or no renderer takes it.
    """
    path = data_dir / f"{name}.json"
    if not path.is_file():
        raise ValidationTableError(
            f"validation.md: the marker '<!-- table: {name}{':' + view if view else ''} -->' needs {path}, "
            f"which does not exist (write it with the bench script named on the page, e.g. "
            f"python bench/<script>.py --out docs/validation/{name}.json)")
    try:
        d = json.loads(path.read_text())
        fn = RENDERERS.get(name)
        if fn is None and "table" not in d and "tables" not in d:
            raise ValidationTableError(f"validation.md: no renderer for {path.name} and it holds no 'table'")
        body = (fn or _generic)(d, view)
    except ValidationTableError:
        raise
    except (KeyError, TypeError, ValueError) as err:
        raise ValidationTableError(f"validation.md: cannot render {path} (view {view!r}): "
                                   f"{type(err).__name__}: {err}") from err
    return body + "\n\n" + provenance(d)


def render_markdown(markdown: str, data_dir: Path = DATA) -> str:
    """``markdown`` with every ``<!-- table: ... -->`` marker replaced by its table."""
    return MARKER.sub(lambda m: render(m.group(1), m.group(2), data_dir), markdown)


PAGE = "validation.md"
"""The one page whose markers are rendered (other pages may quote a marker as an example)."""


def on_page_markdown(markdown: str, page: Any, **_: Any) -> str:
    """mkdocs event: render the markers of ``validation.md``; other pages are returned unchanged."""
    if page.file.src_uri != PAGE:
        return markdown
    return render_markdown(markdown)
