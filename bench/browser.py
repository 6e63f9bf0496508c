"""A headless Chromium driven by Selenium, for the live view's browser test and `python3 dev.py bench view`.

Debian's packages `chromium` and `chromium-driver` (`.ci/run` installs them) and the `selenium` package (test
extra). Chromium starts without background networking, component updates or sync: this machine's network is
closed, and those would only try to reach Google's hosts.
"""
from __future__ import annotations

import shutil
from typing import Any

FLAGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync", "--window-size=1400,1600")

# Bokeh 3 renders widgets inside shadow roots: a deep querySelector.
DEEP_FIND = """
function find(root, css) {
  const hit = root.querySelector(css); if (hit) return hit;
  for (const el of root.querySelectorAll('*')) {
    if (el.shadowRoot) { const h = find(el.shadowRoot, css); if (h) return h; }
  }
  return null;
}
return find(document, arguments[0]);
"""
# A property of the model named arguments[0] in the page's Bokeh document, as plain JSON (null if none yet).
MODEL_PROPERTY = """const doc = window.Bokeh && Bokeh.documents.length ? Bokeh.documents[0] : null;
const m = doc ? doc.get_model_by_name(arguments[0]) : null; return m ? JSON.parse(JSON.stringify(m.%s)) : null;"""


def missing() -> list[str]:
    """What a headless browser session needs and this machine lacks (empty: ready)."""
    out = [name for name in ("chromium", "chromedriver") if shutil.which(name) is None]
    try:
        import selenium  # noqa: F401
    except ImportError:
        out.append("the selenium package")
    return out


def headless_chromium() -> Any:
    """A Selenium WebDriver on a new headless Chromium; RuntimeError naming what is missing."""
    lacking = missing()
    if lacking:
        raise RuntimeError(f"no headless browser: {', '.join(lacking)} not installed "
                           "(apt-get install chromium chromium-driver; pip install selenium)")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    opts.binary_location = shutil.which("chromium")
    for flag in FLAGS:
        opts.add_argument(flag)
    return webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=opts)


def model(driver: Any, name: str, prop: str) -> Any:
    """`prop` (e.g. 'text', 'data["cycle"]') of the page's Bokeh model `name`, or None."""
    return driver.execute_script(MODEL_PROPERTY % prop, name)
