"""The page's pace: the server sends a browser tab its next update only once the tab has shown the last one.

Bokeh's server would otherwise push every update whether or not the browser keeps up: a browser short of CPU (a
loaded machine, a slow laptop) falls behind, its websocket's messages queue, and it shows an ever older past while
the queue grows. Here each tab's document holds a PageSync; the page's update ends by raising `sent`, and the
browser, once it has applied that update and painted the frame after it, copies it into `shown`, which Bokeh sends
back. An update finds `shown < sent` and leaves the document alone: what came meanwhile waits in ViewState (the
points by running number, the latest map and status), so the next update the tab can take brings all of it. A
tab hidden in the background paints no frame, so it takes no update until it is shown again.

A module of its own, imported when a page is made: a Bokeh model class is declared once, at import, and needs
Bokeh (the view extra).
"""
from __future__ import annotations

from typing import Any

from bokeh.core.properties import Int
from bokeh.model import DataModel
from bokeh.models import CustomJS

# after the frame that paints the update (requestAnimationFrame runs before that paint, the timeout after it)
ACK = ("const n = sync.sent; "
       "requestAnimationFrame(() => setTimeout(() => { sync.shown = Math.max(sync.shown, n) }, 0))")


class PageSync(DataModel):
    """sent: updates the server sent this tab; shown: the latest of them the tab has shown."""
    sent = Int(0)
    shown = Int(0)


def page_sync(doc: Any) -> PageSync:
    """A PageSync (model name `page_sync`) in the document `doc`, whose `sent` the browser acknowledges into
    `shown` after each change and once the page is first drawn."""
    sync = PageSync(name="page_sync")
    ack = CustomJS(args={"sync": sync}, code=ACK)
    sync.js_on_change("sent", ack)
    doc.add_root(sync)
    doc.js_on_event("document_ready", ack)
    return sync

