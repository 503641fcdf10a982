"""The explorer's front door: WSGI middleware that checks every request before the web app sees it.

A page on 127.0.0.1 is a network service: any web page the user visits can send requests to it. So:

- the ``Host`` header must name the loopback address the page is served on (``127.0.0.1`` or ``localhost``, on
  the server's port once it is known): a page that re-points its own domain at 127.0.0.1 (DNS rebinding) sends
  its own domain there and is refused (403);
- a request that changes state (POST) must come from the page itself: an ``Origin`` or ``Sec-Fetch-Site`` of
  another site is refused (403), and its body must be JSON (415);
- a body larger than :data:`MAX_BODY_BYTES` is refused before it is read (413);
- a callback request (``_dash-update-component``) is rebuilt from the app's own callback table: the callback
  must be one of the page's, every input and state the callback declares is taken from the request by its id
  and property (one the request lacks arrives as a missing value, for the callback to name), anything else the
  request carries is dropped; a body that is not JSON, or nested deeper than :data:`MAX_DEPTH`, is refused (400);
- no answer may be drawn inside another site's page (a frame whose clicks that page would steer) or read by it.

Refusals are one short plain-text line, with no work done by the app.
"""

from __future__ import annotations

import io
import json
import re
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, TypedDict

from ..io import nesting_depth
from ..records import JsonDict
from ..validate import show

if TYPE_CHECKING:
    from _typeshed import OptExcInfo
    from _typeshed.wsgi import StartResponse, WSGIEnvironment
    from _typeshed.wsgi import WSGIApplication as WSGIApp

__all__ = ["LOOPBACK_NAMES", "MAX_BODY_BYTES", "MAX_DEPTH", "Guard", "Refused", "callback_request"]

#: the largest request body read [bytes]: a real update of the page with 8 tendons sends about 3 kB, one with
#: 100 tendons about 25 kB
MAX_BODY_BYTES = 256 * 1024
#: the deepest nesting of lists and objects read from a request body (the page's deepest is 3)
MAX_DEPTH = 16
#: the host names the page answers to (the server listens on 127.0.0.1 only)
LOOPBACK_NAMES = ("127.0.0.1", "localhost")
#: a ``Host`` header naming the page: one of :data:`LOOPBACK_NAMES` (any case), then a port or nothing; matched
#: whole (``fullmatch``: no trailing newline slips past ``$``)
_HOST = re.compile(rf"({'|'.join(map(re.escape, LOOPBACK_NAMES))})(?::([0-9]{{1,5}}))?", re.IGNORECASE)
_METHODS = ("GET", "HEAD", "POST")
#: on every answer: never drawn inside another site's page (whose clicks would drive it), never read by another
#: site's page, never sniffed into another type
_HEADERS = (("X-Frame-Options", "DENY"), ("Content-Security-Policy", "frame-ancestors 'none'"),
            ("Cross-Origin-Resource-Policy", "same-origin"), ("X-Content-Type-Options", "nosniff"))
_LENGTH = re.compile("[0-9]{1,20}")  # ASCII digits only (str.isdigit takes "²", which int() does not)


class DashDependency(TypedDict):
    """One input or state of a callback as Dash's callback table holds it: the component's id (Dash writes a
    pattern-matching id as its JSON text) and the property."""

    id: str
    property: str


class DashCallback(TypedDict):
    """What the guard reads of one entry of Dash's callback table (``app.callback_map``, which holds more keys):
    the callback's inputs and states."""

    inputs: list[DashDependency]
    state: list[DashDependency]


class Refused(Exception):
    """A request refused: the HTTP status and one line saying why."""

    def __init__(self, status: int, text: str) -> None:
        super().__init__(text)
        self.status, self.text = status, text


_REASONS = {400: "Bad Request", 403: "Forbidden", 405: "Method Not Allowed",
            413: "Content Too Large", 415: "Unsupported Media Type"}


