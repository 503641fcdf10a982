"""``tdcr explore`` as a network service that trusts no request (issue 44, class 1; the page's share of class 5).

At the request level, through Flask's test client and raw HTTP to a server on 127.0.0.1: a foreign ``Host``
(DNS rebinding) and a change from another site are refused with no work done, an oversized body is refused
before it is read, a callback request is rebuilt from the page's own callback table, every wrongly typed or
out-of-range value is answered with a status line naming the control (never a 500 or a traceback), the
sessions a request can create are bounded, and concurrent sessions never see each other's state. The page
never calls an equilibrium stable, or a target reached without a qualifier, when its stability is untested.
"""

from __future__ import annotations

import http.client
import json
import socket
import threading
import time
import uuid
from dataclasses import replace
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from pytdcr import Loads, solve
from pytdcr.paper import paper_robot

UPDATE = "/_dash-update-component"
WRENCH = ("force-x", "force-y", "force-z", "moment-x", "moment-y", "moment-z", "payload")
#: a JSON token written into a request body as it is (NaN, Infinity, a 400-digit integer)
RAW = "__raw__"


@pytest.fixture(scope="module")
def explorer():
    """The explorer of the paper robot (pcc) with its app, warmed once for the module."""
    from pytdcr.explore import Explorer, _warm
    from pytdcr.explore._app import build_app

    ex = Explorer()
    _warm(ex)
    return ex, build_app(ex)


@pytest.fixture(scope="module")
def client(explorer):
    return explorer[1].server.test_client()


def _callback(app) -> tuple[str, dict[str, Any]]:
    key = next(k for k in app.callback_map if "tip.children" in k)
    return key, app.callback_map[key]


def _outputs(key: str) -> list[dict[str, str]]:
    return [dict(zip(("id", "property"), k.rsplit(".", 1), strict=True)) for k in key[2:-2].split("...")]


def update_body(app, *, tensions=None, wrench=None, gravity=("on",), friction="own", model="pcc", aim=None,
                sid=None, changed="tension-0.value", drop=(), extra=()) -> dict[str, Any]:
    """A callback request as the page's browser sends it (the renderer's payload: output, outputs, inputs,
    changedPropIds, parsedChangedPropsIds, state), for the controls given; ``drop`` leaves those ids out."""
    key, cb = _callback(app)
    values: dict[str, Any] = {f"tension-{k}": v for k, v in enumerate(tensions if tensions is not None else
                                                                      [5.0, 0, 0, 0, 0, 0, 0, 0])}
    values |= dict(zip(WRENCH, wrench if wrench is not None else [0.0] * 7, strict=True))
    values |= {"gravity": list(gravity) if isinstance(gravity, tuple) else gravity, "friction": friction,
               "model": model, "reset": 0, "rest": 0, "reach-target": 0, "clear-target": 0, "drive": "tension"}
    values |= {f"pull-{k}": 0.0 for k in range(8)}
    values |= dict(zip(("target-x", "target-y", "target-z"), aim or [None] * 3, strict=True))
    values["session"] = uuid.uuid4().hex if sid is None else sid
    inputs = [{**s, "value": values[s["id"]]} for s in cb["inputs"] if s["id"] not in drop]
    state = [{**s, "value": values[s["id"]]} for s in cb["state"] if s["id"] not in drop]
    return {"output": key, "outputs": _outputs(key), "inputs": inputs + list(extra),
            "changedPropIds": [changed], "parsedChangedPropsIds": [changed], "state": state}


def post(client, body: Any, *, raw: str | None = None, headers: dict[str, str] | None = None):
    """POST ``body`` (JSON; the string ``RAW`` inside it replaced by the token ``raw``) to the update path."""
    text = body if isinstance(body, (str, bytes)) else json.dumps(body)
    if raw is not None:
        text = text.replace(json.dumps(RAW), raw)
    return client.post(UPDATE, data=text, content_type="application/json", headers=headers or {})


def status_text(resp) -> str:
    """The status line's text of a callback's answer."""
    def plain(x: Any) -> str:
        if isinstance(x, list):
            return "".join(plain(v) for v in x)
        if isinstance(x, dict):
            return plain(x.get("props", {}).get("children", ""))
        return "" if x is None else str(x)

    return plain(resp.get_json()["response"]["status"]["children"])


