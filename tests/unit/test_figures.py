"""What the figures draw: read back from the matplotlib Figure objects, not from file sizes.

The circuit diagram: the same layout every time and whatever the declaration order, layered by kind,
every connection drawn once in its sign's colour, no arrow through a population it does not connect,
a legend naming exactly the kinds and signs drawn. The scenario figures: every legend entry names a
line that is drawn (with data), a trial's foraging and homing paths share a colour and join, heading
traces never jump across the axis at ±180°.
"""

import numpy as np
import pytest
from matplotlib.colors import to_rgba
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, FancyArrowPatch

from neuronav.brains.cx import stone2017
from neuronav.circuits.circuit import Circuit
from neuronav.runs.plotting import (
    EDGE_COLOURS,
    KIND_COLOURS,
    break_at_wraps,
    circuit_layout,
    edge_class,
    plot_circuit,
    plot_connectivity,
)
from neuronav.runs.scenario import ScenarioResult
from neuronav.spec.ports import MotorSpec, SensorSpec


# -- helpers ---------------------------------------------------------------------------------
def drawn_path_points(patch, samples: int = 40) -> np.ndarray:
    """Points along everything a patch draws (curves sampled), in data coordinates."""
    points = []
    for segment, _code in patch.get_path().iter_bezier():
        points.append(segment(np.linspace(0.0, 1.0, samples)))
    return np.concatenate(points)


def legend_labels(ax) -> list[str]:
    legend = ax.get_legend()
    assert legend is not None, f"axes {ax.get_title()!r} has no legend"
    return [t.get_text() for t in legend.get_texts()]


def assert_legend_names_drawn_lines(ax):
    """Each legend label belongs to an artist of these axes that shows finite data, in its colour."""
    drawn = {}
    for artist in [*ax.lines, *ax.patches, *ax.collections]:
        label = artist.get_label()
        if isinstance(artist, Line2D):
            data = np.column_stack([np.asarray(artist.get_xdata(), float), np.asarray(artist.get_ydata(), float)])
            finite = np.isfinite(data).all(axis=1).sum()
            has_marker = artist.get_marker() not in (None, "None", "", " ")
            if finite < (1 if has_marker else 2):  # a line without markers shows from two points on
                continue
        drawn.setdefault(label, artist)
    legend = ax.get_legend()
    for text, handle in zip(legend.get_texts(), legend.legend_handles):
        label = text.get_text()
        assert label in drawn, f"legend entry {label!r} names nothing drawn in {ax.get_title()!r}"
        if isinstance(handle, Line2D):
            assert to_rgba(handle.get_color()) == to_rgba(drawn[label].get_color()), label
            assert handle.get_linestyle() == drawn[label].get_linestyle(), label


def lines_by_gid(ax) -> dict[str, Line2D]:
    return {line.get_gid(): line for line in ax.lines if line.get_gid()}


def assert_no_wrap_strokes(line: Line2D):
    """No two consecutive finite points of a heading trace (degrees) more than 180° apart."""
    y = np.asarray(line.get_ydata(), float)
    steps = np.abs(np.diff(y))
    assert np.all(steps[np.isfinite(steps)] <= 180.0), f"a stroke of {np.nanmax(steps):.0f}° crosses the axis"


def assert_trials_share_colours(ax, trials):
    lines = lines_by_gid(ax)
    colours = set()
    for i in trials:
        out, home = lines[f"trial {i} outbound"], lines[f"trial {i} homing"]
        assert to_rgba(out.get_color()) == to_rgba(home.get_color()), f"trial {i}: two colours"
        assert out.get_linestyle() != home.get_linestyle()
        np.testing.assert_allclose(home.get_xydata()[0], out.get_xydata()[-1], err_msg=f"trial {i} not joined")
        colours.add(to_rgba(out.get_color()))
    assert len(colours) == min(len(trials), 10), "trials are not told apart by colour"


# -- circuit diagram -------------------------------------------------------------------------
def shuffled_copy(circuit: Circuit) -> Circuit:
    """The same circuit with populations and connections declared in reverse order."""
    copy = Circuit(circuit.name)
    for name in reversed(list(circuit.graph)):
        copy.add(circuit.graph.nodes[name]["population"])
    for source, target, data in reversed(list(circuit.graph.edges(data=True))):
        copy.connect(source, target, weights=data["weights"], delay=data["delay"])
    return copy


