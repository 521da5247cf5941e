"""A CAD-like part meshed by gmsh, written in gmsh's own order.

The part is a filleted block with three through holes and a cylindrical boss
(gmsh's OpenCASCADE kernel), meshed with tetrahedra of about `--tets` cells.
The mesh is written as binary legacy VTK with the nodes and tetrahedra in
the order gmsh returns them (no renumbering), with a smooth point field
`temperature`, plus a scene TOML (orthographic, fitted to the part, a
transfer function whose opacity is above zero over the whole field range, so
that no cell is culled as empty).

Usage: python part.py --tets N --out DIR/part-N.vtk [--threads T]
"""

import argparse
import math
import sys
import time

import gmsh
import numpy as np

# The part's size in mm and the ratio tets / (volume / h^3) that gmsh's
# Delaunay gives on it; refined by a coarse calibration run below.
BLOCK = (120.0, 80.0, 40.0)


def build_part():
    occ = gmsh.model.occ
    bx, by, bz = BLOCK
    box = occ.addBox(0, 0, 0, bx, by, bz)
    occ.synchronize()
    edges = [t for _, t in occ.getEntities(1)]
    filleted = occ.fillet([box], edges, [6.0])
    occ.synchronize()
    body = [(3, t) for d, t in filleted if d == 3]
    boss = occ.addCylinder(bx * 0.5, by * 0.5, bz, 0, 0, 25.0, 18.0)
    fused, _ = occ.fuse(body, [(3, boss)])
    holes = [
        occ.addCylinder(20.0, 20.0, -5.0, 0, 0, bz + 10.0, 8.0),
        occ.addCylinder(bx - 20.0, 20.0, -5.0, 0, 0, bz + 10.0, 8.0),
        occ.addCylinder(20.0, by - 20.0, -5.0, 0, 0, bz + 10.0, 8.0),
        occ.addCylinder(bx * 0.5, by * 0.5, -5.0, 0, 0, bz + 40.0, 7.0),
        occ.addCylinder(-5.0, by * 0.5, bz * 0.5, bx + 10.0, 0, 0, 6.0),
    ]
    cut, _ = occ.cut(fused, [(3, h) for h in holes])
    occ.synchronize()
    return cut


def mesh_at(h, threads):
    gmsh.model.mesh.clear()
    gmsh.option.setNumber("Mesh.MeshSizeMin", h)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
    # HXT: gmsh's parallel Delaunay, the one that reaches tens of millions.
    gmsh.option.setNumber("Mesh.Algorithm3D", 10)
    gmsh.option.setNumber("General.NumThreads", threads)
    gmsh.option.setNumber("Mesh.Optimize", 0)
    gmsh.model.mesh.generate(3)
    types, tags, _ = gmsh.model.mesh.getElements(3)
    n = 0
    for t, tg in zip(types, tags):
        if t == 4:
            n += len(tg)
    return n