def shown_tip(resp) -> np.ndarray:
    return np.array([float(v) for v in resp.get_json()["response"]["tip"]["children"].split()])


# ---------------------------------------------------------------- who may ask
@pytest.mark.parametrize("host", ["evil.example", "evil.example:8080", "127.0.0.1.evil.example",
                                  "127.0.0.1.evil.example:8050", "localhost.", "127.0.0.2", "0.0.0.0:8050",
                                  "[::1]:8050", "127.0.0.1:99999", "localhost:8050@evil.example", ""])
def test_a_foreign_host_is_refused_with_no_work_done(explorer, client, host):
    ex, app = explorer
    sid = uuid.uuid4().hex
    page = client.get("/", environ_overrides={"HTTP_HOST": host})
    assert page.status_code == 403 and page.get_data(as_text=True).count("\n") == 1
    assert "Host" in page.get_data(as_text=True) and "<html" not in page.get_data(as_text=True).lower()
    change = client.post(UPDATE, data=json.dumps(update_body(app, sid=sid)), content_type="application/json",
                         environ_overrides={"HTTP_HOST": host})
    assert change.status_code == 403
    assert sid not in ex._sessions  # refused before the app: no session made


@pytest.mark.parametrize("host", ["127.0.0.1:8050", "localhost:8050", "LOCALHOST:1", "127.0.0.1", "localhost"])
def test_loopback_hosts_are_answered(explorer, client, host):
    _ex, app = explorer
    assert client.get("/", headers={"Host": host}).status_code == 200
    resp = post(client, update_body(app), headers={"Host": host})
    assert resp.status_code == 200 and "converged" in status_text(resp)


def test_a_server_on_a_port_answers_only_that_port(explorer):
    from pytdcr.explore._app import build_app

    ex, _ = explorer
    app = build_app(ex, port=8050)
    c = app.server.test_client()
    for host in ("127.0.0.1:8050", "localhost:8050"):
        assert c.get("/", headers={"Host": host}).status_code == 200
    for host in ("127.0.0.1:8051", "localhost:80", "127.0.0.1", "localhost"):
        assert c.get("/", headers={"Host": host}).status_code == 403
    here = {"Host": "127.0.0.1:8050"}
    assert post(c, update_body(app), headers={**here, "Origin": "http://127.0.0.1:8050"}).status_code == 200
    # another web app on this machine (another port) is another site
    assert post(c, update_body(app), headers={**here, "Origin": "http://127.0.0.1:3000"}).status_code == 403


def test_the_host_must_be_matched_whole(explorer, client):
    """A Host with anything after the name and port (a trailing newline slips past a ``$`` regex) is
    refused; every name of LOOPBACK_NAMES is answered, on the page's port only once it is known."""
    from pytdcr.explore._guard import LOOPBACK_NAMES, Guard

    guard = Guard(lambda environ, start_response: [])
    for host in ("localhost:8080\n", "127.0.0.1\n", "localhost\n", "127.0.0.1:8050\r", "localhost:8050 "):
        assert not guard.host_allowed(host), repr(host)
    for name in LOOPBACK_NAMES:
        assert guard.host_allowed(name) and guard.host_allowed(f"{name.upper()}:8080")
    guard.narrow(8080)
    assert guard.host_allowed("localhost:8080") and not guard.host_allowed("localhost:8080\n")
    assert client.get("/", environ_overrides={"HTTP_HOST": "localhost:8050\n"}).status_code == 403


def test_request_bodies_are_bounded_by_the_one_nesting_rule(client, explorer):
    """The explorer measures a body's nesting with the rule its files use (:func:`pytdcr.io.nesting_depth`)."""
    from pytdcr.explore._guard import MAX_DEPTH
    from pytdcr.io import nesting_depth

    assert nesting_depth([], MAX_DEPTH) == 1 and nesting_depth({"a": [1, {"b": 2}]}, MAX_DEPTH) == 3
    assert nesting_depth([[]] * 3, MAX_DEPTH) == 2 and nesting_depth(5, MAX_DEPTH) == 0
    deep = "[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1)
    resp = post(client, '{"output": ' + deep + "}")
    assert resp.status_code == 400 and f"deeper than {MAX_DEPTH}" in resp.get_data(as_text=True)
    ok = "[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1)
    assert post(client, '{"output": ' + ok + "}").get_data(as_text=True).startswith("refused: not a callback")


