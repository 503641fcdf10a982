"""``tdcr explore``: the page's solves equal the library's, a target point is answered by inverse statics (or a
workspace run's nearest sample), a browser sees the robot, the workspace and a reached target drawn, and the
response to a slider move is measured (printed, not asserted: speed belongs in the benchmarks).

The browser test drives Debian's Chromium (``/usr/bin/chromium``) through Playwright; without either it is
skipped. Tensions are set through each tendon's number box (fill, Enter): the box is what the server reads, and
it is exact where a slider handle moves by steps of its pixels; one move by the arrow keys on a slider handle
checks that the slider drives the box too.
"""

from __future__ import annotations

import ctypes
import functools
import io
import json
import os
import signal
import socket
import statistics
import subprocess
import sys
import time
import urllib.error
import urllib.request
import uuid
from pathlib import Path

import numpy as np
import pytest

from pytdcr import Loads, pulled_in, solve
from pytdcr.explore._app import OK, STATUS_COLOURS
from pytdcr.palette import PALETTE
from pytdcr.paper import paper_bounds, paper_robot

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
ROOT = Path(__file__).resolve().parents[1]
#: Linux's prctl option: the signal a process gets when the thread that started it dies
PR_SET_PDEATHSIG = 1
#: the C library, loaded before any fork (the child between fork and exec only calls into it)
_LIBC = ctypes.CDLL(None, use_errno=True) if sys.platform.startswith("linux") else None


def _end_with(parent: int) -> None:
    """In a child between fork and exec: SIGKILL when pytest (``parent``, whose main thread started it) dies, and
    at once if it already has (it may die before the call)."""
    _LIBC.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:
        os.kill(os.getpid(), signal.SIGKILL)


def _ends_with_pytest() -> dict:
    """``subprocess`` arguments that make a child die with pytest even when pytest is killed outright (Linux; the
    Popen call must be made from pytest's main thread, as fixtures and tests are)."""
    return {"preexec_fn": functools.partial(_end_with, os.getpid())} if _LIBC is not None else {}


