"""Who can ask the live view for a port tap: only a browser tab that loaded the page with the run's token, from the
page's own origin. Without the token the page, its metadata and its script answer 403 and no page (hence no
panel, no tap) is made; a websocket with a session token it did not get from the page, or without the page's
origin, is refused before any message; the supervisor is asked for nothing. With the token the page is made, and
asks for no tap until a port is chosen. A real Bokeh server on a loopback port, in this process."""
import asyncio
import re
import urllib.error
import urllib.request

import pytest

from carav_stream.view.server import ViewServer
from carav_stream.view.state import ViewState

pytest.importorskip("bokeh.server.server")          # the view extra
pytestmark = pytest.mark.slow                       # a web server and its pages: seconds on a 2-core machine
TOKEN = "the-runs-token-0123456789abcdef"


@pytest.fixture
def served():
    from tests.view.test_document import page
    made, asked = [], []
    state = ViewState(history=10)
    state.ports = [{"node": "adc", "port": "frames", "kind": "adc_frame", "private": False, "edges": 1}]
    control = type("Control", (), {"tap": staticmethod(lambda **f: asked.append(f) or {"ok": False, "error": "x"})})

    def make(doc):
        made.append(doc)
        page(state, control=control(), doc=doc)
    server = ViewServer(make, "127.0.0.1", 0, TOKEN)
    server.start()
    yield server, made, asked
    server.stop()


def refused(url: str) -> int:
    with pytest.raises(urllib.error.HTTPError) as err:
        urllib.request.urlopen(url, timeout=10)
    return err.value.code


def websocket(port: int, token: str, origin: str | None) -> str:
    """What a websocket to the page's /ws gets with `token` as its Bokeh session token and `origin` as its Origin:
    "refused <code>", "closed <code>" before any message, or "message" when the server spoke."""
    from tornado.httpclient import HTTPClientError, HTTPRequest
    from tornado.websocket import websocket_connect

    async def go() -> str:
        headers = {"Origin": origin} if origin else {}
        try:
            ws = await websocket_connect(HTTPRequest(f"ws://127.0.0.1:{port}/ws", headers=headers),
                                         subprotocols=["bokeh", token])
        except HTTPClientError as exc:
            return f"refused {exc.code}"
        msg = await asyncio.wait_for(ws.read_message(), 10)
        ws.close()
        return "message" if msg is not None else f"closed {ws.close_code}"
    return asyncio.run(go())


def test_a_tap_cannot_be_asked_without_the_page_and_its_token(served):
    from bokeh.util.token import generate_jwt_token, generate_session_id
    server, made, asked = served
    base = f"http://127.0.0.1:{server.port}"
    for path in ("/", "/?token=wrong", "/autoload.js", "/metadata"):
        assert refused(base + path) == 403, path
    assert made == [] and asked == []                             # no page made, nothing asked
    own = f"http://127.0.0.1:{server.port}"
    forged = generate_jwt_token(generate_session_id(b"k" * 32, signed=True), secret_key=b"k" * 32, signed=True)
    assert websocket(server.port, forged, own).startswith("closed")     # a session the server did not sign
    assert websocket(server.port, forged, None) == "refused 403"         # no Origin: refused before the upgrade
    assert websocket(server.port, forged, "http://evil.example") == "refused 403"
    assert made == [] and asked == []

    html = urllib.request.urlopen(server.url, timeout=10).read().decode()
    assert len(made) == 1 and asked == []                         # the page alone asks for no tap
    session = re.search(r'"token":"([^"]+)"', html).group(1)
    assert websocket(server.port, session, own) == "message"      # the page's own session, from its origin
    assert websocket(server.port, session, "http://evil.example") == "refused 403"
