"""A headless Chromium for the report pages' tests, driven through chromedriver's W3C
WebDriver protocol (plain HTTP and JSON: no client library). Debian's chromium and
chromium-driver are what `.ci/run` installs; where they are absent the tests say so and
skip. Nothing is downloaded."""

from __future__ import annotations

import base64
import json
import shutil
import socket
import subprocess
import time
import urllib.request
from pathlib import Path

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
#: the flags a root process on this closed network needs (see the machine's notes): no
#: sandbox (root), no GPU, nothing that reaches for the network in the background
FLAGS = ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage"]


def missing() -> str:
    """Why no browser can run here ("" when one can)."""
    for path in (CHROMIUM, CHROMEDRIVER):
        if not Path(path).is_file():
            return (f"{path} is absent: the browser tests need Debian's chromium and "
                    "chromium-driver (apt-get install chromium chromium-driver; .ci/run "
                    "installs them)")
    return ""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Browser:
    """One chromedriver and one browser session; ``with Browser(profile) as b: ...``
    (``scripts=False``: the page's JavaScript switched off, as a reader may have it)."""

    def __init__(self, profile: Path, width: int = 1280, height: int = 900,
                 scripts: bool = True):
        self.port = _free_port()
        self.driver = subprocess.Popen([CHROMEDRIVER, f"--port={self.port}"],
                                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self._wait_ready()
        caps = {"capabilities": {"alwaysMatch": {
            "browserName": "chrome", "goog:loggingPrefs": {"browser": "ALL"},
            "goog:chromeOptions": {"binary": CHROMIUM, "args": [
                *FLAGS, f"--user-data-dir={profile}", f"--window-size={width},{height}",
                *([] if scripts else ["--blink-settings=scriptEnabled=false"])]}}}}
        self.session = self._call("POST", "/session", caps)["sessionId"]

    def _wait_ready(self) -> None:
        for _ in range(100):
            try:
                self._call("GET", "/status")
                return
            except OSError:
                time.sleep(0.1)
        raise RuntimeError("chromedriver did not start")

    def _call(self, method: str, path: str, body: dict | None = None):
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(f"http://127.0.0.1:{self.port}{path}", data=data,
                                     method=method,
                                     headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(req, timeout=60) as r:
            return json.loads(r.read())["value"]

    def _session(self, method: str, path: str, body: dict | None = None):
        return self._call(method, f"/session/{self.session}{path}", body)

    def open(self, url: str) -> None:
        self._session("POST", "/url", {"url": url})

    def run(self, script: str, *args):
        """The value of a JavaScript function body run in the page."""
        return self._session("POST", "/execute/sync", {"script": script, "args": list(args)})

    def size(self, width: int, height: int) -> None:
        self._session("POST", "/window/rect", {"width": width, "height": height})

    def point_at(self, selector: str, index: int = 0) -> None:
        """Move the pointer onto the ``index``-th element matching ``selector``."""
        found = self._session("POST", "/elements", {"using": "css selector",
                                                   "value": selector})
        element = found[index]
        self.run("arguments[0].scrollIntoView({block: 'center'});", element)
        self._session("POST", "/actions", {"actions": [{
            "type": "pointer", "id": "mouse", "parameters": {"pointerType": "mouse"},
            "actions": [{"type": "pointerMove", "duration": 0, "origin": element,
                         "x": 0, "y": 0}]}]})

    def console(self) -> list[dict]:
        """The browser console's entries since the last call (level, message)."""
        return self._session("POST", "/se/log", {"type": "browser"})

    def screenshot(self, path: Path) -> Path:
        """The whole page (its full height) as a PNG."""
        height = int(self.run("return document.documentElement.scrollHeight;"))
        width = int(self.run("return window.innerWidth;"))
        self._session("POST", "/goog/cdp/execute", {
            "cmd": "Emulation.setDeviceMetricsOverride",
            "params": {"width": width, "height": min(height, 16000),
                       "deviceScaleFactor": 1, "mobile": width < 600}})
        path.write_bytes(base64.b64decode(self._session("GET", "/screenshot")))
        self._session("POST", "/goog/cdp/execute", {
            "cmd": "Emulation.clearDeviceMetricsOverride", "params": {}})
        return path

    def element_screenshot(self, selector: str, path: Path) -> Path:
        """The first element matching ``selector``, as it shows now, as a PNG."""
        element = self._session("POST", "/element", {"using": "css selector",
                                                     "value": selector})
        key = next(iter(element))  # the W3C element reference's key
        path.write_bytes(base64.b64decode(
            self._session("GET", f"/element/{element[key]}/screenshot")))
        return path

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        try:
            self._call("DELETE", f"/session/{self.session}")
        except OSError:
            pass
        self.driver.terminate()
        try:
            self.driver.wait(10)
        except subprocess.TimeoutExpired:
            self.driver.kill()


def chromium_on_path() -> bool:
    return shutil.which("chromium") is not None