def temperature(p):
    """A smooth temperature-like field over the part (a hot boss, a cooled hole)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    bx, by, bz = BLOCK
    hot = 80.0 * np.exp(-(((x - bx * 0.5) ** 2 + (y - by * 0.5) ** 2) / 900.0 + (z - bz - 25.0) ** 2 / 1600.0))
    cool = -30.0 * np.exp(-((x - 20.0) ** 2 + (y - 20.0) ** 2) / 200.0)
    wave = 6.0 * np.sin(x / 9.0) * np.cos(y / 7.0) + 0.4 * z
    return (300.0 + hot + cool + wave).astype(np.float32)


def write_vtk(path, pts, tets, field):
    n, m = len(pts), len(tets)
    with open(path, "wb") as f:
        f.write(b"# vtk DataFile Version 3.0\n")
        f.write(b"gmsh CAD-like part, gmsh's node and element order\nBINARY\nDATASET UNSTRUCTURED_GRID\n")
        f.write(f"POINTS {n} float\n".encode())
        f.write(pts.astype(">f4").tobytes())
        f.write(f"\nCELLS {m} {5 * m}\n".encode())
        cells = np.empty((m, 5), dtype=">i4")
        cells[:, 0] = 4
        cells[:, 1:] = tets
        f.write(cells.tobytes())
        del cells
        f.write(f"\nCELL_TYPES {m}\n".encode())
        f.write(np.full(m, 10, dtype=">i4").tobytes())
        f.write(f"\nPOINT_DATA {n}\nSCALARS temperature float 1\nLOOKUP_TABLE default\n".encode())
        f.write(field.astype(">f4").tobytes())
        f.write(b"\n")


def write_scene(path, mesh_name, pts, field):
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    c = (lo + hi) * 0.5
    ext = hi - lo
    # Camera on the -y side, a little above, looking at the centre: every
    # hole and fillet in view. Orthographic; height fits the part with 5 %.
    eye_dir = np.array([0.35, -1.0, 0.55])
    eye_dir /= np.linalg.norm(eye_dir)
    dist = 3.0 * float(np.linalg.norm(ext))
    eye = c + eye_dir * dist
    height = 0.8 * float(np.linalg.norm(ext))
    f0, f1 = float(field.min()), float(field.max())
    # Opacity above zero at every value: no cell is empty under this TF.
    tf = [
        (0.0, 0.230, 0.299, 0.754, 0.05),
        (0.25, 0.552, 0.690, 0.996, 0.08),
        (0.5, 0.865, 0.865, 0.865, 0.10),
        (0.75, 0.958, 0.604, 0.482, 0.15),
        (1.0, 0.706, 0.016, 0.150, 0.30),
    ]
    lines = [
        f"# {mesh_name}: gmsh CAD-like part, {len(pts)} vertices; temperature in [{f0:.3f}, {f1:.3f}]",
        "# Written by bench/meshes/part.py; every cell visible (opacity > 0 over the whole range).",
        "",
        "[data]",
        f'path  = "{mesh_name}"',
        'field = "temperature"',
        "",
        "[camera]",
        f"eye        = [{eye[0]:.4f}, {eye[1]:.4f}, {eye[2]:.4f}]",
        f"target     = [{c[0]:.4f}, {c[1]:.4f}, {c[2]:.4f}]",
        "up         = [0, 0, 1]",
        'projection = "orthographic"',
        f"height     = {height:.4f}",
        "",
        "[image]",
        "width      = 512",
        "height     = 512",
        "background = [0, 0, 0]",
        "",
        "[transfer]",
        "# points over the field's normalised range (its min..max).",
        f"unit_distance = {float(np.linalg.norm(ext)) / 20.0:.4f}",
        "points = [",
    ]
    for t, r, g, b, a in tf:
        lines.append(f"  [{t:.4f}, {r:.4f}, {g:.4f}, {b:.4f}, {a:.4f}],")
    lines.append("]")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tets", type=float, required=True, help="about this many tetrahedra")
    ap.add_argument("--out", required=True, help="output .vtk (the scene goes beside it as .toml)")
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 1)
    gmsh.option.setNumber("General.Verbosity", 2)
    gmsh.model.add("part")
    build_part()
    vol = sum(gmsh.model.occ.getMass(3, t) for _, t in gmsh.model.getEntities(3))
    # Calibrate tets per (volume / h^3) on a coarse mesh, then aim.
    h0 = (vol / 200000.0 * 6.0) ** (1.0 / 3.0)
    n0 = mesh_at(h0, a.threads)
    k = n0 * h0**3 / vol
    h = (k * vol / a.tets) ** (1.0 / 3.0)
    if a.tets > 1.5e6:
        # Boundary layers weigh less at finer sizes: calibrate again at 1/8.
        h1 = h * 2.0
        n1 = mesh_at(h1, a.threads)
        k = n1 * h1**3 / vol
        h = (k * vol / a.tets) ** (1.0 / 3.0)
    t = time.time()
    n = mesh_at(h, a.threads)
    print(f"part.py: h = {h:.4f} mm, {n} tets in {time.time() - t:.1f} s (calibration: {n0} at h = {h0:.3f})", file=sys.stderr)
    tags, coords, _ = gmsh.model.mesh.getNodes()
    pts = coords.reshape(-1, 3).astype(np.float64)
    del coords
    # Map gmsh's node tags to 0-based indices in gmsh's own node order.
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags] = np.arange(len(tags))
    types, _, nodes = gmsh.model.mesh.getElements(3)
    conn = np.concatenate([nd for ty, nd in zip(types, nodes) if ty == 4])
    gmsh.finalize()
    tets = index[conn.astype(np.int64)].reshape(-1, 4).astype(np.int32)
    del conn, index
    # Keep only the nodes the tetrahedra use (gmsh also returns nodes of
    # lower-dimensional entities, all of them on the volume's boundary here),
    # keeping gmsh's order.
    used = np.zeros(len(pts), dtype=bool)
    used[tets.ravel()] = True
    if not used.all():
        new = np.cumsum(used) - 1
        tets = new[tets].astype(np.int32)
        pts = pts[used]
    field = temperature(pts)
    write_vtk(a.out, pts.astype(np.float32), tets, field)
    scene = a.out[:-4] + ".toml" if a.out.endswith(".vtk") else a.out + ".toml"
    write_scene(scene, a.out.split("/")[-1], pts, field)
    print(f"part.py: wrote {a.out} ({len(tets)} tets, {len(pts)} vertices) and {scene}", file=sys.stderr)


if __name__ == "__main__":
    main()
