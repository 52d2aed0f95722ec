"""What a reader would trip on in an off-screen VTK picture, measured by VTK itself at the
moment it is drawn: text running off the canvas or out of its own strip, two texts over
one another, a text over a colour scale or over a flat map's drawing, and text VTK scales
with the window (a corner annotation) or places where it cannot be measured (point labels).
"""

from __future__ import annotations

import itertools

import numpy as np


def _display_box(ren, bounds) -> tuple[float, float, float, float]:
    """(x0, x1, y0, y1) [px] of a 3D prop's bounds seen through the renderer's camera."""
    xs, ys = [], []
    for x, y, z in itertools.product(bounds[0:2], bounds[2:4], bounds[4:6]):
        ren.SetWorldPoint(x, y, z, 1.0)
        ren.WorldToDisplay()
        px, py, _ = ren.GetDisplayPoint()
        xs.append(px)
        ys.append(py)
    return min(xs), max(xs), min(ys), max(ys)


def _overlap(a, b, tol: float = 0.5) -> bool:
    return a[0] < b[1] - tol and b[0] < a[1] - tol and a[2] < b[3] - tol and b[2] < a[3] - tol


def layout_faults(pl) -> list[str]:
    """The faults of the plotter's picture as it is about to be saved (one line each)."""
    pl.render()
    W, H = pl.window_size
    faults, texts, solid = [], [], []
    for ren in pl.renderers:
        x0, y0, x1, y1 = ren.GetViewport()
        room = (x0 * W - 1, x1 * W + 1, y0 * H - 1, y1 * H + 1)
        flat = ren.GetActiveCamera().GetParallelProjection()
        for prop in ren.GetViewProps():
            if not prop.GetVisibility():
                continue
            if prop.IsA("vtkTextActor"):
                bb = [0.0] * 4
                prop.GetBoundingBox(ren, bb)
                px, py = prop.GetPositionCoordinate().GetComputedDisplayValue(ren)
                box = (px + bb[0], px + bb[1], py + bb[2], py + bb[3])
                name = repr(prop.GetInput().replace("\n", " ")[:40])
                if not (box[0] >= room[0] and box[1] <= room[1] and box[2] >= room[2]
                        and box[3] <= room[3]):
                    faults.append(f"{name} runs out of its part of the picture")
                texts.append((name, box))
            elif prop.IsA("vtkCornerAnnotation"):
                faults.append("a corner annotation (its text scales with the window)")
            elif prop.IsA("vtkScalarBarActor"):
                a = prop.GetPositionCoordinate().GetComputedDisplayValue(ren)
                b = prop.GetPosition2Coordinate().GetComputedDisplayValue(ren)
                box = (a[0], b[0], a[1], b[1])
                if not (box[0] >= 0 and box[1] <= W and box[2] >= 0 and box[3] <= H):
                    faults.append("the colour scale runs off the picture")
                solid.append(("the colour scale", box))
            elif prop.IsA("vtkActor2D") and not prop.IsA("vtkLegendBoxActor"):
                faults.append(f"a {type(prop).__name__} whose extent is not measured "
                              "(point labels)")
            elif flat and prop.IsA("vtkActor") and prop.GetProperty().GetOpacity() > 0:
                bounds = prop.GetBounds()
                if bounds is not None and np.all(np.isfinite(bounds)):
                    solid.append(("a map's drawing", _display_box(ren, bounds)))
    for (a, ba), (b, bb) in itertools.combinations(texts, 2):
        if _overlap(ba, bb):
            faults.append(f"{a} overlaps {b}")
    for (a, ba), (b, bb) in itertools.product(texts, solid):
        if _overlap(ba, bb):
            faults.append(f"{a} overlaps {b}")
    return faults
