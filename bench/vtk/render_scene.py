#!/usr/bin/env python3
"""Render a pvrsim grid scene with VTK's CPU ray caster and time it.

VTK's `vtkFixedPointVolumeRayCastMapper` is the peer the grid issue names
(the shared data README quotes its times). This script maps the scene
contract (../shared/spec/scene.md) onto VTK as the contract says VTK reads it:
same camera (orthographic height -> parallel scale height/2, perspective
fov_y -> view angle), image size, background, a colour and an opacity
transfer function over range[0] + s_norm * (range[1] - range[0]),
`unit_distance` -> ScalarOpacityUnitDistance, trilinear interpolation, no
shading. The volume is read by this script (NRRD .nhdr/.nrrd raw or gzip,
NIfTI-1 .nii/.nii.gz with an axis-aligned sform), placed in world space as
pvrsim places it (origin + index * spacing; a negative axis is flipped).

Writes the image as a float RGB .npy-free raw file (f32 little endian,
width*height*3, rows top to bottom) and as PNG, and prints the median wall
time of `--repeats` renders (after one warm-up) as JSON.

    xvfb-run -a python3 bench/vtk/render_scene.py SCENE.toml --out vtk \\
        --threads 2 --sample-distance 0.25 --repeats 5

Needs `pip install vtk numpy pillow` and an X server (xvfb-run) or an
offscreen VTK build. Not part of the test suite.
"""
import argparse
import gzip
import json
import os
import statistics
import struct
import sys
import time
import tomllib

import numpy as np

NRRD_TYPES = {
    "uchar": np.uint8, "unsigned char": np.uint8, "uint8": np.uint8, "uint8_t": np.uint8,
    "short": np.int16, "int16": np.int16, "int16_t": np.int16, "signed short": np.int16,
    "ushort": np.uint16, "unsigned short": np.uint16, "uint16": np.uint16, "uint16_t": np.uint16,
    "float": np.float32,
}
NIFTI_TYPES = {2: np.uint8, 4: np.int16, 512: np.uint16, 16: np.float32, 8: np.int32, 64: np.float64}


def read_nrrd(path):
    with open(path, "rb") as f:
        raw = f.read()
    head, _, body = raw.partition(b"\n\n")
    fields = {}
    for line in head.decode("latin-1").splitlines()[1:]:
        if line.startswith("#") or ":" not in line:
            continue
        k, v = line.split(":", 1)
        fields[k.strip().lower()] = v.strip().lstrip("=").strip()
    sizes = [int(x) for x in fields["sizes"].split()]
    dtype = NRRD_TYPES[fields["type"].lower()]
    if "data file" in fields or "datafile" in fields:
        name = fields.get("data file", fields.get("datafile"))
        with open(os.path.join(os.path.dirname(path), name), "rb") as f:
            body = f.read()
    if fields.get("encoding", "raw") in ("gzip", "gz"):
        body = gzip.decompress(body)
    endian = "<" if fields.get("endian", "little") == "little" else ">"
    a = np.frombuffer(body, dtype=np.dtype(dtype).newbyteorder(endian), count=int(np.prod(sizes)))
    spacing = [1.0, 1.0, 1.0]
    origin = [0.0, 0.0, 0.0]
    if "space directions" in fields:
        dirs = [d.strip("() ").split(",") for d in fields["space directions"].split(")")[:3]]
        dirs = [[float(x) for x in d] for d in dirs]
        spacing = [dirs[i][i] for i in range(3)]
        for i in range(3):
            for j in range(3):
                if i != j and abs(dirs[i][j]) > 1e-9:
                    sys.exit(f"{path}: space directions are not axis-aligned")
    elif "spacings" in fields:
        spacing = [float(x) for x in fields["spacings"].split()]
    if "space origin" in fields:
        origin = [float(x) for x in fields["space origin"].strip("()").split(",")]
    return a.reshape(sizes[::-1]), spacing, origin


