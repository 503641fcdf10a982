"""Issue 44, class 2: a cache is a file we own in a folder others may write (:mod:`pytdcr.runtime._cache`).

Whatever sits at a cache entry's name (a link to a victim file, a dangling link, a FIFO, a folder, another user's
file, a second name of another file, garbage, a truncated file, arrays of the wrong shape or dtype, NaN) is "no
entry": inverse statics builds its start pool again and answers exactly as with no cache at all, and nothing is
written through a link. A cache folder that is a link, writable by everyone or that cannot be made is not used,
never an error.
"""

from __future__ import annotations

import io
import os
import stat
import threading
import zipfile
from pathlib import Path

import numpy as np
import pytest

from pytdcr import InverseSearch, TensionBounds, inverse_statics, paper_loads, paper_robot
from pytdcr.optimize import _inverse_search as search
from pytdcr.runtime import cache_dir, read_arrays, read_entry, write_arrays, write_entry

ROBOT = paper_robot()
LOADS = paper_loads()
BOUNDS = TensionBounds.uniform(8, 0.0, 20.0)
TARGET = [0.1, 0.05, 0.3]
#: a small pool: the pool is built in a fraction of a second
SAMPLES = 16
VICTIM = b"a file of the user's that no cache may touch\n"
#: how long one inverse-statics call may take before it counts as hung (a FIFO opened for reading blocks) [s]
HANG_S = 120.0


def _inverse():
    """Inverse statics of the small problem, its pool built anew (nothing kept in the process), in a thread so
    that a hang fails the test instead of blocking it."""
    search._POOLS.clear()
    out: dict = {}

    def target():
        try:
            out["r"] = inverse_statics(ROBOT, LOADS, TARGET, bounds=BOUNDS, search=InverseSearch(starts=1))
        except BaseException as err:  # handed to the test
            out["err"] = err

    th = threading.Thread(target=target, daemon=True)
    th.start()
    th.join(HANG_S)
    assert not th.is_alive(), "inverse statics hung on what sits at the cache entry's name"
    if "err" in out:
        raise out["err"]
    return out["r"]


