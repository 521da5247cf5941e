"""The jobs: ``render``, ``cluster`` and ``sweep``.

Each takes a scene (a ``Scene`` or a path) and keywords that are the
command's options by flag name; each runs off the GIL on a thread of its
own, and Ctrl-C cancels it (``KeyboardInterrupt``).
"""

from __future__ import annotations

import csv
import io
import json
import os
import sys
import tempfile
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native, _options
from ._errors import FileError
from ._scene import Scene, scene_file

PathLike = Union[str, "os.PathLike[str]"]


def _pandas() -> Any:
    try:
        import pandas
    except ImportError:
        raise ImportError(
            "this pvrsim result is a pandas.DataFrame: pip install pandas "
            "(or pip install './python[pandas]')"
        ) from None
    return pandas


class RenderResult:
    """What ``render`` returns.

    - ``image``: (H, W, 4) uint8; RGB are the pixels of the PNG ``pvrsim
      render`` writes, A the opacity (0 where only background is seen);
    - ``stats``: dict, the ``--stats`` JSON (times, counts, ERT figures);
    - ``summary``: the lines ``pvrsim render`` prints;
    - ``warnings``: what the validation warned about.
    """

    __slots__ = ("image", "stats", "summary", "warnings")

    def __init__(self, raw: Dict[str, Any]) -> None:
        self.image: np.ndarray = raw["image"]
        self.stats: Dict[str, Any] = json.loads(raw["stats"])
        self.summary: List[str] = list(raw["summary"])
        self.warnings: List[str] = list(raw["warnings"])

    def __repr__(self) -> str:
        h, w, _ = self.image.shape
        t = self.stats.get("time_total_s")
        return f"pvrsim.RenderResult({w} x {h}" + (f", {t:.4f} s)" if isinstance(t, float) else ")")


class ClusterResult:
    """What ``cluster`` returns.

    - ``image``: (H, W, 4) uint8, the final frame (as ``-o`` writes it, plus A);
    - ``images``: every frame's image, in order (a series: ``frames=N,
      turn=DEG`` or ``series="session.toml"``; one image otherwise);
    - ``report``: dict, the ``--report`` JSON of the (last) frame; a series
      adds ``report["series"]``: ``fps``, ``total_s`` and one row per frame;
    - ``frames``: every frame's report, in order;
    - ``nodes``: pandas.DataFrame, one row per node: the report's per-node
      figures (nested ones flattened as ``a.b``);
    - ``timeline``: pandas.DataFrame of what each node did when: ``node``,
      ``activity`` (compute, scan, share, steal, idle, composite, send,
      recv), ``start_s``, ``end_s``, ``bytes`` and ``peer`` (messages);
    - ``summary``: the text ``pvrsim cluster`` prints; ``warnings``.
    """

    __slots__ = ("image", "images", "report", "frames", "summary", "warnings", "ranks", "_trace", "_nodes", "_timeline")

    def __init__(self, raw: Dict[str, Any]) -> None:
        self.image: np.ndarray = raw["image"]
        self.images: List[np.ndarray] = list(raw["images"])
        self.report: Dict[str, Any] = json.loads(raw["report"])
        self.frames: List[Dict[str, Any]] = [json.loads(f) for f in raw["frames"]]
        self.summary: str = raw["summary"]
        self.warnings: List[str] = list(raw["warnings"])
        self.ranks: int = raw["ranks"]
        self._trace = raw["trace"]
        self._nodes: Any = None
        self._timeline: Any = None

    @property
    def nodes(self) -> Any:
        if self._nodes is None:
            pd = _pandas()
            rows = self.report.get("nodes", [])
            df = pd.json_normalize(rows) if rows else pd.DataFrame()
            if "node" not in df.columns and "rank" not in df.columns:
                df.insert(0, "node", range(len(df)))
            self._nodes = df
        return self._nodes

    @property
    def timeline(self) -> Any:
        if self._timeline is None:
            pd = _pandas()
            df = pd.DataFrame(
                self._trace, columns=["node", "activity", "start_s", "end_s", "bytes", "peer"]
            )
            df["peer"] = df["peer"].astype("Int64")
            self._timeline = df
        return self._timeline

    def __repr__(self) -> str:
        h, w, _ = self.image.shape
        return f"pvrsim.ClusterResult({self.ranks} nodes, {w} x {h})"