def read_nifti(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rb") as f:
        raw = f.read()
    endian = "<" if struct.unpack("<i", raw[0:4])[0] == 348 else ">"
    dim = struct.unpack(endian + "8h", raw[40:56])
    datatype = struct.unpack(endian + "h", raw[70:72])[0]
    vox_offset = int(struct.unpack(endian + "f", raw[108:112])[0])
    slope, inter = struct.unpack(endian + "2f", raw[112:120])
    sform_code = struct.unpack(endian + "h", raw[254:256])[0]
    srow = [struct.unpack(endian + "4f", raw[280 + 16 * r: 296 + 16 * r]) for r in range(3)]
    pixdim = struct.unpack(endian + "8f", raw[76:108])
    sizes = list(dim[1:4])
    a = np.frombuffer(raw[vox_offset:], dtype=np.dtype(NIFTI_TYPES[datatype]).newbyteorder(endian),
                      count=int(np.prod(sizes))).reshape(sizes[::-1])
    if slope not in (0.0, 1.0) or inter != 0.0:
        a = a.astype(np.float32) * (slope or 1.0) + inter
    if sform_code > 0:
        spacing = [srow[i][i] for i in range(3)]
        origin = [srow[i][3] for i in range(3)]
    else:
        spacing = list(pixdim[1:4])
        origin = [0.0, 0.0, 0.0]
    return a, spacing, origin


def place(a, spacing, origin):
    """Flip negative axes so that the spacing is positive (as pvrsim does)."""
    a = np.array(a)
    for axis in range(3):  # axis 0 = x = last numpy axis
        if spacing[axis] < 0:
            n = a.shape[2 - axis]
            origin[axis] = origin[axis] + spacing[axis] * (n - 1)
            spacing[axis] = -spacing[axis]
            a = np.flip(a, axis=2 - axis)
    return np.ascontiguousarray(a), spacing, origin


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--out", default="vtk")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--sample-distance", type=float, default=0.25)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--size", type=int, default=0, help="override the image size (square)")
    args = ap.parse_args()

    import vtk
    from vtk.util import numpy_support

    with open(args.scene, "rb") as f:
        sc = tomllib.load(f)
    data_path = os.path.join(os.path.dirname(os.path.abspath(args.scene)), sc["data"]["path"])
    if data_path.endswith((".nii", ".nii.gz")):
        a, spacing, origin = read_nifti(data_path)
    elif data_path.endswith((".nhdr", ".nrrd")):
        a, spacing, origin = read_nrrd(data_path)
    else:
        sys.exit(f"{data_path}: this script reads NRRD and NIfTI only")
    a, spacing, origin = place(a, list(spacing), list(origin))
    lo, hi = sc["data"].get("range", [float(a.min()), float(a.max())])

    img = vtk.vtkImageData()
    img.SetDimensions(a.shape[2], a.shape[1], a.shape[0])
    img.SetSpacing(*spacing)
    img.SetOrigin(*origin)
    arr = numpy_support.numpy_to_vtk(a.ravel(order="C"), deep=True)
    img.GetPointData().SetScalars(arr)

    tf = sc["transfer"]
    col = vtk.vtkColorTransferFunction()
    op = vtk.vtkPiecewiseFunction()
    for s, r, g, b, o in tf["points"]:
        x = lo + s * (hi - lo)
        col.AddRGBPoint(x, r, g, b)
        op.AddPoint(x, o)
    prop = vtk.vtkVolumeProperty()
    prop.SetColor(col)
    prop.SetScalarOpacity(op)
    prop.SetScalarOpacityUnitDistance(tf["unit_distance"])
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOff()

    mapper = vtk.vtkFixedPointVolumeRayCastMapper()
    mapper.SetInputData(img)
    mapper.SetNumberOfThreads(args.threads)
    mapper.AutoAdjustSampleDistancesOff()
    mapper.SetSampleDistance(args.sample_distance)
    mapper.SetImageSampleDistance(1.0)
    vol = vtk.vtkVolume()
    vol.SetMapper(mapper)
    vol.SetProperty(prop)

    w, h = sc["image"]["width"], sc["image"]["height"]
    if args.size:
        w = h = args.size
    ren = vtk.vtkRenderer()
    ren.AddVolume(vol)
    ren.SetBackground(*sc["image"].get("background", [0, 0, 0]))
    cam = ren.GetActiveCamera()
    c = sc["camera"]
    cam.SetPosition(*c["eye"])
    cam.SetFocalPoint(*c["target"])
    cam.SetViewUp(*c["up"])
    if c["projection"] == "orthographic":
        cam.ParallelProjectionOn()
        cam.SetParallelScale(c["height"] / 2.0)
    else:
        cam.SetViewAngle(c["fov_y_deg"])
    ren.ResetCameraClippingRange()
    rw = vtk.vtkRenderWindow()
    rw.SetOffScreenRendering(1)
    rw.SetSize(w, h)
    rw.AddRenderer(ren)

    rw.Render()  # warm-up (builds the mapper's tables)
    times = []
    for _ in range(args.repeats):
        t = time.perf_counter()
        rw.Modified()
        vol.Modified()
        rw.Render()
        times.append(time.perf_counter() - t)

    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(rw)
    grab.SetInputBufferTypeToRGB()
    grab.ReadFrontBufferOff()
    grab.Update()
    out = grab.GetOutput()
    px = numpy_support.vtk_to_numpy(out.GetPointData().GetScalars()).reshape(h, w, 3)
    px = np.flipud(px)  # VTK rows run bottom to top
    from PIL import Image
    Image.fromarray(px.astype(np.uint8)).save(args.out + ".png")
    print(json.dumps({
        "scene": args.scene, "width": w, "height": h, "threads": args.threads,
        "sample_distance": args.sample_distance, "repeats": args.repeats,
        "median_ms": 1000 * statistics.median(times), "min_ms": 1000 * min(times),
        "png": args.out + ".png",
    }))


if __name__ == "__main__":
    main()
