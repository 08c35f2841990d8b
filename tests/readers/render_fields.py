"""Render the last step of a run's wall temperature as ParaView 5.11 would read it.

    python tests/readers/render_fields.py RUN_DIR OUT.png [MAX_C]

Reads fields.xdmf with VTK's Xdmf2 reader (ParaView 5.11's "XDMF Reader"), keeps the laid
points (Threshold on `laid`), colours by `temperature_c` clamped to [ambient, MAX_C] (default
600 °C, where steel starts to glow: the melt pool would otherwise wash the wall out), with a
scalar bar. Needs a display (Xvfb) or VTK's off-screen rendering.
"""

import json
import os
import sys

import vtk
from vtkmodules.vtkIOXdmf2 import vtkXdmfReader


def main():
    run, png = sys.argv[1], sys.argv[2]
    top = float(sys.argv[3]) if len(sys.argv) > 3 else 600.0
    ambient = json.load(open(os.path.join(run, "thermal.json"))).get("ambient_c", 20.0)
    reader = vtkXdmfReader()
    reader.SetFileName(os.path.join(run, "fields.xdmf"))
    reader.UpdateInformation()
    steps = reader.GetOutputInformation(0).Get(vtk.vtkStreamingDemandDrivenPipeline.TIME_STEPS())
    reader.UpdateTimeStep(steps[-1])
    laid = vtk.vtkThreshold()
    laid.SetInputData(reader.GetOutputDataObject(0))
    laid.SetInputArrayToProcess(0, 0, 0, vtk.vtkDataObject.FIELD_ASSOCIATION_POINTS, "laid")
    laid.SetLowerThreshold(0.5)
    laid.SetUpperThreshold(1.5)
    laid.SetThresholdFunction(vtk.vtkThreshold.THRESHOLD_BETWEEN)
    laid.SetAllScalars(True)
    surface = vtk.vtkDataSetSurfaceFilter()
    surface.SetInputConnection(laid.GetOutputPort())

    lut = vtk.vtkLookupTable()
    lut.SetHueRange(0.667, 0.0)
    lut.SetTableRange(ambient, top)
    lut.SetAboveRangeColor(1, 1, 1, 1)
    lut.UseAboveRangeColorOn()
    lut.Build()
    mapper = vtk.vtkPolyDataMapper()
    mapper.SetInputConnection(surface.GetOutputPort())
    mapper.SetScalarModeToUsePointFieldData()
    mapper.SelectColorArray("temperature_c")
    mapper.SetLookupTable(lut)
    mapper.SetScalarRange(ambient, top)
    mapper.UseLookupTableScalarRangeOn()
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)

    bar = vtk.vtkScalarBarActor()
    bar.SetLookupTable(lut)
    bar.SetTitle("temperature_c (°C)")
    bar.SetNumberOfLabels(5)
    bar.DrawAboveRangeSwatchOn()
    text = vtk.vtkTextActor()
    text.SetInput(f"fields.xdmf, last of {len(steps)} steps, t = {steps[-1]:.0f} s")
    text.GetTextProperty().SetFontSize(18)
    text.SetPosition(10, 10)

    renderer = vtk.vtkRenderer()
    renderer.SetBackground(0.32, 0.34, 0.43)
    renderer.AddActor(actor)
    renderer.AddViewProp(bar)
    renderer.AddViewProp(text)
    camera = renderer.GetActiveCamera()
    camera.SetViewUp(0, 0, 1)
    camera.SetPosition(1, -2.5, 1.2)
    camera.SetFocalPoint(0, 0, 0)
    renderer.ResetCamera()
    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.AddRenderer(renderer)
    window.SetSize(1000, 750)
    window.Render()
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(window)
    grab.Update()
    writer = vtk.vtkPNGWriter()
    writer.SetFileName(png)
    writer.SetInputConnection(grab.GetOutputPort())
    writer.Write()
    print(f"{png}: step {len(steps)} at {steps[-1]:.1f} s, colours clamped to [{ambient}, {top}] °C")


if __name__ == "__main__":
    main()
