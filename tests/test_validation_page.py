"""The validation page: every table marker of ``docs/validation.md`` has its JSON in ``docs/validation/``, the
mkdocs hook ``docs/_hooks/validation_tables.py`` renders each into a markdown table with its provenance line,
and a marker naming a missing file fails the build; ``bench/_common.write_result`` writes where ``--out`` says,
with the command and the machine."""

from __future__ import annotations

import importlib.util
import json
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "validation.md"
DATA = ROOT / "docs" / "validation"


def _module(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


hook = _module("validation_tables", ROOT / "docs" / "_hooks" / "validation_tables.py")
MARKERS = hook.MARKER.findall(PAGE.read_text())


def test_page_has_markers() -> None:
    assert len(MARKERS) >= 10


@pytest.mark.parametrize(("name", "view"), MARKERS, ids=[f"{n}:{v}" if v else n for n, v in MARKERS])
def test_marker_has_its_json_and_renders_a_table(name: str, view: str) -> None:
    path = DATA / f"{name}.json"
    assert path.is_file(), f"{PAGE.name} names {path}, which is missing"
    data = json.loads(path.read_text())
    assert data.get("command"), f"{path.name} does not say which command wrote it"
    if not data.get("carried"):  # a fresh measurement records the cores, the CPU, the load and the date
        m = data["machine"]
        assert m["cores"] >= 1 and m["cpu"] and m["date"] and len(m["load_average_start"]) == 3
    else:
        assert data["carried"]["source"], f"{path.name} is carried but does not say from where"
    md = hook.render(name, view or None)
    lines = md.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("| "))
    columns = lines[header].count(" | ") + 1
    assert re.fullmatch(r"\|(---\|)+", lines[header + 1]) and lines[header + 1].count("---") == columns
    body = [line for line in lines[header + 2:] if line.startswith("| ")]
    assert body, f"{name}: a table without rows"
    assert all(line.count(" | ") + 1 == columns for line in body), f"{name}: rows of another width than the header"
    assert f"`{data['command']}`" in md
    assert ("*Carried, not re-measured:*" in md) == bool(data.get("carried"))


def test_page_renders_without_markers_left() -> None:
    out = hook.render_markdown(PAGE.read_text())
    assert "<!-- table" not in out
    assert out.count("*Made by*") + out.count("*Carried, not re-measured:*") == len(MARKERS)


def test_hook_renders_only_the_validation_page() -> None:
    class _File:
        def __init__(self, uri: str) -> None:
            self.src_uri = uri

    class _Page:
        def __init__(self, uri: str) -> None:
            self.file = _File(uri)

    quoted = "a marker `<!-- table: NAME -->` quoted on another page"
    assert hook.on_page_markdown(quoted, _Page("development.md")) == quoted
    with pytest.raises(hook.ValidationTableError, match=r"NAME\.json"):
        hook.on_page_markdown(quoted, _Page("validation.md"))


def test_missing_file_fails_with_its_name(tmp_path: Path) -> None:
    with pytest.raises(hook.ValidationTableError, match=r"no_such_bench\.json.*does not exist"):
        hook.render_markdown("# t\n\n<!-- table: no_such_bench -->\n", data_dir=tmp_path)


def test_unreadable_content_fails_with_its_name(tmp_path: Path) -> None:
    (tmp_path / "models.json").write_text(json.dumps({"friction": {"pcc": {"median_ms": 1.0}}}))
    with pytest.raises(hook.ValidationTableError, match=r"cannot render .*models\.json"):
        hook.render("models", data_dir=tmp_path)
    (tmp_path / "other.json").write_text("{}")
    with pytest.raises(hook.ValidationTableError, match=r"no renderer for other\.json"):
        hook.render("other", data_dir=tmp_path)


def test_generic_table_and_provenance(tmp_path: Path) -> None:
    d = {"table": {"columns": ["a", "b"], "rows": [["x", 1234.5]]}, "command": "python bench/x.py --out f",
         "machine": {"cores": 2, "cpu": "CPU X", "load_average_start": [1.5, 1.0, 0.5],
                     "load_average_end": [2.0, 1.0, 0.5], "date": "2026-01-01 00:00 UTC"}}
    (tmp_path / "x.json").write_text(json.dumps(d))
    md = hook.render("x", data_dir=tmp_path)
    assert "| x | 1,234 |" in md  # three significant digits, thousands separated
    assert ("*Made by* `python bench/x.py --out f`; *measured on* 2 cores, CPU X, load average 1.50 at start, "
            "2.00 at end, 2026-01-01 00:00 UTC.") in md


def test_bench_write_result_goes_to_out(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(ROOT / "bench"))
    sys.modules.pop("_common", None)
    common = importlib.import_module("_common")
    monkeypatch.setattr(sys, "argv", [str(ROOT / "bench" / "solve.py"), "--runs", "3"])
    monkeypatch.chdir(ROOT)
    out = tmp_path / "sub" / "solve_speed.json"
    common.write_result("solve", {"x": 1}, False, out=out)
    d = json.loads(out.read_text())
    assert d["x"] == 1 and d["command"] == "python bench/solve.py --runs 3"
    assert d["machine"]["cores"] >= 1 and d["machine"]["cpu"] and len(d["machine"]["load_average_end"]) == 3


def test_a_volume_whose_error_exceeds_it_is_not_shown_as_a_result() -> None:
    assert hook._cm3(55740.0, 4702.0) == "55,740 ± 4,702 cm³"
    shown = hook._cm3(4338.0, 124912.0)
    assert "4,338" not in shown and shown.startswith("not measured")
    page = hook.render_markdown(PAGE.read_text())
    for value, error in re.findall(r"([\d,.]+) ± ([\d,.]+) cm³", page):
        assert float(error.replace(",", "")) < float(value.replace(",", "")), (value, error)
