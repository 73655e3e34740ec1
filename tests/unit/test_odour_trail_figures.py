"""The odour trail's top view (issue 26): its legend covers none of the trail, the paths or the starts."""

import numpy as np
import pytest

from neuronav import registry
from neuronav.config import apply_overrides
from neuronav.runs.runner import load_scenario, run_trials


@pytest.fixture(scope="module")
def short_run():
    ok, reason = registry.availability("backend", "kinematic")
    if not ok:
        pytest.skip(reason)
    scenario = load_scenario("odour-trail")
    config = apply_overrides(scenario.config_type, scenario.smoke_config())
    return run_trials(scenario, config, "kinematic", trials=2, seed=0), config


def test_the_trail_legend_lies_outside_the_axes_and_covers_no_data(short_run):
    from neuronav.scenarios.odour_trail.figures import trajectories_figure
    from neuronav.scenarios.odour_trail.scenario import make_trail

    result, config = short_run
    fig = trajectories_figure(result, config)
    fig.tight_layout()  # as save() lays it out
    fig.canvas.draw()
    ax = fig.axes[0]
    legend = ax.get_legend()
    assert [t.get_text() for t in legend.get_texts()] == ["fixed antennae", "moving antennae", "finish line",
                                                          "start"]
    box = legend.get_window_extent()
    assert not box.overlaps(ax.get_window_extent()), "the legend sits over the axes"
    assert box.x1 <= fig.bbox.x1 and box.y1 <= fig.bbox.y1, "the legend is cut off by the figure's edge"
    # No drawn point (paths, starts, finish line) nor the trail's centre line (its start first) under it.
    trail = make_trail(config.width, config.edge_m)
    points = np.vstack([np.asarray(trail.vertices_m, float), *(line.get_xydata() for line in ax.lines)])
    shown = ax.transData.transform(points)
    inside = ((shown[:, 0] >= box.x0) & (shown[:, 0] <= box.x1) & (shown[:, 1] >= box.y0) & (shown[:, 1] <= box.y1))
    assert not inside.any(), points[inside]