def small_circuit() -> Circuit:
    """Input -> two branches of different depth -> output, a skip connection and a two-way pair."""
    c = Circuit("small")
    c.add_input("x", 2, ports=[SensorSpec("x", (2,))])
    c.add_population("a", 4)
    c.add_population("b", 4, kind="leaky", tau_s=0.02)
    c.add_population("m", 2, kind="integrator")
    c.add_output("y", 1, port=MotorSpec("y", (1,)))
    c.connect("x", "a", weights=np.ones((4, 2)))
    c.connect("a", "b", weights=-np.ones((4, 4)))
    c.connect("b", "a", weights=np.ones((4, 4)), delay=True)
    c.connect("b", "m", weights=np.ones((2, 4)))
    c.connect("x", "m", weights=np.ones((2, 2)))  # skips two columns
    c.connect("m", "y", weights=[[1.0, -1.0]])
    return c


CIRCUITS = {"stone2017": stone2017, "small": small_circuit}


@pytest.mark.parametrize("name", sorted(CIRCUITS))
def test_circuit_layout_is_deterministic_and_layered_by_kind(name):
    circuit = CIRCUITS[name]()
    first, again = circuit_layout(circuit), circuit_layout(CIRCUITS[name]())
    reordered = circuit_layout(shuffled_copy(circuit))
    assert set(first) == set(circuit.graph)
    for node in first:
        np.testing.assert_array_equal(first[node], again[node], err_msg=node)
        np.testing.assert_array_equal(first[node], reordered[node], err_msg=node)
    kind = {n: circuit.population(n).kind for n in circuit.graph}
    columns = {n: p[0] for n, p in first.items()}
    last = max(columns.values())
    assert all(columns[n] == 0 for n in first if kind[n] == "input")
    assert all(columns[n] == last for n in first if kind[n] == "output")
    assert all(0 < columns[n] < last for n in first if kind[n] not in ("input", "output"))
    for source, target, data in circuit.graph.edges(data=True):
        if not data["delay"] and source != target:
            assert columns[source] < columns[target], f"{source} -> {target} runs backwards"
    assert len({tuple(p) for p in first.values()}) == len(first), "two populations on one spot"


@pytest.mark.parametrize("name", sorted(CIRCUITS))
def test_circuit_diagram_draws_every_connection_clear_of_other_populations(name):
    circuit = CIRCUITS[name]()
    ax = plot_circuit(circuit)
    ax.figure.canvas.draw()  # arrow heads are made at draw time
    nodes = {p.get_gid()[5:]: p for p in ax.patches if isinstance(p, Circle) and p.get_gid()}
    edges = {p.get_gid()[5:]: p for p in ax.patches if isinstance(p, FancyArrowPatch)}
    assert set(nodes) == set(circuit.graph)
    labels = {t.get_gid()[6:]: t for t in ax.texts if t.get_gid()}
    for node, disc in nodes.items():
        assert labels[node].get_text() == node
        np.testing.assert_allclose(labels[node].get_position(), disc.center, err_msg=node)
    expected = {f"{s}->{t}": d for s, t, d in circuit.graph.edges(data=True) if s != t}
    assert set(edges) == set(expected)
    for node, disc in nodes.items():
        assert to_rgba(disc.get_facecolor()) == to_rgba(KIND_COLOURS[circuit.population(node).kind]), node
    for key, arrow in edges.items():
        assert to_rgba(arrow.get_edgecolor()) == to_rgba(EDGE_COLOURS[edge_class(expected[key]["weights"])]), key
        points = drawn_path_points(arrow)
        source, target = key.split("->")
        for node, disc in nodes.items():
            distance = np.linalg.norm(points - np.asarray(disc.center), axis=1).min()
            assert distance >= disc.radius, f"edge {key} passes through {node} ({distance:.3f} < {disc.radius:.3f})"


@pytest.mark.parametrize("name", sorted(CIRCUITS))
def test_circuit_legend_names_the_kinds_and_signs_drawn(name):
    circuit = CIRCUITS[name]()
    ax = plot_circuit(circuit)
    kinds = {circuit.population(n).kind for n in circuit.graph}
    signs = {edge_class(d["weights"]) for s, t, d in circuit.graph.edges(data=True) if s != t}
    legend = ax.get_legend()
    labels = legend_labels(ax)
    assert sorted(labels) == sorted(kinds | signs)
    for text, handle in zip(legend.get_texts(), legend.legend_handles):
        label = text.get_text()
        colour = KIND_COLOURS[label] if label in kinds else EDGE_COLOURS[label]
        drawn = handle.get_facecolor() if label in kinds else handle.get_color()
        assert to_rgba(drawn) == to_rgba(colour), label


