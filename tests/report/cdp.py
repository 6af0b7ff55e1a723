"""Drive headless Chromium over the DevTools protocol (a websocket, tornado's client):
open a page, wait for a condition, evaluate expressions, collect what the page logged
as errors, take a screenshot."""

from __future__ import annotations

import asyncio
import base64
import json
import os
import shutil
import subprocess
import tempfile
import time
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any


def chromium() -> str | None:
    """The Chromium on PATH (the distribution's package), or None."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


@dataclass
class PageRun:
    """What a page did: its errors (console, uncaught exceptions, failed loads) and the
    values of the expressions asked for."""

    errors: list[dict[str, Any]] = field(default_factory=list)
    values: dict[str, Any] = field(default_factory=dict)
    url: str = ""
    """The page the browser is on after the expressions (with ``follow``: the one an
    expression navigated to)."""


@contextmanager
def _browser(binary: str, width: int, height: int) -> Iterator[str]:
    """A headless Chromium with a fresh profile; yields its first page's websocket URL."""
    profile = tempfile.mkdtemp(prefix="marops-chromium-")
    args = [
        binary,
        "--headless",
        "--remote-debugging-port=0",
        f"--user-data-dir={profile}",
        f"--window-size={width},{height}",
        "--no-first-run",
        "--no-default-browser-check",
        "--disable-extensions",
        "--disable-background-networking",
        "--disable-dev-shm-usage",  # containers give /dev/shm a few MB
        "about:blank",
    ]
    if os.geteuid() == 0:  # Chromium's sandbox refuses root (CI containers)
        args.insert(1, "--no-sandbox")
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        port_file = Path(profile) / "DevToolsActivePort"
        deadline = time.monotonic() + 60
        while not (port_file.is_file() and port_file.read_text().strip()):
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("chromium did not start its DevTools endpoint")
            time.sleep(0.1)
        port = int(port_file.read_text().split()[0])
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=30) as r:
            targets = json.loads(r.read())
        yield next(t["webSocketDebuggerUrl"] for t in targets if t["type"] == "page")
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        shutil.rmtree(profile, ignore_errors=True)


class _Session:
    def __init__(self, ws: Any, run: PageRun) -> None:
        self.ws, self.run, self.n = ws, run, 0
        self.loaded = False

    async def call(self, method: str, **params: Any) -> dict[str, Any]:
        self.n += 1
        me = self.n
        await self.ws.write_message(json.dumps({"id": me, "method": method, "params": params}))
        while True:
            msg = await self.ws.read_message()
            if msg is None:
                raise RuntimeError("chromium closed the connection")
            doc = json.loads(msg)
            if doc.get("id") == me:
                if "error" in doc:
                    raise RuntimeError(f"{method}: {doc['error']}")
                return doc.get("result", {})
            self._event(doc)

    def _event(self, doc: dict[str, Any]) -> None:
        method, p = doc.get("method"), doc.get("params", {})
        if method == "Page.loadEventFired":
            self.loaded = True
        elif method == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
            text = " ".join(str(a.get("value", a.get("description", ""))) for a in p["args"])
            self.run.errors.append({"source": "console", "text": text})
        elif method == "Runtime.exceptionThrown":
            details = p.get("exceptionDetails", {})
            text = details.get("exception", {}).get("description") or details.get("text")
            self.run.errors.append({"source": "exception", "text": text})
        elif method == "Log.entryAdded" and p["entry"].get("level") == "error":
            e = p["entry"]
            self.run.errors.append(
                {"source": e.get("source"), "text": e["text"], "url": e.get("url")}
            )

    async def evaluate(self, expression: str) -> Any:
        """The value of ``expression``; of a Promise, the value it resolves to."""
        res = await self.call(
            "Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True
        )
        if "exceptionDetails" in res:
            raise RuntimeError(f"{expression}: {res['exceptionDetails']}")
        return res["result"].get("value")


async def _drive(
    ws_url: str,
    url: str,
    ready: str,
    expressions: dict[str, str],
    screenshot: Path | None,
    size: tuple[int, int],
    run: PageRun,
    follow: bool = False,
) -> None:
    from tornado.websocket import websocket_connect

    ws = await websocket_connect(ws_url, max_message_size=256 * 2**20)
    try:
        s = _Session(ws, run)
        for domain in ("Runtime", "Log", "Page"):
            await s.call(f"{domain}.enable")
        await s.call(
            "Emulation.setDeviceMetricsOverride",
            width=size[0],
            height=size[1],
            deviceScaleFactor=1,
            mobile=False,
        )
        await s.call("Page.navigate", url=url)
        deadline = time.monotonic() + float(os.environ.get("CDP_WAIT", 90))
        # Each call reads the events that came before its answer (the load among them).
        while not (await s.evaluate(ready) and s.loaded):
            if time.monotonic() > deadline:
                raise RuntimeError(f"the page never got ready: {ready}")
            await asyncio.sleep(0.2)
        await asyncio.sleep(0.5)  # a last frame for what the page draws after load
        for name, expr in expressions.items():
            run.values[name] = await s.evaluate(expr)
        if screenshot is not None:
            shot = await s.call("Page.captureScreenshot", format="png")
            screenshot.write_bytes(base64.b64decode(shot["data"]))
        run.url = await _current_url(s, url)
        while follow and run.url == url and time.monotonic() < deadline:
            await asyncio.sleep(0.1)  # the navigation an expression started
            run.url = await _current_url(s, url)
    finally:
        ws.close()


async def _current_url(s: _Session, before: str) -> str:
    """The page's URL; ``before`` while the tab is between two documents (a navigation an
    expression started detaches it for a moment), so that the caller asks again."""
    try:
        history = await s.call("Page.getNavigationHistory")
    except RuntimeError as exc:
        if "Not attached to an active page" not in str(exc):
            raise
        return before
    return str(history["entries"][history["currentIndex"]]["url"])


def open_page(
    url: str,
    *,
    ready: str,
    expressions: dict[str, str],
    screenshot: Path | None = None,
    size: tuple[int, int] = (1300, 1000),
    follow: bool = False,
) -> PageRun:
    """Open ``url`` in headless Chromium, wait until the JavaScript ``ready`` is true,
    evaluate ``expressions`` and take a screenshot of the viewport; with ``follow``,
    wait for the navigation to another page that an expression started (a click on a
    link), whose address is then :attr:`PageRun.url`."""
    binary = chromium()
    if binary is None:
        raise RuntimeError("no chromium on PATH")
    run = PageRun()
    with _browser(binary, *size) as ws_url:
        asyncio.run(_drive(ws_url, url, ready, expressions, screenshot, size, run, follow))
    return run