@pytest.mark.parametrize(("headers", "code"), [
    ({"Origin": "http://evil.example"}, 403), ({"Origin": "null"}, 403),
    ({"Origin": "http://127.0.0.1.evil.example"}, 403), ({"Origin": "https://localhost"}, 403),
    ({"Sec-Fetch-Site": "cross-site"}, 403), ({"Sec-Fetch-Site": "same-site"}, 403),
    ({"Origin": "http://localhost"}, 200), ({"Origin": "http://127.0.0.1", "Sec-Fetch-Site": "same-origin"}, 200),
    ({}, 200)])
def test_a_change_from_another_site_is_refused(explorer, client, headers, code):
    ex, app = explorer
    sid = uuid.uuid4().hex
    resp = post(client, update_body(app, sid=sid), headers=headers)
    assert resp.status_code == code, resp.get_data(as_text=True)
    assert (sid in ex._sessions) == (code == 200)


def test_no_answer_may_be_framed_or_read_by_another_site(explorer, client):
    """A page that frames the explorer would steer the user's clicks into it (clickjacking)."""
    _, app = explorer
    for resp in (client.get("/"), client.get("/_dash-layout"), post(client, update_body(app)),
                 client.get("/", headers={"Host": "evil.example"})):
        assert resp.headers["X-Frame-Options"] == "DENY"
        assert "frame-ancestors 'none'" in resp.headers["Content-Security-Policy"]
        assert resp.headers["Cross-Origin-Resource-Policy"] == "same-origin"
        assert resp.headers.getlist("X-Frame-Options") == ["DENY"]


def test_a_change_not_sent_as_json_is_refused(explorer, client):
    ex, app = explorer
    sid = uuid.uuid4().hex
    resp = client.post(UPDATE, data=json.dumps(update_body(app, sid=sid)), content_type="text/plain")
    assert resp.status_code == 415 and sid not in ex._sessions
    assert client.open(UPDATE, method="PUT", data="{}", content_type="application/json").status_code == 405


# ---------------------------------------------------------------- what a request may carry
def test_an_oversized_body_is_refused_before_it_is_read(explorer, client):
    from pytdcr.explore._guard import MAX_BODY_BYTES

    _ex, app = explorer
    real = json.dumps(update_body(app)).encode()
    assert 10 * len(real) < MAX_BODY_BYTES  # the page's own requests are far below the bound
    # not JSON at all: refused for its size (413), not for its form (400), so before it is parsed
    resp = client.post(UPDATE, data=b"x" * (MAX_BODY_BYTES + 1), content_type="application/json")
    assert resp.status_code == 413 and "bytes" in resp.get_data(as_text=True)
    big = update_body(app, sid="a" * MAX_BODY_BYTES)
    assert post(client, big).status_code == 413
    assert client.get("/", environ_overrides={"CONTENT_LENGTH": str(10**15)}).status_code == 413
    for length in ("12ab", "\xb2", "-1", "1" * 40):
        assert client.get("/", environ_overrides={"CONTENT_LENGTH": length}).status_code == 400


@pytest.mark.parametrize("body", [b"", b"{", b"[1, 2]", b'"text"', b"\xff\xfe", b'{"output": 5}',
                                  b'{"output": "graph.figure"}', b"[" * 100_000 + b"]" * 100_000,
                                  b'{"a":' * 5000 + b"1" + b"}" * 5000, b'{"output": ' + b"9" * 5000 + b"}"])
def test_a_body_that_is_no_callback_request_is_refused(client, body):
    resp = client.post(UPDATE, data=body, content_type="application/json")
    assert resp.status_code == 400, resp.get_data(as_text=True)
    assert "Traceback" not in resp.get_data(as_text=True)


