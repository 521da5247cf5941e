"""Data in memory: tetrahedral meshes (``Mesh``) and regular grids (``Volume``).

Both are held by the Rust side, read by the command line's readers and
checked by its validation; arrays are converted once at the boundary, with
shape and dtype checks that name the argument.
"""

from __future__ import annotations

import os
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._errors import DataError

PathLike = Union[str, "os.PathLike[str]"]

#: The VTK cell type of a linear tetrahedron (pyvista's ``cells_dict`` key).
_VTK_TETRA = 10


def _array(value: Any, name: str) -> np.ndarray:
    try:
        return np.asarray(value)
    except Exception as e:  # a ragged list, an object numpy cannot hold
        raise DataError(f"{name}: not an array ({e})") from None


class Mesh:
    """A tetrahedral mesh: points, tetrahedra and named point data.

    Build one with ``Mesh.read(path)``, ``Mesh.from_arrays(points, tets,
    point_data)``, ``Mesh.from_meshio(m)`` or ``Mesh.from_pyvista(grid)``.

    Attributes (arrays are computed on first use, then kept):

    - ``points``: (N, 3) float32 when every coordinate is exactly a float32
      (files that store ``float``), else float64;
    - ``tets``: (M, 4) int64 vertex indices;
    - ``point_data``: ``{name: (N,) array}`` (``(N, k)`` for a k-component
      field, which renders as its magnitude), float64;
    - ``path``: the file it was read from, or ``None``.
    """

    __slots__ = ("_native", "path", "_points", "_tets", "_point_data")

    def __init__(self, native: "_native.NativeMesh", path: Optional[str] = None) -> None:
        self._native = native
        self.path = path
        self._points: Optional[np.ndarray] = None
        self._tets: Optional[np.ndarray] = None
        self._point_data: Optional[Dict[str, np.ndarray]] = None

    @classmethod
    def read(cls, path: PathLike) -> "Mesh":
        """Reads a mesh file the command line reads: legacy VTK ``.vtk``
        (ASCII or binary), VTK XML ``.vtu`` and its partitioned ``.pvtu``,
        AVS UCD ``.inp``; other 3D linear cells are split into tetrahedra as
        the CLI does.

        Raises ``FileError`` (an ``OSError``) naming the file and the line,
        byte or field at fault.
        """
        p = os.fspath(path)
        return cls(_native.NativeMesh.read(p), os.path.abspath(p))

    @classmethod
    def from_arrays(
        cls,
        points: Any,
        tets: Any,
        point_data: Optional[Mapping[str, Any]] = None,
    ) -> "Mesh":
        """A mesh from arrays of any float or integer dtype.

        ``points`` (N, 3), ``tets`` (M, 4) integer vertex indices into
        ``points``, ``point_data`` ``{name: (N,) or (N, k) array}``. Raises
        ``DataError`` (a ``ValueError``) for a wrong shape or dtype, a
        non-finite coordinate or value, or an index out of range, with the
        command line's message for the last two.
        """
        p = _array(points, "points")
        t = _array(tets, "tets")
        if p.ndim != 2 or p.shape[1] != 3:
            raise DataError(f"points: expected shape (N, 3), got {p.shape}")
        if t.ndim != 2 or t.shape[1] != 4:
            raise DataError(f"tets: expected shape (M, 4), got {t.shape}")
        if not (np.issubdtype(p.dtype, np.floating) or np.issubdtype(p.dtype, np.integer)):
            raise DataError(f"points: expected a float or integer dtype, got {p.dtype}")
        if t.size and not np.issubdtype(t.dtype, np.integer):
            raise DataError(f"tets: expected an integer dtype, got {t.dtype}")
        if t.dtype == np.uint64 and t.size and t.max() > np.iinfo(np.int64).max:
            raise DataError(f"tets: index {t.max()} is out of range (the mesh has {len(p)} points)")
        fields = []
        for name, v in (point_data or {}).items():
            a = _array(v, f"point_data[{name!r}]")
            if a.ndim == 1:
                a = a[:, None]
            if a.ndim != 2 or a.shape[0] != p.shape[0]:
                raise DataError(
                    f"point_data[{name!r}]: expected shape ({p.shape[0]},) or ({p.shape[0]}, k), got {np.shape(v)}"
                )
            if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
                raise DataError(f"point_data[{name!r}]: expected a numeric dtype, got {a.dtype}")
            fields.append((str(name), np.ascontiguousarray(a, dtype=np.float64)))
        native = _native.NativeMesh.from_arrays(
            np.ascontiguousarray(p, dtype=np.float64),
            np.ascontiguousarray(t, dtype=np.int64),
            fields,
        )
        return cls(native)

    @classmethod
    def from_meshio(cls, mesh: Any) -> "Mesh":
        """A mesh from a ``meshio.Mesh`` (duck-typed: ``points``, ``cells``
        with ``type``/``data``, ``point_data``); its ``tetra`` cells are
        used, and any other cell type is refused by name."""
        tets = []
        other = set()
        for block in mesh.cells:
            kind = getattr(block, "type", None)
            data = getattr(block, "data", None)
            if kind is None and isinstance(block, tuple):
                kind, data = block
            if kind == "tetra":
                tets.append(np.asarray(data))
            else:
                other.add(str(kind))
        if other:
            raise DataError(
                f"meshio mesh: only tetra cells are taken, it also has {', '.join(sorted(other))} "
                "(write it to .vtu/.vtk and use Mesh.read, which splits them as the CLI does)"
            )
        t = np.concatenate(tets) if tets else np.zeros((0, 4), np.int64)
        return cls.from_arrays(mesh.points, t, dict(getattr(mesh, "point_data", {}) or {}))

    @classmethod
    def from_pyvista(cls, grid: Any) -> "Mesh":
        """A mesh from a ``pyvista.UnstructuredGrid`` (duck-typed:
        ``points``, ``cells_dict``, ``point_data``) of tetrahedra."""
        cells = dict(grid.cells_dict)
        other = sorted(str(k) for k in cells if int(k) != _VTK_TETRA)
        if other:
            raise DataError(
                f"pyvista grid: only tetrahedra (VTK cell type {_VTK_TETRA}) are taken, it also has types {', '.join(other)} "
                "(grid.triangulate() splits them)"
            )
        t = cells.get(_VTK_TETRA, np.zeros((0, 4), np.int64))
        pd = {str(k): np.asarray(grid.point_data[k]) for k in grid.point_data.keys()}
        return cls.from_arrays(np.asarray(grid.points), t, pd)

    @property
    def points(self) -> np.ndarray:
        if self._points is None:
            p = self._native.points()
            p32 = p.astype(np.float32)
            self._points = p32 if np.array_equal(p32, p) else p
        return self._points

    @property
    def tets(self) -> np.ndarray:
        if self._tets is None:
            self._tets = self._native.tets()
        return self._tets

    @property
    def point_data(self) -> Dict[str, np.ndarray]:
        if self._point_data is None:
            self._point_data = {
                name: (a[:, 0] if a.shape[1] == 1 else a) for name, a in self._native.fields()
            }
        return self._point_data

    @property
    def file_vertex_ids(self) -> Optional[np.ndarray]:
        """For each vertex, its index in the file read, or ``None`` when the
        mesh keeps the file's numbering. A file whose numbering is scattered
        (a mesher's or a solver's order) is renumbered along a space-filling
        curve at load, as the command line does, so that rendering gathers
        vertices from cache: ``mesh.point_data[f][i]`` is the file's value
        of vertex ``mesh.file_vertex_ids[i]``."""
        return self._native.file_vertex_ids()

    @property
    def file_cell_ids(self) -> Optional[np.ndarray]:
        """For each tetrahedron, its index in the file read (after splitting
        other cells into tetrahedra), or ``None`` when the mesh keeps the
        file's numbering (see ``file_vertex_ids``)."""
        return self._native.file_cell_ids()

    @property
    def n_points(self) -> int:
        return self._native.counts()[0]

    @property
    def n_tets(self) -> int:
        return self._native.counts()[1]

    def save(self, path: PathLike) -> None:
        """Writes the mesh as binary legacy VTK (``.vtk``), the CLI's writer."""
        self._native.write_vtk(os.fspath(path))

    def __repr__(self) -> str:
        n, m = self._native.counts()
        fields = ", ".join(name for name, _ in self._native.fields())
        src = f", path={self.path!r}" if self.path else ""
        return f"pvrsim.Mesh({m} tetrahedra, {n} points, fields [{fields}]{src})"


