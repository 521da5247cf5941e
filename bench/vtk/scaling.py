"""One point of the scaling benchmark for VTK's unstructured-grid ray caster
(vtkUnstructuredGridVolumeRayCastMapper, the mapper render_ugrid.py times):
reads the mesh of a pvrsim demo scene, renders SIZE x SIZE off-screen with the
scene's camera and transfer function, and prints one CSV row:

    cells,image,threads,load_s,first_frame_s,frame_s,peak_rss_bytes,bytes_per_tet

load_s = vtkUnstructuredGridReader; first_frame_s = the first Render() (the
mapper's set-up, e.g. face lists, plus one frame); frame_s = the median of
REPEATS further frames; peak RSS from getrusage (this process only).

    PY bench/vtk/scaling.py SCENE.toml SIZE THREADS REPEATS
"""

import os, resource, statistics, sys, time, tomllib
import vtk

scene, size, threads, reps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
cfg = tomllib.load(open(scene, 'rb'))
d = os.path.dirname(scene)
t0 = time.perf_counter()
r = vtk.vtkUnstructuredGridReader(); r.SetFileName(os.path.join(d, cfg['data']['path'])); r.ReadAllScalarsOn(); r.Update()
load_s = time.perf_counter() - t0
ug = r.GetOutput(); ug.GetPointData().SetActiveScalars(cfg['data']['field'])
tf = cfg['transfer']
ctf = vtk.vtkColorTransferFunction(); otf = vtk.vtkPiecewiseFunction()
for s, R, G, B, o in tf['points']:
    ctf.AddRGBPoint(s, R, G, B); otf.AddPoint(s, o)
prop = vtk.vtkVolumeProperty(); prop.SetColor(ctf); prop.SetScalarOpacity(otf)
prop.SetScalarOpacityUnitDistance(tf['unit_distance']); prop.ShadeOff(); prop.SetInterpolationTypeToLinear()
m = vtk.vtkUnstructuredGridVolumeRayCastMapper(); m.SetNumberOfThreads(threads); m.SetInputData(ug)
vol = vtk.vtkVolume(); vol.SetMapper(m); vol.SetProperty(prop)
ren = vtk.vtkRenderer(); ren.AddVolume(vol); ren.SetBackground(*cfg['image'].get('background', [0, 0, 0]))
win = vtk.vtkRenderWindow(); win.SetOffScreenRendering(1); win.AddRenderer(ren); win.SetSize(size, size)
c = cfg['camera']; cam = ren.GetActiveCamera()
cam.SetPosition(*c['eye']); cam.SetFocalPoint(*c['target']); cam.SetViewUp(*c['up'])
if c.get('projection') == 'orthographic':
    cam.ParallelProjectionOn(); cam.SetParallelScale(c['height'] / 2)
ren.ResetCameraClippingRange()
t0 = time.perf_counter(); win.Render(); first = time.perf_counter() - t0
ts = []
for _ in range(reps):
    vol.Modified(); t0 = time.perf_counter(); win.Render(); ts.append(time.perf_counter() - t0)
frame = statistics.median(ts) if ts else float('nan')
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
n = ug.GetNumberOfCells()
print(f"{n},{size},{threads},{load_s:.4f},{first:.4f},{frame:.4f},{rss},{rss / n:.2f}")