def render(scene: Union[Scene, PathLike], **options: Any) -> RenderResult:
    """Renders ``scene`` as ``pvrsim render`` does; returns a ``RenderResult``.

    ``scene`` is a ``Scene`` or the path of a scene file. Keywords are the
    options of ``pvrsim render`` (flag name with _ for -): the same
    defaults, values and checks. ``output="x.png"`` and ``stats="s.json"``
    also write those files, as the command line does.

        res = pvrsim.render("scene.toml", threads=1, ert=0.9, integrator="midpoint")
        res.image.shape        # (H, W, 4) uint8
        res.stats["time_total_s"]

    Raises ``OptionError`` (a ``ValueError``) for a bad or refused option,
    ``UnknownOptionError`` for a keyword that is no option, ``FileError``
    (an ``OSError``) for a missing or malformed scene or data file;
    Ctrl-C stops the render (before its next tile) and raises
    ``KeyboardInterrupt``.
    """
    opts = _options.options("render", scene_file(scene), options)
    return RenderResult(_native.render(opts))


def cluster(scene: Union[Scene, PathLike], **options: Any) -> ClusterResult:
    """Runs ``scene`` on a simulated (or real) PC cluster as ``pvrsim
    cluster`` does; returns a ``ClusterResult`` (image, report, nodes,
    timeline).

    Keywords are the options of ``pvrsim cluster`` (flag name with _ for
    -): ``nodes=8, ert=0.9, share=True, dlb=True``, ``transport="threads"``
    (in this process) or ``"processes"`` (worker processes started as
    ``python -m pvrsim worker``), ``"tcp"`` with ``workers=[...]``.
    ``output``, ``report``, ``trace`` and ``timeline`` paths also write
    those files.

        cl = pvrsim.cluster("scene.toml", nodes=4, ert=0.9)
        cl.report["speedup"], cl.nodes, cl.timeline

    Errors as for ``render``. Ctrl-C raises ``KeyboardInterrupt`` within a
    second; a cluster frame has no cancellation points, so it finishes in
    the background (the next job waits for it).
    """
    opts = _options.options("cluster", scene_file(scene), options)
    return ClusterResult(_native.cluster(opts))


class _Progress:
    """Prints the rows results.csv gains while a sweep runs."""

    def __init__(self, csv_path: str, out: Any) -> None:
        self.path = csv_path
        self.out = out
        self.seen = -1
        self.stamp: Tuple[int, int] = (-1, -1)

    def __call__(self) -> None:
        # Progress must never stop the sweep: a row that cannot be read now
        # is printed at the next call.
        try:
            self._print_new_rows()
        except Exception:
            pass

    def _print_new_rows(self) -> None:
        try:
            st = os.stat(self.path)
        except OSError:
            return
        stamp = (st.st_size, st.st_mtime_ns)
        if stamp == self.stamp:
            return
        self.stamp = stamp
        with open(self.path, encoding="utf-8", newline="") as f:
            text = f.read()
        complete = text[: text.rfind("\n") + 1]
        rows = list(csv.DictReader(io.StringIO(complete)))
        if self.seen < 0:
            self.seen = 0
        for k, row in enumerate(rows[self.seen :], start=self.seen + 1):
            params = []
            for k, v in row.items():
                if k == "repetition":
                    break
                params.append(f"{k}={v}")
            line = (
                f"[{k}] {' '.join(params)} rep {row.get('repetition', '')}: "
                f"{row.get('status', '')} in {row.get('wall_s', '')} s"
            )
            if row.get("error"):
                line += f" ({row['error']})"
            print(line, file=self.out, flush=True)
        self.seen = len(rows)