class Guard:
    """WSGI middleware around the explorer's app: the checks of this module, then ``app``.

    Parameters
    ----------
    app : WSGI application
        The web app (the Dash app's Flask server's ``wsgi_app``).
    port : int, optional
        The port the page is served on: only ``127.0.0.1:port`` and ``localhost:port`` are answered (bare names
        too for port 80). None: the loopback names on any port (a test client, a notebook); :meth:`narrow` sets it.
    callbacks : dict, optional
        The app's callback table (Dash's ``app.callback_map``): callback requests are rebuilt from it
        (:func:`callback_request`).
    update_path : str
        The path of callback requests.
    """

    def __init__(self, app: WSGIApp, *, port: int | None = None, callbacks: dict[str, DashCallback] | None = None,
                 update_path: str = "/_dash-update-component") -> None:
        self.app, self.port, self.callbacks, self.update_path = app, port, callbacks, update_path

    def narrow(self, port: int | None) -> None:
        """Answer only requests to ``port`` from now on (None: any port)."""
        self.port = port

    # ------------------------------------------------------------------ the checks
    def host_allowed(self, host: str | None) -> bool:
        """Whether a ``Host`` header (or an ``Origin``'s host and port) names this page: one of
        :data:`LOOPBACK_NAMES`, on its port, and nothing else (not even a trailing newline)."""
        m = _HOST.fullmatch(host or "")
        if m is None:
            return False
        if self.port is None:
            return m.group(2) is None or 1 <= int(m.group(2)) <= 65535
        return int(m.group(2)) == self.port if m.group(2) is not None else self.port == 80

    def _check_headers(self, environ: WSGIEnvironment) -> None:
        """:class:`Refused` for a foreign host, a method the page does not use, a POST from another site or not
        of JSON, or a body declared too long."""
        if not self.host_allowed(environ.get("HTTP_HOST")):
            raise Refused(403, "refused: the Host header does not name this explorer (127.0.0.1 or localhost on "
                          "its port)")
        method = environ.get("REQUEST_METHOD", "")
        if method not in _METHODS:
            raise Refused(405, "refused: the explorer answers GET, HEAD and POST only")
        length = environ.get("CONTENT_LENGTH") or ""
        if length and not _LENGTH.fullmatch(length):
            raise Refused(400, "refused: Content-Length is not a byte count")
        if length and int(length) > MAX_BODY_BYTES:
            raise Refused(413, f"refused: a request body is at most {MAX_BODY_BYTES} bytes")
        if method != "POST":
            return
        origin = environ.get("HTTP_ORIGIN")
        if origin is not None and not (origin.lower().startswith("http://")
                                       and self.host_allowed(origin[len("http://"):])):
            raise Refused(403, "refused: a change from another site (Origin is not this explorer's page)")
        if environ.get("HTTP_SEC_FETCH_SITE", "same-origin") not in ("same-origin", "none"):
            raise Refused(403, "refused: a change from another site (Sec-Fetch-Site is not same-origin)")
        mime = (environ.get("CONTENT_TYPE") or "").split(";")[0].strip().lower()
        if mime != "application/json":
            raise Refused(415, "refused: a change is sent as application/json")

    def _body(self, environ: WSGIEnvironment) -> bytes:
        """The request's body, at most :data:`MAX_BODY_BYTES` (:class:`Refused` 413 beyond; 400 when it cannot be
        read: a malformed chunked body, a connection cut short)."""
        stream = environ.get("wsgi.input")
        length = environ.get("CONTENT_LENGTH") or ""
        if length:
            want = int(length)
        elif environ.get("wsgi.input_terminated"):  # chunked: read to the end, one byte past the bound at most
            want = MAX_BODY_BYTES + 1
        else:  # neither a length nor chunks: no body (RFC 9112, 6.3)
            want = 0
        try:
            data = stream.read(want) if stream is not None and want else b""
        except (OSError, ValueError) as err:  # the server's reader: "Invalid chunk header", a closed connection
            raise Refused(400, f"refused: the request body cannot be read ({show(str(err), 80)[1:-1]})") from None
        if len(data) > MAX_BODY_BYTES:
            raise Refused(413, f"refused: a request body is at most {MAX_BODY_BYTES} bytes")
        return data

    def _rebuilt(self, data: bytes) -> bytes:
        """A callback request's body rebuilt from the app's callback table (:func:`callback_request`)."""
        try:
            body = json.loads(data)
        except (ValueError, RecursionError):  # not UTF-8, not JSON, an integer of too many digits, too deep
            raise Refused(400, "refused: the request body is not JSON") from None
        if nesting_depth(body, MAX_DEPTH) > MAX_DEPTH:
            raise Refused(400, f"refused: the request body nests deeper than {MAX_DEPTH} levels")
        return json.dumps(callback_request(body, self.callbacks or {})).encode()

    # ------------------------------------------------------------------ WSGI
    def __call__(self, environ: WSGIEnvironment, start_response: StartResponse) -> Iterable[bytes]:
        try:
            self._check_headers(environ)
            if environ.get("REQUEST_METHOD") == "POST":
                data = self._body(environ)
                if environ.get("PATH_INFO") == self.update_path and self.callbacks is not None:
                    data = self._rebuilt(data)
                environ["wsgi.input"] = io.BytesIO(data)
                environ["CONTENT_LENGTH"] = str(len(data))
                environ.pop("wsgi.input_terminated", None)
                environ.pop("HTTP_TRANSFER_ENCODING", None)
        except Refused as why:
            text = (why.text + "\n").encode()
            start_response(f"{why.status} {_REASONS.get(why.status, 'Refused')}",
                           [("Content-Type", "text/plain; charset=utf-8"), ("Content-Length", str(len(text))),
                            *_HEADERS])
            return [text]

        def own_page_only(status: str, headers: list[tuple[str, str]],
                          exc_info: OptExcInfo | None = None) -> Callable[[bytes], object]:
            names = {h.lower() for h, _ in _HEADERS}
            return start_response(status, [*(h for h in headers if h[0].lower() not in names), *_HEADERS],
                                  exc_info)

        return self.app(environ, own_page_only)


