"""Screenshots of a page in a headless Chromium, taken through the DevTools protocol until the page shows
what a test waits for (a WebGL scene fades in over real time, so one fixed-delay ``--screenshot`` is flaky).

Needs a ``chromium`` (or ``chromium-browser`` / ``google-chrome``) executable and the ``websockets``
package (a dependency of viser)."""

from __future__ import annotations

import base64
import io
import json
import re
import shutil
import subprocess
import tempfile
import time
from collections.abc import Callable

import numpy as np


def chromium() -> str | None:
    """The path of a Chromium-like browser, or ``None``."""
    return next((p for p in (shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")) if p), None)


def screenshot(url: str, until: Callable[[np.ndarray], bool], size=(800, 600), timeout: float = 40.0) -> np.ndarray:
    """Load ``url`` and return the first screenshot (an ``(H, W, 3)`` uint8 array) for which ``until``
    is true, polling twice a second; the last one if ``timeout`` seconds pass first."""
    from PIL import Image
    from websockets.sync.client import connect

    with tempfile.TemporaryDirectory(ignore_cleanup_errors=True) as profile:  # chromium helpers may still write
        proc = subprocess.Popen(
            [
                chromium(),
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--no-first-run",
                "--enable-unsafe-swiftshader",
                "--use-angle=swiftshader",
                f"--window-size={size[0]},{size[1]}",
                "--remote-debugging-port=0",
                f"--user-data-dir={profile}",
                "about:blank",
            ],
            stderr=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            text=True,
        )
        try:
            ws_url, t0 = None, time.monotonic()
            while ws_url is None and time.monotonic() - t0 < 30:
                line = proc.stderr.readline()
                m = re.search(r"DevTools listening on (ws://\S+)", line)
                ws_url = m.group(1) if m else None
                if not line and proc.poll() is not None:
                    raise RuntimeError("chromium exited before it listened")
            if ws_url is None:
                raise RuntimeError("chromium never listened for DevTools")
            with connect(ws_url, max_size=None) as ws:
                ids = iter(range(1, 1 << 30))

                def call(method, session=None, **params):
                    i = next(ids)
                    msg = {"id": i, "method": method, "params": params}
                    if session:
                        msg["sessionId"] = session
                    ws.send(json.dumps(msg))
                    while True:
                        r = json.loads(ws.recv())
                        if r.get("id") == i:
                            if "error" in r:
                                raise RuntimeError(f"{method}: {r['error']}")
                            return r["result"]

                target = call("Target.createTarget", url=url)["targetId"]
                session = call("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]
                img, t0 = None, time.monotonic()
                while time.monotonic() - t0 < timeout:
                    time.sleep(0.5)
                    data = call("Page.captureScreenshot", session, format="png")["data"]
                    img = np.array(Image.open(io.BytesIO(base64.b64decode(data))).convert("RGB"))
                    if until(img):
                        break
                return img
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:  # pragma: no cover
                proc.kill()
