"""Properties of a drawn matplotlib ``Figure`` that tests assert: where its legends sit,
the colours and labels of its lines, and its titles (read back from the artists, never
from pixels)."""

from __future__ import annotations

from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_hex
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.transforms import Bbox


def legends(figure: Figure) -> list[Legend]:
    """Every legend of ``figure``: its own and its axes'."""
    found = list(figure.legends)
    found += [axis.get_legend() for axis in figure.axes if axis.get_legend() is not None]
    return found


def legend_labels(figure: Figure) -> list[str]:
    """The texts of every legend of ``figure``, in order."""
    return [text.get_text() for legend in legends(figure) for text in legend.get_texts()]


def legends_over_axes(figure: Figure) -> list[tuple[int, int]]:
    """``(legend, axes)`` index pairs where a legend's box overlaps an axes' box (in
    display coordinates, after a draw); empty when every legend lies outside the data."""
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    renderer = canvas.get_renderer()
    overlaps = []
    for i, legend in enumerate(legends(figure)):
        box = legend.get_window_extent(renderer)
        for k, axis in enumerate(figure.axes):
            inner = axis.get_window_extent(renderer)
            if Bbox.intersection(box, inner) is not None and _area(box, inner) > 0.0:
                overlaps.append((i, k))
    return overlaps


def _area(first: Bbox, second: Bbox) -> float:
    """The area the two boxes share."""
    both = Bbox.intersection(first, second)
    return 0.0 if both is None else both.width * both.height


def line_colours(axis: Axes) -> dict[str, str]:
    """The hex colour of every labelled line of ``axis``, by label."""
    return {
        line.get_label(): to_hex(line.get_color())
        for line in axis.get_lines()
        if not line.get_label().startswith("_")
    }


def suptitle(figure: Figure) -> str:
    """The figure's title text (empty when it has none)."""
    title = figure.get_suptitle()
    return title.strip()