def test_a_request_for_a_browser_only_callback_is_refused(explorer, client):
    _ex, app = explorer
    key = next(k for k in app.callback_map if k.startswith("..slider-0"))
    resp = post(client, {"output": key, "outputs": _outputs(key), "inputs": [], "changedPropIds": []})
    assert resp.status_code == 400


T1 = "T1: give a tension in [0, 20] N"
FORCE = "force x: give a number in [-1e+06, 1e+06] N"
MOMENT = "moment z: give a number in [-1e+06, 1e+06] N m"
PAYLOAD = "payload: give a number in [0, 10000] kg"
MODEL = "model: choose one of pcc, pcc2, sscr, cosserat"
FRICTION = "friction: choose one of own, none"
GRAVITY = "gravity: give on or off"
SESSION = "session: the page's session id is not one this explorer issued"
TARGET_X = "target x: give a number in [-4000, 4000] mm"
MALFORMED = [
    *[({"tensions": [v, 0, 0, 0, 0, 0, 0, 0]}, None, T1) for v in ("5", [5], {"a": 1}, True, None, 1e308, -1, 20.5)],
    *[({"tensions": [RAW, 0, 0, 0, 0, 0, 0, 0]}, tok, T1) for tok in ("NaN", "Infinity", "-Infinity", "9" * 400)],
    *[({"wrench": [v, 0, 0, 0, 0, 0, 0]}, None, FORCE) for v in ("1", [], {}, False, None, 1e308, 2e6)],
    ({"wrench": [RAW, 0, 0, 0, 0, 0, 0]}, "NaN", FORCE),
    ({"wrench": [0, 0, 0, 0, 0, RAW, 0]}, "-Infinity", MOMENT),
    *[({"wrench": [0, 0, 0, 0, 0, 0, v]}, None, PAYLOAD) for v in (-1, True, "1", 1e5)],
    *[({"model": v}, None, MODEL) for v in ("nope", 5, None, ["pcc"], {"pcc": 1}, "PCC")],
    *[({"friction": v}, None, FRICTION) for v in ("sticky", ["own"], None, 0)],
    *[({"gravity": v}, None, GRAVITY) for v in ("on", [1], {"on": 1}, ["on", "off"], True)],
    *[({"sid": v}, None, SESSION) for v in (5, "x", "../../etc/passwd", uuid.uuid4().hex.upper(), "a" * 100_000,
                                            ["0" * 32], {"id": "0" * 32}, "0" * 31 + "\n", "")],
    *[({"aim": [v, 0, 0], "changed": "reach-target.n_clicks"}, None, TARGET_X) for v in ("1", 1e300, [1], True)],
    ({"aim": [RAW, 0, 0], "changed": "reach-target.n_clicks"}, "Infinity", TARGET_X),
    ({"aim": [1, None, 2], "changed": "reach-target.n_clicks"}, None, "target: give x, y and z in mm"),
    ({"drop": ("tension-3",)}, None, "T4: give a tension in [0, 20] N"),  # a control missing from the request
    ({"drop": ("tension-7",)}, None, "T8: give a tension in [0, 20] N"),  # one tension too few
    ({"drop": ("model",)}, None, MODEL),
    ({"drop": ("session",)}, None, SESSION),
]


@pytest.mark.parametrize(("fields", "raw", "words"), MALFORMED,
                         ids=[f"{i}-{next(iter(f))}" for i, (f, _, _) in enumerate(MALFORMED)])
def test_a_malformed_value_is_named_on_the_status_line(explorer, client, fields, raw, words):
    ex, app = explorer
    before = set(ex._sessions)
    fields = dict(fields)
    resp = post(client, update_body(app, **fields), raw=raw)
    text = resp.get_data(as_text=True)
    assert resp.status_code == 200, text
    assert words in status_text(resp), status_text(resp)
    assert "Traceback" not in text and "internal error" not in text and "bug in pytdcr" not in text
    if "sid" in fields or fields.get("drop") == ("session",):
        assert not set(ex._sessions) - before  # a session id the page did not issue makes no session


