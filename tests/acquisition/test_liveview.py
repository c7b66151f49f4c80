"""The live view: a page on 127.0.0.1 fed by Server-Sent Events, looked at in Chromium."""

from __future__ import annotations

import json
import math
import threading
import time
import urllib.request

import pytest
from tests._browser import Browser

from evtribo.acquisition.live.liveview import LiveView


def _events(url: str, n: int) -> list[dict]:
    out = []
    with urllib.request.urlopen(url + "events", timeout=10) as resp:
        assert resp.headers["Content-Type"] == "text/event-stream"
        for raw in resp:
            line = raw.decode().strip()
            if line.startswith("data: "):
                out.append(json.loads(line[6:]))
                if len(out) == n:
                    return out
    return out


def test_events_carry_the_latest_state_and_no_nan():
    with LiveView(0) as view:
        view.publish({"normal_force_N": math.nan, "rates_Hz": {"FzCell": math.inf},
                      "title": "P01/run-01"})
        first = _events(view.url, 1)[0]
        assert first["normal_force_N"] is None and first["rates_Hz"] == {"FzCell": None}
        view.publish({"normal_force_N": 0.5})
        with urllib.request.urlopen(view.url + "state", timeout=10) as resp:
            state = json.load(resp)
        assert state["normal_force_N"] == 0.5 and state["seq"] == first["seq"] + 1
        with urllib.request.urlopen(view.url, timeout=10) as resp:
            page = resp.read().decode()
        # no external asset: nothing fetched from another origin
        assert "http://" not in page and "https://" not in page and "src=" not in page


def test_unknown_path_is_404():
    with LiveView(0) as view, pytest.raises(urllib.error.HTTPError) as err:
        urllib.request.urlopen(view.url + "nope", timeout=10)
    assert err.value.code == 404
    err.value.close()


def test_chromium_sees_the_gauge_move_and_the_band():
    with LiveView(0) as view:
        stop = threading.Event()

        def feed() -> None:
            t0 = time.monotonic()
            while not stop.is_set():
                t = time.monotonic() - t0
                view.publish({"title": "P01/run-01", "elapsed_s": t, "duration_s": 20.0,
                              "normal_force_N": 0.5 + 0.1 * math.sin(3 * t),
                              "target_N": 0.5, "band_N": 0.1, "band_state": "in",
                              "tangential_force_N": 0.2 * math.sin(2 * t), "hv_on": True,
                              "hv_amplitude_V": 100.0, "hv_waveform": "square"})
                time.sleep(0.02)

        thread = threading.Thread(target=feed, daemon=True)
        thread.start()
        try:
            with Browser() as browser:
                page = browser.open(view.url)
                assert page.wait_for("Number(document.body.dataset.updates) >= 5")
                seen = page.wait_for("Number(document.body.dataset.fnMax) - "
                                     "Number(document.body.dataset.fnMin) > 0.01 && "
                                     "document.body.dataset.fnMax")
                assert seen
                band = float(page.eval("document.getElementById('band').getAttribute('width')"))
                # target ± band on a scale of target ± 4 band: a quarter of the gauge
                assert band == pytest.approx(250.0, abs=1)
                assert page.eval("document.getElementById('hv').textContent").startswith(
                    "HIGH VOLTAGE ON  100 V")
        finally:
            stop.set()
            thread.join()


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.slow
def test_chromium_watches_a_simulated_trial_stream_through_acquire_view(tmp_path,
                                                                        simulate_pty):
    import subprocess
    import sys

    from _process import kill_and_reap

    _sim, pty = simulate_pty("--duration", "120")
    port = _free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "evtribo", "acquire", "--study", str(tmp_path / "study"),
         "--subject", "P01", "--trial", "run-01", "--duration", "8", "--interface", "slcan",
         "--channel", pty, "--bus-option", "sleep_after_open=0", "--target-force", "0.5",
         "--band", "0.1", "--view", str(port), "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline() if proc.stdout else ""
        assert f"http://127.0.0.1:{port}/" in line, (line, proc.poll())
        with Browser() as browser:
            page = browser.open(f"http://127.0.0.1:{port}/")
            assert page.wait_for("Number(document.body.dataset.updates) >= 10")
            assert page.wait_for("document.getElementById('fn').dataset.value !== undefined")
            first = page.eval("document.getElementById('fn').dataset.value")
            # the subject's normal force moves, and the gauge with it
            assert page.wait_for("Number(document.body.dataset.fnMax) - "
                                 "Number(document.body.dataset.fnMin) > 0.002")
            assert page.wait_for(
                f"document.getElementById('fn').dataset.value !== {first!r}")
            width = float(page.eval("document.getElementById('band').getAttribute('width')"))
            assert width == pytest.approx(250.0, abs=1)  # target ± band, a quarter of it
            assert page.eval("document.getElementById('trial').textContent") == "P01/run-01"
            # the amplifier's status: the simulated trial alternates ON and OFF at 140 V
            assert page.wait_for("document.getElementById('hv').dataset.on === 'true'")
            assert "140 V" in page.eval("document.getElementById('hv').textContent")
        proc.wait(timeout=60)
    finally:
        kill_and_reap(proc, timeout=10)
    assert proc.returncode == 0
    assert (tmp_path / "study" / "P01" / "run-01.log").exists()


