"""Pictures of a run's folder drawn by ParaView: run by `render` as
`xvfb-run -a pvpython cli/paraview_render.py JOB.json` (this ParaView build needs an
X display even offscreen). Uses only ParaView's own modules, not the project's.

JOB.json: {"run": folder, "out": folder, "times": [s, ...] or null (a third, two thirds and
the end of the run), "cut": [x, y, z] or null (the model's centre), "animate": bool (also
every frame as out/animation.avi, Motion JPEG)}. The model is cut by the plane y = cut[1]
and the half y < cut[1] is shown from the cut's side: spheres (`spheres.pvd`) as shaded
spheres of their radius coloured by damage, the FE part (`fe.xdmf`) as a surface coloured by
displacement magnitude, each on one colour range for all pictures. Prints one JSON line per
file written: {"file": path, "times": [frame times shown]}.
"""
import json
import sys
from pathlib import Path

from paraview.simple import (AnnotateTime, Clip, ColorBy, CreateRenderView,
                             GetAnimationScene, GetColorTransferFunction, GetScalarBar,
                             PVDReader, Render, SaveAnimation, SaveScreenshot, Show,
                             Xdmf3ReaderS, _DisableFirstRenderCameraReset)

SIZE = [1600, 900]
BLACK = [0.0, 0.0, 0.0]


def half(source, cut):
    """The part of `source` on the side y < cut[1], whole cells kept (spheres stay whole)."""
    clip = Clip(Input=source)
    clip.ClipType = "Plane"
    clip.ClipType.Origin = cut
    clip.ClipType.Normal = [0.0, 1.0, 0.0]
    clip.Crinkleclip = 1
    return clip


def bar(lut, view, title, position):
    sb = GetScalarBar(lut, view)
    sb.Title = title
    sb.ComponentTitle = ""
    sb.TitleColor = sb.LabelColor = BLACK
    sb.TitleFontSize = sb.LabelFontSize = 18
    sb.WindowLocation = "Any Location"
    sb.Orientation = "Horizontal"
    sb.Position = position
    sb.ScalarBarLength = 0.33
    sb.RangeLabelFormat = "%-#6.3g"
    return sb


def value_range(source, times, array, component=-1):
    """(min, max) of a point array over the given times (component -1: the magnitude)."""
    lo, hi = float("inf"), float("-inf")
    for t in times:
        source.UpdatePipeline(t)
        info = source.GetPointDataInformation().GetArray(array)
        r = info.GetRange(component)
        lo, hi = min(lo, r[0]), max(hi, r[1])
    return lo, hi


def nearest(frames, t):
    return min(frames, key=lambda f: abs(f - t))


def main(job_file):
    job = json.loads(Path(job_file).read_text())
    run, out = Path(job["run"]), Path(job["out"])
    spheres = fe = None
    if (run / "spheres.pvd").is_file():
        spheres = PVDReader(FileName=str(run / "spheres.pvd"))
    if (run / "fe.xdmf").is_file():
        fe = Xdmf3ReaderS(FileName=str(run / "fe.xdmf"))
    sources = [s for s in (spheres, fe) if s is not None]
    frames = sorted({t for s in sources for t in s.TimestepValues})
    wanted = job["times"] if job["times"] is not None else [frames[-1] * k / 3 for k in (1, 2, 3)]
    pictures = [(out / f"t_{t:.4e}s.png", t)
                for t in sorted({nearest(frames, t) for t in wanted})]
    lo, hi = bounds(sources, frames[0])
    centre = [(a + b) / 2 for a, b in zip(lo, hi)]
    cut = job["cut"] or centre

    _DisableFirstRenderCameraReset()      # keep the camera placed below
    view = CreateRenderView()
    view.ViewSize = SIZE
    view.UseColorPaletteForBackground = 0
    view.Background = [1.0, 1.0, 1.0]
    view.OrientationAxesVisibility = 1
    if spheres is not None:
        show_spheres(view, half(spheres, cut))
    if fe is not None:
        show_fe(view, half(fe, cut), value_range(
            fe, frames if job["animate"] else [t for _, t in pictures], "displacement")[1])
    label = AnnotateTime(Format=f"{run.name}   t = {{time:.4e}} s   cut at y = {cut[1]:.3f} m")
    d = Show(label, view)
    d.Color = BLACK
    d.FontSize = 20
    d.WindowLocation = "Upper Left Corner"
    place_camera(view, lo, hi, cut)
    for png, t in pictures:
        view.ViewTime = t
        Render(view)
        SaveScreenshot(str(png), view, ImageResolution=SIZE, TransparentBackground=0)
        print(json.dumps({"file": str(png), "times": [t]}), flush=True)
    if job["animate"]:
        scene = GetAnimationScene()
        scene.ViewModules = [view]
        scene.UpdateAnimationUsingDataTimeSteps()
        movie = out / "animation.avi"
        SaveAnimation(str(movie), view, ImageResolution=SIZE, FrameRate=10)
        print(json.dumps({"file": str(movie), "times": frames}), flush=True)


def show_spheres(view, source):
    """Spheres as shaded spheres of their radius, coloured by damage 0-1."""
    d = Show(source, view)
    d.SetRepresentationType("Point Gaussian")
    d.ShaderPreset = "Sphere"
    d.ScaleByArray = 1
    d.SetScaleArray = ["POINTS", "radius"]
    d.UseScaleFunction = 0          # the radius itself, not mapped through a ramp
    d.GaussianRadius = 1.0
    ColorBy(d, ("POINTS", "damage"))
    damage = GetColorTransferFunction("damage")
    damage.ApplyPreset("Cool to Warm", True)
    damage.RescaleTransferFunction(0.0, 1.0)
    damage.AutomaticRescaleRangeMode = "Never"
    d.SetScalarBarVisibility(view, True)
    bar(damage, view, "sphere damage (broken / initial links)", [0.05, 0.04])


def show_fe(view, source, top):
    """The FE part coloured by displacement magnitude, 0 to `top` in every picture."""
    d = Show(source, view)
    ColorBy(d, ("POINTS", "displacement", "Magnitude"))
    u = GetColorTransferFunction("displacement")
    u.ApplyPreset("Viridis (matplotlib)", True)
    u.RescaleTransferFunction(0.0, max(top, 1e-30))
    u.AutomaticRescaleRangeMode = "Never"
    d.SetScalarBarVisibility(view, True)
    bar(u, view, "FE displacement magnitude (m)", [0.60, 0.04])


def bounds(sources, t):
    """(lower corner, upper corner) of the sources' data at time t."""
    lo, hi = [float("inf")] * 3, [float("-inf")] * 3
    for s in sources:
        s.UpdatePipeline(t)
        b = s.GetDataInformation().GetBounds()
        lo = [min(lo[i], b[2 * i]) for i in range(3)]
        hi = [max(hi[i], b[2 * i + 1]) for i in range(3)]
    return lo, hi


def place_camera(view, lo, hi, cut):
    """Look at the cut face from the +y side, a little from above and from +x."""
    centre = [(lo[0] + hi[0]) / 2, (lo[1] + cut[1]) / 2, (lo[2] + hi[2]) / 2]
    size = max(b - a for a, b in zip(lo, hi))
    direction = [0.3, 1.0, 0.55]
    norm = sum(c * c for c in direction) ** 0.5
    view.CameraFocalPoint = centre
    view.CameraPosition = [c + 1.6 * size * d / norm for c, d in zip(centre, direction)]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    view.CameraViewAngle = 30.0
    view.CenterOfRotation = centre


if __name__ == "__main__":
    main(sys.argv[1])
