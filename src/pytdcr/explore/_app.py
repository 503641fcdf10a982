"""The explorer's web page (Dash): the controls, the 3D figure, the status line, and the callbacks between them.

One server callback solves: it takes every control, continues the session's last equilibrium
(:meth:`~pytdcr.explore._session.Explorer.step`), or answers the target point placed ("Reach target":
:meth:`~pytdcr.explore._session.Explorer.reach`, whose tensions it writes back into the tendons' boxes), and
sends the figure's moving traces as a partial update (``dash.Patch``), the status and the tip. A click on the
workspace boundary fills the target's boxes (in the browser). Each tendon has a slider and a number box kept
equal in the browser (a clientside callback: the slider's value while it is dragged or moved by the arrow keys
goes to the box); the number box is the value the server reads. While a slider is dragged, Dash drops the
answers of requests a newer one has overtaken, so the page follows the last position.
"""

from __future__ import annotations

import re
import sys
import traceback
import uuid
from typing import TYPE_CHECKING

import numpy as np
from dash import Dash, Input, Output, Patch, State, ctx, dcc, html, no_update
from dash.exceptions import PreventUpdate

from ..palette import PALETTE
from ..results import StaticSolution
from ..statics import MODELS
from ..validate import MAX_FORCE_N, MAX_MOMENT_NM, finite_real
from ._figure import MM, MOVING, REST, base_figure, pose_data, rest_data, target_data
from ._guard import MAX_BODY_BYTES, Guard
from ._session import FRICTIONS, Action, Controls, Explorer, Outcome, same_equilibrium
from ._target import CONTINUED, INVERSE, TargetAnswer, show_distance

if TYPE_CHECKING:
    from collections.abc import Callable

    from dash.development.base_component import Component

__all__ = ["DRIVES", "PULL_SPAN", "TARGET_SPAN", "build_app"]

_WRENCH = ("force-x", "force-y", "force-z", "moment-x", "moment-y", "moment-z", "payload")
_TARGET = ("target-x", "target-y", "target-z")
_ACTIONS = {"reset": Action.RESET, "rest": Action.REST, "reach-target": Action.TARGET,
            "clear-target": Action.CLEAR}
#: the range each load box takes: low, high, unit (the tip force and moment as :class:`pytdcr.Loads` takes them)
_WRENCH_RANGE = {**dict.fromkeys(_WRENCH[:3], (-MAX_FORCE_N, MAX_FORCE_N, "N")),
                 **dict.fromkeys(_WRENCH[3:6], (-MAX_MOMENT_NM, MAX_MOMENT_NM, "N m")), "payload": (0.0, 1e4, "kg")}
#: each coordinate of a target lies within this many robot lengths of the base
TARGET_SPAN = 10.0
#: how the tendons are driven: by their tensions, or by their pull-ins (every tendon)
DRIVES = ("tension", "displacement")
#: a pull-in slider spans this fraction of the robot's length either way
PULL_SPAN = 0.1
#: pull-ins written into the boxes are rounded to this many decimals [mm] (0.1 µm, the displacement solve's
#: tolerance: coarser, a taut antagonistic pair of inextensible tendons would be asked to stretch)
_PULL_DECIMALS = 4
#: a slack tendon's pull-in, when the drive turns to pull-ins, is this much short of taking up its slack [mm]
SLACK_MARGIN_MM = 0.5
#: the form of a session id the page issues (``uuid.uuid4().hex``)
_SID = re.compile("[0-9a-f]{32}")
#: tensions written back into the boxes are rounded to this many decimals [N] (0.01 N)
_DECIMALS = 2
#: the status line's classes: a stable equilibrium (or a target reached by one on the path asked for), a state
#: said in words that needs the reader's care (unstable, untested, another branch, not converged, refused), neutral
OK, WARNING, NEUTRAL = "status-ok", "status-warning", "status-note"
#: the colour of each class (the shared palette's warning colour; Okabe and Ito's bluish green for a good state)
STATUS_COLOURS = {OK: PALETTE.series[2], WARNING: PALETTE.warning, NEUTRAL: "#5f6b7a"}
_BOX = {"width": "80px", "marginLeft": "8px"}
# the slider and the number box of one tendon, kept equal; the one the user moved wins
_SYNC_JS = """
function(drag, box) {
    const nu = window.dash_clientside.no_update;
    const trig = window.dash_clientside.callback_context.triggered.map(t => t.prop_id);
    if (trig.length && trig[0].includes('slider-')) {
        if (drag === null || drag === undefined) { return [nu, nu]; }
        const shown = Math.round(drag * SCALE) / SCALE;  // the box's decimals
        return shown === box ? [nu, nu] : [nu, shown];
    }
    if (box === null || box === undefined || Number.isNaN(box)) { return [nu, nu]; }
    return [box, nu];
}
"""
# a click on a point of the workspace's traces (the boundary; not the robot's moving traces) fills the target [mm]
_CLICK_JS = """
function(click) {
    const nu = window.dash_clientside.no_update;
    const p = (click && click.points && click.points.length) ? click.points[0] : null;
    if (!p || p.curveNumber < MOVING || ![p.x, p.y, p.z].every(v => typeof v === 'number' && Number.isFinite(v))) {
        return [nu, nu, nu];
    }
    return [p.x, p.y, p.z].map(v => Math.round(v * 1000) / 1000);
}
""".replace("MOVING", str(MOVING))
# the drive's rows shown, the other's hidden
_DRIVE_JS = """
function(drive) {
    return drive === 'displacement' ? [{display: 'none'}, {}] : [{}, {display: 'none'}];
}
"""
# said at once while the server searches
_SEARCHING_JS = """
function(n) {
    return n ? 'searching for tensions that put the tip at the target ...' : window.dash_clientside.no_update;
}
"""