def test_extra_and_repeated_entries_are_dropped(explorer, client):
    """A request with a tension too many, a repeated tension and a made-up trigger is answered as the page's
    own controls say (the first value of each), solved as solve() solves them."""
    _ex, app = explorer
    t = [3.0, 0, 0, 0, 0, 0, 0, 0]
    extra = [{"id": "tension-8", "property": "value", "value": 9.0},
             {"id": "tension-0", "property": "value", "value": 19.0}]
    body = update_body(app, tensions=t, extra=extra)
    body["changedPropIds"] = ["reset.n_clicks.x", "graph.figure", 5]
    resp = post(client, body)
    assert resp.status_code == 200 and status_text(resp).startswith("stable equilibrium")
    ref = solve(paper_robot(), Loads(np.array(t))).tip_position
    assert np.allclose(shown_tip(resp), ref, atol=1e-9, rtol=0)


# ---------------------------------------------------------------- what a request can make the server keep
def test_the_sessions_and_robot_variants_a_request_makes_are_bounded(explorer, client):
    from pytdcr.explore._session import FRICTIONS, MAX_SESSIONS

    ex, app = explorer
    for k in range(2 * MAX_SESSIONS + 5):
        body = update_body(app, tensions=[0.05 * (k % 40), 0, 0, 0, 0, 0, 0, 0], gravity=("on",) if k % 2 else (),
                           friction=FRICTIONS[k % 2], wrench=[0, 0, 0, 0, 0, 0, 1e-3 * k])
        assert post(client, body).status_code == 200
    assert len(ex._sessions) == MAX_SESSIONS
    assert len(ex._robots) <= 4  # gravity on or off, friction own or none: whatever the payload


def test_one_session_never_sees_another(explorer, client):
    """Session B, fresh, sees no target that session A placed, and A's next change continues A's pose."""
    _ex, app = explorer
    a, b = uuid.uuid4().hex, uuid.uuid4().hex
    target = solve(paper_robot(), Loads(np.array([6.0, 0, 0, 0, 0, 4.0, 0, 0]))).tip_position * 1e3
    reach = post(client, update_body(app, sid=a, aim=target.tolist(), changed="reach-target.n_clicks"))
    assert "target reached" in status_text(reach)
    other = post(client, update_body(app, sid=b, tensions=[0, 0, 4.0, 0, 0, 0, 0, 0]))
    assert "target" not in status_text(other) and "solved from rest" in status_text(other)
    answer = reach.get_json()["response"]
    again = post(client, update_body(app, sid=a, tensions=[answer[f"tension-{k}"]["value"] for k in range(8)]))
    assert "target" in status_text(again) and "continued" in status_text(again)


# ---------------------------------------------------------------- never claim a test that was not run
def _head(parts: Any) -> tuple[str, str, str]:
    """The status line's headline: its text, its class and its colour."""
    first = parts[0]
    return first.children, first.className, first.style["color"]


