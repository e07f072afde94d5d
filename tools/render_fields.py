"""Renders one time of a run's fields.xdmf to a PNG with ParaView (pvpython): particles as spheres of their radius
coloured by contact force, the structure coloured by von Mises stress, walls and boxes translucent.

usage: tools/virtual_display.sh pvpython tools/render_fields.py RUN_DIR PNG [TIME]   (TIME: simulated s, default the last)
Debian's ParaView renders through X: tools/virtual_display.sh runs it on a private Xvfb display (no screen needed).
"""
import os
import sys

from paraview import servermanager
from paraview.simple import (ColorBy, GetActiveViewOrCreate, GetColorTransferFunction, GetScalarBar, Render,
                             SaveScreenshot, Show, TrivialProducer, XDMFReader)


def blocks_at(path, time=None):
    """(time, {grid name: VTK data set}) of fields.xdmf at `time` (default: the last snapshot)."""
    reader = XDMFReader(FileNames=[path])
    times = list(reader.TimestepValues)
    time = times[-1] if time is None else min(times, key=lambda t: abs(t - time))
    reader.UpdatePipeline(time)
    data = servermanager.Fetch(reader)
    blocks = {}
    iterator = data.NewIterator()
    iterator.InitTraversal()
    while not iterator.IsDoneWithTraversal():
        # The XDMF reader names a block after its grid and the time index: "particles[19]".
        blocks[iterator.GetCurrentMetaData().Get(data.NAME()).split("[")[0]] = iterator.GetCurrentDataObject()
        iterator.GoToNextItem()
    return time, times, blocks


def _show(block, view):
    source = TrivialProducer()
    source.GetClientSideObject().SetOutput(block)
    return source, Show(source, view)


def _legend(display, view, array, preset=None):
    """Colours `display` by the point array, with a dark legend on the white background."""
    ColorBy(display, ("POINTS", array))
    lut = GetColorTransferFunction(array)
    if preset:
        lut.ApplyPreset(preset, True)
    bar = GetScalarBar(lut, view)
    bar.TitleColor = bar.LabelColor = [0.1, 0.1, 0.1]
    display.SetScalarBarVisibility(view, True)


def render(path, png, time=None, size=(1200, 700)):
    """Renders fields.xdmf at `time` into `png`; returns the time shown."""
    time, _, blocks = blocks_at(path, time)
    view = GetActiveViewOrCreate("RenderView")
    view.ViewSize = list(size)
    view.UseColorPaletteForBackground = 0
    view.Background = [1, 1, 1]
    view.OrientationAxesVisibility = 0
    if "particles" in blocks:
        _, display = _show(blocks["particles"], view)
        display.SetRepresentationType("Point Gaussian")
        display.ScaleByArray = 1
        display.SetScaleArray = ["POINTS", "radius"]
        display.ScaleTransferFunction.Points = [0, 0, 0.5, 0, 1, 1, 0.5, 0]  # scale = radius (identity map)
        display.GaussianRadius = 1.0
        display.ShaderPreset = "Sphere"
        _legend(display, view, "contact_force", "Inferno (matplotlib)")
    if "structure" in blocks:
        _, display = _show(blocks["structure"], view)
        _legend(display, view, "von_mises")
    for name in ("walls", "boxes"):
        if name in blocks:
            _, display = _show(blocks[name], view)
            display.Opacity = 0.25 if name == "walls" else 0.8
    # z up, seen from the front-left and above (the scenes' gravity is -z).
    view.CameraViewUp = [0, 0, 1]
    view.CameraFocalPoint = [0, 0, 0]
    view.CameraPosition = [-0.5, -1.0, 0.55]
    view.ResetCamera()
    Render(view)
    SaveScreenshot(png, view, ImageResolution=list(size))
    return time


if __name__ == "__main__":
    run, png = sys.argv[1], sys.argv[2]
    shown = render(os.path.join(run, "fields.xdmf"), png, float(sys.argv[3]) if len(sys.argv) > 3 else None)
    print(f"rendered t = {shown:g} s -> {png}")
    sys.stdout.flush()
    # Debian's VTK may fail to release the GLX context at interpreter exit under Xvfb; the PNG is written.
    os._exit(0)