#: The voxel types the renderers hold; any other dtype becomes float32.
_VOXEL_TYPES = ("uint8", "uint16", "int16", "float32")


class Volume:
    """A regular grid of one scalar.

    Build one with ``Volume.read(path)`` or ``Volume.from_array(a,
    spacing, origin)``.

    Attributes: ``array`` (``a[z, y, x]``, C order, the file's dtype:
    uint8, uint16, int16 or float32), ``dims`` (samples along x, y, z),
    ``spacing`` and ``origin`` (x, y, z, world units), ``field`` (the
    scalar's name), ``path`` (the file, or ``None``).
    """

    __slots__ = ("_native", "path", "_array")

    def __init__(self, native: "_native.NativeVolume", path: Optional[str] = None) -> None:
        self._native = native
        self.path = path
        self._array: Optional[np.ndarray] = None

    @classmethod
    def read(cls, path: PathLike, field: Optional[str] = None) -> "Volume":
        """Reads a grid file the command line reads: NRRD (``.nhdr``,
        ``.nrrd``), NIfTI-1 (``.nii``, ``.nii.gz``), VTK XML ImageData
        (``.vti``; ``field`` picks its array when it has several), AVS
        field (``.fld``). Raises ``FileError`` naming the file and field."""
        p = os.fspath(path)
        return cls(_native.NativeVolume.read(p, field or ""), os.path.abspath(p))

    @classmethod
    def from_array(
        cls,
        a: Any,
        spacing: Sequence[float] = (1.0, 1.0, 1.0),
        origin: Sequence[float] = (0.0, 0.0, 0.0),
        field: str = "intensity",
    ) -> "Volume":
        """A grid from a 3-D array ``a[z, y, x]`` (C order: x varies fastest).

        uint8, uint16, int16 and float32 samples are kept as they are; any
        other numeric dtype (bool, other integers, float64) is converted to
        float32, the renderers' type. ``spacing`` and ``origin`` are (x, y,
        z) in world units. Raises ``DataError`` for a wrong shape, a
        spacing that is not finite and positive, or a non-finite sample
        (the command line's messages).
        """
        arr = _array(a, "array")
        if arr.ndim != 3:
            raise DataError(f"array: expected a 3-D array a[z, y, x], got shape {arr.shape}")
        if not (np.issubdtype(arr.dtype, np.number) or arr.dtype == np.bool_):
            raise DataError(f"array: expected a numeric dtype, got {arr.dtype}")
        if arr.dtype.name not in _VOXEL_TYPES:
            arr = arr.astype(np.float32)
        arr = np.ascontiguousarray(arr)
        sp = _triple(spacing, "spacing")
        og = _triple(origin, "origin")
        native = _native.NativeVolume.from_array(arr, arr.dtype.name, sp, og, str(field))
        return cls(native)

    @property
    def array(self) -> np.ndarray:
        if self._array is None:
            self._array = self._native.array()
        return self._array

    @property
    def dims(self) -> Tuple[int, int, int]:
        return tuple(self._native.dims())  # type: ignore[return-value]

    @property
    def spacing(self) -> Tuple[float, float, float]:
        return tuple(self._native.spacing())  # type: ignore[return-value]

    @property
    def origin(self) -> Tuple[float, float, float]:
        return tuple(self._native.origin())  # type: ignore[return-value]

    @property
    def field(self) -> str:
        return self._native.field()

    def save(self, path: PathLike) -> None:
        """Writes the grid as NRRD (``.nrrd``, raw), the CLI's writer."""
        self._native.write_nrrd(os.fspath(path))

    def __repr__(self) -> str:
        x, y, z = self.dims
        src = f", path={self.path!r}" if self.path else ""
        return f"pvrsim.Volume({x} x {y} x {z} {self.field!r}, spacing {self.spacing}{src})"


def _triple(v: Sequence[float], name: str) -> Tuple[float, float, float]:
    try:
        t = tuple(float(x) for x in v)
    except (TypeError, ValueError):
        raise DataError(f"{name}: expected three numbers (x, y, z), got {v!r}") from None
    if len(t) != 3:
        raise DataError(f"{name}: expected three numbers (x, y, z), got {len(t)}")
    return t  # type: ignore[return-value]