def test_an_untested_equilibrium_is_never_called_stable(explorer):
    from pytdcr.explore._app import OK, STATUS_COLOURS, WARNING, _status
    from pytdcr.explore._session import Outcome
    from pytdcr.palette import PALETTE

    assert STATUS_COLOURS[WARNING] == PALETTE.warning and STATUS_COLOURS[OK] != PALETTE.warning
    ex, _ = explorer
    target = solve(paper_robot(), Loads(np.array([6.0, 0, 0, 0, 0, 4.0, 0, 0]))).tip_position
    sid = uuid.uuid4().hex
    reached = ex.reach(sid, ex.defaults, target)
    assert reached.answer.reached and reached.solution.stable is True and not reached.answer.departs
    assert _head(_status(reached)[0]) == ("target reached", OK, STATUS_COLOURS[OK])

    untested = replace(reached.solution, _stability_fn=None)  # as a model without a stability test answers
    assert untested.stable is None
    parts = _status(replace(reached, solution=untested))[0]
    assert _head(parts) == ("target reached, but the equilibrium's stability is untested", WARNING, PALETTE.warning)
    assert "stable" not in _plain(parts).replace("stability", "")
    moved = ex.step(sid, replace(ex.defaults, tensions=np.array([1.0, 0, 0, 0, 0, 0, 0, 0])))
    parts = _status(Outcome(moved.robot, moved.loads, replace(moved.solution, _stability_fn=None)))[0]
    assert _head(parts) == ("equilibrium, stability untested", WARNING, PALETTE.warning)
    assert _head(_status(moved)[0]) == ("stable equilibrium", OK, STATUS_COLOURS[OK])

    from pytdcr.explore._figure import BACKBONE, pose_data

    assert pose_data(ex.robot, untested, reached.loads)[BACKBONE]["name"] == "backbone (stability untested)"
    assert pose_data(ex.robot, reached.solution, reached.loads)[BACKBONE]["name"] == "backbone"

    stab = reached.solution.stability
    unstable = replace(reached.solution, _stability_fn=lambda: replace(stab, stable=False))
    parts = _status(replace(reached, solution=unstable))[0]
    assert _head(parts) == ("target reached, but the equilibrium is unstable", WARNING, PALETTE.warning)
    assert pose_data(ex.robot, unstable, reached.loads)[BACKBONE]["name"] == "backbone (UNSTABLE)"
    # the loading path's answer from rest says its own stability too
    rest = ex.step(sid, replace(ex.defaults, tensions=np.array([1.0, 0, 0, 0, 0, 0, 0, 0])), _rest_action())
    text = _plain(_status(replace(rest, rest=replace(rest.rest, _stability_fn=None)))[0])
    assert "loading path from rest" in text and text.rstrip().endswith("equilibrium, stability untested")


def test_a_target_is_reached_only_on_the_path_asked_for(explorer):
    """A stable equilibrium on another branch, or one the pose shown does not get to by moving its tendons, is no
    "target reached": the status says which, in the warning colour; so is a solve that does not converge."""
    from pytdcr.explore._app import OK, WARNING, _status
    from pytdcr.explore._session import Outcome
    from pytdcr.palette import PALETTE

    ex, _ = explorer
    target = solve(paper_robot(), Loads(np.array([6.0, 0, 0, 0, 0, 4.0, 0, 0]))).tip_position
    reached = ex.reach(uuid.uuid4().hex, ex.defaults, target)
    assert _head(_status(reached)[0])[1] == OK
    branch = replace(reached, answer=replace(reached.answer, path="another branch", departs=True))
    assert _head(_status(branch)[0]) == ("target reached, but it is on another branch than the loading path",
                                         WARNING, PALETTE.warning)
    departs = replace(reached, answer=replace(reached.answer, path="loading path", departs=True))
    assert _head(_status(departs)[0]) == ("target reached, but moving the tendons from the pose shown does not get "
                                          "there (reached from rest only)", WARNING, PALETTE.warning)
    fresh = replace(reached, answer=replace(reached.answer, path="loading path", departs=False))
    assert _head(_status(fresh)[0])[:2] == ("target reached", OK)  # no pose shown: from rest is the path asked
    stab = reached.solution.stability
    both = replace(branch, solution=replace(reached.solution, _stability_fn=lambda: replace(stab, stable=False)))
    assert _head(_status(both)[0])[0] == ("target reached, but the equilibrium is unstable and it is on another "
                                          "branch than the loading path")
    far = replace(reached, answer=replace(reached.answer, reached=False, distance_m=0.01234))
    head, kind, _ = _head(_status(far)[0])
    assert (head, kind) == ("target out of reach", WARNING) and "12.3 mm from the target" in _plain(_status(far)[0])

    failed = replace(reached.solution, converged=False, residual=3.2e-3, failure="the step became too small")
    parts, tip = _status(Outcome(reached.robot, reached.loads, failed, note="continued"))
    head, kind, colour = _head(parts)
    assert (kind, colour, tip) == (WARNING, PALETTE.warning, "not converged")
    assert head.startswith("not converged: largest residual 3.2e-03 N m, above the tolerance")
    assert "the step became too small" in head and "target reached" not in _plain(parts)