def _status_span(text: str, kind: str) -> Component:
    """``text`` in the status line's class ``kind`` (:data:`OK`, :data:`WARNING`, :data:`NEUTRAL`) and colour."""
    return html.Span(text, className=kind, style={"color": STATUS_COLOURS[kind]})


def _button(label: str, ident: str, primary: bool = False) -> Component:
    """A styled button (``explorer.css``'s ``explore-button``; ``primary``: the page's main action)."""
    return html.Button(label, id=ident, n_clicks=0, className="explore-button" + (" primary" if primary else ""))


def _number(ident: str, value: float | None, **extra: object) -> Component:
    """A styled number box, read by the server when the user presses Enter or leaves it (``debounce``)."""
    return dcc.Input(id=ident, type="number", step="any", value=value, debounce=True, className="explore-input",
                     **extra)


def _slider_row(label: str, slider: str, box: str, lo: float, hi: float, step: float | None,
                value: float) -> Component:
    """One tendon's row: its label, a slider over [lo, hi] with ``step`` and a number box, both at ``value``."""
    marks = {f"{v:g}": f"{v:g}" for v in np.linspace(lo, hi, 5)}
    return html.Div([
        html.Div(label, className="explore-label"),
        html.Div([
            html.Div(dcc.Slider(id=slider, min=lo, max=hi, step=step, value=value, marks=marks,
                                updatemode="mouseup"), style={"flex": "1", "minWidth": "0"}),
            _number(box, value, min=lo, max=hi, style=_BOX),
        ], className="explore-tendon-row"),
    ], className="explore-tendon")


def _tension_rows(ex: Explorer) -> list[Component]:
    """One row per tendon: its label, a slider over its bounds [N] and a number box (0.01 N)."""
    rows = [html.Div("tendon tensions [N]", className="explore-heading")]
    for k, t in enumerate(ex.robot.tendons):
        lo, hi = float(ex.bounds.lower[k]), float(ex.bounds.upper[k])
        rows.append(_slider_row(f"T{k + 1} · segment {t.segment}, {t.angle_deg:g}°", f"slider-{k}", f"tension-{k}",
                                lo, hi, (hi - lo) / 400 or None, round(float(ex.defaults.tensions[k]), _DECIMALS)))
    return rows


def _pull_span_mm(ex: Explorer) -> float:
    """How far a pull-in slider reaches either way [mm]: :data:`PULL_SPAN` of the robot's length, to 0.1 mm."""
    return round(PULL_SPAN * ex.robot.length * MM, 1)


