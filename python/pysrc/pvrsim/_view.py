"""``view``: the live viewer (``pvrsim view``) from Python and Jupyter."""

from __future__ import annotations

import html
from typing import Any, Optional, Union

from . import _native, _options
from ._jobs import PathLike
from ._scene import Scene, scene_file


class Viewer:
    """A running ``pvrsim view`` server: the page at ``url`` (with its
    access token) turns the camera, edits the transfer function and shows
    the frames; ``close()`` (or leaving the ``with`` block) stops the
    server, its render loop and a cluster's workers. In Jupyter the
    viewer displays the page inline (an iframe of ``url``)."""

    def __init__(self, native: Any) -> None:
        self._native: Optional[Any] = native
        self.url: str = native.url

    @property
    def running(self) -> bool:
        """Whether the server still runs."""
        return self._native is not None and self._native.running()

    def close(self) -> None:
        """Stops the server (the port closes). Idempotent."""
        if self._native is not None:
            n, self._native = self._native, None
            n.close()

    def _repr_html_(self) -> str:
        if self._native is None:
            return "<p>pvrsim viewer (closed)</p>"
        u = html.escape(self.url, quote=True)
        return (
            f'<iframe src="{u}" width="100%" height="760" style="border:0" '
            f'title="pvrsim view"></iframe>'
        )

    def __enter__(self) -> "Viewer":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass

    def __repr__(self) -> str:
        return f"pvrsim.Viewer({self.url if self._native is not None else 'closed'})"


def view(scene: Union[Scene, PathLike], **options: Any) -> Viewer:
    """Starts the live viewer of ``pvrsim view`` on ``scene`` and returns
    a ``Viewer`` (``.url``, ``.close()``; shown inline in Jupyter).

        v = pvrsim.view("tests/data/aorta-small-view-b.toml", width=512, height=512)
        v.url          # http://127.0.0.1:PORT/?token=...
        v              # in Jupyter: the page
        v.close()

    Keywords are ``pvrsim view``'s options (``port``, ``bind``,
    ``interactive_scale``, ``nodes``, ``transport``, and ``pvrsim
    render``'s). Errors are the exceptions of ``render``.
    """
    opts = _options.options("view", scene_file(scene), options)
    return Viewer(_native.NativeViewer(opts))
