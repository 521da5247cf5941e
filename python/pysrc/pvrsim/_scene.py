"""Scenes: the scene contract's TOML (data, camera, image, transfer
function), loaded and checked by the CLI's parser, or fitted to data the
way ``pvrsim scene`` fits it.

A job runs on a scene *file*. A scene loaded from a file runs on that
file. A scene fitted to data in memory (``Mesh.from_arrays``,
``Volume.from_array``) is written, with its data (the crate's VTK or NRRD
writer), into a private temporary folder the first time a job needs it;
the folder lives as long as the ``Scene`` object.
"""

from __future__ import annotations

import os
import tempfile
from typing import Any, Optional, Tuple, Union

from . import _native
from ._data import Mesh, Volume

PathLike = Union[str, "os.PathLike[str]"]

#: The data file name a fitted scene names while its data is in memory.
_IN_MEMORY = {"mesh": "data.vtk", "volume": "data.nrrd"}


class Scene:
    """A scene (the scene contract: ``docs/`` and ``/spec/scene.md``).

    - ``Scene.load(path)``: read and check a scene file;
    - ``Scene.fit(data, field=None, view="-y", size=(512, 512), perspective=None)``:
      fit camera and transfer function to a ``Mesh`` or ``Volume``;
    - ``scene.to_toml()``, ``scene.save(path)``;
    - ``scene.path`` (the file, or ``None``), ``scene.data_path``,
      ``scene.field``, ``scene.size`` (width, height).
    """

    __slots__ = ("_text", "path", "_data", "_info", "_tmp")

    def __init__(self, text: str, path: Optional[str], data: Optional[Union[Mesh, Volume]] = None) -> None:
        check_at = path or os.path.join(os.getcwd(), "scene.toml")
        self._info = _native.check_scene(text, check_at)
        self._text = text
        self.path = path
        self._data = data
        self._tmp: Optional[tempfile.TemporaryDirectory] = None

    @classmethod
    def load(cls, path: PathLike) -> "Scene":
        """Reads and checks a scene file. Raises ``FileError`` naming the
        file and the line or field (``camera.up``) at fault."""
        p = os.path.abspath(os.fspath(path))
        try:
            with open(p, encoding="utf-8") as f:
                text = f.read()
        except OSError as e:
            from ._errors import FileError

            err = FileError(f"{p}: {e.strerror or e}")
            err.filename = p
            raise err from None
        return cls(text, p)

    @classmethod
    def fit(
        cls,
        data: Union[Mesh, Volume],
        field: Optional[str] = None,
        view: str = "-y",
        size: Tuple[int, int] = (512, 512),
        perspective: Optional[float] = None,
    ) -> "Scene":
        """A scene fitted to ``data``, as ``pvrsim scene`` writes it.

        The camera looks at the centre of the bounding box from ``view``
        (``"+x"`` .. ``"-z"`` or ``"AZ,EL"`` degrees), orthographic (or
        perspective with ``perspective`` degrees of vertical field of view);
        the transfer function spans ``field``'s range (a grid's only field
        may be left out). ``size`` is (width, height).
        """
        if not isinstance(data, (Mesh, Volume)):
            raise TypeError(f"Scene.fit takes a pvrsim.Mesh or a pvrsim.Volume, not {type(data).__name__}")
        try:
            w, h = (int(x) for x in size)
        except (TypeError, ValueError):
            from ._errors import OptionError

            raise OptionError(f"size={size!r}: expected (width, height)") from None
        kind = "mesh" if isinstance(data, Mesh) else "volume"
        name = data.path or _IN_MEMORY[kind]
        text = _native.fit_scene(
            data._native, name, field, view, w, h,
            None if perspective is None else float(perspective),
        )
        return cls(text, None, None if data.path else data)

    @property
    def data_path(self) -> str:
        """The data file the scene names (resolved against its folder), or
        ``"<in memory>"`` while its data is a ``Mesh``/``Volume`` in memory."""
        return "<in memory>" if self._data is not None else self._info["data_path"]

    @property
    def field(self) -> str:
        return self._info["field"]

    @property
    def size(self) -> Tuple[int, int]:
        """Image (width, height)."""
        return (self._info["width"], self._info["height"])

    @property
    def data(self) -> Optional[Union[Mesh, Volume]]:
        """The data in memory this scene renders (``None``: the file it names)."""
        return self._data

    def to_toml(self) -> str:
        """The scene's TOML text (with its comments)."""
        return self._text

    def save(self, path: PathLike) -> None:
        """Writes the scene to ``path``.

        The data path is kept valid from the new place: a scene loaded from
        a file and saved in another folder names its data by absolute path
        (written again in the contract's format); a scene whose data is in
        memory also writes the data next to it (``NAME.vtk`` or
        ``NAME.nrrd`` for ``NAME.toml``) and names that file.
        """
        p = os.path.abspath(os.fspath(path))
        folder = os.path.dirname(p)
        text = self._text
        if self._data is not None:
            kind = "mesh" if isinstance(self._data, Mesh) else "volume"
            ext = os.path.splitext(_IN_MEMORY[kind])[1]
            data_file = os.path.splitext(p)[0] + ext
            self._data.save(data_file)
            text = _replace_data_path(text, _IN_MEMORY[kind], os.path.basename(data_file))
        elif self.path is not None and os.path.dirname(self.path) != folder:
            if not os.path.isabs(_data_path_as_written(text)):
                text = _native.rewrite_scene(text, self.path, self.data_path)
        with open(p, "w", encoding="utf-8") as f:
            f.write(text)

    def _file(self) -> str:
        """A scene file a job can run on (written once if need be)."""
        if self.path is not None and self._data is None:
            return self.path
        if self._tmp is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="pvrsim-scene-")
        target = os.path.join(self._tmp.name, "scene.toml")
        if not os.path.exists(target):
            self.save(target)
        return target

    def __repr__(self) -> str:
        w, h = self.size
        src = self.path or ("in memory: " + repr(self._data) if self._data else "fitted")
        return f"pvrsim.Scene({self.field!r} of {self.data_path!r}, {w} x {h}, {src})"


def _data_path_as_written(text: str) -> str:
    import re

    m = re.search(r'(?m)^\s*path\s*=\s*"([^"]*)"', text)
    return m.group(1) if m else ""


def _replace_data_path(text: str, old: str, new: str) -> str:
    line = f"path  = {old!r}".replace("'", '"')
    assert line in text, "a fitted scene names its in-memory data"
    return text.replace(line, f'path  = "{new}"', 1)


def scene_file(scene: Any) -> str:
    """The scene file for a job: a ``Scene`` (written if need be) or a path."""
    if isinstance(scene, Scene):
        return scene._file()
    if isinstance(scene, (str, os.PathLike)):
        return os.fspath(scene)
    raise TypeError(f"expected a pvrsim.Scene or a path to a scene file, not {type(scene).__name__}")


__all__ = ["Scene", "scene_file"]
