"""``tdcr explore``: a local web page to move a robot's tendons and loads and watch its equilibrium, live.

Each change is solved by continuation from the last equilibrium shown (``pytdcr.solve(..., start=last)``), the
quasi-static answer of a robot whose tensions move; "solve from rest" shows the loading path's answer beside it.
A target point is answered by inverse statics (:func:`pytdcr.inverse_statics`), or by a workspace run's nearest
sample for a model without a tip gradient. A finished ``tdcr workspace`` folder adds its boundary and its
largest-reach pose.

The page is a Dash app (imported when the app is built, never with :mod:`pytdcr`), served on 127.0.0.1 only; it
answers only requests addressed to 127.0.0.1 or localhost on its port, changes only from its own page, and checks
every value a request carries (:mod:`._guard`, :mod:`._app`).
"""

from __future__ import annotations

import socket
import threading
import time
import webbrowser
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from ..robot import Robot
from ..runtime import check_cancelled
from ..validate import SettingsError
from ._session import Explorer
from ._workspace import WorkspaceView, read_workspace

if TYPE_CHECKING:
    from dash import Dash

__all__ = ["HOST", "Explorer", "PortError", "WorkspaceView", "check_port", "create_app", "read_workspace", "serve"]

#: the only address the page is served on
HOST = "127.0.0.1"


def create_app(robot: Robot | None = None, *, workspace: str | Path | None = None, model: str | None = "pcc",
               port: int | None = None) -> Dash:
    """The explorer's Dash app (for tests and notebooks; :func:`serve` runs it).

    Its server (``app.server``, a WSGI app) answers only requests that name 127.0.0.1 or localhost as their host,
    changes only from its own page, bodies of a bounded size and callback requests of the page's own form
    (:mod:`pytdcr.explore._guard`); every value a request carries is checked before it is used.

    Parameters
    ----------
    robot : Robot, optional
        Default: the workspace run's robot with ``workspace``, else :func:`pytdcr.paper.paper_robot`.
    workspace : str or Path, optional
        A finished ``tdcr workspace`` output folder: its FSW boundary and largest-reach pose are drawn.
    model : str or None
        The registered model selected first (:data:`pytdcr.statics.MODELS`); None: the workspace run's, else pcc.
    port : int, optional
        The port the page is served on: requests to another are refused. None: any port.

    Raises
    ------
    SettingsError
        Naming ``workspace`` for a folder that is not a finished workspace run, ``model`` for an unknown model,
        ``port`` for a port outside [1, 65535].
    """
    from ._app import build_app

    port = None if port is None else check_port(port)
    ex = Explorer(robot, workspace=workspace, model=model)
    _warm(ex)
    return build_app(ex, port=port)


def _warm(ex: Explorer) -> None:
    """Solve once from rest and once by continuation, so the first move on the page does not load the kernels;
    and, unless the first model is slow, answer a target once (inverse statics' kernels and its start pool for
    the first loads, kept on disk: :func:`pytdcr.inverse_statics`)."""
    sid = "warm-up"
    ex.step(sid, ex.defaults)
    moved = ex.step(sid, replace(ex.defaults, tensions=ex.bounds.lower + 0.1 * (ex.bounds.upper - ex.bounds.lower)))
    if moved.solution is not None and moved.solution.converged and ex.model.name not in ex.slow_models():
        ex.reach(sid, ex.defaults, moved.solution.tip_position)
    ex.forget(sid)


class PortError(OSError):
    """The port cannot be listened on (in use, or not allowed); the message begins with ``port N``."""


def check_port(port: int) -> int:
    """``port`` as an int in [1, 65535]; :class:`SettingsError` naming ``port`` otherwise."""
    if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
        raise SettingsError("port", f" = {port!r}: must be an integer in [1, 65535]")
    return port


def _check_free(port: int) -> None:
    """:class:`PortError` when ``port`` on 127.0.0.1 cannot be listened on (in use, say)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server does
        try:
            s.bind((HOST, port))
        except OSError as err:
            raise PortError(f"port {port}: cannot listen on {HOST}:{port} ({err.strerror or err}); choose "
                            "another port") from None


def serve(robot: Robot | None = None, *, workspace: str | Path | None = None, port: int = 8080,
          model: str | None = "pcc", open_browser: bool = False) -> None:
    """Serve the explorer at http://127.0.0.1:``port``/ until interrupted (Ctrl-C); blocks.

    Parameters as for :func:`create_app`; ``port`` in [1, 65535]; ``open_browser`` opens the page in the
    default browser once the server listens.

    Raises
    ------
    SettingsError
        For a bad port, workspace folder or model.
    PortError
        When the port cannot be listened on (in use, say), naming it.
    """
    from werkzeug.serving import WSGIRequestHandler, make_server

    class Quiet(WSGIRequestHandler):
        """No line per request on stderr."""

        def log_request(self, *args: object) -> None:
            pass

    _check_free(check_port(port))
    app = create_app(robot, workspace=workspace, model=model, port=port)
    try:
        server = make_server(HOST, port, app.server, threaded=True, request_handler=Quiet)
    except (OSError, SystemExit):  # werkzeug says why on stderr and exits
        raise PortError(f"port {port}: cannot listen on {HOST}:{port}; choose another port") from None
    url = f"http://{HOST}:{port}/"
    thread = threading.Thread(target=server.serve_forever, name="tdcr-explore", daemon=True)
    thread.start()
    print(f"tdcr explore: serving {url} (Ctrl-C stops)", flush=True)
    if open_browser:
        webbrowser.open(url)
    try:
        while thread.is_alive():
            time.sleep(0.2)
            check_cancelled()  # the command line's Ctrl-C
    except KeyboardInterrupt:
        pass
    finally:
        server.shutdown()
        server.server_close()