def _pull_rows(ex: Explorer) -> list[Component]:
    """One row per tendon in the displacement drive: its label, a slider of its pull-in [mm] (negative: paid out)
    and a number box (0.0001 mm)."""
    span = _pull_span_mm(ex)
    rows = [html.Div("tendon pull-ins [mm] (tensions found; a tendon paid out goes slack)",
                     className="explore-heading")]
    for k, t in enumerate(ex.robot.tendons):
        rows.append(_slider_row(f"Δ{k + 1} · segment {t.segment}, {t.angle_deg:g}°", f"pull-slider-{k}",
                                f"pull-{k}", -span, span, span / 200, 0.0))
    return rows


def _drive_rows(ex: Explorer) -> list[Component]:
    """The drive's choice, then the tension rows and the pull-in rows (the chosen one shown)."""
    return [dcc.RadioItems(id="drive", value=DRIVES[0], inline=True, className="explore-row",
                           options=[{"label": " drive by tensions ", "value": DRIVES[0]},
                                    {"label": " drive by pull-ins", "value": DRIVES[1]}]),
            html.Div(_tension_rows(ex), id="tension-rows"),
            html.Div(_pull_rows(ex), id="pull-rows", style={"display": "none"})]


def _load_rows(ex: Explorer) -> list[Component]:
    """Tip force [N], tip moment [N m], payload [kg], gravity, friction and model."""
    d = ex.defaults
    values = [*d.tip_force.tolist(), *d.tip_moment.tolist(), d.payload_kg]

    def box(i: int) -> Component:
        return _number(_WRENCH[i], values[i], placeholder="xyz"[i % 3] if i < 6 else "",
                       min=0 if _WRENCH[i] == "payload" else None)

    law = ex.robot.friction.law
    return [html.Div([
        html.Div("loads", className="explore-heading"),
        html.Div([html.Span("tip force [N]", className="explore-label"), *[box(i) for i in range(3)]],
                 className="explore-row"),
        html.Div([html.Span("tip moment [N m]", className="explore-label"), *[box(i) for i in range(3, 6)]],
                 className="explore-row"),
        html.Div([html.Span("payload at the tip [kg]", className="explore-label"), box(6)], className="explore-row"),
        dcc.Checklist(id="gravity", options=[{"label": " gravity", "value": "on"}],
                      value=["on"] if d.gravity else [], style={"marginTop": "4px"}),
    ], className="explore-section"), html.Div([
        html.Div("model", className="explore-heading"),
        html.Div("friction", className="explore-label"),
        dcc.Dropdown(id="friction", clearable=False, searchable=False, value=d.friction,
                     options=[{"label": f"the robot's own ({law})", "value": FRICTIONS[0]},
                              {"label": "none", "value": FRICTIONS[1]}]),
        html.Div("model", className="explore-label", style={"marginTop": "6px"}),
        dcc.Dropdown(id="model", clearable=False, searchable=False, value=d.model,
                     options=[{"label": label, "value": name, "title": text}
                              for name, label, text in ex.model_choices()]),
        html.Div([_button("Reset", "reset"), _button("Solve from rest", "rest")], className="explore-row",
                 style={"marginTop": "10px"}),
    ], className="explore-section"), *_target_rows(ex)]


def _target_rows(ex: Explorer) -> list[Component]:
    """The target point x, y, z [mm] (base frame), "Reach target" and "Clear"."""
    hint = "; or click the boundary" if ex.workspace is not None and ex.workspace.faces is not None else ""
    return [html.Div([
        html.Div("target", className="explore-heading"),
        html.Div(f"x, y, z [mm] in the base frame{hint}", className="explore-muted"),
        html.Div([_number(i, None, placeholder=i[-1]) for i in _TARGET], className="explore-row"),
        html.Div([_button("Reach target", "reach-target", primary=True), _button("Clear", "clear-target")],
                 className="explore-row"),
    ], className="explore-section")]


def _workspace_text(ex: Explorer) -> str:
    """A line on the workspace run drawn (empty without one)."""
    ws = ex.workspace
    if ws is None:
        return ""
    shown = f"{len(ws.faces)} of {ws.faces_total} faces" if ws.faces is not None else "no boundary mesh"
    text = f"workspace run {ws.folder}: FSW boundary ({shown})"
    text += ", its realisable part (no disk below the base, none intersecting)" if ws.realisable is not None else ""
    if ws.reach is not None:
        text += f"; largest reach {np.linalg.norm(ws.reach.tip) * MM:.1f} mm"
        text += f" ({ws.reach.note})" if ws.reach.note else ""
    if ws.robot != ex.robot:
        text += f"; computed for robot '{ws.robot.name}', not the robot shown"
    return text