# ---------------------------------------------------------------- without a browser
def test_importing_the_package_imports_no_web_framework():
    code = ("import sys, pytdcr, pytdcr.explore\n"
            "print(','.join(m for m in ('dash', 'flask', 'matplotlib', 'pytdcr.explore._app') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == ""
    assert "explore" not in (ROOT / "src" / "pytdcr" / "__init__.py").read_text()


def test_the_explorer_continues_and_matches_solve():
    from pytdcr.explore import Explorer
    from pytdcr.explore._session import Action

    ex = Explorer()
    robot = paper_robot()
    assert ex.robot == robot and np.array_equal(ex.bounds.upper, paper_bounds(8).upper)
    first = ex.step("s", ex.defaults)
    assert first.solution.converged and first.solution.path == "loading"
    t = np.zeros(8)
    t[0] = 5.0
    from dataclasses import replace

    out = ex.step("s", replace(ex.defaults, tensions=t))
    assert out.solution.path == "continued" and out.solution.converged
    ref = solve(robot, Loads(t))
    assert np.allclose(out.solution.tip_position, ref.tip_position, atol=1e-9, rtol=0)
    # a payload is m g along the robot's gravity at the tip; "solve from rest" adds the loading path's answer
    c = replace(ex.defaults, tensions=t, payload_kg=0.01, tip_moment=np.array([0.0, 0.0, 0.02]))
    rest = ex.step("s", c, Action.REST)
    ref = solve(robot, Loads(t, tip_force=[0.0, 0.0, -0.0981], tip_moment=[0.0, 0.0, 0.02]))
    assert np.allclose(rest.rest.tip_position, ref.tip_position, atol=1e-9, rtol=0)
    assert np.allclose(rest.solution.tip_position, ref.tip_position, atol=1e-6, rtol=0)
    # another model or robot is solved from rest, and says so
    changed = ex.step("s", replace(c, gravity=False))
    assert changed.solution.path == "loading" and "solved from rest" in changed.note


def test_the_model_menu_comes_from_the_registry():
    from pytdcr.explore import Explorer
    from pytdcr.statics import MODELS

    choices = Explorer().model_choices()
    assert [c[0] for c in choices] == list(MODELS)
    labels = {name: label for name, label, _ in choices}
    assert labels["pcc"] == "pcc" and labels["sscr"] == "sscr (slow)"


def test_the_page_callback_shows_the_tip_of_solve():
    """The server callback itself (called as Dash calls it): the tip it shows is solve()'s, to 1e-9 m."""
    from dash._callback_context import context_value
    from dash._utils import AttributeDict

    from pytdcr.explore import create_app

    app = create_app()
    key = next(k for k in app.callback_map if "tip.children" in k)
    on_change = app.callback_map[key]["callback"].__wrapped__
    context_value.set(AttributeDict(triggered_inputs=[{"prop_id": "tension-0.value", "value": 5.0}]))
    t = [5.0, 0, 0, 0, 0, 0, 0, 0]
    options = {"gravity": ["on"], "friction": "own", "model": "pcc"}
    sid = uuid.uuid4().hex  # a session id of the form the page issues
    out = on_change(t, [0, 0, 0, 0, 0, 0, 0], options, [0] * 4, [None] * 3, sid)
    shown = np.array([float(v) for v in out["tip"].split()])
    assert np.allclose(shown, solve(paper_robot(), Loads(np.array(t))).tip_position, atol=1e-9, rtol=0)
    bad = on_change([25.0, *t[1:]], [0] * 7, {**options, "gravity": []}, [0] * 4, [None] * 3, sid)
    assert "T1" in str(bad["status"]) and "[0, 20] N" in str(bad["status"])
    # "Reach target" with a target made by the forward model: the boxes take the answer's tensions
    made = solve(paper_robot(), Loads(np.array(TARGET_TENSIONS))).tip_position
    context_value.set(AttributeDict(triggered_inputs=[{"prop_id": "reach-target.n_clicks", "value": 1}]))
    out = on_change(t, [0] * 7, options, [0, 0, 1, 0], (made * 1e3).tolist(), sid)
    assert _plain(out["status"]).startswith("target reached · tip at ("), out["status"]
    shown = np.array([float(v) for v in out["tip"].split()])
    assert np.linalg.norm(shown - made) <= 1e-4
    assert len(out["tensions"]) == 8 and all(0.0 <= v <= 20.0 for v in out["tensions"])
    empty = on_change(t, [0] * 7, options, [0, 0, 2, 0], [1.0, None, 2.0], sid)
    assert "target: give x, y and z in mm" in str(empty["status"])


def test_the_page_drives_the_tendons_by_their_pull_ins():
    """The displacement drive (called as Dash calls the callback): the pull-ins of a tension solve give its tip
    back with its tensions; a pull-in out of the sliders' range is refused naming it; a change of the drive not in
    use solves nothing."""
    from dash._callback_context import context_value
    from dash._utils import AttributeDict
    from dash.exceptions import PreventUpdate

    from pytdcr.explore import create_app

    app = create_app()
    key = next(k for k in app.callback_map if "tip.children" in k)
    on_change = app.callback_map[key]["callback"].__wrapped__
    t = np.array([5.0, 0, 0, 0, 2.0, 0, 0, 0])
    ref = solve(paper_robot(), Loads(t))
    pulls = pulled_in(paper_robot(), ref) * 1e3 - 0.5 * (t == 0)  # [mm]; the unpulled tendons paid out, slack
    options = {"gravity": ["on"], "friction": "own", "model": "pcc", "drive": "displacement",
               "pulls": pulls.tolist()}
    sid = uuid.uuid4().hex
    context_value.set(AttributeDict(triggered_inputs=[{"prop_id": "pull-0.value", "value": pulls[0]}]))
    out = on_change([0.0] * 8, [0] * 7, options, [0] * 4, [None] * 3, sid)
    shown = np.array([float(v) for v in out["tip"].split()])
    assert np.allclose(shown, ref.tip_position, atol=1e-6, rtol=0), (shown, ref.tip_position)
    status = _plain(out["status"])
    assert "tensions found [5.00, 0.00, 0.00, 0.00, 2.00, 0.00, 0.00, 0.00] N" in status, status
    assert "slack: T2, T3, T4, T6, T7, T8" in status, status
    # the model's stability test holds the tensions: with the pull-ins held it is said untested, never passed
    assert status.startswith("equilibrium, stability untested with the pull-ins held (stable with the tensions held)")
    far = on_change([0.0] * 8, [0] * 7, {**options, "pulls": [99.0, *pulls.tolist()[1:]]}, [0] * 4, [None] * 3, sid)
    assert "Δ1: give a pull-in in [-40, 40] mm" in _plain(far["status"])
    with pytest.raises(PreventUpdate):
        on_change([0.0] * 8, [0] * 7, {**options, "drive": "tension"}, [0] * 4, [None] * 3, sid)


# ---------------------------------------------------------------- the target point
def _plain(parts) -> str:
    """The text of the status line's parts (Dash components and strings)."""
    if isinstance(parts, (list, tuple)):
        return "".join(_plain(p) for p in parts)
    if isinstance(parts, str):
        return parts
    return _plain(getattr(parts, "children", None) or "")


#: the tensions [N] whose tip (from rest, no tip load) is the target made by the forward model
TARGET_TENSIONS = [6.0, 0, 0, 0, 0, 4.0, 0, 0]


def test_a_target_made_by_the_forward_model_is_reached_and_continued():
    from dataclasses import replace

    from pytdcr.explore import Explorer
    from pytdcr.explore._target import INVERSE, SEARCH
    from pytdcr.optimize import InverseSearch

    assert SEARCH.tol == InverseSearch().tol  # the library's own tolerance
    ex = Explorer()
    robot = paper_robot()
    target = solve(robot, Loads(np.array(TARGET_TENSIONS))).tip_position
    elsewhere = np.zeros(8)
    elsewhere[2] = 3.0
    assert ex.step("s", replace(ex.defaults, tensions=elsewhere)).solution.converged
    out = ex.reach("s", ex.defaults, target)
    a, session = out.answer, ex.session("s")
    assert a.method == INVERSE and a.reached and session.reached
    assert a.distance_m <= SEARCH.tol and np.linalg.norm(out.solution.tip_position - target) <= SEARCH.tol
    assert np.all(out.tensions >= ex.bounds.lower) and np.all(out.tensions <= ex.bounds.upper)
    assert a.path in ("continued", "loading path", "another branch") and a.evaluations > 0
    assert session.last is out.solution and np.array_equal(session.target, target)
    # the next change (the boxes hold the tensions to 6 decimals) continues from the answer's pose
    nxt = ex.step("s", replace(ex.defaults, tensions=np.round(out.tensions, 6)))
    assert nxt.solution.path == "continued" and "solved from rest" not in nxt.note
    assert np.linalg.norm(nxt.solution.tip_position - out.solution.tip_position) <= 1e-6
    assert not ex.session("s").reached and np.array_equal(nxt.target, target)  # the marker stays, not reached
    ex.clear_target("s")
    assert ex.session("s").target is None


def test_a_target_out_of_reach_is_said_so():
    from pytdcr.explore import Explorer
    from pytdcr.explore._app import _status

    ex = Explorer()
    target = np.array([0.45, 0.0, 0.0])  # 0.45 m from the base; the robot is 0.4 m long
    out = ex.reach("s", ex.defaults, target)
    assert not out.answer.reached and not ex.session("s").reached
    assert out.answer.distance_m >= 0.05
    assert np.isclose(np.linalg.norm(out.solution.tip_position - target), out.answer.distance_m, rtol=0, atol=1e-12)
    text = _plain(_status(out)[0])
    assert text.startswith("target out of reach · nearest tip found at (") and "target reached" not in text
    # the nearest point found is an equilibrium: the next change continues from it
    assert ex.session("s").last is out.solution


def test_the_nearest_workspace_sample(workspace_run, monkeypatch):
    """With a workspace run, its nearest converged, stable sample is named beside the inverse answer; for a
    model without a tip gradient (no registered one lacks it: the capability check is patched) it is the
    answer, drawn at its tensions and never called reached."""
    from pytdcr.explore import Explorer, _session
    from pytdcr.explore._app import _status
    from pytdcr.explore._target import SAMPLE, nearest_sample
    from pytdcr.runs import read_workspace_pool
    from pytdcr.statics import MODELS

    pool = read_workspace_pool(workspace_run)
    target = pool.tips[3] + np.array([0.004, -0.003, 0.002])
    near = nearest_sample(pool.tensions, pool.tips, target)
    d = np.linalg.norm(pool.tips - target, axis=1)
    assert near.distance_m == d.min() and np.array_equal(near.tip, pool.tips[np.argmin(d)])
    assert np.array_equal(near.tensions, pool.tensions[np.argmin(d)]) and near.count == len(d)
    with pytest.raises(ValueError):
        nearest_sample(np.zeros((0, 8)), np.zeros((0, 3)), target)

    ex = Explorer(workspace=workspace_run)
    assert ex.samples is not None and all(m.capabilities.gradient is not None for m in MODELS.values())
    inverse = ex.reach("s", ex.defaults, target)
    assert inverse.answer.sample.distance_m == near.distance_m and "nearest workspace sample" in inverse.answer.note
    monkeypatch.setattr(_session, "can_inverse", lambda model: False)
    out = ex.reach("s", ex.defaults, target)
    a = out.answer
    assert a.method == SAMPLE and not a.reached and not ex.session("s").reached
    assert np.array_equal(out.tensions, ex.bounds.clip(near.tensions)) and a.sample.index == near.index
    assert np.isclose(a.distance_m, np.linalg.norm(out.solution.tip_position - target), rtol=0, atol=1e-12)
    assert "nearest workspace sample" in _plain(_status(out)[0])
    # without a workspace run, a model without inverse statics says so
    bare = Explorer().reach("s", Explorer().defaults, target)
    assert "no tip gradient" in bare.error


@pytest.mark.parametrize(("args", "words"), [
    (["--port", "0"], "--port"), (["--port", "70000"], "--port"), (["--model", "nope"], "--model"),
    (["--workspace", "."], "--workspace")])
def test_bad_input_is_refused_naming_the_option(capsys, args, words):
    from pytdcr.cli import main

    assert main(["explore", *args]) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1


def test_a_port_in_use_is_refused_naming_the_option(capsys):
    from pytdcr.cli import main

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        assert main(["explore", "--port", str(port)]) == 2
    err = capsys.readouterr().err
    assert f"--port {port}: cannot listen" in err


# ---------------------------------------------------------------- in a browser
def _browser_missing() -> str:
    if not CHROMIUM.exists():
        return "no /usr/bin/chromium (apt-get install chromium chromium-driver)"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "playwright is not installed (pip install 'playwright>=1.45,<2')"
    return ""


#: a stand-in for pytest: starts a long child with :func:`_ends_with_pytest`, prints its pid and waits
_STAND_IN = """
import subprocess, sys, time
sys.path.insert(0, sys.argv[1])
from test_explore import _ends_with_pytest
child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"], **_ends_with_pytest())
print(child.pid, flush=True)
time.sleep(120)
"""


def _alive(pid: int) -> bool:
    """True while process ``pid`` exists and is not a zombie (killed, waiting to be reaped)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the parent-death signal is Linux's")
def test_a_server_the_tests_start_dies_when_pytest_is_killed():
    """The explorer the browser tests start must not outlive a pytest killed outright (SIGKILL): a stand-in for
    pytest starts a child as the fixture does, is killed, and the child must be gone within seconds."""
    parent = subprocess.Popen([sys.executable, "-c", _STAND_IN, str(Path(__file__).parent)], stdout=subprocess.PIPE,
                              text=True)
    child = 0
    try:
        child = int(parent.stdout.readline())
        assert _alive(child)
        parent.kill()
        parent.wait(10)
        deadline = time.monotonic() + 10
        while _alive(child) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _alive(child), "the child outlived its killed parent"
    finally:
        parent.kill()
        parent.wait(10)
        if child and _alive(child):
            os.kill(child, signal.SIGKILL)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def workspace_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("explore") / "ws"
    subprocess.run([sys.executable, "-m", "pytdcr.cli", "workspace", "--n", "64", "--budget", "60",
                    "--directions", "0", "--out", str(out), "-q"], check=True, capture_output=True,
                   **_ends_with_pytest())
    summary = json.loads((out / "workspace.json").read_text())
    assert summary["mesh"] == "fsw.ply" and summary["realisable"]["mesh"] == "fsw_realisable.ply"
    return out


@pytest.fixture(scope="module")
def page_url(workspace_run):
    why = _browser_missing()
    if why:
        pytest.skip(why)
    port = _free_port()
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "pytdcr.cli", "explore", "--port", str(port), "--workspace",
                             str(workspace_run)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env,
                            **_ends_with_pytest())
    url = f"http://127.0.0.1:{port}/"
    deadline = time.monotonic() + 90
    try:
        while True:
            try:
                with urllib.request.urlopen(url, timeout=5) as r:
                    if r.status == 200:
                        break
            except (urllib.error.URLError, ConnectionError, TimeoutError):
                pass
            if proc.poll() is not None or time.monotonic() > deadline:
                pytest.fail(f"the explorer did not answer at {url}: {proc.stdout.read().decode()[-2000:]}")
            time.sleep(0.3)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


#: records, in the page, when a key went down and when the tip text and the figure last changed [ms]
_INSTRUMENT = """() => {
  window.__tip = []; window.__plot = []; window.__key = 0;
  new MutationObserver(() => window.__tip.push(performance.now())).observe(document.getElementById('tip'),
      {childList: true, subtree: true, characterData: true});
  document.querySelector('#graph .js-plotly-plot').on('plotly_afterplot', () => window.__plot.push(performance.now()));
  document.addEventListener('keydown', () => { window.__key = performance.now(); }, true);
}"""


def _set(page, box: str, value: float) -> tuple[float, float]:
    """Type ``value`` in the number box ``box`` and press Enter; the ms until the tip shown and the figure
    changed."""
    n, m = page.evaluate("[window.__tip.length, window.__plot.length]")
    page.fill(box, f"{value:g}")
    page.press(box, "Enter")
    page.wait_for_function(f"window.__tip.length > {n} && window.__plot.length > {m}", timeout=30_000)
    return tuple(page.evaluate(f"[window.__tip[{n}] - window.__key, window.__plot[{m}] - window.__key]"))


def _reach_in_browser(page) -> None:
    """Fill the target boxes with a forward-made tip [mm], press "Reach target", wait for the answer; the tip shown
    lies within 1e-4 m of the target, a target marker is drawn, the boxes hold the answer's tensions (and stay:
    no second solve overwrites the answer)."""
    # a click on the boundary fills the target boxes; one on the robot does not (plotly's click event, as the
    # figure emits it: a real click in a 3D scene counts only where a frame is drawn while the button is down)
    boxes = ("#target-x", "#target-y", "#target-z")
    vertex = page.evaluate("""() => {
        const gd = document.querySelector('#graph .js-plotly-plot');
        const n = gd.data.findIndex(t => t.name === 'FSW boundary');
        const m = gd.data[n], pt = {curveNumber: n, pointNumber: 0, x: m.x[0], y: m.y[0], z: m.z[0]};
        gd.emit('plotly_click', {points: [pt]});
        return [m.x[0], m.y[0], m.z[0]];
    }""")
    page.wait_for_function("document.getElementById('target-x').value !== ''", timeout=10_000)
    assert [float(page.input_value(b)) for b in boxes] == pytest.approx(vertex, abs=1e-3)
    page.evaluate("() => document.querySelector('#graph .js-plotly-plot').emit('plotly_click', "
                  "{points: [{curveNumber: 0, pointNumber: 0, x: 1, y: 2, z: 3}]})")
    page.wait_for_timeout(300)
    assert [float(page.input_value(b)) for b in boxes] == pytest.approx(vertex, abs=1e-3)

    target = solve(paper_robot(), Loads(np.array(TARGET_TENSIONS))).tip_position
    for box, v in zip(boxes, target * 1e3, strict=True):
        page.fill(box, f"{v:.6f}")
    page.evaluate("() => document.getElementById('reach-target').addEventListener('click', "
                  "() => { window.__reach = performance.now(); })")
    n = page.evaluate("window.__tip.length")
    page.click("#reach-target")
    page.wait_for_function("/target reached|out of reach|not solved|not converged|workspace sample/.test("
                           "document.getElementById('status').textContent)", timeout=60_000)
    ms = page.evaluate(f"window.__tip[{n}] - window.__reach")  # from the click to the new tip shown
    status = page.text_content("#status")
    assert "target reached" in status, status
    head, kind, colour = _headline(page)
    # "target reached" alone, in the good colour, only for a stable equilibrium on the path asked for
    assert (kind, colour) == (("status-ok", _rgb(STATUS_COLOURS[OK])) if head == "target reached" else
                              ("status-warning", _rgb(PALETTE.warning))), (head, kind, colour)
    assert head == "target reached" or head.startswith("target reached, but "), head
    shown = np.array([float(v) for v in page.text_content("#tip").split()])
    assert np.linalg.norm(shown - target) <= 1e-4, (shown, target)
    marker = page.evaluate("Array.from(document.querySelector('#graph .js-plotly-plot').data)"
                           ".filter(t => t.name === 'target').map(t => [t.mode, t.marker.symbol, t.x.length])")
    assert marker == [["markers", "circle-open", 1]], marker
    page.wait_for_timeout(800)
    assert "target reached" in page.text_content("#status")
    tensions = [float(page.input_value(f"#tension-{k}")) for k in range(8)]
    assert any(v > 0 for v in tensions) and all(0 <= v <= 20 for v in tensions), tensions
    assert all(len(page.input_value(f"#tension-{k}").partition(".")[2]) <= 2 for k in range(8)), tensions  # 0.01 N
    print(f"\nexplore target (pcc, paper robot, forward-made target): {ms:.0f} ms from the click to the answer "
          f"shown; {status[:110]}")


def _rgb(colour: str) -> str:
    """A hex colour as the browser's computed style says it (``rgb(r, g, b)``)."""
    return "rgb({}, {}, {})".format(*(int(colour[i:i + 2], 16) for i in (1, 3, 5)))