def test_connectivity_plot_labels_every_population_block():
    circuit = stone2017()
    ax = plot_connectivity(circuit)
    matrix, blocks = circuit.weight_matrix()
    names = [name for name, _, _ in blocks]
    assert [t.get_text() for t in ax.get_xticklabels()] == names
    assert [t.get_text() for t in ax.get_yticklabels()] == names
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("source", "target")
    np.testing.assert_array_equal(ax.images[0].get_array(), matrix)


# -- headings --------------------------------------------------------------------------------
def test_break_at_wraps_inserts_one_gap_per_crossing_and_meets_the_edges():
    time = np.arange(200.0)
    heading = np.linspace(0.0, 6 * np.pi, 200)  # three turns: crosses ±180° three times
    t, wrapped = break_at_wraps(time, heading)
    assert np.isnan(wrapped).sum() == 3 and len(wrapped) == 200 + 3 * 3
    # The samples are kept (same angles, in order) ...
    samples = np.isin(t, time)
    np.testing.assert_allclose(np.exp(1j * wrapped[samples]), np.exp(1j * heading))
    # ... and each piece runs to the edge it crosses, the next starts on the other edge at the same time:
    for gap in np.flatnonzero(np.isnan(wrapped)):
        assert wrapped[gap - 1] == pytest.approx(np.pi) and wrapped[gap + 1] == pytest.approx(-np.pi)
        assert t[gap - 1] == t[gap + 1] and time[0] < t[gap - 1] < time[-1]
        crossing = np.interp(t[gap - 1], time, heading)
        assert np.mod(crossing, 2 * np.pi) == pytest.approx(np.pi, abs=1e-9)
    steps = np.abs(np.diff(wrapped))
    assert np.all(steps[np.isfinite(steps)] < np.pi)


# -- path integration (a real short run) -----------------------------------------------------
@pytest.fixture(scope="module")
def path_integration_run():
    from neuronav.config import apply_overrides
    from neuronav.scenarios.path_integration.scenario import PathIntegration, PathIntegrationConfig

    scenario = PathIntegration()
    config = apply_overrides(PathIntegrationConfig, [f"{k}={v}" for k, v in scenario.smoke_config().items()])
    return scenario.run(config, backend="kinematic", trials=4, seed=3), config


def test_path_integration_trajectories_pair_colours_and_legend(path_integration_run):
    from neuronav.scenarios.path_integration.figures import trajectories_figure

    result, config = path_integration_run
    ax = trajectories_figure(result, config).axes[0]
    assert_trials_share_colours(ax, range(4))
    assert_legend_names_drawn_lines(ax)
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x (steps)", "y (steps)")


def test_path_integration_heading_and_tb1_figures(path_integration_run):
    from neuronav.scenarios.path_integration.figures import cpu4_figure, tb1_figure

    result, config = path_integration_run
    fig = cpu4_figure(result, config)
    memory, heading_ax = fig.axes[0], fig.axes[1]
    assert memory.images[0].get_array().shape == result.timeseries["cpu4_memory"][0].T.shape
    assert heading_ax.get_ylabel() == "heading (deg)"
    assert_no_wrap_strokes(lines_by_gid(heading_ax)["heading"])
    ax = tb1_figure(result, config).axes[0]
    assert ax.images[0].get_array().shape == result.timeseries["tb1_rates"][0].T.shape
    assert_legend_names_drawn_lines(ax)