@pytest.fixture(scope="module")
def problem(tmp_path_factory):
    """The answer with no disk cache, the pool entry's file name and the whole entry's bytes (from a run into a
    scratch cache); the pool small for the whole module."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(search, "POOL_SAMPLES", SAMPLES)
        mp.setenv("PYTDCR_CACHE_DIR", "")
        answer = _inverse()
        scratch = tmp_path_factory.mktemp("scratch-cache")
        mp.setenv("PYTDCR_CACHE_DIR", str(scratch))
        _same(_inverse(), answer)
        names = [p.name for p in scratch.iterdir()]
        assert len(names) == 1 and names[0].startswith("inverse-pool-")
        yield answer, names[0], (scratch / names[0]).read_bytes()
    search._POOLS.clear()


@pytest.fixture
def solve_inverse(problem, monkeypatch):
    monkeypatch.setattr(search, "_POOLS", {})
    return _inverse


@pytest.fixture
def reference(problem):
    return problem


def _same(a, b) -> None:
    assert np.array_equal(a.tensions, b.tensions) and np.array_equal(a.tip_position, b.tip_position)
    assert a.evaluations == b.evaluations


def _npz(**arrays) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def _valid_kept(cache: Path, name: str) -> bool:
    """The entry is a regular file that the cache reads as a whole pool."""
    p = cache / name
    return stat.S_ISREG(os.lstat(p).st_mode) and read_arrays(
        name, {"tensions": ("K", 8), "tips": ("K", 3), "jacobians": ("K", 3, 8)}, folder=cache) is not None


def test_a_link_at_the_pools_name_is_replaced_and_its_target_untouched(reference, solve_inverse, monkeypatch,
                                                                      tmp_path):
    answer, name, _ = reference
    cache, victim = tmp_path / "cache", tmp_path / "victim.txt"
    cache.mkdir(mode=0o700)
    victim.write_bytes(VICTIM)
    (cache / name).symlink_to(victim)
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(cache))
    _same(solve_inverse(), answer)
    assert victim.read_bytes() == VICTIM
    assert _valid_kept(cache, name)  # the link was replaced by the pool, not followed


def test_a_dangling_link_at_the_pools_name_creates_nothing_where_it_points(reference, solve_inverse, monkeypatch,
                                                                           tmp_path):
    answer, name, _ = reference
    cache, nowhere = tmp_path / "cache", tmp_path / "elsewhere" / "made-by-the-link"
    cache.mkdir(mode=0o700)
    nowhere.parent.mkdir()
    (cache / name).symlink_to(nowhere)
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(cache))
    _same(solve_inverse(), answer)
    assert not nowhere.exists() and list(nowhere.parent.iterdir()) == []


def test_a_fifo_at_the_pools_name_neither_hangs_nor_is_read(reference, solve_inverse, monkeypatch, tmp_path):
    answer, name, _ = reference
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    os.mkfifo(cache / name)
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(cache))
    _same(solve_inverse(), answer)


def test_a_folder_at_the_pools_name_is_no_entry_and_no_error(reference, solve_inverse, monkeypatch, tmp_path):
    answer, name, _ = reference
    cache = tmp_path / "cache"
    (cache / name).mkdir(parents=True)
    (cache / name / "inside").write_bytes(VICTIM)
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(cache))
    _same(solve_inverse(), answer)
    assert (cache / name / "inside").read_bytes() == VICTIM


def test_a_cache_folder_that_is_a_link_is_not_used(reference, solve_inverse, monkeypatch, tmp_path):
    answer, name, kept = reference
    elsewhere, link = tmp_path / "elsewhere", tmp_path / "cache-link"
    elsewhere.mkdir(mode=0o700)
    link.symlink_to(elsewhere, target_is_directory=True)
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(link))
    _same(solve_inverse(), answer)
    assert list(elsewhere.iterdir()) == []  # nothing written through the link
    (elsewhere / name).write_bytes(kept)  # a whole pool there is not read either
    assert read_entry(name, folder=link) is None and read_entry(name, folder=elsewhere) is not None


def test_a_cache_folder_everyone_may_write_is_not_used(reference, solve_inverse, monkeypatch, tmp_path):
    answer, name, kept = reference
    cache = tmp_path / "cache"
    cache.mkdir()
    cache.chmod(0o777)
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(cache))
    _same(solve_inverse(), answer)
    assert list(cache.iterdir()) == []
    (cache / name).write_bytes(kept)
    assert read_entry(name, folder=cache) is None


@pytest.mark.parametrize("mode", [0o770, 0o730, 0o720])
def test_a_cache_folder_its_group_may_write_is_not_used(mode, reference, solve_inverse, monkeypatch, tmp_path):
    answer, name, kept = reference
    cache = tmp_path / "cache"
    cache.mkdir()
    cache.chmod(mode)
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(cache))
    _same(solve_inverse(), answer)
    assert list(cache.iterdir()) == []
    (cache / name).write_bytes(kept)
    assert read_entry(name, folder=cache) is None
    assert not write_entry("inverse-pool-x.npz", b"x", folder=cache)


def test_the_one_npz_reader_refuses_a_huge_header_from_its_bytes(reference, tmp_path):
    """The entry's array headers are read before any data: a shape of 2**40 items is "no entry", never a
    MemoryError."""
    _, name, kept = reference
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    (cache / name).write_bytes(_claiming(kept))
    shapes = {"tensions": ("K", 8), "tips": ("K", 3), "jacobians": ("K", 3, 8)}
    assert read_arrays(name, shapes, folder=cache) is None
    (cache / name).write_bytes(kept)
    assert read_arrays(name, shapes, folder=cache) is not None


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_arrays_reading_would_refuse_are_not_written(bad, tmp_path):
    """A pool with a non-finite value is not kept (reading would refuse it, and every run write it again)."""
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    good = {"tensions": np.ones((2, 8)), "tips": np.zeros((2, 3))}
    spoiled = {**good, "tips": np.array([[0.0, bad, 0.0], [0.0, 0.0, 0.0]])}
    assert not write_arrays("inverse-pool-bad.npz", spoiled, folder=cache)
    assert list(cache.iterdir()) == []
    assert write_arrays("inverse-pool-good.npz", good, folder=cache)
    got = read_arrays("inverse-pool-good.npz", {"tensions": ("K", 8), "tips": ("K", 3)}, folder=cache)
    assert got is not None and all(np.array_equal(got[k], good[k]) for k in good)


def test_a_new_cache_folder_is_private(reference, solve_inverse, monkeypatch, tmp_path):
    answer, name, _ = reference
    cache = tmp_path / "deep" / "cache"
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(cache))
    _same(solve_inverse(), answer)
    assert stat.S_IMODE(cache.stat().st_mode) == 0o700
    assert stat.S_IMODE((cache / name).stat().st_mode) == 0o600
    assert [p.name for p in cache.iterdir()] == [name]  # no temporary file left


def _garbage(kept: bytes) -> bytes:
    return b"\x00garbage, not an npz file" * 10


def _truncated(kept: bytes) -> bytes:
    return kept[: len(kept) // 2]


def _wrong_shape(kept: bytes) -> bytes:
    with np.load(io.BytesIO(kept)) as z:
        return _npz(tensions=z["tensions"][:, :7], tips=z["tips"], jacobians=z["jacobians"][:, :, :7])


def _too_many_rows(kept: bytes) -> bytes:
    with np.load(io.BytesIO(kept)) as z:
        return _npz(**{k: np.concatenate([z[k]] * (SAMPLES + 1)) for k in ("tensions", "tips", "jacobians")})


def _nan_filled(kept: bytes) -> bytes:
    with np.load(io.BytesIO(kept)) as z:
        return _npz(tensions=z["tensions"], tips=np.full_like(z["tips"], np.nan), jacobians=z["jacobians"])


def _integers(kept: bytes) -> bytes:
    with np.load(io.BytesIO(kept)) as z:
        return _npz(tensions=z["tensions"].astype(np.int64), tips=z["tips"], jacobians=z["jacobians"])


def _pickled(kept: bytes) -> bytes:
    with np.load(io.BytesIO(kept)) as z:
        return _npz(tensions=np.array([object()] * 3, dtype=object), tips=z["tips"], jacobians=z["jacobians"])


def _claiming(kept: bytes, shape: tuple[int, ...] = (2**40,)) -> bytes:
    """The pool with its ``tensions`` member's header declaring ``shape`` (2**40 float64 items: 8 TiB) over 8
    bytes of data."""
    buf = io.BytesIO()
    with np.load(io.BytesIO(kept)) as z, zipfile.ZipFile(buf, "w") as zf:
        for key in z.files:
            member = io.BytesIO()
            if key == "tensions":
                np.lib.format.write_array_header_1_0(member, {"descr": "<f8", "fortran_order": False,
                                                              "shape": shape})
                member.write(b"\x00" * 8)
            else:
                np.lib.format.write_array(member, z[key])
            zf.writestr(f"{key}.npy", member.getvalue())
    return buf.getvalue()


def _claiming_more_than_held(kept: bytes) -> bytes:
    return _claiming(kept, (SAMPLES, 8))


@pytest.mark.parametrize("spoil", [_garbage, _truncated, _wrong_shape, _too_many_rows, _nan_filled, _integers,
                                   _pickled, _claiming, _claiming_more_than_held])
def test_an_entry_that_cannot_be_trusted_is_built_again(spoil, reference, solve_inverse, monkeypatch, tmp_path):
    answer, name, kept = reference
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    (cache / name).write_bytes(spoil(kept))
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(cache))
    _same(solve_inverse(), answer)
    assert (cache / name).read_bytes() == kept  # written whole again


def test_a_whole_entry_is_read_and_gives_the_same_answer(reference, solve_inverse, monkeypatch, tmp_path):
    """The cache still works: a kept pool is read (not built again) and answers alike."""
    answer, name, kept = reference
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    (cache / name).write_bytes(kept)
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(cache))
    built = []
    monkeypatch.setattr(search, "solve_batch", lambda *a, **k: built.append(1) or pytest.fail("pool built again"))
    _same(solve_inverse(), answer)
    assert built == []


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="giving a file away needs root")
def test_another_users_entry_is_not_read(reference, solve_inverse, monkeypatch, tmp_path):
    answer, name, kept = reference
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    (cache / name).write_bytes(kept)
    os.chown(cache / name, 12345, 12345)
    assert read_entry(name, folder=cache) is None
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(cache))
    _same(solve_inverse(), answer)
    assert (cache / name).stat().st_uid == os.geteuid()  # replaced by our own


def test_an_entry_with_a_second_name_is_not_read_nor_written_through(reference, solve_inverse, monkeypatch,
                                                                     tmp_path):
    answer, name, _ = reference
    cache, victim = tmp_path / "cache", tmp_path / "victim.txt"
    cache.mkdir(mode=0o700)
    victim.write_bytes(VICTIM)
    os.link(victim, cache / name)
    assert read_entry(name, folder=cache) is None
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(cache))
    _same(solve_inverse(), answer)
    assert victim.read_bytes() == VICTIM


def test_a_cache_that_cannot_be_written_answers_without_an_error(reference, solve_inverse, monkeypatch, tmp_path):
    """Root ignores permission bits: the folder's parent is a regular file, so it can never be made."""
    answer, name, _ = reference
    blocker = tmp_path / "a-file"
    blocker.write_bytes(VICTIM)
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(blocker / "cache"))
    _same(solve_inverse(), answer)
    assert blocker.read_bytes() == VICTIM
    assert not write_entry(name, b"x", folder=blocker / "cache")
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(blocker))  # the cache folder itself a file
    _same(solve_inverse(), answer)
    assert blocker.read_bytes() == VICTIM