def _layout(ex: Explorer) -> Callable[[], Component]:
    """The page: controls on the left, status and figure on the right; a fresh session id per page load.

    The status line (``#status``) is the one line the reader reads; ``#tip`` holds the tip [m] to 9 decimals for
    scripts and tests, never shown."""
    r = ex.robot

    def layout() -> Component:
        controls = html.Div([
            html.H3("pytdcr explore"),
            html.Div(f"robot '{r.name}': {len(r.segments)} segments, {r.n_tendons} tendons, {r.n_disks} disks, "
                     f"{r.length * MM:g} mm long", className="explore-muted", style={"marginBottom": "10px"}),
            *_drive_rows(ex), *_load_rows(ex),
        ], className="explore-controls")
        view = html.Div([
            html.Div(id="status", className="explore-status"),
            html.Div(id="tip", hidden=True),
            html.Div(_workspace_text(ex), id="workspace-info", className="explore-muted",
                     style={"marginTop": "4px"}),
            dcc.Graph(id="graph", figure=base_figure(r, ex.workspace), className="explore-graph",
                      style={"height": "100%"}, config={"displaylogo": False}),
        ], className="explore-view")
        return html.Div([controls, view, dcc.Store(id="session", data=uuid.uuid4().hex)], className="explore-page")

    return layout


def _controls(ex: Explorer, tensions: object, wrench: object, options: object) -> Controls | str:
    """The controls read from the page, or what is wrong with them (naming the control and what it takes).

    Every value is checked for its type and range here: a request may carry anything in any field (each number by
    :func:`~pytdcr.validate.finite_real`: a string, a list, true, NaN or an integer too large for a float is none)."""
    lo, hi = ex.bounds.lower, ex.bounds.upper
    tensions = tensions if isinstance(tensions, (list, tuple)) else []
    wrench = wrench if isinstance(wrench, (list, tuple)) else []
    for k in range(ex.robot.n_tendons):
        t = finite_real(tensions[k]) if k < len(tensions) else None
        if t is None or not lo[k] <= t <= hi[k]:
            return f"T{k + 1}: give a tension in [{lo[k]:g}, {hi[k]:g}] N"
    if len(tensions) != ex.robot.n_tendons:
        return f"tensions: give one per tendon ({ex.robot.n_tendons})"
    for i, name in enumerate(_WRENCH):
        x = finite_real(wrench[i]) if i < len(wrench) else None
        low, high, unit = _WRENCH_RANGE[name]
        if x is None or not low <= x <= high:
            return f"{name.replace('-', ' ')}: give a number in [{low:g}, {high:g}] {unit}"
    options = options if isinstance(options, dict) else {}
    gravity = options.get("gravity")
    if gravity is not None and not (isinstance(gravity, list) and all(g == "on" for g in gravity)):
        return "gravity: give on or off"
    if not isinstance(options.get("friction"), str) or options["friction"] not in FRICTIONS:
        return f"friction: choose one of {', '.join(FRICTIONS)}"
    if not isinstance(options.get("model"), str) or options["model"] not in MODELS:
        return f"model: choose one of {', '.join(MODELS)}"
    pulls = _pulls(ex, options)
    if isinstance(pulls, str):
        return pulls
    w = np.array([float(v) for v in wrench], dtype=float)
    return Controls(np.array([float(v) for v in tensions], dtype=float), w[:3], w[3:6], float(w[6]),
                    bool(gravity), options["friction"], options["model"], pulls)


def _pulls(ex: Explorer, options: dict) -> np.ndarray | str | None:
    """The pull-ins [m] of the displacement drive (None: the tensions drive), or what is wrong with them."""
    drive = options.get("drive", DRIVES[0])
    if not isinstance(drive, str) or drive not in DRIVES:
        return f"drive: choose one of {', '.join(DRIVES)}"
    if drive == DRIVES[0]:
        return None
    span = _pull_span_mm(ex)
    pulls = options.get("pulls")
    pulls = pulls if isinstance(pulls, (list, tuple)) else []
    for k in range(ex.robot.n_tendons):
        x = finite_real(pulls[k]) if k < len(pulls) else None
        if x is None or not -span <= x <= span:
            return f"Δ{k + 1}: give a pull-in in [{-span:g}, {span:g}] mm"
    return np.array([float(v) for v in pulls[:ex.robot.n_tendons]], dtype=float) / MM


