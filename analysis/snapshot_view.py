"""A picture of a parode H5MD snapshot as ParaView draws it, without a display.

Run with ParaView's batch interpreter under a virtual X server (Debian's
ParaView is built for X, without offscreen Mesa; -noreset, because pvbatch
connects twice and a resetting server refuses the second connection):

    xvfb-run -a -s "-screen 0 1920x1200x24 -noreset" \
        pvbatch analysis/snapshot_view.py run.xdmf --out view.png [--time T]

It opens FILE.xdmf with ParaView's XDMF Reader (XDMF 2; the Xdmf3 readers of
ParaView 5.11 do not read HyperSlab items), takes the frame at time T (default:
the last), draws every body as a sphere of its radius coloured by its speed
(or by any point array of the file, `--colour-by program_inside`),
an arrow along each body's x axis (the `x_axis` attribute, as ParaView's Glyph
filter orients), and the static geometry (floor, ramps) in grey.
Trade-off: a fixed oblique camera fitted to the bodies, good for the catom
piles and the buggy; other scenes may want their own view in the ParaView GUI
(README, "Snapshots for ParaView").
"""
import argparse

from paraview import simple as pv


def bodies_and_statics(path):
    reader = pv.XDMFReader(FileNames=[path])
    reader.UpdatePipelineInformation()
    bodies = pv.ExtractBlock(Input=reader, Selectors=["/Root/bodies"])
    statics = pv.ExtractBlock(Input=reader, Selectors=["/Root/statics"])
    return reader, pv.MergeBlocks(Input=bodies), pv.MergeBlocks(Input=statics)


def spheres(bodies):
    speed = pv.Calculator(Input=bodies, ResultArrayName="speed", Function="mag(velocity)")
    glyph = pv.Glyph(Input=speed, GlyphType="Sphere", ScaleArray=["POINTS", "radius"], ScaleFactor=2.0,
                     OrientationArray=["POINTS", "No orientation array"], GlyphMode="All Points")
    glyph.GlyphType.ThetaResolution = 16
    glyph.GlyphType.PhiResolution = 12
    return glyph


def arrows(bodies):
    return pv.Glyph(Input=bodies, GlyphType="Arrow", OrientationArray=["POINTS", "x_axis"],
                    ScaleArray=["POINTS", "radius"], ScaleFactor=2.0, GlyphMode="All Points")


def draw(view, source, colour=None, by=None, title=""):
    shown = pv.Show(source, view)
    if by:
        pv.ColorBy(shown, ("POINTS", by))
        shown.RescaleTransferFunctionToDataRange(True, False)
        shown.SetScalarBarVisibility(view, True)
        bar = pv.GetScalarBar(pv.GetColorTransferFunction(by), view)
        bar.Title, bar.ComponentTitle = title or by, ""
        bar.TitleColor = bar.LabelColor = [0, 0, 0]
    elif colour:
        shown.ColorArrayName = ["POINTS", ""]
        shown.AmbientColor = shown.DiffuseColor = colour
    return shown


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("xdmf")
    ap.add_argument("--out", required=True)
    ap.add_argument("--time", type=float, help="simulated time of the frame (default: the last)")
    ap.add_argument("--size", type=int, nargs=2, default=[1600, 1000])
    ap.add_argument("--colour-by", default="speed", help="a point array (default: speed, |velocity|)")
    a = ap.parse_args()
    reader, bodies, statics = bodies_and_statics(a.xdmf)
    t = a.time if a.time is not None else reader.TimestepValues[-1]
    view = pv.CreateView("RenderView")
    view.ViewSize = a.size
    view.ViewTime = t
    view.UseColorPaletteForBackground = 0
    view.Background = [1, 1, 1]
    view.OrientationAxesVisibility = 0
    draw(view, statics, colour=[0.75, 0.75, 0.72])
    by = a.colour_by
    draw(view, spheres(bodies), by=by, title="speed (m/s)" if by == "speed" else by)
    draw(view, arrows(bodies), colour=[0.1, 0.1, 0.1])
    text = pv.Text(Text=f"{a.xdmf.rsplit('/', 1)[-1]}  t = {t:.3f} s")
    draw(view, text).Color = [0, 0, 0]
    frame_camera(view, bodies, t)
    pv.SaveScreenshot(a.out, view, ImageResolution=a.size)
    print(f"{a.out}: frame at t = {t} s of {a.xdmf}")


def frame_camera(view, bodies, t):
    bodies.UpdatePipeline(t)
    x0, x1, y0, y1, z0, z1 = bodies.GetDataInformation().GetBounds()
    cx, cy, cz = (x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2
    size = max(x1 - x0, y1 - y0, z1 - z0, 1.0)
    view.CameraFocalPoint = [cx, cy, cz]
    view.CameraPosition = [cx - 1.3 * size, cy - 1.9 * size, cz + 1.1 * size]
    view.CameraViewUp = [0, 0, 1]
    view.CameraViewAngle = 30


if __name__ == "__main__":
    main()
