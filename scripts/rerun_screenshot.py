"""Screenshot of rerun's real web viewer showing an `.rrd`, taken in headless Chromium.

    python scripts/rerun_screenshot.py demo.rrd docs/rerun_viewer.png [--wait 40]

A rerun server on 127.0.0.1 serves the recording and the web viewer; Chromium (Debian's
`chromium` package) opens it headless with software WebGL (SwiftShader), waits `--wait`
seconds of real time for the wasm viewer to start and draw, and saves the page through the
DevTools protocol (`websockets`, installed with mujoco). `--screenshot` alone does not work:
it fires at the page's load event, before the viewer has drawn anything.
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import contextlib
import json
import shutil
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path

import websockets

from resus.visualize.recording import WebViewerServer

DEVTOOLS_PORT = 9333
CHROMIUM_FLAGS = (
    "--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
    f"--remote-debugging-port={DEVTOOLS_PORT}", "--remote-debugging-address=127.0.0.1",
)  # fmt: skip


def page_socket() -> str:
    """DevTools WebSocket address of Chromium's first page, once it answers."""
    for _ in range(150):
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{DEVTOOLS_PORT}/json") as answer:
                pages = [t for t in json.load(answer) if t["type"] == "page"]
            if pages:
                return pages[0]["webSocketDebuggerUrl"]
        except OSError:
            pass
        time.sleep(0.2)
    raise RuntimeError("headless Chromium did not open its DevTools port")


async def capture(url: str, out: Path, wait: float) -> None:
    """Open `url`, let it run `wait` seconds, write a PNG of the page to `out`."""
    async with websockets.connect(page_socket(), max_size=2**28) as socket:
        ids = iter(range(1, 1_000_000))

        async def call(method: str, **params: object) -> dict:
            key = next(ids)
            await socket.send(json.dumps({"id": key, "method": method, "params": params}))
            while True:
                message = json.loads(await socket.recv())
                if message.get("id") == key:
                    return message

        await call("Page.navigate", url=url)
        deadline = time.monotonic() + wait
        while time.monotonic() < deadline:  # drain events while the viewer starts up
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(socket.recv(), timeout=1.0)
        shot = await call("Page.captureScreenshot", format="png")
        out.write_bytes(base64.b64decode(shot["result"]["data"]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recording", type=Path, help=".rrd file to show")
    parser.add_argument("out", type=Path, help="PNG to write")
    parser.add_argument("--wait", type=float, default=40.0, help="seconds to let the viewer draw")
    parser.add_argument("--size", default="1600,900", help="window width,height (pixels)")
    parser.add_argument("--grpc-port", type=int, default=9886)
    parser.add_argument("--web-port", type=int, default=9096)
    args = parser.parse_args()
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        raise SystemExit("needs Chromium: apt-get install chromium")
    server = WebViewerServer(args.grpc_port, args.web_port, (args.recording,))
    try:
        with tempfile.TemporaryDirectory() as profile:
            browser = subprocess.Popen(
                [chromium, *CHROMIUM_FLAGS, f"--window-size={args.size}",
                 f"--user-data-dir={profile}", "about:blank"],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            )  # fmt: skip
            try:
                args.out.parent.mkdir(parents=True, exist_ok=True)
                asyncio.run(capture(server.url, args.out, args.wait))
            finally:
                browser.terminate()
                browser.wait(timeout=10)
    finally:
        server.stop()
    print(json.dumps({"png": str(args.out), "bytes": args.out.stat().st_size, "wait_s": args.wait}))


if __name__ == "__main__":
    main()