def _values(items: object) -> dict[tuple[str, str], object]:
    """The values a request gives, by (id, property); the first of each, entries of another form ignored."""
    found: dict[tuple[str, str], object] = {}
    if isinstance(items, dict):
        items = [items]
    for it in items if isinstance(items, list) else ():
        if isinstance(it, dict) and isinstance(it.get("id"), str) and isinstance(it.get("property"), str) \
                and "value" in it:
            found.setdefault((it["id"], it["property"]), it["value"])
    return found


def _filled(specs: list[DashDependency], items: object) -> list[JsonDict]:
    """One entry per dependency the callback declares (``specs``), with the request's value for it if any."""
    got = _values(items)
    out = []
    for s in specs:
        if not isinstance(s.get("id"), str):
            raise Refused(400, "refused: a pattern-matching callback is not answered")
        key = (s["id"], s["property"])
        out.append({"id": s["id"], "property": s["property"], **({"value": got[key]} if key in got else {})})
    return out


def _outputs(key: str) -> JsonDict | list[JsonDict]:
    """The outputs of the callback of id ``key`` (Dash's own form of a callback's id: ``..a.b...c.d..`` for
    several, ``a.b`` for one), as the page sends them."""
    if key.startswith(".."):
        return [_outputs(k) for k in key[2:-2].split("...")]
    id_, prop = key.rsplit(".", 1)
    return {"id": id_, "property": prop}


def callback_request(body: object, callbacks: dict[str, DashCallback]) -> JsonDict:
    """A callback request rebuilt from the app's callback table: the callback named by ``body["output"]`` (one
    of ``callbacks``, else :class:`Refused` 400), its outputs as the table has them, each of its inputs and
    states with the request's value (by id and property; none where the request has none) and the inputs
    the request says changed (those of the callback only)."""
    key = body.get("output") if isinstance(body, dict) else None
    if not isinstance(key, str) or key not in callbacks:
        raise Refused(400, "refused: not a callback of this page")
    cb = callbacks[key]
    inputs = _filled(cb["inputs"], body.get("inputs"))
    known = {f"{s['id']}.{s['property']}" for s in inputs}
    changed = body.get("changedPropIds")
    changed = list(dict.fromkeys(c for c in changed if isinstance(c, str) and c in known)) \
        if isinstance(changed, list) else []
    return {"output": key, "outputs": _outputs(key), "inputs": inputs, "state": _filled(cb["state"], body.get("state")),
            "changedPropIds": changed}