def _get(url: str, host: str) -> tuple[int, bytes]:
    request = urllib.request.Request(url, headers={"Host": host})
    try:
        with urllib.request.urlopen(request, timeout=30) as resp:
            return resp.status, resp.read()
    except urllib.error.HTTPError as err:
        with err:
            return err.code, err.read()


def test_only_this_machines_names_are_answered():
    """DNS rebinding: a page of attacker.example that resolves to 127.0.0.1 sends its own
    name as Host; the view refuses it (403) and gives nothing of the state."""
    with LiveView(0) as view:
        view.publish({"subject": "P01", "normal_force_N": 0.5})
        for path in ("", "state", "events"):
            code, body = _get(view.url + path, "attacker.example")
            assert code == 403 and b"P01" not in body, path
            assert _get(view.url + path, f"attacker.example:{view.port}")[0] == 403
        for host in ("127.0.0.1", f"127.0.0.1:{view.port}", f"localhost:{view.port}",
                     "LOCALHOST", f"[::1]:{view.port}"):
            code, body = _get(view.url + "state", host)
            assert code == 200 and json.loads(body)["subject"] == "P01", host
        assert _get(view.url + "state", f"localhost:{view.port + 1}")[0] == 403


def _handler_threads() -> int:
    return sum("process_request_thread" in t.name for t in threading.enumerate())


def _closed(sock, deadline_s: float = 60.0) -> bool:
    """Whether the server closes *sock* (reads EOF) before the deadline; a loaded machine
    may be slow, so the deadline is far beyond the view's idle timeout."""
    sock.settimeout(deadline_s)
    try:
        return sock.recv(1) == b""
    except TimeoutError:
        return False
    except OSError:
        return True


def test_idle_connections_are_bounded_in_number_and_dropped():
    """60 connections that send nothing held 47 threads for ever: now at most max_clients
    are served at once (each newcomer takes the place of the oldest silent one, which is
    closed), and a silent one is dropped."""
    import socket

    with LiveView(0, idle_timeout_s=120.0, max_clients=4) as view:
        idle = [socket.create_connection(("127.0.0.1", view.port), timeout=30)
                for _ in range(60)]
        try:
            assert all(_closed(sock) for sock in idle[:-4])  # made room for the next ones
            assert _handler_threads() <= 4
        finally:
            for sock in idle:
                sock.close()
    with LiveView(0, idle_timeout_s=0.5, max_clients=4) as view:
        idle = [socket.create_connection(("127.0.0.1", view.port), timeout=30)
                for _ in range(4)]
        try:
            assert all(_closed(sock) for sock in idle)  # dropped once silent
        finally:
            for sock in idle:
                sock.close()
        for _ in range(1200):  # their slots come back: a browser is served again
            if _handler_threads() == 0:
                break
            time.sleep(0.05)
        code, body = _get(view.url + "state", "127.0.0.1")
        assert code == 200 and "seq" in json.loads(body)


def test_clients_trickling_their_requests_never_shut_the_viewer_out():
    """16 clients each sending a byte every 4 s held every slot for ever (the timeout was
    per read) and the viewer got 503: a request must now be whole within the timeout of its
    connection, and the oldest incomplete one makes room for a newcomer."""
    import socket

    stop = threading.Event()
    with LiveView(0, idle_timeout_s=3.0, max_clients=4) as view:
        slow = []
        for _ in range(4):
            sock = socket.create_connection(("127.0.0.1", view.port), timeout=30)
            sock.sendall(b"GET /state HTTP/1.0\r\nHost: 127.0.0.1\r\n")
            slow.append(sock)

        def trickle():  # a header's byte every 0.5 s: each read well within 3 s
            while not stop.wait(0.5):
                for sock in slow:
                    try:
                        sock.sendall(b"X")
                    except OSError:
                        pass

        dripping = threading.Thread(target=trickle, daemon=True)
        dripping.start()
        try:
            code, body = _get(view.url + "state", "127.0.0.1")
            assert code == 200 and "seq" in json.loads(body)
            # and a request that never ends is dropped, however it trickles
            assert all(_closed(sock) for sock in slow)
        finally:
            stop.set()
            dripping.join(10)
            for sock in slow:
                sock.close()
