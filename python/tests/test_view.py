"""``pvrsim.view``: the live viewer's server started from Python; its
token guards every route; ``close()`` stops it (the port closes)."""

from __future__ import annotations

import json
import socket
import time
import urllib.error
import urllib.parse
import urllib.request

import pytest

import pvrsim

from conftest import VIEW_B


def get(url: str):
    try:
        with urllib.request.urlopen(url, timeout=60) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def test_view_serves_with_its_token_and_closes():
    v = pvrsim.view(VIEW_B, width=64, height=48)
    try:
        u = urllib.parse.urlparse(v.url)
        assert u.scheme == "http" and u.hostname == "127.0.0.1"
        token = urllib.parse.parse_qs(u.query)["token"][0]
        assert len(token) == 32
        base = f"http://{u.hostname}:{u.port}"
        assert v.running
        html = v._repr_html_()
        assert "<iframe" in html and v.url.replace("&", "&amp;") in html
        deadline = time.time() + 120
        while True:
            st, body = get(f"{base}/state.json?token={token}")
            assert st == 200
            state = json.loads(body)
            if state and state.get("seq", 0) >= 1 or time.time() > deadline:
                break
            time.sleep(0.05)
        assert state["seq"] >= 1 and state["scale"] == 1, state
        assert "--ert" in state["options"], state
        for path in ["/state.json", "/frame.png", "/scene.toml", "/"]:
            assert get(base + path)[0] == 403, path
            assert get(f"{base}{path}?token=wrong")[0] == 403, path
    finally:
        v.close()
    assert not v.running
    v.close()  # idempotent
    with pytest.raises(OSError):
        socket.create_connection((u.hostname, u.port), timeout=5).close()
    assert "closed" in v._repr_html_()


def test_view_options_are_checked():
    with pytest.raises(pvrsim.UnknownOptionError):
        pvrsim.view(VIEW_B, no_such_option=1)
    with pytest.raises(pvrsim.OptionError, match="interactive"):
        pvrsim.view(VIEW_B, interactive_scale="3")
    with pytest.raises(pvrsim.OptionError, match="-o and --stats"):
        pvrsim.view(VIEW_B, stats="s.json")
