"""Writes the .vtu fixtures of tests/io_formats.rs and expected.json.

Run with meshio 5.3.5 and numpy (pip install meshio):  python3 make_fixtures.py

The mesh: a unit cube split into 12 tetrahedra around its centre (9 points),
with point data "temperature" (Float64), "velocity" (Float32 x3),
"label" (Int32) and "flag" (UInt8).

- meshio writes the ascii, inline-binary (UInt32 / UInt64 header) and
  inline-binary zlib files.
- meshio cannot write appended data, so the appended files (raw and base64,
  plain and zlib, little- and big-endian) are written below by hand following
  the VTK XML file-format documentation, exactly as VTK/ParaView lays them out
  (UInt64 headers, "_" marker, offsets counted from just after it).
- Every fixture is read back with meshio; expected.json holds meshio's view of
  the mesh (from binary-uint32.vtu; meshio reads all binary fixtures
  identically, and ascii.vtu to 1e-11 relative, as it prints 12 digits),
  which the Rust test compares every fixture against.
"""
import base64, json, zlib
import numpy as np
import meshio

pts = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)] + [[0.5, 0.5, 0.5]], dtype=np.float64)
pts[:, 0] *= 1.25  # not a cube: makes coordinates non-trivial
faces = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [1, 3, 7, 5], [3, 2, 6, 7], [2, 0, 4, 6]]
tets = []
for f in faces:
    for tri in ([f[0], f[1], f[2]], [f[0], f[2], f[3]]):
        t = [tri[0], tri[1], tri[2], 8]
        a, b, c, d = (pts[i] for i in t)
        if np.linalg.det(np.array([b - a, c - a, d - a])) < 0:
            t[1], t[2] = t[2], t[1]
        tets.append(t)
tets = np.array(tets, dtype=np.int64)
n = len(pts)
point_data = {
    "temperature": np.linspace(0.1, 0.9, n) ** 2 + 1e-9,
    "velocity": (pts * np.array([1.0, -2.0, 0.5]) + 0.1).astype(np.float32),
    "label": np.arange(n, dtype=np.int32) * 3 - 7,
    "flag": (np.arange(n) % 2).astype(np.uint8),
}
mesh = meshio.Mesh(pts, [("tetra", tets)], point_data=point_data)

mesh.write("ascii.vtu", binary=False)
meshio.vtu.write("binary-uint32.vtu", mesh, binary=True, compression=None, header_type="UInt32")
meshio.vtu.write("binary-uint64.vtu", mesh, binary=True, compression=None, header_type="UInt64")
meshio.vtu.write("binary-zlib.vtu", mesh, binary=True, compression="zlib", header_type="UInt32")


def vtk_type(a):
    return {"float64": "Float64", "float32": "Float32", "int32": "Int32", "int64": "Int64", "uint8": "UInt8"}[a.dtype.name]


def appended(name, encoding, compress, big_endian):
    bo = ">" if big_endian else "<"
    arrays = [("Points", "Points", pts, 3)]
    arrays += [("Cells", "connectivity", tets.ravel(), 1), ("Cells", "offsets", np.arange(4, 4 * len(tets) + 1, 4, dtype=np.int64), 1),
               ("Cells", "types", np.full(len(tets), 10, dtype=np.uint8), 1)]
    arrays += [("PointData", k, v, 1 if v.ndim == 1 else v.shape[1]) for k, v in point_data.items()]
    blob = b""
    xml = {"Points": [], "Cells": [], "PointData": []}
    for parent, aname, a, ncomp in arrays:
        data = a.astype(a.dtype.newbyteorder(bo)).tobytes()
        if compress:
            # one block per 40 bytes, to exercise several blocks
            bs = 40
            blocks = [data[i:i + bs] for i in range(0, len(data), bs)] or [b""]
            comp = [zlib.compress(b) for b in blocks]
            last = len(blocks[-1]) if len(blocks[-1]) != bs else 0
            header = np.array([len(blocks), bs, last] + [len(c) for c in comp], dtype=bo + "u8").tobytes()
            body = b"".join(comp)
        else:
            header = np.array([len(data)], dtype=bo + "u8").tobytes()
            body = data
        chunk = header + body if encoding == "raw" else base64.b64encode(header) + base64.b64encode(body)
        xml[parent].append(f'<DataArray type="{vtk_type(a)}" Name="{aname}" NumberOfComponents="{ncomp}" format="appended" offset="{len(blob)}"/>')
        blob += chunk
    comp_attr = ' compressor="vtkZLibDataCompressor"' if compress else ""
    head = (f'<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" byte_order="{"BigEndian" if big_endian else "LittleEndian"}" header_type="UInt64"{comp_attr}>\n'
            f'<UnstructuredGrid>\n<Piece NumberOfPoints="{n}" NumberOfCells="{len(tets)}">\n'
            f'<PointData>\n{chr(10).join(xml["PointData"])}\n</PointData>\n<Points>\n{xml["Points"][0]}\n</Points>\n'
            f'<Cells>\n{chr(10).join(xml["Cells"])}\n</Cells>\n</Piece>\n</UnstructuredGrid>\n'
            f'<AppendedData encoding="{encoding}">\n   _')
    with open(name, "wb") as f:
        f.write(head.encode() + blob + b"\n</AppendedData>\n</VTKFile>\n")


appended("appended-raw.vtu", "raw", False, False)
appended("appended-raw-zlib.vtu", "raw", True, False)
appended("appended-base64.vtu", "base64", False, False)
appended("appended-base64-zlib.vtu", "base64", True, False)
appended("appended-raw-bigendian.vtu", "raw", False, True)

names = ["binary-uint32.vtu", "ascii.vtu", "binary-uint64.vtu", "binary-zlib.vtu", "appended-raw.vtu", "appended-raw-zlib.vtu",
         "appended-base64.vtu", "appended-base64-zlib.vtu", "appended-raw-bigendian.vtu"]
ref = None
for nm in names:
    m = meshio.read(nm)
    view = {
        "points": m.points.tolist(),
        "tets": m.get_cells_type("tetra").tolist(),
        "fields": {k: np.asarray(v, dtype=np.float64).reshape(n, -1).tolist() for k, v in sorted(m.point_data.items())},
    }
    if ref is None:
        ref = view
    if nm == "ascii.vtu":
        # meshio prints 12 significant digits: equal to 1e-12, relative
        assert view["tets"] == ref["tets"]
        assert np.allclose(view["points"], ref["points"], rtol=1e-12, atol=0)
        for k in ref["fields"]:
            assert np.allclose(view["fields"][k], ref["fields"][k], rtol=1e-11, atol=0), k
    else:
        assert view == ref, f"meshio reads {nm} differently"
    print("meshio reads", nm, "OK")
# Floats as repr() strings: exact, and parsed exactly by Rust's str::parse
# (serde_json's default float parsing is not always correctly rounded).
exact = lambda rows: [[repr(float(x)) for x in r] for r in rows]
ref = {"points": exact(ref["points"]), "tets": ref["tets"], "fields": {k: exact(v) for k, v in ref["fields"].items()}}
with open("expected.json", "w") as f:
    json.dump({"files": names, **ref}, f, indent=1)