def _target_point(ex: Explorer, aim: object) -> np.ndarray | str:
    """The target boxes [mm] as a point [m], or what is wrong with them (each coordinate within
    :data:`TARGET_SPAN` robot lengths of the base)."""
    aim = aim if isinstance(aim, (list, tuple)) and len(aim) == 3 else [None] * 3
    if any(v is None for v in aim):
        return "target: give x, y and z in mm"
    span = TARGET_SPAN * ex.robot.length * MM
    for axis, v in zip("xyz", aim, strict=True):
        x = finite_real(v)
        if x is None or not -span <= x <= span:
            return f"target {axis}: give a number in [{-span:g}, {span:g}] mm ({TARGET_SPAN:g} robot lengths)"
    return np.array([float(v) for v in aim], dtype=float) / MM


def _session_id(sid: object) -> str | None:
    """``sid`` when it has the form of an id the page issues (:func:`uuid.uuid4`'s 32 hex digits), else None."""
    return sid if isinstance(sid, str) and _SID.fullmatch(sid) else None


def _mm(point: np.ndarray) -> str:
    """A point [m] as the page says it: ``(x, y, z) mm`` to 0.1 mm."""
    return "({:.1f}, {:.1f}, {:.1f}) mm".format(*(np.asarray(point, dtype=float) * MM))


def _equilibrium_words(sol: StaticSolution) -> tuple[str, str]:
    """A converged equilibrium's headline and class: ``stable equilibrium`` (:data:`OK`) only when tested
    stable; ``unstable equilibrium`` or ``equilibrium, stability untested`` (:data:`WARNING`)."""
    return {True: ("stable equilibrium", OK), False: ("unstable equilibrium", WARNING),
            None: ("equilibrium, stability untested", WARNING)}[sol.stable]


def _driven_words(sol: StaticSolution) -> tuple[str, str]:
    """The headline of an equilibrium held by pull-ins: its stability with the pull-ins held is untested
    (:data:`WARNING`); the model's test, made with the tensions held, is said beside it."""
    held = {True: "stable", False: "unstable", None: "untested"}[sol.stable]
    return f"equilibrium, stability untested with the pull-ins held ({held} with the tensions held)", WARNING


def _status(out: Outcome) -> tuple[list[Component | str], str]:
    """The status line's parts and the tip [m] for scripts (9 decimals; "not converged" without an equilibrium).

    The line's first part says the state in words in its class (:func:`_status_span`); then the tip [mm, 0.1 mm],
    the path and the time; then notes, smaller."""
    if out.error:
        return [_status_span(f"not solved: {out.error}", WARNING)], "not solved"
    sol = out.solution
    if sol is None or not sol.converged:
        why = f" ({sol.failure})" if sol is not None and sol.failure else ""
        res = f": largest residual {sol.residual:.1e} N m, above the tolerance {sol.atol:.0e} N m" \
            if sol is not None else ""
        note = out.answer.note if out.answer is not None else out.note
        return [_status_span(f"not converged{res}{why}", WARNING), " · nothing drawn; the last equilibrium is kept "
                "for the next change", *_notes(note)], "not converged"
    tip = sol.tip_position
    text = " ".join(f"{v:.9f}" for v in tip)
    if out.answer is not None:
        return _answer_text(out), text
    word, kind = _equilibrium_words(sol) if out.drive is None else _driven_words(sol)
    aim = "" if out.target is None else f" · target {_gap(float(np.linalg.norm(tip - out.target)))} away"
    parts: list[Component | str] = [_status_span(word, kind), f" · tip at {_mm(tip)}{aim} · path {sol.path} · "
                                    f"converged in {out.seconds * 1e3:.0f} ms", *_notes(out.note)]
    if out.drive is not None:
        d = out.drive
        slack = ", ".join(f"T{k + 1}" for k in np.flatnonzero(d.slack)) or "none"
        found = ", ".join(f"{t:.2f}" for t in d.tensions)
        parts += [html.Br(), _status_span(f"tensions found [{found}] N · slack: {slack}", NEUTRAL)]
    if out.rest is not None:
        parts += [html.Br(), _rest_text(out)]
    return parts, text


