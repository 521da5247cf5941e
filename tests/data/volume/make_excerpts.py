#!/usr/bin/env python3
"""Writes a 32^3 crop of ../shared/data/mni152_t1.raw (x 80..111, y 100..131,
z 80..111; uint8, 1 mm, origin = (-98,-134,-72) + (80,100,80)) in three formats,
independently of pvrsim (standard library only). Run in tests/data/volume/."""
import base64, gzip, struct, sys

SRC = "../../../../shared/data/mni152_t1.raw"
NX, NY, NZ = 197, 233, 189
X0, Y0, Z0, N = 80, 100, 80, 32
raw = open(SRC, "rb").read()
crop = bytearray()
for k in range(Z0, Z0 + N):
    for j in range(Y0, Y0 + N):
        s = X0 + NX * (j + NY * k)
        crop += raw[s:s + N]
crop = bytes(crop)
org = (-98 + X0, -134 + Y0, -72 + Z0)

# NRRD, detached header + gzip data.
open("mni-crop.nhdr", "w").write(
    "NRRD0004\n# 32^3 crop of mni152_t1 (see README.md)\ntype: uint8\ndimension: 3\n"
    "space: RAS\nsizes: 32 32 32\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n"
    "kinds: domain domain domain\nencoding: gzip\n"
    f"space origin: ({org[0]},{org[1]},{org[2]})\ndata file: mni-crop.raw.gz\n")
open("mni-crop.raw.gz", "wb").write(gzip.compress(crop, mtime=0))

# NIfTI-1 single file, sform axis-aligned, gzip.
h = bytearray(348)
struct.pack_into("<i", h, 0, 348)
struct.pack_into("<8h", h, 40, 3, N, N, N, 1, 1, 1, 1)
struct.pack_into("<hh", h, 70, 2, 8)            # datatype uint8, bitpix 8
struct.pack_into("<8f", h, 76, 1, 1, 1, 1, 1, 1, 1, 1)
struct.pack_into("<f", h, 108, 352.0)           # vox_offset
struct.pack_into("<ff", h, 112, 1.0, 0.0)       # scl_slope, scl_inter
struct.pack_into("<hh", h, 252, 0, 2)           # qform_code, sform_code
struct.pack_into("<4f", h, 280, 1, 0, 0, org[0])
struct.pack_into("<4f", h, 296, 0, 1, 0, org[1])
struct.pack_into("<4f", h, 312, 0, 0, 1, org[2])
h[344:348] = b"n+1\0"
open("mni-crop.nii.gz", "wb").write(gzip.compress(bytes(h) + b"\0" * 4 + crop, mtime=0))

# VTK XML ImageData, inline base64 with a UInt32 length header, extent offset
# so the origin is carried by the extent (Origin + Extent_lo * Spacing).
b64 = base64.b64encode(struct.pack("<I", len(crop)) + crop).decode()
open("mni-crop.vti", "w").write(
    '<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" header_type="UInt32">\n'
    f'  <ImageData WholeExtent="{X0} {X0+N-1} {Y0} {Y0+N-1} {Z0} {Z0+N-1}" Origin="-98 -134 -72" Spacing="1 1 1">\n'
    f'  <Piece Extent="{X0} {X0+N-1} {Y0} {Y0+N-1} {Z0} {Z0+N-1}">\n    <PointData Scalars="t1">\n'
    f'      <DataArray type="UInt8" Name="t1" format="binary">{b64}</DataArray>\n'
    '    </PointData>\n  </Piece>\n  </ImageData>\n</VTKFile>\n')
print("crop bytes", len(crop), "sum", sum(crop), "nonzero", sum(1 for b in crop if b))
