"""pvrsim from Python: volume rendering of tetrahedral meshes (cell projection
with early ray termination) and regular grids (texture slicing, shear-warp,
splatting), and a simulator of the PC cluster that renders them, with numpy
in and out.

The module is thin over pvrsim's job layer: every keyword of ``render``,
``cluster`` is an option of ``pvrsim render`` / ``pvrsim cluster`` (flag
name with ``_`` for ``-``), with the command line's defaults, checks and
messages, and the images are the command line's pixels.

A tour
------

Render a scene file, get an (H, W, 4) uint8 image and the statistics::

    import pvrsim
    res = pvrsim.render("tests/data/aorta-small-view-b.toml", threads=1, ert=0.9)
    res.image.shape, res.stats["time_total_s"]

Data from numpy, a fitted scene, a render::

    mesh = pvrsim.Mesh.from_arrays(points, tets, point_data={"speed": s})
    scene = pvrsim.Scene.fit(mesh, field="speed", view="-y", size=(300, 300))
    img = pvrsim.render(scene).image

    vol = pvrsim.Volume.from_array(a, spacing=(1, 1, 1))     # a[z, y, x]
    img = pvrsim.render(pvrsim.Scene.fit(vol, view="+z")).image

A simulated cluster of 8 nodes, its report, per-node table and timeline
(pandas)::

    cl = pvrsim.cluster(scene, nodes=8, ert=0.9, share=True, dlb=True)
    cl.report["speedup"], cl.nodes, cl.timeline
    cl = pvrsim.cluster(scene, nodes=4, transport="processes")   # real worker processes

A parameter sweep (a config file of ``pvrsim sweep``, or a dict) as a
DataFrame of results.csv's rows::

    df = pvrsim.sweep("configs/smoke.toml", progress=True)
    df.groupby("tile")["time_scan_s"].mean()

Errors carry the command line's messages: ``pvrsim.Error`` is the base;
``OptionError`` (a ``ValueError``) for options, ``UnknownOptionError`` (also
a ``TypeError``) for unknown keywords, ``DataError`` (a ``ValueError``) for
malformed arrays, ``FileError`` (an ``OSError``) for missing or malformed
files, ``RunError`` (a ``RuntimeError``) for the rest. Jobs run without the
GIL; Ctrl-C stops them and raises ``KeyboardInterrupt``.

``python -m pvrsim ARGS`` (and the ``pvrsim`` script this package
installs) is the command line itself. The guide is docs/python.md in the
repository.
"""

from __future__ import annotations


from . import _native
from ._data import Mesh, Volume
from ._errors import *  # noqa: F403 (the exception classes, listed once: _errors.__all__)
from ._errors import __all__ as _error_names
from ._jobs import ClusterResult, RenderResult, cluster, render, sweep
from ._options import doc as _doc
from ._scene import Scene
from ._session import Session
from ._view import Viewer, view

__version__: str = _native.__version__

# The option lists come from the command line's definitions.
render.__doc__ = (render.__doc__ or "") + "\n" + _doc("render")
cluster.__doc__ = (cluster.__doc__ or "") + "\n" + _doc("cluster")
view.__doc__ = (view.__doc__ or "") + "\n" + _doc("view")

__all__ = [
    "Mesh",
    "Volume",
    "Scene",
    "render",
    "cluster",
    "Session",
    "view",
    "Viewer",
    "sweep",
    "RenderResult",
    "ClusterResult",
    *_error_names,
    "__version__",
]
