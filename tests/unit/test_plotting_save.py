"""plotting.save lays a figure out and writes it with one draw, at the figure's own 100 dpi."""

import numpy as np
from matplotlib.figure import Figure
from PIL import Image

from neuronav.runs.plotting import new_figure, save


def test_a_saved_figure_is_drawn_once_at_100_dpi(tmp_path, monkeypatch):
    draws = []
    real_draw = Figure.draw
    monkeypatch.setattr(Figure, "draw", lambda self, renderer: draws.append(1) or real_draw(self, renderer))
    fig, ax = new_figure((6, 4))
    ax.plot(np.arange(10), np.arange(10) ** 2, label="a line")
    ax.set_xlabel("x (m)")
    ax.legend()
    path = save(fig, tmp_path / "one.png")
    assert len(draws) == 1
    assert fig.get_layout_engine() is None
    assert Image.open(path).size == (600, 400)

