"""Headless Chromium driven over the DevTools protocol, to look at a page as a person would.

Chromium is Debian's package (``apt-get install chromium``; ``make test`` installs it when
it is absent and it runs as root); without it, a test that opens a :class:`Browser` is
skipped and says why. The protocol's WebSocket is spoken by ``websocket-client`` (the
``test`` extra).
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import tempfile
import time
import urllib.request
from typing import Any

import pytest
import websocket

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


class Browser:
    """A headless Chromium (a context manager); :meth:`open` gives a :class:`Page`."""

    def __init__(self) -> None:
        if CHROMIUM is None:  # a test that looks at a page is skipped, and says why
            pytest.skip("no Chromium to look at the page: sudo apt-get install chromium "
                        "(make test installs it when run as root)")
        self.dir = tempfile.mkdtemp(prefix="evtribo-chromium-")
        self.stderr_path = f"{self.dir}/stderr.txt"
        with open(self.stderr_path, "w") as err:  # a file: Chromium never blocks on it
            self.proc = subprocess.Popen(
                [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                 "--remote-debugging-port=0", f"--user-data-dir={self.dir}/profile",
                 "about:blank"], stdout=subprocess.DEVNULL, stderr=err)
        self.pages: list[Page] = []
        self.port = self._port()

    def _port(self) -> int:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and self.proc.poll() is None:
            with open(self.stderr_path) as f:
                m = re.search(r"DevTools listening on ws://[^:]+:(\d+)/", f.read())
            if m:
                return int(m.group(1))
            time.sleep(0.05)
        self.close()
        raise RuntimeError("Chromium did not start its DevTools server")

    def open(self, url: str) -> Page:
        req = urllib.request.Request(f"http://127.0.0.1:{self.port}/json/new?{url}",
                                     method="PUT")
        with urllib.request.urlopen(req, timeout=30) as resp:
            info = json.load(resp)
        page = Page(info["webSocketDebuggerUrl"])
        self.pages.append(page)
        return page

    def close(self) -> None:
        for page in getattr(self, "pages", []):
            page.ws.close()
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        shutil.rmtree(self.dir, ignore_errors=True)

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class Page:
    """One tab: :meth:`eval` runs JavaScript in it and returns the value."""

    def __init__(self, ws_url: str) -> None:
        self.ws = websocket.create_connection(ws_url, timeout=30, suppress_origin=True)
        self.n = 0

    def eval(self, expression: str) -> Any:
        self.n += 1
        self.ws.send(json.dumps({"id": self.n, "method": "Runtime.evaluate",
                                 "params": {"expression": expression,
                                            "returnByValue": True}}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == self.n:
                return msg["result"]["result"].get("value")

    def wait_for(self, expression: str, timeout: float = 20.0) -> Any:
        """Evaluate *expression* until it is truthy; return it."""
        deadline = time.monotonic() + timeout
        while True:
            value = self.eval(expression)
            if value or time.monotonic() > deadline:
                return value
            time.sleep(0.1)