# -- embodied homing (synthetic recordings) --------------------------------------------------
def embodied_result(trials: int = 3, steps: int = 60):
    from neuronav.scenarios.path_integration.scenario import PathIntegrationConfig

    config = PathIntegrationConfig()
    rng = np.random.default_rng(0)
    time_s = np.tile(np.linspace(0.0, 2 * config.outbound_s, steps), (trials, 1))
    heading = np.cumsum(rng.normal(0.0, 0.8, (trials, steps)), axis=1) + np.linspace(0, 8 * np.pi, steps)
    position = np.cumsum(np.stack([np.sin(heading), np.cos(heading)], -1), axis=1) * 0.05
    time_s[1, -5:] = np.nan  # a trial that ended early: padded with NaN, as run_embodied does
    time_s[0, 3:] = np.nan  # a trial home before its foraging ended: no homing line to draw
    timeseries = {"time_s": time_s, "position_m": position, "heading_rad": heading,
                  "cpu4": np.where(np.isfinite(time_s)[..., None], rng.uniform(0, 1, (trials, steps, 16)), np.nan),
                  "fed_velocity": rng.normal(0, 0.1, (trials, steps, 2)),
                  "measured_velocity": rng.normal(0, 0.1, (trials, steps, 2))}
    trials_rows = [{"trial": i, "seed": i, "success": True, "status": "ok"} for i in range(trials)]
    return ScenarioResult(trials=trials_rows, timeseries=timeseries), config


def test_embodied_figures_pair_colours_break_wraps_and_name_drawn_lines():
    from neuronav.scenarios.path_integration.embodied_figures import cpu4_figure, trajectories_figure, velocity_figure

    result, config = embodied_result()
    ax = trajectories_figure(result, config).axes[0]
    assert_trials_share_colours(ax, range(1, 3))
    assert_legend_names_drawn_lines(ax)
    assert sorted(legend_labels(ax)) == ["foraging (dashed)", "homing, CX (solid)", "nest"]
    heading_ax = cpu4_figure(result, config, trial=1).axes[1]
    assert_no_wrap_strokes(lines_by_gid(heading_ax)["heading"])
    assert np.isnan(lines_by_gid(heading_ax)["heading"].get_ydata()).any(), "the synthetic heading wraps"
    fig = velocity_figure(result, config, trial=1)
    assert [a.get_ylabel() for a in fig.axes] == ["vx (m/s)", "vy (m/s)", "speed (m/s)"]
    assert_legend_names_drawn_lines(fig.axes[0])


# -- locomotion (a real short run on the wall) -----------------------------------------------
@pytest.fixture(scope="module")
def wall_run():
    from neuronav import registry
    from neuronav.scenarios.locomotion.scenario import Locomotion, LocomotionConfig

    ok, reason = registry.availability("backend", "mujoco")
    if not ok:
        pytest.skip(reason)
    config = LocomotionConfig(terrain="wall", duration_s=0.2)
    return Locomotion().run(config, backend="mujoco", trials=2, seed=1), config


def test_climb_figure_legend_names_only_drawn_lines(wall_run):
    from neuronav.scenarios.locomotion.figures import climb_figure

    result, config = wall_run
    side, height = climb_figure(result, config).axes
    assert side.get_legend() is None or legend_labels(side)
    assert_legend_names_drawn_lines(height)
    assert sorted(legend_labels(height)) == ["trial 0", "trial 1"]
    for ax in (side, height):
        lines = lines_by_gid(ax)
        for i in range(2):
            centre, root = lines[f"trial {i} centre"], lines[f"trial {i} root"]
            assert to_rgba(centre.get_color()) == to_rgba(root.get_color())
            assert (centre.get_linestyle(), root.get_linestyle()) == ("-", "--")
    assert "solid: centre, dashed: root" in side.get_title()


def test_locomotion_trajectory_leg_and_gait_figures(wall_run):
    from neuronav.bodies.desert_ant import LEGS
    from neuronav.scenarios.locomotion.figures import gait_diagram_figure, leg_traces_figure, trajectory_figure

    result, config = wall_run
    ax = trajectory_figure(result, config).axes[0]
    assert_legend_names_drawn_lines(ax)
    assert "wall" in legend_labels(ax)
    ts = result.timeseries
    time_s = np.arange(ts["mr_angles_rad"].shape[1]) * config.control_dt_s
    angles, torques = leg_traces_figure(ts, config, time_s).axes
    assert [line.get_label() for line in angles.lines] == ["ThCz", "CTr", "FTi"]
    np.testing.assert_allclose(angles.lines[1].get_ydata(), np.degrees(ts["mr_angles_rad"][0, :, 1]))
    assert_legend_names_drawn_lines(angles)
    gait = gait_diagram_figure(ts, config, time_s).axes[0]
    assert [t.get_text() for t in gait.get_yticklabels()] == list(LEGS[::-1])