def _gap(metres: float) -> str:
    """A distance [m] to 0.1 mm, or under 0.1 mm as the tolerance-scale text of :func:`show_distance`."""
    return show_distance(metres) if metres < 1e-4 else f"{metres * MM:.1f} mm"


def _notes(note: str) -> list[Component]:
    """A note under the status line, smaller (none when empty)."""
    return [html.Br(), html.Span(note, className="status-note")] if note else []


def reach_words(answer: TargetAnswer, sol: StaticSolution) -> tuple[str, str]:
    """What a target answer says and its class: ``target reached`` (:data:`OK`) only for a target reached by a
    tested-stable equilibrium on the path asked for (the pose shown, its tendons moved there; or, with no pose to
    move from, the loading path from rest); else the state in words, in :data:`WARNING`.

    Parameters
    ----------
    answer : TargetAnswer
        How the target was answered (:mod:`._target`).
    sol : StaticSolution
        The answer's converged equilibrium.

    Returns
    -------
    words, kind : str
        The headline (e.g. ``"target reached, but the equilibrium is unstable"``) and its class.
    """
    if answer.method != INVERSE:
        return "nearest workspace sample, not a search (no inverse statics for this model)", WARNING
    if not answer.reached:
        return "target out of reach", WARNING
    but = {True: [], False: ["the equilibrium is unstable"], None: ["the equilibrium's stability is untested"]}[
        sol.stable]
    if answer.path == "another branch":
        but.append("it is on another branch than the loading path")
    elif answer.path != CONTINUED and answer.departs:
        but.append("moving the tendons from the pose shown does not get there (reached from rest only)")
    return ("target reached", OK) if not but else ("target reached, but " + " and ".join(but), WARNING)


def _answer_text(out: Outcome) -> list[Component | str]:
    """The status line of a target answered (a converged equilibrium drawn), headed by :func:`reach_words`."""
    a = out.answer
    sol = out.solution
    word, kind = reach_words(a, sol)
    how = f"path {a.path}, {a.evaluations} solves in {out.seconds:.1f} s"
    if a.method == INVERSE and a.reached:
        where = f"tip at {_mm(sol.tip_position)}, {show_distance(a.distance_m)} from the target"
    elif a.method == INVERSE:
        where = f"nearest tip found at {_mm(sol.tip_position)}, {_gap(a.distance_m)} from the target"
    else:
        where = f"its tensions solved from rest put the tip {_gap(a.distance_m)} from the target"
    stable = "" if a.method == INVERSE and a.reached else f" · {_equilibrium_words(sol)[0]}"
    return [_status_span(word, kind), f" · {where}{stable} · {how}", html.Br(),
            html.Span("the tendons are set to its tensions; the next change continues from this pose",
                      className="status-note"), *_notes(a.note)]


def _rest_text(out: Outcome) -> Component:
    """How the loading path from rest compares with the equilibrium shown."""
    rest, sol = out.rest, out.solution
    if not rest.converged:
        return _status_span(f"the loading path from rest does not converge (largest residual {rest.residual:.1e} "
                            "N m)", WARNING)
    same, gap = same_equilibrium(sol, rest)
    if same:
        return html.Span(f"the loading path from rest (drawn translucent) ends on the same equilibrium: "
                         f"{_equilibrium_words(rest)[0]}", className="status-note")
    return _status_span(f"the loading path from rest (drawn translucent) ends on another equilibrium, tip at "
                        f"{_mm(rest.tip_position)}, {_gap(gap)} away; {_equilibrium_words(rest)[0]}", WARNING)


def _patch(out: Outcome | None) -> Patch:
    """The figure's moving traces for ``out`` (the pose's empty when there is no equilibrium); with ``out``
    None, only the target's, emptied."""
    p = Patch()
    sol = None if out is None or out.error else out.solution
    parts = target_data(None if out is None else out.target, sol)
    if out is not None:
        parts |= pose_data(out.robot, sol, out.loads)
        parts[REST] = rest_data(out.robot, out.rest)
    for i, data in parts.items():
        for key, value in data.items():
            p["data"][i][key] = value
    return p


