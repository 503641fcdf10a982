"""How an equilibrium was reached is one enumeration (:class:`pytdcr.SolvePath`): its integer codes are the
compiled kernels' globals, the solvers return its members, and a member writes and reads back as the same text
the files have always held; inverse statics' own vocabulary is :class:`pytdcr.optimize.InversePath`."""

from __future__ import annotations

import csv
import io
import json
import pickle
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import pytdcr
from pytdcr import Loads, NoFriction, SolvePath, solve, solve_batch
from pytdcr.optimize import InversePath
from pytdcr.statics import options
from pytdcr.statics.kernels import loading_path

GOLDEN = Path(__file__).resolve().parent / "golden"

#: the kernels' codes as the numba caches were compiled with them: they must never change
KERNEL_CODES = {"direct": 0, "loading": 1, "snap": 2, "fallback": 3, "continued": 4, "fold": 5}


def test_every_member_round_trips_through_its_code():
    assert len({m.code for m in SolvePath}) == len(SolvePath)
    for member in SolvePath:
        assert SolvePath.from_code(member.code) is member
        assert SolvePath.from_code(np.int64(member.code)) is member
        assert SolvePath(member.value) is member
    codes = np.array([[m.code for m in SolvePath]] * 2, dtype=np.int64)
    back = SolvePath.from_codes(codes)
    assert back.shape == codes.shape and back.dtype == object
    assert all(b is m for b, m in zip(back[1], SolvePath, strict=True))
    assert SolvePath.from_codes(np.array([], dtype=np.int64)).shape == (0,)


def test_unknown_codes_are_refused_by_name():
    with pytest.raises(ValueError, match=r"unknown path code 6.*0 \(direct\)"):
        SolvePath.from_code(6)
    with pytest.raises(ValueError, match="unknown path code -3"):
        SolvePath.from_codes(np.array([0, -3]))
    with pytest.raises(TypeError, match="integer"):
        SolvePath.from_code(1.0)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="integer"):
        SolvePath.from_code(True)
    with pytest.raises(TypeError, match="integers"):
        SolvePath.from_codes(np.array([1.0]))


def test_the_kernels_read_the_members_codes_as_plain_integers():
    for name, code in KERNEL_CODES.items():
        member = SolvePath(name)
        assert member.code == code
        glob = getattr(options, f"PATH_{member.name}")
        assert type(glob) is int and glob == code  # a plain int: numba freezes it as a constant
        assert getattr(loading_path, f"PATH_{member.name}") == code  # what the kernel file imported
    assert SolvePath.NO_START.code == -1  # what the Python side writes for a row it did not solve
    assert SolvePath.SELF_CONTACT.code < 0  # decided after the kernels: no kernel returns a negative code
    assert [SolvePath.from_code(k).code for k in range(6)] == list(range(6))
    assert [m.value for m in SolvePath] == [*KERNEL_CODES, "no start", "self-contact"]


def test_a_member_writes_as_its_text_everywhere():
    p = SolvePath.NO_START
    assert p == "no start" and str(p) == "no start" and f"{p}" == "no start" and f"{p:>9}" == " no start"
    assert json.dumps({"path": p}) == '{"path": "no start"}'
    buf = io.StringIO()
    csv.writer(buf).writerow([p, SolvePath.LOADING])
    assert buf.getvalue() == "no start,loading\r\n"
    frame = pd.DataFrame({"path": np.array([SolvePath.SNAP, SolvePath.LOADING], dtype=object)})
    assert frame.to_csv(index=False) == "path\nsnap\nloading\n"
    assert np.array([SolvePath.FOLD]).tolist() == ["fold"]  # a plain string array holds the text
    assert pickle.loads(pickle.dumps(SolvePath.FALLBACK)) is SolvePath.FALLBACK


def test_a_solve_returns_a_member_and_writes_todays_text(paper):
    sol = solve(paper, Loads(np.array([4.0, 0, 1, 0, 2, 0, 0, 3])))
    assert sol.converged and sol.path is SolvePath.LOADING
    assert '"path": "loading"' in json.dumps(sol.to_dict())
    assert pickle.loads(pickle.dumps(sol)).path is SolvePath.LOADING  # what a worker process sends back
    rod = solve(paper.with_friction(NoFriction()), Loads(np.array([4.0, 0, 1, 0, 2, 0, 0, 3])), model="cosserat")
    assert rod.converged and rod.path is SolvePath.LOADING  # the shooting solver's too


def test_a_batch_holds_members_and_no_start_for_rows_not_continued(paper):
    T = np.array([[4.0, 0, 1, 0, 2, 0, 0, 3], [0, 2.0, 0, 1, 0, 3, 0, 0]])
    batch = solve_batch(paper, T, Loads(np.zeros(8)))
    assert batch.path.dtype == object and all(p is SolvePath.LOADING for p in batch.path)
    assert np.all(batch.path == "loading")  # comparing with the text still works element-wise
    start = replace(batch, converged=np.array([True, False]))
    moved = solve_batch(paper, T * 1.01, Loads(np.zeros(8)), start=start)
    assert moved.path[0] is SolvePath.CONTINUED and moved.converged[0]
    assert moved.path[1] is SolvePath.NO_START and not moved.converged[1]


def test_paths_in_todays_files_load_as_members():
    seen = set()
    for name in ("solve_pcc", "solve_cosserat"):
        for case in json.loads((GOLDEN / f"{name}.json").read_text())["data"].values():
            text = case["result"]["path"]
            member = SolvePath(text)
            assert member == text and member.value == text
            seen.add(member)
    assert SolvePath.SNAP in seen and SolvePath.LOADING in seen
    cell = next(csv.reader(io.StringIO(f"{SolvePath.SELF_CONTACT}\n")))[0]
    assert cell == SolvePath.SELF_CONTACT and SolvePath(cell) is SolvePath.SELF_CONTACT


def test_inverse_paths_are_one_enumeration():
    assert [m.value for m in InversePath] == ["loading path", "continued", "another branch"]
    assert InversePath("another branch") is InversePath.ANOTHER_BRANCH
    assert json.dumps([InversePath.LOADING_PATH]) == '["loading path"]' and f"{InversePath.CONTINUED}" == "continued"
    assert InversePath.CONTINUED == SolvePath.CONTINUED  # the same text, two vocabularies


def test_the_enumeration_is_public():
    assert pytdcr.SolvePath is SolvePath and "SolvePath" in pytdcr.__all__
    assert "SolvePath" in pytdcr.statics.__all__ and "InversePath" in pytdcr.optimize.__all__
