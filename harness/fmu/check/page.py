"""The FMU's page (documentation/index.html) in a real headless browser: its layout measured, a screenshot.

A headless Chromium (Debian's ``chromium``, Google Chrome, or Playwright's build, whichever is installed) loads
the page at a given window width with a small script appended that measures the layout, and prints the DOM, from
which the measurements are read: the page's scroll width against the window's, and every element whose box
reaches beyond the right edge of the body's content (or of the window, where that is nearer).  No browser
library is needed.

    python3 -m sphrom.fmu.check.page FILE.fmu [--width 1280] [--screenshot PAGE.png]

exits 1 when the page overflows horizontally (and says which elements), 2 when no headless Chromium is found.
"""

from __future__ import annotations

import argparse
import glob
import html
import json
import os
import re
import shutil
import subprocess
import tempfile
import zipfile
from pathlib import Path


DOC_INDEX = "documentation/index.html"       # the FMU's page: FMI 2.0 / 3.0's documentation entry point

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome", "headless_shell")
PLAYWRIGHT = ("~/.cache/ms-playwright/chromium*/chrome-linux*/chrome",
              "~/.cache/ms-playwright/chromium_headless_shell*/chrome-*/headless_shell")

# appended to a copy of the page: measures the layout once it is laid out and writes the result into the DOM
_PROBE = """<script>
window.addEventListener('load', function () {
  var width = document.documentElement.clientWidth, over = [], b = document.body.getBoundingClientRect();
  var edge = Math.min(width, b.right - parseFloat(getComputedStyle(document.body).paddingRight));
  document.querySelectorAll('body *').forEach(function (e) {
    var r = e.getBoundingClientRect();
    var up = e.parentElement;
    if (r.right > edge + 0.5 && !(up && up !== document.body && up.getBoundingClientRect().right > edge + 0.5))
      over.push(e.tagName.toLowerCase() + (e.id ? '#' + e.id : '') + ' to ' + Math.round(r.right) + ' px');
  });
  var out = {window: window.innerWidth, client: width, scroll: document.documentElement.scrollWidth,
             body: Math.round(b.width), edge: Math.round(edge), over: over.slice(0, 20)};
  var pre = document.createElement('pre'); pre.id = 'sphrom-layout';
  pre.textContent = JSON.stringify(out); document.body.appendChild(pre);
});
</script>"""


def find_chromium():
    """The path of a headless-capable Chromium on this machine, or None (``SPHROM_CHROMIUM`` overrides)."""
    given = os.environ.get("SPHROM_CHROMIUM")
    if given:
        return given if Path(given).is_file() else None
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    for pattern in PLAYWRIGHT:
        found = sorted(glob.glob(os.path.expanduser(pattern)))
        if found:
            return found[-1]
    return None


def _run(browser, args, timeout):
    cmd = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--no-first-run",
           "--disable-dev-shm-usage", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)


def layout(html_path, width=1280, browser=None, timeout=60):
    """The page's layout at a window ``width`` [px]: dict with ``window``, ``client`` (the viewport's width),
    ``scroll`` (the page's scroll width), ``body`` (the body's width), ``edge`` (the right edge of the body's
    content, or of the viewport where that is nearer) and ``over`` (up to 20 outermost elements reaching beyond
    that edge, with their right edge)."""
    browser = browser or find_chromium()
    if browser is None:
        raise FileNotFoundError("no headless Chromium found (chromium, google-chrome or Playwright's)")
    html_path = Path(html_path)
    text = html_path.read_text(encoding="utf-8")
    probe = text.replace("</body>", _PROBE + "</body>") if "</body>" in text else text + _PROBE
    with tempfile.NamedTemporaryFile("w", suffix=".html", dir=html_path.parent, delete=False,
                                     encoding="utf-8") as f:
        f.write(probe)
    try:
        with tempfile.TemporaryDirectory() as profile:
            done = _run(browser, [f"--user-data-dir={profile}", f"--window-size={width},900", "--dump-dom",
                                  Path(f.name).as_uri()], timeout)
    finally:
        os.unlink(f.name)
    m = re.search(r'<pre id="sphrom-layout">(.*?)</pre>', done.stdout, re.S)
    if not m:
        raise RuntimeError(f"the browser gave no layout (exit status {done.returncode}): {done.stderr[-500:]}")
    return json.loads(html.unescape(m.group(1)))


def screenshot(html_path, png, width=1280, height=2400, browser=None, timeout=60):
    """A PNG of the page at a window of ``width`` x ``height`` px."""
    browser = browser or find_chromium()
    if browser is None:
        raise FileNotFoundError("no headless Chromium found (chromium, google-chrome or Playwright's)")
    png = Path(png).resolve()
    with tempfile.TemporaryDirectory() as profile:
        done = _run(browser, [f"--user-data-dir={profile}", f"--window-size={width},{height}",
                              f"--screenshot={png}", Path(html_path).resolve().as_uri()], timeout)
    if not png.is_file():
        raise RuntimeError(f"the browser wrote no screenshot (exit status {done.returncode}): {done.stderr[-500:]}")
    return png


def extract_page(fmu, folder):
    """documentation/ of an FMU file extracted into ``folder``: the path of its index.html."""
    with zipfile.ZipFile(fmu) as z:
        for name in z.namelist():
            if name.startswith("documentation/"):
                z.extract(name, folder)
    return Path(folder) / DOC_INDEX


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python3 -m sphrom.fmu.check.page",
                                     description="Load an FMU's documentation/index.html in a headless Chromium: "
                                                 "no element may reach beyond the window's width (exit 1 if one "
                                                 "does; 2 without a browser); optionally save a screenshot.")
    parser.add_argument("fmu", metavar="FILE.fmu")
    parser.add_argument("--width", type=int, default=1280, help="window width [px] (default 1280)")
    parser.add_argument("--screenshot", metavar="PAGE.png", help="write a screenshot of the page")
    args = parser.parse_args(argv)
    if find_chromium() is None:
        print("no headless Chromium found (apt-get install chromium, or set SPHROM_CHROMIUM)")
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        page = extract_page(args.fmu, tmp)
        result = layout(page, args.width)
        if args.screenshot:
            print(f"wrote {screenshot(page, args.screenshot, args.width)}")
    print(f"{args.fmu}: window {result['window']} px, page {result['scroll']} px wide, body {result['body']} px")
    for element in result["over"]:
        print(f"  beyond the page's right edge ({result['edge']} px): {element}")
    return 1 if result["scroll"] > result["client"] or result["over"] else 0


if __name__ == "__main__":
    raise SystemExit(main())
