"""Render frames of a swarmsim XDMF export to PNG images with ParaView, without a display.

    swarmsim export OUT.h5 --format xdmf             # OUT.xmf2 beside OUT.h5
    pvbatch scripts/paraview_render.py OUT.xmf2 -o frames/OUT.%04d.png [--frames A:B]
            [--size W H] [--point-size PX] [--view 3d|xy|xz|yz]

(pvbatch is in Debian's package paraview. Debian's ParaView renders through X: on a machine without a
display run it as `xvfb-run -a pvbatch ...`, Debian's packages xvfb and xauth.)
It opens the .xmf2 as the GUI's File > Open does (OpenDataFile: the XDMF Reader), splits the swarms from
the obstacles (the swarm attribute exists only on swarm points), draws the obstacles as grey surfaces and
the insects as points coloured by their swarm, fits the camera once to the scene over the rendered frames
and writes one PNG per frame. The file name's %d-style field (e.g. %04d) is the HDF5 frame number, so
image N is HDF5 frame N whatever --frames chose: render-farm nodes can each render their own range into one
folder (docs/tools.md#render-farms). Without a %d field only one frame may be rendered.
Frames A:B are HDF5 frames A..B-1 (Python slice style; default: all). Exit code 2 for bad arguments or
an input ParaView cannot read.
"""
import argparse
import os
import sys

from paraview.simple import (ColorBy, GetActiveViewOrCreate, GetColorTransferFunction, OpenDataFile, Render,
                             ResetCamera, SaveScreenshot, Show, Threshold)
from paraview import servermanager as sm


def fail(msg):
    print("paraview_render.py: error: %s" % msg, file=sys.stderr)
    sys.exit(2)


def frame_range(text, count):
    parts = text.split(":")
    if len(parts) != 2:
        fail("--frames: expected A:B (HDF5 frames A..B-1), got '%s'" % text)
    try:
        a, b = (int(p) if p.strip() else None for p in parts)
    except ValueError:
        fail("--frames: expected integers in A:B, got '%s'" % text)
    return range(*slice(a, b).indices(count))