def _config_file(config: Union[PathLike, Mapping[str, Any]], tmp: str) -> str:
    """A config path as given, or a dict written as TOML in ``tmp`` (its
    ``scene`` and ``requires`` paths made absolute from the current folder)."""
    if isinstance(config, (str, os.PathLike)):
        return os.fspath(config)
    if not isinstance(config, Mapping):
        raise TypeError(f"sweep takes a config path or a dict, not {type(config).__name__}")
    c = dict(config)
    if isinstance(c.get("scene"), (str, os.PathLike)):
        c["scene"] = os.path.abspath(os.fspath(c["scene"]))
    if isinstance(c.get("requires"), (list, tuple)):
        c["requires"] = [os.path.abspath(os.fspath(p)) for p in c["requires"]]
    c.setdefault("name", "sweep")
    path = os.path.join(tmp, "sweep.toml")
    with open(path, "w", encoding="utf-8") as f:
        f.write(_native.toml_from_json(json.dumps(c, default=_jsonable)))
    return path


def _jsonable(v: Any) -> Any:
    if isinstance(v, os.PathLike):
        return os.fspath(v)
    if hasattr(v, "tolist"):
        return v.tolist()
    raise TypeError(f"cannot write {v!r} ({type(v).__name__}) into a sweep config")


def sweep(
    config: Union[PathLike, Mapping[str, Any]],
    *,
    out: Optional[PathLike] = None,
    force: bool = False,
    only: Optional[Union[Mapping[str, Any], Sequence[Tuple[str, Any]]]] = None,
    allow_missing: bool = False,
    progress: bool = False,
) -> Any:
    """Runs a sweep as ``pvrsim sweep`` does; returns results.csv's rows as
    a pandas.DataFrame (one row per run: the parameters, ``repetition``,
    ``status``, ``wall_s``, ``error`` and every statistic).

    ``config`` is a sweep config file (``docs/sweeps.md``) or a dict with
    its keys (``command``, ``scene``, ``fixed``, ``vary``, ``zip``,
    ``repetitions``, ...; relative paths from the current folder).
    ``out=None`` runs in a temporary folder that is removed afterwards;
    ``out="results"`` keeps OUT/NAME/ (results.csv, summary.md, plots) and,
    as the command line does, skips runs already there unless ``force``.
    ``only`` keeps the points whose parameters have these values
    (``{"tile": 16}``, or pairs to give one key several values).
    ``progress=True`` prints each finished run's row.

    The DataFrame's ``attrs`` hold ``summary`` (summary.md's text) and
    ``out_dir``. Ctrl-C stops the sweep (between runs, or inside a
    render's tiles) and raises ``KeyboardInterrupt``.
    """
    pd = _pandas()
    pairs: List[Tuple[str, str]] = []
    if only:
        items = only.items() if isinstance(only, Mapping) else only
        pairs = [(str(k), str(v)) for k, v in items]
    with tempfile.TemporaryDirectory(prefix="pvrsim-sweep-") as tmp:
        cfg = _config_file(config, tmp)
        root = os.fspath(out) if out is not None else os.path.join(tmp, "results")
        tick = None
        if progress:
            tick = _Progress(_planned_csv(cfg, root), sys.stdout)
        r = _native.sweep(cfg, root, force, pairs, allow_missing, tick)
        if tick is not None:
            tick()
        if r["missing"]:
            df = pd.DataFrame()
        else:
            if not os.path.exists(r["csv"]):
                err = FileError(f"{r['csv']}: the sweep wrote no results")
                err.filename = r["csv"]
                raise err
            df = pd.read_csv(r["csv"])
        df.attrs["summary"] = r["summary"]
        df.attrs["out_dir"] = r["out_dir"] if out is not None else None
        df.attrs["warnings"] = r["warnings"]
        df.attrs["missing"] = r["missing"]
        for w in r["warnings"]:
            print(f"warning: {w}", file=sys.stderr)
        return df


def _planned_csv(config: str, root: str) -> str:
    """Where the sweep of ``config`` writes results.csv (OUT/NAME/)."""
    return os.path.join(root, _native.sweep_name(config), "results.csv")