def test_where_the_cache_is(monkeypatch, tmp_path):
    monkeypatch.setenv("PYTDCR_CACHE_DIR", "")
    assert cache_dir() is None and search.cache_dir is cache_dir
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(tmp_path))
    assert cache_dir() == tmp_path
    monkeypatch.delenv("PYTDCR_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() == tmp_path / "xdg" / "pytdcr"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/xdg")  # not absolute: ignored, as the XDG rule says
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache_dir() == tmp_path / "home" / ".cache" / "pytdcr"


def test_entry_names_never_leave_the_cache_folder(tmp_path):
    (tmp_path / "cache").mkdir(mode=0o700)
    for bad in ("../escape", "/abs", ".hidden", "a/b", ""):
        assert not write_entry(bad, b"x", folder=tmp_path / "cache")
        assert read_entry(bad, folder=tmp_path / "cache") is None
    assert not (tmp_path / "escape").exists()
    assert write_arrays("ok.npz", {"a": np.ones(2)}, folder=tmp_path / "cache")
    assert np.array_equal(read_arrays("ok.npz", {"a": (2,)}, folder=tmp_path / "cache")["a"], np.ones(2))


def test_a_link_at_an_output_folders_lock_is_never_written_through(tmp_path):
    """The lock beside a run's folder is a file we write in a folder others may write (the --out's parent): a
    link at its name is refused (one line, before any work), its target untouched; so is a FIFO (no hang)."""
    from pytdcr.runtime import FolderError, output_folder

    victim = tmp_path / "victim.txt"
    victim.write_bytes(VICTIM)
    (tmp_path / ".out.lock").symlink_to(victim)
    with pytest.raises(FolderError, match="lock"), output_folder(tmp_path / "out", "test"):
        pass
    assert victim.read_bytes() == VICTIM and not (tmp_path / "out").exists()
    (tmp_path / ".out.lock").unlink()
    os.mkfifo(tmp_path / ".out.lock")
    with pytest.raises(FolderError, match="not a regular file"), output_folder(tmp_path / "out", "test"):
        pass
    (tmp_path / ".out.lock").unlink()
    with output_folder(tmp_path / "out", "test") as run:  # the ordinary case still works
        run.file("a.txt").write_text("a")
    assert (tmp_path / "out" / "a.txt").read_text() == "a"


