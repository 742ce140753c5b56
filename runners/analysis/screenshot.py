"""A screenshot of the Rerun viewer showing a recording, for the docs.

The native viewer needs a GPU-backed window; on a machine without one, Rerun's own
web viewer (the same viewer, compiled to WebAssembly) is served by the ``rerun``
command from rerun-sdk and drawn by headless Chromium with its software renderer,
driven by Playwright (``pip install -e '.[docs]'``, and Debian's
``chromium``).
"""

from __future__ import annotations

import io
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.parse
from pathlib import Path


BROWSERS = ("chromium", "chromium-browser", "google-chrome")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def looks_drawn(png: bytes) -> bool:
    """The page shows the recording, not the loading screen or a half-loaded viewer:
    a light page with at least 1% strongly coloured pixels (the curves and blocks)."""
    import matplotlib.image as mpimg

    img = (mpimg.imread(io.BytesIO(png), format="png")[..., :3] * 255).astype(int)
    saturated = (img.max(axis=-1) - img.min(axis=-1)) > 60
    return float(img.mean()) > 128 and float(saturated.mean()) > 0.01


def find_browser() -> str | None:
    return next((shutil.which(b) for b in BROWSERS if shutil.which(b)), None)


def screenshot(rrd: Path, png: Path, size: tuple[int, int] = (1600, 1000), timeout: float = 180.0) -> Path:
    """Serve `rrd` with Rerun's web viewer and save what headless Chromium shows as `png`,
    once the viewer has drawn the recording (the run is then a moment into playing)."""
    browser = find_browser()
    if browser is None:
        raise OSError("a screenshot needs Chromium (Debian: apt-get install chromium); none found on PATH")
    try:
        from playwright.sync_api import Error as PlaywrightError
        from playwright.sync_api import sync_playwright
    except ImportError:
        raise OSError("a screenshot needs Playwright: pip install -e '.[docs]'") from None
    rerun = shutil.which("rerun") or str(Path(sys.executable).parent / "rerun")
    if not Path(rerun).exists():
        raise OSError("the Rerun viewer (rerun, from pip rerun-sdk) is not installed")
    if not Path(rrd).is_file():
        raise FileNotFoundError(f"recording {rrd} does not exist")
    png = Path(png)
    png.parent.mkdir(parents=True, exist_ok=True)
    grpc_port, web_port = _free_port(), _free_port()
    server = subprocess.Popen([rerun, str(rrd), "--serve-web", "--port", str(grpc_port),
                               "--web-viewer-port", str(web_port)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                              start_new_session=True)  # its own process group: the wrapper starts a child
    try:
        for line in server.stderr:  # wait until the web viewer is up
            if "Hosting a web-viewer" in line:
                break
        else:
            raise OSError("the Rerun web viewer did not start")
        source = urllib.parse.quote(f"rerun+http://localhost:{grpc_port}/proxy", safe="")
        url = f"http://127.0.0.1:{web_port}/?url={source}&renderer=webgl"
        with sync_playwright() as pw:
            try:
                chrome = pw.chromium.launch(executable_path=browser, args=[
                    "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-background-networking",
                    "--disable-quic", "--disable-component-update", "--disable-sync"])
            except PlaywrightError as exc:
                raise OSError(f"Chromium did not start: {str(exc).splitlines()[0]}") from None
            page = chrome.new_page(viewport={"width": size[0], "height": size[1]})
            page.goto(url)
            deadline = time.monotonic() + timeout
            while not looks_drawn(page.screenshot()):
                if time.monotonic() > deadline:
                    page.screenshot(path=str(png))
                    raise OSError(f"the viewer did not draw the recording in {timeout:.0f} s (what it showed: {png})")
                page.wait_for_timeout(2000)
            page.wait_for_timeout(1000)  # let the layout settle
            page.screenshot(path=str(png))
            chrome.close()
        return png
    finally:
        os.killpg(server.pid, signal.SIGKILL)
        server.wait()