def _refused(text: str, keep: dict[str, object]) -> dict[str, object]:
    """The callback's answer to controls it cannot solve: the status says which control and what it takes."""
    return {"figure": no_update, "status": _status_span(f"not solved: {text}", WARNING),
            "tip": no_update, **keep}


def _respond(ex: Explorer, action: Action, tensions: object, wrench: object, options: object, aim: object,
             sid: object) -> dict[str, object]:
    """The page's answer to one request: the controls checked, then solved (continued from session ``sid``'s
    last equilibrium) or the target answered, and the figure's moving traces, the status and the tip."""
    n = ex.robot.n_tendons
    keep = {"tensions": [no_update] * n, "wrench": [no_update] * len(_WRENCH), "gravity": no_update,
            "pulls": [no_update] * n, "drive": no_update}
    session = _session_id(sid)
    if session is None:
        return _refused("session: the page's session id is not one this explorer issued; reload the page", keep)
    if action is Action.CLEAR:
        ex.clear_target(session)
        return {"figure": _patch(None), "status": _status_span("target cleared", NEUTRAL),
                "tip": no_update, **keep}
    if action is Action.RESET:
        d = ex.defaults
        tensions = d.tensions.tolist()
        wrench = [*d.tip_force.tolist(), *d.tip_moment.tolist(), d.payload_kg]
        options = {**(options if isinstance(options, dict) else {}), "gravity": ["on"] if d.gravity else [],
                   "drive": DRIVES[0]}
        keep = {**keep, "tensions": tensions, "wrench": wrench, "gravity": options["gravity"], "drive": DRIVES[0]}
    if action is Action.DRIVE:
        tensions, options = _switch_drive(ex, session, tensions, options, keep)
    c = _controls(ex, tensions, wrench, options)
    point = _target_point(ex, aim) if action is Action.TARGET else None
    for wrong in (c, point):
        if isinstance(wrong, str):
            return _refused(wrong, keep)
    out = ex.step(session, c, action) if point is None else ex.reach(session, c, point)
    if out.tensions is not None and out.solution is not None and out.solution.converged:
        # the answer's tensions, into the boxes (the sliders follow in the browser)
        keep["tensions"] = np.clip(np.round(out.tensions, _DECIMALS), ex.bounds.lower, ex.bounds.upper).tolist()
    status, tip = _status(out)
    return {"figure": _patch(out), "status": status, "tip": tip, **keep}


def _switch_drive(ex: Explorer, session: str, tensions: object, options: object,
                  keep: dict[str, object]) -> tuple[object, object]:
    """The drive just changed: the chosen drive's boxes take the inputs of the pose drawn (its pull-ins [mm] or
    its tensions [N]), so the robot stays where it is; the tensions and options to solve with. A slack tendon's
    pull-in is :data:`SLACK_MARGIN_MM` short of what would take up its slack, so that it stays slack (exactly
    taken up, inextensible tendons that carry nothing would still hold the robot's shape against the loading
    path from rest)."""
    pose = ex.pose_inputs(session)
    if pose is None or not isinstance(options, dict):
        return tensions, options
    found, pulls = pose
    if options.get("drive") == DRIVES[1]:
        span = _pull_span_mm(ex)
        pulls_mm = np.round(pulls * MM, _PULL_DECIMALS) - SLACK_MARGIN_MM * (found <= 0.0)
        keep["pulls"] = np.clip(pulls_mm, -span, span).tolist()
        return tensions, {**options, "pulls": keep["pulls"]}
    keep["tensions"] = np.clip(np.round(found, _DECIMALS), ex.bounds.lower, ex.bounds.upper).tolist()
    return keep["tensions"], options


def _other_drives(trigger: object, options: object) -> bool:
    """Whether the change ``trigger`` (a component id) is a box of the drive not chosen in ``options``."""
    drive = options.get("drive", DRIVES[0]) if isinstance(options, dict) else DRIVES[0]
    if not isinstance(trigger, str):
        return False
    return trigger.startswith("pull-") if drive == DRIVES[0] else trigger.startswith("tension-")


