"""Times VTK's unstructured-grid volume mappers on an aorta scene (issue 21's peer):
vtkUnstructuredGridVolumeRayCastMapper (Bunyk, N threads) or
vtkUnstructuredGridVolumeZSweepMapper, camera, image size and transfer function from
the scene TOML, off-screen; prints the median of REPEATS frames after one warm-up frame.

    PY bench/vtk/render_ugrid.py SCENE.toml raycast|zsweep THREADS REPEATS [OUT.png]
"""

import sys, time, statistics, tomllib, os
import vtk
scene = sys.argv[1]; mapper_name = sys.argv[2]; threads = int(sys.argv[3]); reps = int(sys.argv[4])
cfg = tomllib.load(open(scene, 'rb'))
d = os.path.dirname(scene)
r = vtk.vtkUnstructuredGridReader(); r.SetFileName(os.path.join(d, cfg['data']['path'])); r.ReadAllScalarsOn(); r.Update()
ug = r.GetOutput(); ug.GetPointData().SetActiveScalars(cfg['data']['field'])
tf = cfg['transfer']; ud = tf['unit_distance']
ctf = vtk.vtkColorTransferFunction(); otf = vtk.vtkPiecewiseFunction()
for s, R, G, B, o in tf['points']:
    ctf.AddRGBPoint(s, R, G, B); otf.AddPoint(s, o)
prop = vtk.vtkVolumeProperty(); prop.SetColor(ctf); prop.SetScalarOpacity(otf); prop.SetScalarOpacityUnitDistance(ud); prop.ShadeOff(); prop.SetInterpolationTypeToLinear()
if mapper_name == 'raycast':
    m = vtk.vtkUnstructuredGridVolumeRayCastMapper(); m.SetNumberOfThreads(threads)
else:
    m = vtk.vtkUnstructuredGridVolumeZSweepMapper()
m.SetInputData(ug)
vol = vtk.vtkVolume(); vol.SetMapper(m); vol.SetProperty(prop)
ren = vtk.vtkRenderer(); ren.AddVolume(vol); ren.SetBackground(*cfg['image'].get('background', [0, 0, 0]))
win = vtk.vtkRenderWindow(); win.SetOffScreenRendering(1); win.AddRenderer(ren)
win.SetSize(cfg['image']['width'], cfg['image']['height'])
c = cfg['camera']; cam = ren.GetActiveCamera()
cam.SetPosition(*c['eye']); cam.SetFocalPoint(*c['target']); cam.SetViewUp(*c['up'])
if c.get('projection') == 'orthographic':
    cam.ParallelProjectionOn(); cam.SetParallelScale(c['height'] / 2)
ren.ResetCameraClippingRange()
win.Render()  # first frame: set-up
ts = []
for _ in range(reps):
    vol.Modified(); t0 = time.perf_counter(); win.Render(); ts.append((time.perf_counter() - t0) * 1e3)
print(mapper_name, threads, 'median_ms', round(statistics.median(ts), 1), 'all', [round(t, 1) for t in ts])
if len(sys.argv) > 5:
    w2i = vtk.vtkWindowToImageFilter(); w2i.SetInput(win); w2i.ReadFrontBufferOff(); w2i.Update()
    wr = vtk.vtkPNGWriter(); wr.SetFileName(sys.argv[5]); wr.SetInputConnection(w2i.GetOutputPort()); wr.Write()