# -- the cache folder is bounded: the newest MAX_ENTRIES_PER_KIND entries of each kind are kept ---------------------

def _write_aged(cache: Path, names: list[str], start: float) -> None:
    """Write each entry, then date it ``start + i`` seconds (so that their order by age is the list's)."""
    for i, name in enumerate(names):
        assert write_entry(name, name.encode(), folder=cache)
        os.utime(cache / name, (start + i, start + i))


def test_writing_past_the_cap_keeps_the_newest_entries_of_the_kind(tmp_path, monkeypatch):
    from pytdcr.runtime import _cache

    cache = tmp_path / "cache"
    cap = _cache.MAX_ENTRIES_PER_KIND
    names = [f"inverse-pool-{i:032x}.npz" for i in range(cap + 10)]
    other = [f"other-kind-{i:04x}.npz" for i in range(3)] + ["inverse-pool-0000.json"]  # other kinds: untouched
    _write_aged(cache, other, 1e9)
    _write_aged(cache, names, 1.5e9)
    kept = sorted(p.name for p in cache.iterdir())
    assert kept == sorted(other + names[-cap:])
    for name in names[-cap:]:  # each the whole entry it was
        assert read_entry(name, folder=cache) == name.encode()


def test_pruning_never_follows_or_removes_what_is_not_an_entry_of_ours(tmp_path, monkeypatch):
    """Among the names of the kind: a link to a victim file, a dangling link, a folder, a FIFO and a second name
    of a victim file; none is followed, counted or removed (a link's target, a folder's files stay)."""
    from pytdcr.runtime import _cache

    monkeypatch.setattr(_cache, "MAX_ENTRIES_PER_KIND", 2)
    cache, victim = tmp_path / "cache", tmp_path / "victim.txt"
    cache.mkdir(mode=0o700)
    victim.write_bytes(VICTIM)
    old = 1e9
    (cache / "inverse-pool-link.npz").symlink_to(victim)
    (cache / "inverse-pool-dangling.npz").symlink_to(tmp_path / "nowhere")
    (cache / "inverse-pool-folder.npz").mkdir()
    (cache / "inverse-pool-folder.npz" / "inside").write_bytes(VICTIM)
    os.mkfifo(cache / "inverse-pool-fifo.npz")
    os.link(victim, cache / "inverse-pool-hardlink.npz")
    for name in ("inverse-pool-link.npz", "inverse-pool-dangling.npz", "inverse-pool-folder.npz",
                 "inverse-pool-fifo.npz"):
        os.utime(cache / name, (old, old), follow_symlinks=False)
    strangers = sorted(p.name for p in cache.iterdir())
    names = [f"inverse-pool-{i:04x}.npz" for i in range(5)]
    _write_aged(cache, names, 1.5e9)
    assert sorted(p.name for p in cache.iterdir()) == sorted(strangers + names[-2:])
    assert victim.read_bytes() == VICTIM and os.stat(victim).st_nlink == 2
    assert (cache / "inverse-pool-folder.npz" / "inside").read_bytes() == VICTIM
    assert not (tmp_path / "nowhere").exists()


