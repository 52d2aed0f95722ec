"""The text of the off-screen VTK pictures (maps, shapes, previews): measured by VTK's own
text renderer, broken into lines that fit, placed in pixels. Every label is a plain
``vtkTextActor`` of a fixed size (not a corner annotation, which scales with its window),
so a picture's layout is known before it is drawn: strips are as tall as their text, and
nothing runs off the canvas or into its neighbour at any ``render --size``."""

from __future__ import annotations

import textwrap

#: text sizes [VTK points: pixels of a line at 72 dpi]: a picture's title, a panel's
#: caption, a legend's or a colour scale's names
TITLE, CAPTION, NAME = 22, 18, 20
#: pixels between text and whatever is next to it
GAP = 6


#: VTK's justification codes
_ALIGN = {"left": 0, "bottom": 0, "center": 1, "right": 2, "top": 2}


def _prop(size: int, bold: bool = False):
    from vtkmodules.vtkRenderingCore import vtkTextProperty

    prop = vtkTextProperty()
    prop.SetFontFamilyToArial()
    prop.SetFontSize(size)
    prop.SetBold(bold)
    return prop


def measure(text: str, size: int, bold: bool = False) -> tuple[int, int]:
    """(width, height) [px] of ``text`` (lines broken at newlines) at ``size``."""
    import vtkmodules.vtkRenderingFreeType  # noqa: F401  (the text renderer's factory)
    from vtkmodules.vtkRenderingCore import vtkTextRenderer

    box = [0, 0, 0, 0]
    vtkTextRenderer.GetInstance().GetBoundingBox(_prop(size, bold), text, box, 72)
    return box[1] - box[0] + 1, box[3] - box[2] + 1


def fit(text: str, width: float, size: int) -> str:
    """``text`` broken at spaces into lines each at most ``width`` pixels wide (the line
    length shrunk in steps of a twentieth until they fit; a word longer than the width,
    a path, is broken inside); its own line breaks kept."""
    out = []
    for para in text.split("\n"):
        n = len(para)
        while n > 1 and measure("\n".join(textwrap.wrap(para, n)) or " ", size)[0] > width:
            n -= max(1, n // 20)
        out.append("\n".join(textwrap.wrap(para, max(n, 1))) or para)
    return "\n".join(out)


def strip(text: str, width: float, size: int) -> tuple[str, int]:
    """``text`` fitted to a strip ``width`` pixels wide (:func:`fit`, a gap each side) and
    the strip's height [px]: its lines and a gap above and below."""
    fitted = fit(text, width - 2 * GAP, size)
    return fitted, measure(fitted, size)[1] + 2 * GAP


def place(pl, text: str, x: float, y: float, *, size: int, color: str = "black",
          h: str = "center", v: str = "center"):
    """``text`` in the plotter's current renderer at (x, y) in its normalized viewport
    coordinates, aligned there by ``h`` (left | center | right) and ``v`` (bottom | center
    | top); the actor."""
    import pyvista as pv
    from vtkmodules.vtkRenderingCore import vtkTextActor

    actor = vtkTextActor()
    actor.SetInput(text)
    prop = actor.GetTextProperty()
    prop.ShallowCopy(_prop(size))
    prop.SetColor(pv.Color(color).float_rgb)
    prop.SetJustification(_ALIGN[h])
    prop.SetVerticalJustification(_ALIGN[v])
    actor.GetPositionCoordinate().SetCoordinateSystemToNormalizedViewport()
    actor.SetPosition(x, y)
    pl.renderer.AddViewProp(actor)
    return actor
