# Renders an mpmrom output (the XDMF side file of a snapshot or of a ROM file with decoded fields) with ParaView:
# the last frame as NAME.png, every frame as NAME_frames/frame_NNN.png and an animated NAME.gif, points as spheres
# coloured by displacement |x - X|, on the same camera and colour range throughout. Run by scripts/render.sh
# (pvbatch under a virtual X server).
import argparse
import math
import os
import sys

from paraview import servermanager
from paraview.simple import (Calculator, ColorBy, CreateView, GetColorTransferFunction, GetScalarBar, Render,
                             SaveScreenshot, Show, Text, XDMFReader)


def arguments():
    parser = argparse.ArgumentParser(description="Render an mpmrom XDMF output to PNG images and a GIF")
    parser.add_argument("xmf", help="snapshot or ROM side file (.xmf)")
    parser.add_argument("--out", required=True, help="directory for NAME.png, NAME_frames/ and NAME.gif")
    parser.add_argument("--name", help="output name (default: the input's)")
    parser.add_argument("--title", default="", help="text over the picture (default: the file name)")
    parser.add_argument("--rollout", type=int, default=0, help="ROM files: the rollout to show (default 0)")
    parser.add_argument("--size", default="960x720", help="image size WxH")
    parser.add_argument("--max-frames", type=int, default=48, help="at most this many frames in the animation")
    parser.add_argument("--gif-width", type=int, default=480, help="width of the GIF's frames (pixels)")
    return parser.parse_args()


def main():
    args = arguments()
    if not os.path.isfile(args.xmf):
        sys.exit("render: error: %s: no such file" % args.xmf)
    name = args.name or os.path.splitext(os.path.basename(args.xmf))[0]
    width, height = (int(v) for v in args.size.split("x"))
    reader = XDMFReader(FileNames=[os.path.abspath(args.xmf)])
    grids = list(reader.GetProperty("GridInfo")[::2]) if reader.GetProperty("GridInfo") else []
    rollouts = sorted({g.split(" (")[0] for g in grids if g.startswith("rollout ")})
    if rollouts:  # a ROM file: one block per rollout and frame; keep the rollout asked for
        prefix = "rollout %d (" % args.rollout
        chosen = [g for g in grids if g.startswith(prefix)]
        if not chosen:
            sys.exit("render: error: %s has %d rollouts; no rollout %d" % (args.xmf, len(rollouts), args.rollout))
        reader.GridStatus = chosen
    times = list(reader.TimestepValues) if reader.TimestepValues else [0.0]
    if len(times) > args.max_frames:  # evenly spaced, the last one included
        times = [times[round(i * (len(times) - 1) / (args.max_frames - 1))] for i in range(args.max_frames)]

    displacement = Calculator(Input=reader, ResultArrayName="displacement", Function="mag(coords - X)")
    # One camera and one colour range for every frame: from the bounds and values over all of them.
    bounds = [math.inf, -math.inf] * 3
    largest = 0.0
    for t in times:
        displacement.UpdatePipeline(t)
        info = displacement.GetDataInformation()
        b = info.GetBounds()
        for d in range(3):
            bounds[2 * d] = min(bounds[2 * d], b[2 * d])
            bounds[2 * d + 1] = max(bounds[2 * d + 1], b[2 * d + 1])
        largest = max(largest, displacement.PointData["displacement"].GetRange()[1])
    points = max(1, info.GetNumberOfPoints())
    extent = [bounds[2 * d + 1] - bounds[2 * d] for d in range(3)]
    volume = max(extent[0], 1e-9) * max(extent[1], 1e-9) * max(extent[2], 1e-9)
    radius = 0.45 * (volume / points) ** (1.0 / 3.0)

    view = CreateView("RenderView")
    view.ViewSize = [width, height]
    view.Background = [1.0, 1.0, 1.0]
    if hasattr(view, "UseColorPaletteForBackground"):
        view.UseColorPaletteForBackground = 0
    view.OrientationAxesVisibility = 1
    shown = Show(displacement, view)
    shown.SetRepresentationType("Point Gaussian")
    shown.GaussianRadius = radius
    ColorBy(shown, ("POINTS", "displacement"))
    colors = GetColorTransferFunction("displacement")
    colors.ApplyPreset("Viridis (matplotlib)", True)
    colors.RescaleTransferFunction(0.0, max(largest, 1e-12))
    colors.AutomaticRescaleRangeMode = "Never"
    bar = GetScalarBar(colors, view)
    bar.Title = "displacement |x - X| (m)"
    bar.ComponentTitle = ""
    bar.TitleColor = bar.LabelColor = [0.1, 0.1, 0.1]
    bar.Visibility = 1
    label = Text()
    label_shown = Show(label, view)
    label_shown.Color = [0.1, 0.1, 0.1]
    label_shown.WindowLocation = "Upper Left Corner"
    label_shown.FontSize = 14

    center = [(bounds[2 * d] + bounds[2 * d + 1]) / 2 for d in range(3)]
    diagonal = math.sqrt(sum(e * e for e in extent))
    view.CameraFocalPoint = center
    view.CameraPosition = [center[0] + 1.6 * diagonal, center[1] - 1.2 * diagonal, center[2] + 1.0 * diagonal]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    view.CameraParallelProjection = 0

    title = args.title or os.path.basename(args.xmf)
    frames_dir = os.path.join(args.out, name + "_frames")
    os.makedirs(frames_dir, exist_ok=True)
    frame_files = []
    for k, t in enumerate(times):
        view.ViewTime = t
        label.Text = "%s\nt = %.4f s" % (title, t)
        Render(view)
        path = os.path.join(frames_dir, "frame_%03d.png" % k)
        SaveScreenshot(path, view, ImageResolution=[width, height])
        frame_files.append(path)
    final = os.path.join(args.out, name + ".png")
    SaveScreenshot(final, view, ImageResolution=[width, height])
    try:
        from PIL import Image
    except ImportError:
        print("render: wrote %s and %d frames (no GIF: python3-pil is missing)" % (final, len(frame_files)))
        return
    gif_size = (args.gif_width, round(args.gif_width * height / width))
    images = [Image.open(f).convert("RGB").resize(gif_size, Image.LANCZOS).convert("P", palette=Image.ADAPTIVE)
              for f in frame_files]
    gif = os.path.join(args.out, name + ".gif")
    images[0].save(gif, save_all=True, append_images=images[1:], duration=120, loop=0)
    print("render: wrote %s, %s and %d frames in %s" % (final, gif, len(frame_files), frames_dir))


main()
