"""``Session``: a cluster that stays up between frames."""

from __future__ import annotations

import json
from typing import Any, Dict, Mapping, Optional, Tuple, Union

from . import _native, _options
from ._jobs import ClusterResult, PathLike
from ._scene import Scene, scene_file


class Session:
    """A persistent cluster session: the nodes of ``pvrsim cluster``
    (threads in this process, ``transport="processes"`` worker processes,
    ``"tcp"`` workers) are set up once, their cells sent or their pieces
    read once; each ``render`` is one frame on them, carrying only what
    changed.

        with pvrsim.Session("scene.toml", nodes=4, transport="processes",
                            ert=1, canonical=True) as s:
            a = s.render()                                   # the scene's view
            b = s.render(camera={"eye": [0, -300, 0], "target": [0, 0, 0],
                                 "up": [0, 0, 1], "projection": "orthographic",
                                 "height": 200})
            c = s.render(transfer={"unit_distance": 1.0,
                                   "points": [[0, 0, 0, 1, 0.1], [1, 1, 0, 0, 0.5]]})

    Keywords are ``pvrsim cluster``'s options (as for ``cluster``); a
    series option (``frames``, ``series``) is not one of them. ``render``
    takes ``camera`` and ``transfer`` as the scene file's ``[camera]`` and
    ``[transfer]`` tables (dicts; the whole table), ``step`` (a time step)
    and ``size`` (``(width, height)``), and returns a ``ClusterResult``, as
    ``cluster`` does; each frame equals the one-off ``cluster`` frame at
    that camera. ``close()`` (or leaving the ``with`` block) ends the
    nodes. Errors are the exceptions of ``cluster``.
    """

    def __init__(self, scene: Union[Scene, PathLike], **options: Any) -> None:
        for k in ("frames", "turn", "series"):
            if k in options:
                raise _options_error(
                    f"Session: {k}= is a series option; call render() once a frame"
                )
        opts = _options.options("cluster", scene_file(scene), options)
        self._native: Optional[Any] = _native.NativeSession(opts)

    @property
    def scene(self) -> Scene:
        """The scene the session was opened on."""
        s = self._live().scene_toml()
        return Scene(s, None)

    @property
    def frames(self) -> int:
        """Frames rendered so far."""
        return 0 if self._native is None else self._native.frames()

    def render(
        self,
        camera: Optional[Mapping[str, Any]] = None,
        transfer: Optional[Mapping[str, Any]] = None,
        step: Optional[int] = None,
        size: Optional[Tuple[int, int]] = None,
    ) -> ClusterResult:
        """One frame on the session's nodes (see the class docs)."""
        changes: Dict[str, Any] = {}
        if camera is not None:
            changes["camera"] = dict(camera)
        if transfer is not None:
            changes["transfer"] = dict(transfer)
        text = json.dumps(changes) if changes else None
        sz = None if size is None else (int(size[0]), int(size[1]))
        return ClusterResult(self._live().render(text, step, sz))

    def close(self) -> None:
        """Ends the nodes (worker processes exit). Idempotent."""
        if self._native is not None:
            n, self._native = self._native, None
            n.close()

    def _live(self) -> Any:
        if self._native is None:
            raise _options_error("the session is closed")
        return self._native

    def __enter__(self) -> "Session":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass

    def __repr__(self) -> str:
        state = "closed" if self._native is None else f"{self.frames} frames"
        return f"pvrsim.Session({state})"


def _options_error(msg: str) -> Exception:
    from ._errors import OptionError

    return OptionError(msg)
