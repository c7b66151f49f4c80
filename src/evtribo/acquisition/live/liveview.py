"""The live view in a browser: a page on 127.0.0.1 that a subject can watch on a second screen.

``evtribo acquire --view [PORT]`` and ``evtribo session --view [PORT]`` serve it while they
record. The page shows, large, the normal force against its target band, the friction trace
of the last seconds, the high voltage's state and amplitude, what to do now (lift the finger,
slide) and the trial's progress; below, for the experimenter, frames per second per message,
drops and bus errors.

Served by the standard library (:mod:`http.server`, one thread per client) with
Server-Sent Events: ``GET /`` is the page (no external asset: styles and script inline),
``GET /events`` a ``text/event-stream`` of the state as JSON at :data:`RATE_HZ`,
``GET /state`` the latest state once. The recording publishes with :meth:`LiveView.publish`
(a dict swap, never blocking the receive path); a browser that goes away costs nothing.

Only this machine is served, whatever reaches the port: a request whose ``Host`` header is
not a loopback name (``127.0.0.1``, ``localhost``, ``[::1]``) is refused with 403, so that a
web page elsewhere cannot read the state through DNS rebinding. At most :data:`MAX_CLIENTS`
connections are served at once, so half-open connections cannot pile up threads; and they
cannot shut the viewer out either:

- a request must arrive whole within :data:`IDLE_TIMEOUT_S` of its connection, however
  its bytes trickle in (a client sending a byte every few seconds is dropped then, not kept
  for ever by a timeout that each byte restarts);
- when every connection is taken, the oldest one whose request is still incomplete is
  dropped to make room for the newcomer (a browser sends its request at once, so it is
  served); only when all are streams being watched does a newcomer get 503;
- a client that stops reading its stream for :data:`IDLE_TIMEOUT_S` is dropped.
"""

from __future__ import annotations

import json
import logging
import math
import socket
import threading
import time
from collections.abc import Mapping
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any

log = logging.getLogger(__name__)

__all__ = ["IDLE_TIMEOUT_S", "MAX_CLIENTS", "RATE_HZ", "LiveView"]

#: Updates per second sent to each browser.
RATE_HZ = 20.0
#: Default port of ``--view`` without a number.
DEFAULT_PORT = 8765
#: Seconds a client has to send its whole request (and may leave its stream unread) before
#: it is dropped.
IDLE_TIMEOUT_S = 10.0
#: Clients served at once (a browser tab holds one for its stream).
MAX_CLIENTS = 16
#: Host names the view answers to (with or without its port).
LOOPBACK_HOSTS = frozenset({"127.0.0.1", "localhost", "[::1]"})


def _own_host(header: str | None, names: frozenset[str], port: int) -> bool:
    """Whether a request's ``Host`` header is one of *names* (with or without *port*)."""
    if not header:
        return False
    host = header.strip().lower().rstrip(".")
    if host in names:
        return True
    name, _, number = host.rpartition(":")
    return name.rstrip(".") in names and number == str(port)


class _BoundedServer(ThreadingHTTPServer):
    """A threading HTTP server that serves at most *limit* connections at once, gives each
    *deadline_s* to deliver its whole request, and drops the oldest incomplete one to make
    room for a newcomer."""

    daemon_threads = True

    def __init__(self, address: tuple[str, int], handler: Any, limit: int,
                 deadline_s: float) -> None:
        super().__init__(address, handler)
        self._slots = threading.BoundedSemaphore(limit)
        self._deadline_s = deadline_s
        self._pending: dict[Any, float] = {}  # connection -> when it came, in order
        self._pending_lock = threading.Lock()

    def started(self, request: Any) -> None:
        """A connection is served: its request is awaited."""
        with self._pending_lock:
            self._pending[request] = time.monotonic()

    def complete(self, request: Any) -> None:
        """Its request arrived whole (or the connection ended)."""
        with self._pending_lock:
            self._pending.pop(request, None)

    def _drop(self, request: Any) -> None:
        try:
            request.shutdown(socket.SHUT_RDWR)  # its thread's read ends; the slot comes back
        except OSError:
            pass

    def _make_room(self) -> bool:
        """Drop the oldest connection whose request is incomplete; whether there was one."""
        with self._pending_lock:
            oldest = next(iter(self._pending), None)
            if oldest is None:
                return False
            del self._pending[oldest]
        self._drop(oldest)
        return True

    def service_actions(self) -> None:
        """Between polls: drop the connections whose request is late."""
        now = time.monotonic()
        with self._pending_lock:
            late = [r for r, t in self._pending.items() if now - t > self._deadline_s]
            for r in late:
                del self._pending[r]
        for r in late:
            self._drop(r)

    def process_request(self, request: Any, client_address: Any) -> None:
        free = self._slots.acquire(blocking=False)
        if not free and self._make_room():
            free = self._slots.acquire(timeout=2.0)
        if not free:
            try:
                request.sendall(b"HTTP/1.0 503 Service Unavailable\r\nContent-Length: 0\r\n"
                                b"Connection: close\r\n\r\n")
            except OSError:
                pass
            self.shutdown_request(request)
            return
        self.started(request)
        super().process_request(request, client_address)

    def process_request_thread(self, request: Any, client_address: Any) -> None:
        try:
            super().process_request_thread(request, client_address)
        finally:
            self.complete(request)
            self._slots.release()