def test_the_status_line_rounds_to_what_the_numbers_mean(explorer, client):
    """One status line: the tip in mm to 0.1 mm, said once; the tip [m] for scripts in a hidden element; the
    tensions written back to the boxes to 0.01 N."""
    import re

    from pytdcr.explore._app import _status

    ex, app = explorer
    t = [5.0, 0, 0, 0, 0, 0, 0, 0]
    resp = post(client, update_body(app, tensions=t))
    text = status_text(resp)
    ref = solve(paper_robot(), Loads(np.array(t))).tip_position
    shown = "({:.1f}, {:.1f}, {:.1f}) mm".format(*(ref * 1e3))
    assert text.count("tip at") == 1 and f"tip at {shown}" in text, text
    assert not re.search(r"\d\.\d{2,}", text.replace(" ms", "")), text  # no more than 0.1 mm (one decimal) shown
    layout = app.layout()
    tip = next(c for c in _walk(layout) if getattr(c, "id", None) == "tip")
    assert tip.hidden is True
    target = solve(paper_robot(), Loads(np.array([6.0, 0, 0, 0, 0, 4.0, 0, 0]))).tip_position * 1e3
    reach = post(client, update_body(app, aim=target.tolist(), changed="reach-target.n_clicks")).get_json()
    boxes = [reach["response"][f"tension-{k}"]["value"] for k in range(8)]
    assert all(round(v, 2) == v for v in boxes) and any(round(v, 6) != round(v, 1) for v in boxes), boxes
    assert "target reached" in status_text(SimpleNamespace(get_json=lambda: reach))
    parts, _ = _status(ex.reach(uuid.uuid4().hex, ex.defaults, target / 1e3))
    assert _plain(parts).count("tip at") == 1


def _walk(component: Any):
    yield component
    children = getattr(component, "children", None)
    for child in children if isinstance(children, list) else [children] if children is not None else []:
        if hasattr(child, "children") or hasattr(child, "id"):
            yield from _walk(child)


def _rest_action():
    from pytdcr.explore._session import Action

    return Action.REST


def _plain(parts: Any) -> str:
    if isinstance(parts, str):
        return parts
    if isinstance(parts, list):
        return "".join(_plain(p) for p in parts)
    return _plain(getattr(parts, "children", None) or "")


# ---------------------------------------------------------------- a real server, many sessions at once
def _raw_request(port: int, method: str, path: str, headers: dict[str, str], body: bytes = b"",
                 timeout: float = 30.0) -> tuple[int, bytes]:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
    try:
        conn.request(method, path, body=body, headers=headers)
        r = conn.getresponse()
        return r.status, r.read()
    finally:
        conn.close()


@pytest.fixture(scope="module")
def server(explorer):
    """The explorer's app on a threaded werkzeug server on 127.0.0.1 (an ephemeral port), answering that port."""
    from werkzeug.serving import WSGIRequestHandler, make_server

    class Quiet(WSGIRequestHandler):
        def log_request(self, *args: Any) -> None:
            pass

    _, app = explorer
    srv = make_server("127.0.0.1", 0, app.server, threaded=True, request_handler=Quiet)
    port = srv.server_address[1]
    app.server.wsgi_app.narrow(port)
    thread = threading.Thread(target=srv.serve_forever, daemon=True)
    thread.start()
    try:
        yield port
    finally:
        srv.shutdown()
        srv.server_close()
        app.server.wsgi_app.narrow(None)