def build_app(ex: Explorer, *, port: int | None = None) -> Dash:
    """The Dash app of ``ex``: layout and callbacks, behind the request checks of :class:`._guard.Guard`.

    Parameters
    ----------
    ex : Explorer
        The robot, models and sessions.
    port : int, optional
        The port the page is served on: requests naming another host or port are refused. None: 127.0.0.1 and
        localhost on any port (``app.server.wsgi_app.narrow(port)`` narrows it later).
    """
    n = ex.robot.n_tendons
    app = Dash(__name__, title="pytdcr explore", update_title=None)
    app.layout = _layout(ex)
    for k in range(n):
        app.clientside_callback(_SYNC_JS.replace("SCALE", str(10**_DECIMALS)), Output(f"slider-{k}", "value"),
                                Output(f"tension-{k}", "value", allow_duplicate=True),
                                Input(f"slider-{k}", "drag_value"), Input(f"tension-{k}", "value"),
                                prevent_initial_call=True)
        app.clientside_callback(_SYNC_JS.replace("SCALE", str(10**_PULL_DECIMALS)), Output(f"pull-slider-{k}", "value"),
                                Output(f"pull-{k}", "value", allow_duplicate=True),
                                Input(f"pull-slider-{k}", "drag_value"), Input(f"pull-{k}", "value"),
                                prevent_initial_call=True)
    app.clientside_callback(_DRIVE_JS, Output("tension-rows", "style"), Output("pull-rows", "style"),
                            Input("drive", "value"))
    app.clientside_callback(_CLICK_JS, [Output(i, "value") for i in _TARGET], Input("graph", "clickData"),
                            prevent_initial_call=True)
    app.clientside_callback(_SEARCHING_JS, Output("status", "children", allow_duplicate=True),
                            Input("reach-target", "n_clicks"), prevent_initial_call=True)
    tension_ids, wrench_ids = [f"tension-{k}" for k in range(n)], list(_WRENCH)

    @app.callback(
        output={"figure": Output("graph", "figure"), "status": Output("status", "children"),
                "tip": Output("tip", "children"), "tensions": [Output(i, "value") for i in tension_ids],
                "wrench": [Output(i, "value") for i in wrench_ids], "gravity": Output("gravity", "value"),
                "pulls": [Output(f"pull-{k}", "value") for k in range(n)], "drive": Output("drive", "value")},
        inputs={"tensions": [Input(i, "value") for i in tension_ids],
                "wrench": [Input(i, "value") for i in wrench_ids],
                "options": {"gravity": Input("gravity", "value"), "friction": Input("friction", "value"),
                            "model": Input("model", "value"), "drive": Input("drive", "value"),
                            "pulls": [Input(f"pull-{k}", "value") for k in range(n)]},
                "clicks": [Input(i, "n_clicks") for i in _ACTIONS],
                "aim": [State(i, "value") for i in _TARGET], "sid": State("session", "data")})
    def on_change(tensions: list, wrench: list, options: dict, clicks: list, aim: list, sid: str) -> dict[str, object]:
        """Solve the controls (continued from the session's last equilibrium), or answer the target, and redraw."""
        trigger = ctx.triggered_id if isinstance(ctx.triggered_id, str) else None
        action = Action.DRIVE if trigger == "drive" else _ACTIONS.get(trigger, Action.CHANGE)
        if _other_drives(ctx.triggered_id, options):
            raise PreventUpdate  # a box of the drive not in use changed: nothing to solve
        try:
            return _respond(ex, action, tensions, wrench, options, aim, sid)
        except Exception as err:  # a bug: said on the page, its traceback in the server's log, never a 500
            traceback.print_exc(file=sys.stderr)
            return _refused(f"a bug in pytdcr ({type(err).__name__}); please report it with the server's log",
                            {"tensions": [no_update] * n, "wrench": [no_update] * len(_WRENCH),
                             "gravity": no_update, "pulls": [no_update] * n, "drive": no_update})

    server_callbacks = {k: v for k, v in app.callback_map.items() if callable(v.get("callback"))}
    app.server.config["MAX_CONTENT_LENGTH"] = MAX_BODY_BYTES
    app.server.wsgi_app = Guard(app.server.wsgi_app, port=port, callbacks=server_callbacks,
                                update_path=f"{app.config.routes_pathname_prefix}_dash-update-component")
    return app