def _finite(value: Any) -> Any:
    """*value* with NaN and infinities (not JSON) as None, in dicts too."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Mapping):
        return {k: _finite(v) for k, v in value.items()}
    return value


def _page() -> bytes:
    """The page's HTML (package data ``evtribo/data/liveview.html``)."""
    return (resources.files("evtribo") / "data" / "liveview.html").read_bytes()


class LiveView:
    """A live view of the recording, served on ``http://HOST:PORT/``.

    Parameters
    ----------
    port : int
        TCP port (0: any free one; :attr:`url` tells which).
    host : str
        Address to bind; the default keeps the page on this machine.
    rate_Hz : float
        Updates per second to each browser.
    idle_timeout_s : float, s
        A client whose request is not whole this long after it connected (or that does not
        read its stream this long) is dropped.
    max_clients : int
        Clients served at once; more get 503.

    Examples
    --------
    >>> view = LiveView(0).start()                    # doctest: +SKIP
    >>> view.publish({"normal_force_N": 0.51, "target_N": 0.5, "band_N": 0.1})  # doctest: +SKIP
    >>> view.stop()                                   # doctest: +SKIP
    """

    def __init__(self, port: int = DEFAULT_PORT, host: str = "127.0.0.1",
                 rate_Hz: float = RATE_HZ, *, idle_timeout_s: float = IDLE_TIMEOUT_S,
                 max_clients: int = MAX_CLIENTS) -> None:
        self.host, self.port, self.rate_Hz = host, port, rate_Hz
        self.idle_timeout_s, self.max_clients = idle_timeout_s, max_clients
        self._state: dict[str, Any] = {"seq": 0}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._server: ThreadingHTTPServer | None = None
        self._thread: threading.Thread | None = None
        self.clients = 0

    @property
    def url(self) -> str:
        """The page's address."""
        return f"http://{self.host}:{self.port}/"

    def publish(self, state: Mapping[str, Any]) -> None:
        """Make *state* (JSON-ready values; NaN becomes null) what the browsers see next."""
        clean = {k: _finite(v) for k, v in state.items()}
        with self._lock:
            seq = int(self._state.get("seq", 0)) + 1
            self._state = {**clean, "seq": seq}

    def state(self) -> dict[str, Any]:
        """The latest state published."""
        with self._lock:
            return dict(self._state)

    def start(self) -> LiveView:
        """Serve in a background thread; returns self.

        Raises
        ------
        OSError
            The port is taken (or not allowed).
        """
        view = self
        names = LOOPBACK_HOSTS | {self.host.lower()}

        class Handler(BaseHTTPRequestHandler):
            server_version = "evtribo-liveview"
            timeout = view.idle_timeout_s  # a silent client is dropped

            def log_message(self, format: str, *args: Any) -> None:
                log.debug("live view: " + format, *args)

            def parse_request(self) -> bool:
                ok = super().parse_request()  # the request line and headers are in
                server.complete(self.connection)
                return ok

            def do_GET(self) -> None:
                path = self.path.split("?", 1)[0]
                if not _own_host(self.headers.get("Host"), names, view.port):
                    self.send_error(HTTPStatus.FORBIDDEN, "the live view answers only to "
                                    "127.0.0.1, localhost and [::1]")
                elif path in ("/", "/index.html"):
                    self._send(_page(), "text/html; charset=utf-8")
                elif path == "/state":
                    self._send(json.dumps(view.state()).encode(), "application/json")
                elif path == "/events":
                    view._stream(self)
                else:
                    self.send_error(HTTPStatus.NOT_FOUND)

            def _send(self, body: bytes, kind: str) -> None:
                self.send_response(HTTPStatus.OK)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)

        server = _BoundedServer((self.host, self.port), Handler, self.max_clients,
                                self.idle_timeout_s)
        self._server = server
        self.port = int(server.server_address[1])
        self._thread = threading.Thread(target=server.serve_forever, kwargs={
            "poll_interval": 0.1}, name="evtribo-liveview", daemon=True)
        self._thread.start()
        log.info("live view on %s", self.url)
        return self

    def _stream(self, handler: BaseHTTPRequestHandler) -> None:
        """Send the state as Server-Sent Events until the browser leaves or the view
        stops."""
        handler.send_response(HTTPStatus.OK)
        handler.send_header("Content-Type", "text/event-stream")
        handler.send_header("Cache-Control", "no-store")
        handler.end_headers()
        self.clients += 1
        period = 1.0 / self.rate_Hz
        try:
            handler.wfile.write(b"retry: 500\n\n")
            while not self._stop.is_set():
                data = json.dumps(self.state(), allow_nan=False, default=str)
                handler.wfile.write(f"data: {data}\n\n".encode())
                handler.wfile.flush()
                time.sleep(period)
        except (OSError, ValueError):
            pass  # the browser went away, or stopped reading for IDLE_TIMEOUT_S
        finally:
            self.clients -= 1

    def stop(self) -> None:
        """Stop serving (open pages keep the last picture)."""
        self._stop.set()
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
        if self._thread is not None:
            self._thread.join(timeout=2)

    def __enter__(self) -> LiveView:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
