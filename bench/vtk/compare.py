#!/usr/bin/env python3
"""max-abs and RMSE (in 1/255) between two 8-bit RGB PNGs of the same size.

    python3 bench/vtk/compare.py A.png B.png
"""
import sys

import numpy as np
from PIL import Image

a = np.asarray(Image.open(sys.argv[1]).convert("RGB"), dtype=np.float64)
b = np.asarray(Image.open(sys.argv[2]).convert("RGB"), dtype=np.float64)
if a.shape != b.shape:
    sys.exit(f"sizes differ: {a.shape} vs {b.shape}")
d = a - b
print(f"max {np.abs(d).max():.2f} rmse {np.sqrt((d * d).mean()):.3f} mean {d.mean():+.3f}")