def test_a_cache_folder_that_cannot_be_listed_still_keeps_the_entry(tmp_path, monkeypatch):
    from pytdcr.runtime import _cache

    def refuse(*args):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(_cache.os, "listdir", refuse)
    assert write_entry("inverse-pool-1.npz", b"kept", folder=tmp_path / "cache")
    assert read_entry("inverse-pool-1.npz", folder=tmp_path / "cache") == b"kept"


def test_an_entry_that_cannot_be_removed_is_no_error(tmp_path, monkeypatch):
    from pytdcr.runtime import _cache

    monkeypatch.setattr(_cache, "MAX_ENTRIES_PER_KIND", 1)
    cache = tmp_path / "cache"
    assert write_entry("inverse-pool-1.npz", b"1", folder=cache)
    real = os.unlink

    def refuse(path, *args, **kwargs):
        if str(path).startswith("inverse-pool-"):
            raise PermissionError(13, "Permission denied")
        return real(path, *args, **kwargs)

    monkeypatch.setattr(_cache.os, "unlink", refuse)
    assert write_entry("inverse-pool-2.npz", b"2", folder=cache)
    assert sorted(p.name for p in cache.iterdir()) == ["inverse-pool-1.npz", "inverse-pool-2.npz"]


def test_temporary_files_a_dead_writer_left_are_removed_when_stale(tmp_path):
    from pytdcr.runtime import _cache

    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    stale, fresh = cache / ".inverse-pool-a.npz.tmp-123-abcd", cache / ".inverse-pool-b.npz.tmp-124-abce"
    stale.write_bytes(b"x")
    fresh.write_bytes(b"x")
    then = stale.stat().st_mtime - _cache.STALE_TEMP_S - 60
    os.utime(stale, (then, then))
    assert write_entry("inverse-pool-c.npz", b"c", folder=cache)
    assert not stale.exists() and fresh.exists()


def test_the_start_pool_cache_is_bounded(reference, solve_inverse, monkeypatch, tmp_path):
    """Inverse statics under ever new bounds (as a slider moved through values would give) keeps only the newest
    pools; each answer is the one without a cache."""
    from pytdcr.runtime import _cache

    monkeypatch.setattr(_cache, "MAX_ENTRIES_PER_KIND", 2)
    cache = tmp_path / "cache"
    monkeypatch.setenv("PYTDCR_CACHE_DIR", str(cache))
    made: list[str] = []
    for upper in (20.0, 19.0, 18.0, 17.0):
        monkeypatch.setattr(search, "_POOLS", {})
        before = {p.name for p in cache.iterdir()} if cache.exists() else set()
        inverse_statics(ROBOT, LOADS, TARGET, bounds=TensionBounds.uniform(8, 0.0, upper),
                        search=InverseSearch(starts=1))
        [new] = {p.name for p in cache.iterdir()} - before
        made.append(new)
        then = 1e9 + len(made)
        os.utime(cache / new, (then, then))
    assert sorted(p.name for p in cache.iterdir()) == sorted(made[-2:])
