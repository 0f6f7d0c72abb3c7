"""Headless Chromium driven over the DevTools protocol through a pipe (no port, no extra package).

Why a pipe: ``--remote-debugging-pipe`` makes Chromium read protocol messages from fd 3 and
write them to fd 4, NUL-separated JSON. That needs no listening port and no websocket client,
works offline, and is what Puppeteer and Playwright use under the hood. The page is loaded in a
fresh profile with everything that talks to the network on its own switched off, and every
request the page makes is recorded, so a test can check the page loaded nothing from outside.

Debian's ``chromium`` package provides /usr/bin/chromium (``apt-get install -y chromium``).
"""
from __future__ import annotations

import base64
import fcntl
import json
import os
import shutil
import subprocess
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, Callable

from mycobot_planning.polling import wait_until as poll_until

CHROMIUM = Path("/usr/bin/chromium")
FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--disable-default-apps", "--disable-extensions", "--mute-audio", "--hide-scrollbars",
    "--enable-unsafe-swiftshader",  # WebGL in software, since --disable-gpu leaves no GPU
]


class BrowserError(RuntimeError):
    pass


class Chromium:
    """One headless Chromium with one page; ``call`` sends a protocol command to the page."""

    def __init__(self, width: int = 1400, height: int = 900, executable: Path = CHROMIUM) -> None:
        self.profile = Path(tempfile.mkdtemp(prefix="mycobot-chromium-"))
        to_chrome_r, self._to_chrome = os.pipe()
        self._from_chrome, from_chrome_w = os.pipe()
        # Move the child's ends above 3 and 4 first, so the shell's redirections cannot clobber them.
        to_chrome_r, from_chrome_w = (self._high(fd) for fd in (to_chrome_r, from_chrome_w))
        # bash (not dash, which takes single-digit fds only) puts the pipe ends on fds 3 and 4,
        # where --remote-debugging-pipe expects them.
        command = ["/bin/bash", "-c", f'exec "$0" "$@" 3<&{to_chrome_r} 4>&{from_chrome_w}', str(executable),
                   *FLAGS, f"--user-data-dir={self.profile}", f"--window-size={width},{height}",
                   "--remote-debugging-pipe", "about:blank"]
        self.log_path = self.profile / "chromium.log"
        self._log = open(self.log_path, "w")
        self.proc = subprocess.Popen(command, pass_fds=(to_chrome_r, from_chrome_w), stdout=self._log,
                                     stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True)
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self._next_id = 0
        self._lock = threading.Lock()
        self._replies: dict[int, dict] = {}
        self._cond = threading.Condition()
        self.events: list[dict] = []
        self.requests: list[str] = []
        self.console: list[str] = []
        self.exceptions: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self.session = None
        try:
            target = self._call_browser("Target.createTarget", {"url": "about:blank"}, timeout=30)["targetId"]
            self.session = self._call_browser("Target.attachToTarget",
                                              {"targetId": target, "flatten": True})["sessionId"]
            for domain in ("Page", "Runtime", "Network"):
                self.call(f"{domain}.enable")
            self.call("Emulation.setDeviceMetricsOverride",
                      {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False})
        except Exception:
            log = self.log_path.read_text(errors="replace")[-2000:] if self.log_path.exists() else ""
            self.close()
            raise BrowserError(f"chromium did not start: {log}") from None

    @staticmethod
    def _high(fd: int) -> int:
        high = fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 100)
        os.close(fd)
        return high

    # ------------------------------------------------------------------ protocol
    def _read(self) -> None:
        buffer = b""
        while True:
            try:
                chunk = os.read(self._from_chrome, 1 << 20)
            except OSError:
                break
            if not chunk:
                break
            buffer += chunk
            while b"\0" in buffer:
                raw, buffer = buffer.split(b"\0", 1)
                try:
                    message = json.loads(raw)
                except json.JSONDecodeError:
                    continue
                self._dispatch(message)
        with self._cond:
            self._cond.notify_all()

    def _dispatch(self, message: dict) -> None:
        if "id" in message:
            with self._cond:
                self._replies[message["id"]] = message
                self._cond.notify_all()
            return
        method = message.get("method", "")
        params = message.get("params", {})
        if method == "Network.requestWillBeSent":
            self.requests.append(params.get("request", {}).get("url", ""))
        elif method == "Runtime.consoleAPICalled":
            self.console.append(" ".join(str(a.get("value", a.get("description", ""))) for a in params.get("args", [])))
        elif method == "Runtime.exceptionThrown":
            details = params.get("exceptionDetails", {})
            self.exceptions.append(details.get("exception", {}).get("description") or details.get("text", ""))
        self.events.append(message)

    def _send(self, method: str, params: dict | None, session: str | None, timeout: float) -> dict:
        with self._lock:
            self._next_id += 1
            ident = self._next_id
            message = {"id": ident, "method": method, "params": params or {}}
            if session:
                message["sessionId"] = session
            os.write(self._to_chrome, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + timeout
        with self._cond:
            while ident not in self._replies:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or self.proc.poll() is not None:
                    raise BrowserError(f"no answer to {method} within {timeout} s (chromium log: {self.log_path})")
                self._cond.wait(min(remaining, 0.5))
            reply = self._replies.pop(ident)
        if "error" in reply:
            raise BrowserError(f"{method}: {reply['error'].get('message')}")
        return reply.get("result", {})

    def _call_browser(self, method: str, params: dict | None = None, timeout: float = 10.0) -> dict:
        return self._send(method, params, None, timeout)

    def call(self, method: str, params: dict | None = None, timeout: float = 30.0) -> dict:
        return self._send(method, params, self.session, timeout)

    # ------------------------------------------------------------------ page helpers
    def navigate(self, url: str) -> None:
        self.call("Page.navigate", {"url": url})

    def evaluate(self, expression: str, timeout: float = 30.0) -> Any:
        result = self.call("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                                "awaitPromise": True}, timeout=timeout)
        if "exceptionDetails" in result:
            raise BrowserError(f"page script failed: {result['exceptionDetails'].get('text')}: "
                               f"{result.get('result', {}).get('description', '')}")
        return result.get("result", {}).get("value")

    def wait_for(self, expression: str, timeout: float = 30.0, period: float = 0.2) -> Any:
        """Poll a page expression until it is truthy; returns its value (or the last, falsy)."""
        deadline = time.monotonic() + timeout
        value = None
        while time.monotonic() < deadline:
            value = self.evaluate(expression)
            if value:
                return value
            time.sleep(period)
        return value

    def text(self) -> str:
        return self.evaluate("document.body ? document.body.innerText : ''") or ""

    def screenshot(self, path: str | Path) -> Path:
        data = self.call("Page.captureScreenshot", {"format": "png"}, timeout=60)["data"]
        path = Path(path)
        path.write_bytes(base64.b64decode(data))
        return path

    def click_at(self, x: float, y: float) -> None:
        """A real mouse click (press and release) at page coordinates."""
        for kind in ("mouseMoved", "mousePressed", "mouseReleased"):
            params = {"type": kind, "x": x, "y": y, "button": "left" if kind != "mouseMoved" else "none",
                      "clickCount": 1 if kind != "mouseMoved" else 0}
            self.call("Input.dispatchMouseEvent", params)

    def _button(self, text: str, timeout: float) -> list[float]:
        script = ("(() => { const b = [...document.querySelectorAll('button')].find("
                  f"e => e.innerText.trim() === {json.dumps(text)} && e.offsetParent !== null && !e.disabled);"
                  " if (!b) return null; b.scrollIntoView({block: 'nearest'}); const r = b.getBoundingClientRect();"
                  " return [r.left + r.width / 2, r.top + r.height / 2]; })()")
        box = self.wait_for(script, timeout)
        if not box:
            raise BrowserError(f"no visible button '{text}'")
        return box

    def _button_on_top(self, text: str, timeout: float) -> list[float]:
        """Where the button ``text`` is and nothing covers it (the page may still be laying out,
        folders opening, the panel scrolling)."""
        deadline = time.monotonic() + timeout
        while True:
            x, y = self._button(text, max(0.1, deadline - time.monotonic()))
            hit = self.evaluate(f"(() => {{ const e = document.elementFromPoint({x}, {y}); const b = e && e.closest('button');"
                                f" return !!b && b.innerText.trim() === {json.dumps(text)}; }})()")
            if hit:
                return [x, y]
            if time.monotonic() > deadline:
                raise BrowserError(f"button '{text}' does not stay where it is")
            # a hint (tooltip) of the button the mouse was left on may cover it: move the mouse away
            self.call("Input.dispatchMouseEvent", {"type": "mouseMoved", "x": 0, "y": 0, "button": "none",
                                                   "clickCount": 0})
            time.sleep(0.05)

    def click_button(self, text: str, timeout: float = 10.0) -> None:
        """Click the visible, enabled button whose text is ``text`` once there is one (a page
        updated by its server may show it a moment later); BrowserError if none appears."""
        self.click_at(*self._button_on_top(text, timeout))

    def press_button(self, text: str, timeout: float = 10.0) -> list[float]:
        """Press the mouse on the button ``text`` (as click_button finds it) and keep it down;
        where, for release_at."""
        x, y = self._button_on_top(text, timeout)
        self.call("Input.dispatchMouseEvent", {"type": "mouseMoved", "x": x, "y": y, "button": "none", "clickCount": 0})
        self.call("Input.dispatchMouseEvent", {"type": "mousePressed", "x": x, "y": y, "button": "left", "clickCount": 1})
        return [x, y]

    def release_at(self, x: float, y: float) -> None:
        self.call("Input.dispatchMouseEvent", {"type": "mouseReleased", "x": x, "y": y, "button": "left", "clickCount": 1})

    def type_into(self, label: str, text: str, timeout: float = 10.0) -> None:
        """Type ``text`` into the text field labelled ``label`` (focused by a real click, typed as
        keyboard input), replacing what it held."""
        # the label's own field, else the first input of the row the label is in (viser's text
        # inputs carry another id than their label names)
        field_script = (
            f"(() => {{ const l = [...document.querySelectorAll('label')].find(l => l.innerText.trim() === {json.dumps(label)});"
            " if (!l) return null; const own = document.getElementById(l.htmlFor); if (own) return own;"
            " let e = l; const q = 'input:not([type=hidden]), textarea';"
            " while (e && !e.querySelector(q)) e = e.parentElement; return e ? e.querySelector(q) : null; })()")
        if not self.wait_for(f"!!{field_script}", timeout):
            raise BrowserError(f"no text field labelled '{label}'")
        self.click_at(*self._center(field_script))
        self.evaluate(f"(() => {{ const e = {field_script}; e.select(); }})()")
        self.call("Input.insertText", {"text": text})

    def _center(self, script: str) -> list[float] | None:
        return self.evaluate("(() => { const e = (" + script + "); if (!e) return null;"
                             " e.scrollIntoView({block: 'nearest'}); const r = e.getBoundingClientRect();"
                             " return [r.left + r.width / 2, r.top + r.height / 2]; })()")

    def select_option(self, label: str, option_text: str, timeout: float = 10.0, attempts: int = 3) -> None:
        """Choose ``option_text`` in the dropdown labelled ``label`` as a user does: click the
        dropdown, then click the option in the list that opens (real mouse events). Like a user,
        look at the dropdown afterwards and try again if the page moved under the pointer."""
        field_script = (
            f"(() => {{ const l = [...document.querySelectorAll('label')].find(l => l.innerText.trim() === {json.dumps(label)});"
            " return l ? document.getElementById(l.htmlFor) : null; })()")
        for _ in range(attempts):
            field = self._center(field_script)
            if not field:
                raise BrowserError(f"no dropdown labelled '{label}'")
            self.click_at(*field)
            option = self.wait_for(
                "(() => { const o = [...document.querySelectorAll('[role=option]')].find(o => o.offsetParent !== null"
                f" && o.innerText.replace(/\\u00a0/g, ' ').trim() === {json.dumps(option_text)}); if (!o) return null;"
                " o.scrollIntoView({block: 'nearest'}); const r = o.getBoundingClientRect();"
                " return [r.left + r.width / 2, r.top + r.height / 2]; })()", timeout)
            if not option:
                # The click may have landed while the page was still laying out (a loaded machine):
                # like a user, click elsewhere to close whatever opened and try the dropdown again.
                self.click_at(1.0, 1.0)
                continue
            self.click_at(*option)
            chosen = self.wait_for(f"(() => {{ const e = {field_script}; return e && e.value.replace(/\\u00a0/g, ' ')"
                                   f".trim() === {json.dumps(option_text)}; }})()", 3.0)
            if chosen:
                return
        raise BrowserError(f"could not choose '{option_text}' in the dropdown '{label}' "
                           f"(the dropdown offered no such option or did not take it, {attempts} tries)")

    def slider(self, label: str) -> dict | None:
        """The slider labelled ``label``: {"min", "max", "value", "track": [left, top, width, height],
        "thumb": [x, y]} (page coordinates, scrolled into view), None when there is none."""
        return self.evaluate(
            f"(() => {{ const l = [...document.querySelectorAll('label')].find(l => l.innerText.trim() === {json.dumps(label)});"
            " const root = l && document.getElementById(l.htmlFor); if (!root) return null;"
            " root.scrollIntoView({block: 'center'}); const t = root.querySelector('[role=slider]');"
            " const track = root.querySelector('.mantine-Slider-track') || root; const r = track.getBoundingClientRect();"
            " const h = t.getBoundingClientRect();"
            " return {min: +t.getAttribute('aria-valuemin'), max: +t.getAttribute('aria-valuemax'),"
            "  value: +t.getAttribute('aria-valuenow'), track: [r.left, r.top, r.width, r.height],"
            "  thumb: [h.left + h.width / 2, h.top + h.height / 2]}; })()")

    def drag_slider(self, label: str, value: float, steps: int = 8) -> None:
        """Drag the thumb of the slider labelled ``label`` to ``value`` with the mouse (pressed on
        the thumb, moved in ``steps``, released), as a user does."""
        info = self.slider(label)
        if not info:
            raise BrowserError(f"no slider labelled '{label}'")
        left, top, width, height = info["track"]
        fraction = min(max((value - info["min"]) / (info["max"] - info["min"]), 0.0), 1.0)
        x1, y = left + fraction * width, top + height / 2
        x0, _ = info["thumb"]
        self.call("Input.dispatchMouseEvent", {"type": "mouseMoved", "x": x0, "y": y, "button": "none", "clickCount": 0})
        self.call("Input.dispatchMouseEvent", {"type": "mousePressed", "x": x0, "y": y, "button": "left", "clickCount": 1})
        for i in range(1, steps + 1):
            self.call("Input.dispatchMouseEvent", {"type": "mouseMoved", "x": x0 + (x1 - x0) * i / steps, "y": y,
                                                   "button": "left", "buttons": 1, "clickCount": 0})
            time.sleep(0.02)
        self.call("Input.dispatchMouseEvent", {"type": "mouseReleased", "x": x1, "y": y, "button": "left", "clickCount": 1})

    def rect_of_text(self, text: str, max_width: float = 450.0) -> list[float] | None:
        """[left, top, right, bottom] of the widest element (at most ``max_width`` px wide) that
        contains ``text``: a toast, a panel, to leave out of pixel counts."""
        return self.evaluate(
            "(() => { const w = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT); let n;"
            f" while ((n = w.nextNode())) {{ if (!n.textContent.includes({json.dumps(text)})) continue;"
            "   let e = n.parentElement, best = e;"
            f"   while (e && e.getBoundingClientRect().width <= {max_width}) {{ best = e; e = e.parentElement; }}"
            "   const r = best.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; }"
            " return null; })()")

    def close(self) -> None:
        try:
            if self.proc.poll() is None:
                try:
                    self._call_browser("Browser.close", timeout=5)
                except BrowserError:
                    pass
                try:
                    self.proc.wait(5)
                except subprocess.TimeoutExpired:
                    os.killpg(self.proc.pid, 9)
                    self.proc.wait(5)
        finally:
            for fd in (self._to_chrome, self._from_chrome):
                try:
                    os.close(fd)
                except OSError:
                    pass
            self._log.close()
            shutil.rmtree(self.profile, ignore_errors=True)

    def __enter__(self) -> "Chromium":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def available() -> bool:
    return CHROMIUM.exists()


def wait_until(predicate: Callable[[], Any], timeout: float, period: float = 0.1) -> Any:
    return poll_until(predicate, timeout, period)