def _headline(page) -> tuple[str, str, str]:
    """The status line's headline in the page: its text, its class and its computed colour."""
    return tuple(page.evaluate("""() => { const h = document.querySelector('#status > span');
        return [h.textContent, h.className, getComputedStyle(h).color]; }"""))


@pytest.mark.slow
def test_the_page_in_a_browser(page_url):
    from PIL import Image
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.goto(page_url)
            page.wait_for_function("document.getElementById('tip') && document.getElementById('tip').textContent "
                                   "&& !!document.querySelector('#graph .js-plotly-plot') && typeof "
                                   "document.querySelector('#graph .js-plotly-plot').on === 'function'",
                                   timeout=60_000)
            assert page.text_content("#tip").split() == ["0.000000000", "0.000000000", "0.400000000"]
            page.evaluate(_INSTRUMENT)

            # one move from rest, on a unique branch: tendon 1 to 5 N, no tip load
            _set(page, "#tension-0", 5.0)
            shown = np.array([float(v) for v in page.text_content("#tip").split()])
            ref = solve(paper_robot(), Loads(np.array([5.0, 0, 0, 0, 0, 0, 0, 0])))
            assert np.allclose(shown, ref.tip_position, atol=1e-6, rtol=0), (shown, ref.tip_position)
            assert "converged" in page.text_content("#status") and "continued" in page.text_content("#status")
            # one status line: the state in words, the tip in mm to 0.1 mm said once; the tip [m] never shown
            assert _headline(page) == ("stable equilibrium", "status-ok", _rgb(STATUS_COLOURS[OK]))
            status = page.text_content("#status")
            assert status.count("tip at") == 1 and "tip at ({:.1f}, {:.1f}, {:.1f}) mm".format(
                *(ref.tip_position * 1e3)) in status, status
            assert not page.is_visible("#tip") and "tip [m]" not in page.inner_text("body")
            assert page.get_attribute("#slider-0 [role=slider]", "aria-valuenow") == "5"

            # the workspace's boundary is drawn
            traces = page.evaluate("Array.from(document.querySelector('#graph .js-plotly-plot').data)"
                                   ".map(t => [t.type, t.name, (t.i || []).length])")
            assert any(t == "mesh3d" and name == "FSW boundary" and faces > 0 for t, name, faces in traces), traces
            assert any(t == "mesh3d" and name == "realisable part" and faces > 0 for t, name, faces in traces), traces
            assert "FSW boundary" in page.text_content("#workspace-info")

            # a target made by the forward model: "Reach target" puts the tip there and draws a target marker
            _reach_in_browser(page)

            # the arrow keys on a slider handle move its tendon
            n = page.evaluate("window.__tip.length")
            page.focus("#slider-2 [role=slider]")
            page.keyboard.press("ArrowRight")
            page.wait_for_function(f"window.__tip.length > {n}", timeout=30_000)
            assert float(page.input_value("#tension-2")) > 0

            # the figure is not blank
            png = page.locator("#graph").screenshot()
            pixels = np.asarray(Image.open(io.BytesIO(png)).convert("L"), dtype=float)
            assert pixels.std() > 5.0, pixels.std()

            # response: 20 moves of tendon 2 (ms from the key to the new tip shown, and to the figure redrawn)
            times = [_set(page, "#tension-1", 0.5 * k) for k in range(1, 21)]
            tip_ms, plot_ms = statistics.median(t[0] for t in times), statistics.median(t[1] for t in times)
            print(f"\nexplore response over 20 moves (pcc, paper robot): median {tip_ms:.1f} ms to the new tip "
                  f"shown, {plot_ms:.1f} ms to the figure redrawn")
            assert "converged" in page.text_content("#status")

            # driven by pull-ins: the pull-in rows replace the tension rows and take the pose's pull-ins (the robot
            # stays), a box moves the robot, the status gives the tensions found
            before = np.array([float(v) for v in page.text_content("#tip").split()])
            page.click("#drive label:has-text(\"drive by pull-ins\")")
            page.wait_for_function("document.getElementById('status').textContent.includes('tensions found')",
                                   timeout=30_000)
            page.wait_for_function("getComputedStyle(document.getElementById('pull-rows')).display !== 'none'")
            assert not page.is_visible("#tension-0") and page.is_visible("#pull-0")
            assert "tensions found" in page.text_content("#status"), page.text_content("#status")
            held = np.array([float(v) for v in page.text_content("#tip").split()])
            assert np.linalg.norm(held - before) < 1e-4, (held, before)  # boxes rounded to 0.01 mm
            _set(page, "#pull-2", float(page.input_value("#pull-2")) - 1.0)  # tendon 3 paid out: slack
            status = page.text_content("#status")
            assert "tensions found" in status and "slack:" in status, status
            # the tensions found, applied as tensions, hold the tip shown and pull the taut tendons in as asked
            found = np.array([float(v) for v in status.split("tensions found [")[1].split("]")[0].split(",")])
            again = solve(paper_robot(), Loads(found))
            shown = np.array([float(v) for v in page.text_content("#tip").split()])
            assert np.linalg.norm(shown - again.tip_position) < 2e-4, (shown, again.tip_position)  # 0.01 N shown
            asked = np.array([float(page.input_value(f"#pull-{k}")) for k in range(8)])
            taut = found > 0.05
            assert np.allclose(pulled_in(paper_robot(), again)[taut] * 1e3, asked[taut], atol=0.05)
        finally:
            browser.close()


def test_a_workspace_runs_boundaries_are_read_whole(workspace_run):
    """The FSW boundary and its realisable part are the run's own meshes, every face (a small run is under the
    drawing's face limit)."""
    import trimesh

    from pytdcr.explore import read_workspace

    view = read_workspace(workspace_run)
    for (v, f), name in (((view.vertices, view.faces), "fsw.ply"), (view.realisable, "fsw_realisable.ply")):
        mesh = trimesh.load(workspace_run / name, force="mesh")
        assert np.allclose(v, mesh.vertices) and np.array_equal(f, mesh.faces)