def test_raw_http_to_the_server(explorer, server):
    from pytdcr.explore._guard import MAX_BODY_BYTES

    _, app = explorer
    port = server
    here = {"Host": f"127.0.0.1:{port}"}
    assert _raw_request(port, "GET", "/", here)[0] == 200
    assert _raw_request(port, "GET", "/", {"Host": "attacker.example"})[0] == 403
    assert _raw_request(port, "GET", "/", {"Host": f"127.0.0.1:{port + 1}"})[0] == 403
    body = json.dumps(update_body(app)).encode()
    json_here = {**here, "Content-Type": "application/json"}
    code, out = _raw_request(port, "POST", UPDATE, json_here, body)
    assert code == 200 and b"converged" in out
    # a chunked body past the bound (no Content-Length) is cut off at the bound and refused
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        s.sendall(f"POST {UPDATE} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Type: application/json\r\n"
                  "Transfer-Encoding: chunked\r\n\r\n".encode())
        chunk = b"x" * 65536
        try:
            for _ in range(MAX_BODY_BYTES // len(chunk) + 2):
                s.sendall(f"{len(chunk):x}\r\n".encode() + chunk + b"\r\n")
            s.sendall(b"0\r\n\r\n")
        except OSError:  # the server may close once it has refused
            pass
        reply = s.recv(4096)
    assert reply.startswith(b"HTTP/1.1 413"), reply[:200]
    # a request line the server cannot read is its own 400, and the server answers on
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        s.sendall(b"\x00\x01 garbage\r\n\r\n")
        assert b"400" in s.recv(4096)
    assert _raw_request(port, "GET", "/", here)[0] == 200


@pytest.mark.parametrize("body", [b"zz\r\n{}\r\n0\r\n\r\n", b"2\r\n{}XX3\r\n", b"-1\r\n{}\r\n0\r\n\r\n"])
def test_a_malformed_chunked_body_is_a_400_not_a_500(explorer, server, body):
    """A chunked body the server cannot read ("Invalid chunk header", an OSError of its reader) is refused
    with one plain line, never an internal error; the server answers on."""
    port = server
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        s.sendall(f"POST {UPDATE} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Type: application/json\r\n"
                  "Transfer-Encoding: chunked\r\nConnection: close\r\n\r\n".encode() + body)
        reply = b""
        while chunk := s.recv(4096):
            reply += chunk
    head, _, text = reply.partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 400"), reply[:300]
    assert text.count(b"\n") == 1 and text.startswith(b"refused: the request body cannot be read"), text
    assert _raw_request(port, "GET", "/", {"Host": f"127.0.0.1:{port}"})[0] == 200


def test_concurrent_sessions_see_only_their_own_state(explorer, server):
    """8 clients at once, each with its own session, each moving its own tendon and switching gravity at its
    own step: every answer shows the tip solve() gives for the tensions that session sent, and says it was
    solved from rest exactly where that session's own last pose cannot be continued."""
    _, app = explorer
    port = server
    clients, moves, deadline_s = 8, 10, 45.0
    robots = {True: paper_robot(), False: paper_robot().with_gravity(None)}
    assert np.any(robots[True].gravity)
    failures: list[str] = []
    done = []

    def run(i: int) -> None:
        sid = uuid.uuid4().hex
        last_gravity = None
        try:
            for j in range(moves):
                t = np.zeros(8)
                t[i] = 0.5 + 0.6 * j + 0.05 * i
                gravity = j < 3 + i % 5
                body = update_body(app, sid=sid, tensions=t.tolist(), gravity=("on",) if gravity else (),
                                   changed=f"tension-{i}.value")
                code, out = _raw_request(port, "POST", UPDATE, {"Host": f"localhost:{port}",
                                                                "Origin": f"http://localhost:{port}",
                                                                "Content-Type": "application/json"},
                                         json.dumps(body).encode())
                r = json.loads(out)["response"] if code == 200 else {}
                text = json.dumps(r.get("status", ""))
                if code != 200 or "converged" not in text:
                    failures.append(f"client {i} move {j}: {code} {text[:200]}")
                    return
                tip = np.array([float(v) for v in r["tip"]["children"].split()])
                ref = solve(robots[gravity], Loads(t)).tip_position
                if np.linalg.norm(tip - ref) > 1e-6:
                    failures.append(f"client {i} move {j}: tip {tip} is not this session's ({ref})")
                from_rest = "solved from rest" in text
                if from_rest != (last_gravity is None or last_gravity != gravity):
                    failures.append(f"client {i} move {j}: another session's pose was continued: {text[:200]}")
                last_gravity = gravity
            done.append(i)
        except Exception as err:  # reported below, with the client that met it
            failures.append(f"client {i}: {type(err).__name__}: {err}")

    threads = [threading.Thread(target=run, args=(i,), daemon=True) for i in range(clients)]
    t0 = time.monotonic()
    for th in threads:
        th.start()
    for th in threads:
        th.join(max(0.0, deadline_s - (time.monotonic() - t0)))
    assert not failures, failures
    assert sorted(done) == list(range(clients)), f"not finished within {deadline_s} s: {sorted(done)}"