def main(argv):
    p = argparse.ArgumentParser(prog="paraview_render.py",
                                description="Render frames of a swarmsim XDMF export (.xmf2) to PNG with ParaView.")
    p.add_argument("xmf", help="the .xmf2 (or .xmf) written by `swarmsim export OUT.h5 --format xdmf`")
    p.add_argument("-o", "--output", required=True, metavar="PATTERN",
                   help="PNG path; a %%d field (e.g. frames/run.%%04d.png) takes the HDF5 frame number")
    p.add_argument("--frames", default="", metavar="A:B", help="HDF5 frames A..B-1 (default: all)")
    p.add_argument("--size", type=int, nargs=2, default=[960, 540], metavar=("W", "H"),
                   help="image size in pixels (default: 960 540)")
    p.add_argument("--point-size", type=float, default=3.0, metavar="PX", help="insect size in pixels (default: 3)")
    p.add_argument("--view", choices=["3d", "xy", "xz", "yz"], default="3d",
                   help="camera: a 3-D view from the front left, or looking down an axis (default: 3d)")
    args = p.parse_args(argv)
    if not os.path.isfile(args.xmf):
        fail("%s: no such file" % args.xmf)
    if args.size[0] <= 0 or args.size[1] <= 0:
        fail("--size: expected two positive integers")

    reader = OpenDataFile(args.xmf)
    if reader is None:
        fail("%s: ParaView has no reader for this file" % args.xmf)
    times = list(reader.TimestepValues) if reader.TimestepValues else [0.0]
    frames = frame_range(args.frames, len(times)) if args.frames else range(len(times))
    if len(frames) == 0:
        fail("--frames %s selects no frames (the file has %d: 0..%d)" % (args.frames, len(times), len(times) - 1))
    try:
        named = args.output % 0
        patterned = named != args.output
    except TypeError:
        patterned = False
    if not patterned and len(frames) > 1:
        fail("-o %s: no %%d field for the frame number, and %d frames to render" % (args.output, len(frames)))

    # swarm points carry the point attribute "swarm" (0, 1, ...); obstacle meshes do not: a threshold on it
    # keeps the insects, and the obstacles are the triangles (cells of more than one point)
    reader.UpdatePipeline(times[frames[0]])
    data = sm.Fetch(reader)
    swarm_count = 0
    it = data.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        arr = it.GetCurrentDataObject().GetPointData().GetArray("swarm")
        if arr is not None and arr.GetNumberOfTuples() > 0:
            swarm_count = max(swarm_count, int(arr.GetRange()[1]) + 1)
        it.GoToNextItem()

    view = GetActiveViewOrCreate("RenderView")
    view.ViewSize = list(args.size)
    view.OrientationAxesVisibility = 1
    view.Background = [1.0, 1.0, 1.0]
    try:
        view.UseColorPaletteForBackground = 0  # ParaView 5.10+: else the palette's background wins
    except AttributeError:
        pass

    scene = Show(reader, view)  # everything, for the obstacles: a grey translucent surface
    scene.ColorArrayName = ["POINTS", ""]
    scene.AmbientColor = scene.DiffuseColor = [0.62, 0.62, 0.62]
    scene.Opacity = 0.55
    scene.PointSize = 1.0  # the swarms' own points, grey, lie under the coloured insects
    insects = Threshold(Input=reader)
    insects.Scalars = ["POINTS", "swarm"]
    try:
        insects.LowerThreshold, insects.UpperThreshold = -0.5, max(swarm_count, 1) - 0.5
    except AttributeError:  # older ParaView: ThresholdRange
        insects.ThresholdRange = [-0.5, max(swarm_count, 1) - 0.5]
    dots = Show(insects, view)
    dots.SetRepresentationType("Points")
    dots.PointSize = args.point_size
    dots.RenderPointsAsSpheres = 1
    ColorBy(dots, ("POINTS", "swarm"))
    lut = GetColorTransferFunction("swarm")
    lut.InterpretValuesAsCategories = 1
    palette = [(0.12, 0.47, 0.71), (1.0, 0.50, 0.05), (0.17, 0.63, 0.17), (0.84, 0.15, 0.16),
               (0.58, 0.40, 0.74), (0.55, 0.34, 0.29)]
    lut.Annotations = sum(([str(k), "swarm %d" % k] for k in range(max(swarm_count, 1))), [])
    lut.IndexedColors = sum((list(palette[k % len(palette)]) for k in range(max(swarm_count, 1))), [])
    dots.SetScalarBarVisibility(view, False)

    # one camera for every frame: fitted to the first rendered frame's scene
    view.ViewTime = times[frames[0]]
    direction = {"3d": ([-1.0, -1.6, 0.8], [0, 0, 1]), "xy": ([0, 0, 1], [0, 1, 0]),
                 "xz": ([0, -1, 0], [0, 0, 1]), "yz": ([1, 0, 0], [0, 0, 1])}[args.view]
    view.CameraPosition = direction[0]
    view.CameraFocalPoint = [0, 0, 0]
    view.CameraViewUp = direction[1]
    ResetCamera(view)
    view.GetActiveCamera().Dolly(1.35)  # ResetCamera leaves a wide margin around the scene
    folder = os.path.dirname(os.path.abspath(args.output % frames[0] if patterned else args.output))
    os.makedirs(folder, exist_ok=True)
    for f in frames:
        view.ViewTime = times[f]
        Render(view)
        target = args.output % f if patterned else args.output
        tmp = os.path.join(os.path.dirname(os.path.abspath(target)), "." + os.path.basename(target) + ".part.png")
        SaveScreenshot(tmp, view, ImageResolution=list(args.size))
        os.replace(tmp, target)  # a node that dies mid-frame leaves no half-written image under its name
    print("paraview_render.py: %d frames (%d..%d) -> %s" % (len(frames), frames[0], frames[-1], args.output))


if __name__ == "__main__":
    main(sys.argv[1:])
