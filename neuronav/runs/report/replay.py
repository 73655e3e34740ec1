"""A trial's replay: one Plotly figure whose panels move together under one time slider.

Generic over what a run recorded in ``timeseries.h5`` (first axis: the trial), by shape and name:

=====================================  =========================================================
recorded (one trial's array)           drawn
=====================================  =========================================================
``position*`` (T, 2)                   the path, with a cursor at the ant's position and a
                                       heading tick (``heading*`` (T,), clockwise from +y, as
                                       the backends' heading sensor) at the current time; a
                                       ``position*_m`` (T, 3) too (x, y: seen from above)
``*position*`` (A, T, 2)               every agent's path (up to :data:`MAX_AGENTS`) and cursors
``time_s`` / ``cycle_time_s`` (T,)     the time of the series of the same length
(T,) other                             a line over time, with a vertical cursor
(T, n), n <= 4 (also (T, a, b))        n lines in one panel (odour left/right, wind components)
(T, n), n > 4                          a population: heatmap (unit × time), vertical cursor
``objects*_m`` (K, 3)                  the world: objects as circles of x, y, radius_m (trees, a
                                       landmark, the compass scene's objects); with a
                                       ``scene_yaw_rad`` (T,), turned by it in every frame
                                       (counter-clockwise about the origin, as
                                       ``Backend.set_scene_yaw``)
(N, 2) ``*route*/*trail*/*path*/       the world: a line (a learnt route, a training walk, an odour
*line*_m``                             trail's centre line, a finish line); with a number
                                       ``NAME_width_m`` beside ``NAME_m``, a band that wide under it
                                       (an odour trail's width)
(N, 2) / (2,) other ``*_m``            the world: points (puffs, homes, a source)
(H, W) with ``P_x_m`` / ``P_y_m``      the world: a map under the path (``landscape_novelty``,
(or ``NAME_x_m`` / ``NAME_y_m``)       ``plume_raster``): the axes give the x of each column and the
                                       y of each row (decreasing: row 0 drawn at the top)
(H, W) other                           an image panel (eye views, plume snapshot: pixel axes)
=====================================  =========================================================

A world array is one whatever its length (a trail of as many vertices as the path has samples). A
series is "over time" when its length is the length of the trial's ``time_s``, heading or path
(or one less). Series of other lengths that span the trial (per gait cycle) are placed by their own
``cycle_time_s`` or spread evenly over the trial. A trial padded with NaN (shorter than the longest)
is cut at its last sample. The slider has at most :data:`MAX_FRAMES` steps; long series are
thinned for drawing (:data:`MAX_POINTS`), the cursors read the full series.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from neuronav.runs.plotting import break_at_wraps

MAX_FRAMES = 200
"""Slider steps of a replay at most (the frames of the animation)."""
MAX_POINTS = 1500
"""Samples per drawn line or heatmap column at most."""
MAX_AGENTS = 100
"""Agents drawn of a many-agent run at most."""
MAX_AGENT_POINTS = 200
"""Points per drawn agent's path at most."""
MAX_IMAGES = 4
"""Image panels per replay at most."""
MAX_TIME_PANELS = 8
"""Time panels (populations and lines) per replay at most."""
PATH_COLOUR = "#d62728"
"""The path's colour (the browser test looks for it in a screenshot)."""
CURSOR_COLOUR = "#111111"
HEATMAP_CURSOR_COLOUR = "#ff00ff"
"""The time cursor over a heatmap (magenta: not in the viridis colour map)."""
MAX_MITRE = 4.0
"""A band's corner reaches at most this many half widths from its centre line (:func:`band_outline`)."""
WORLD_COLOUR = "#7f7f7f"
POINT_COLOURS = ("#2ca02c", "#1f77b4", "#ff7f0e", "#9467bd", "#8c564b", "#17becf")
"""The colours of a world's named points (nest, turn-back point, source, goal) in their recorded order."""


@dataclass
class TrialData:
    """One trial's recorded arrays, sorted by what the replay does with them."""

    trial: int
    path_name: str = ""
    path: np.ndarray | None = None
    heading: np.ndarray | None = None
    agents: np.ndarray | None = None
    times: dict[int, np.ndarray] = field(default_factory=dict)
    panels: list[tuple[str, np.ndarray]] = field(default_factory=list)
    world_lines: list[tuple[str, np.ndarray]] = field(default_factory=list)
    line_widths_m: dict[str, float] = field(default_factory=dict)  # a world line's width (m), by its name
    world_points: list[tuple[str, np.ndarray]] = field(default_factory=list)
    world_maps: list[tuple[str, np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)
    world_objects: list[tuple[str, np.ndarray]] = field(default_factory=list)
    scene_yaw: np.ndarray | None = None
    images: list[tuple[str, np.ndarray]] = field(default_factory=list)
    t_end: float = 0.0
    time_unit: str = "sample"


def replay_trials(series: dict[str, np.ndarray]) -> list[int]:
    """The trials whose path or heading was recorded (those a replay can show), in order."""
    paths = [a for name, a in series.items() if a.ndim >= 2 and (
        (a.ndim == 3 and _is_path(name, a[0])) or (a.ndim == 2 and name.startswith("heading")))]
    count = max((len(a) for a in paths), default=0)
    return [t for t in range(count) if any(t < len(a) and np.isfinite(a[t]).any() for a in paths)]


def trial_data(series: dict[str, np.ndarray], trial: int, config: dict | None = None) -> TrialData:
    """Sort the arrays of trial ``trial`` (index along every array's first axis) for drawing."""
    data = TrialData(trial=trial)
    own = {name: np.asarray(a)[trial] for name, a in series.items() if np.ndim(a) >= 1 and len(a) > trial}
    own = {name: _trimmed(a) for name, a in own.items()}
    axes = {n for p in own if own[p].ndim == 2 and _map_axes(p, own) for n in _map_axes(p, own)}
    for name, a in own.items():
        if data.path is None and _is_path(name, a) and a.ndim == 2:
            data.path_name, data.path = name, a[:, :2]
    for name in sorted(own):
        if name.startswith("heading") and own[name].ndim == 1 and data.heading is None:
            data.heading = own[name]
    if data.path is None:  # a turning ant that does not walk (visual compass): its pose at the origin
        if data.heading is None:
            raise ValueError(f"trial {trial} has no recorded path or heading")
        data.path_name, data.path = "heading only", np.zeros((len(data.heading), 2))
    clock = own.get("time_s")
    lengths = {len(data.path), len(data.path) - 1} | ({len(data.heading)} if data.heading is not None else set())
    if clock is not None and clock.ndim == 1 and len(clock) > 1:
        lengths.add(len(clock))
        data.t_end, data.time_unit = float(np.nanmax(clock)), "s"
        data.times[len(clock)] = clock
    else:
        data.t_end = float(max(lengths) - 1)
    cycle = own.get("cycle_time_s")
    if cycle is not None and cycle.ndim == 1 and data.time_unit == "s":
        data.times.setdefault(len(cycle), cycle)
    for name, a in own.items():
        if name in axes or name in ("time_s", "cycle_time_s") or name == data.path_name:
            continue
        if name.startswith("heading") and a is data.heading:
            continue
        _sort(data, name, a, own, lengths)
    for name, _ in data.world_lines:
        width = own.get(name[:-2] + "_width_m")
        if width is not None and np.ndim(width) == 0 and np.isfinite(width) and width > 0:
            data.line_widths_m[name] = float(width)
    yaw = own.get("scene_yaw_rad")
    if data.world_objects and yaw is not None and yaw.ndim == 1 and len(yaw) > 1:
        data.scene_yaw = yaw
    for label, point in _config_points(config or {}, data.path_name):
        data.world_points.append((label, point))
    data.panels = data.panels[:MAX_TIME_PANELS]
    data.images = data.images[:MAX_IMAGES]
    return data


def _sort(data: TrialData, name: str, a: np.ndarray, own: dict, lengths: set[int]) -> None:
    over_time = a.ndim >= 1 and len(a) > 1 and (len(a) in lengths or len(a) in data.times)
    if a.ndim == 1 and name.endswith("_m") and len(a) == 2:
        data.world_points.append((name, a[None, :]))
    elif a.ndim == 1 and over_time and np.issubdtype(a.dtype, np.number):
        data.panels.append((name, a.astype(float)))
    elif a.ndim == 2 and name.startswith("objects") and name.endswith("_m") and a.shape[1] == 3:
        data.world_objects.append((name, a))
    elif a.ndim == 2 and _map_axes(name, own):
        x_name, y_name = _map_axes(name, own)
        data.world_maps.append((name, a, own[x_name], own[y_name]))
    elif a.ndim == 2 and a.shape[1] == 2 and name.endswith("_m"):  # of any length, the path's too
        lines = any(word in name for word in ("route", "trail", "path", "position", "line"))
        (data.world_lines if lines else data.world_points).append((name, a))
    elif a.ndim == 2 and over_time:
        data.panels.append((name, a.astype(float)))
    elif a.ndim == 2 and min(a.shape) > 1:
        data.images.append((name, a.astype(float)))
    elif a.ndim == 3 and a.shape[-1] == 2 and "position" in name:
        data.agents = a[:MAX_AGENTS] if data.agents is None else data.agents
    elif a.ndim == 3 and over_time:
        data.panels.append((name, a.reshape(len(a), -1).astype(float)))


def figure(data: TrialData, title: str = "") -> dict:
    """The replay of one trial as a Plotly figure dict (``data``, ``layout``, ``frames``): the world and
    path on the left, the time panels on the right, images below, and one slider (with play/pause)
    moving every cursor; one frame per slider step.

    ``layout.meta`` holds ``{"frame_times": [...], "time_unit": ...}``: the time of each slider step.
    """
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    n_time = len(data.panels)
    body_rows = max(n_time, 2)
    image_rows = (len(data.images) + 1) // 2
    rows = body_rows + image_rows
    specs = [[{"rowspan": body_rows}, {} if n_time else None]]
    specs += [[None, {} if r < n_time else None] for r in range(1, body_rows)]
    specs += [[{}, {} if 2 * i + 1 < len(data.images) else None] for i in range(image_rows)]
    titles = ([f"path ({data.path_name})"] + [name for name, _ in data.panels]
              + [f"{name} (pixels)" for name, _ in data.images])
    height_px = max(440, 190 * rows)
    fig = make_subplots(rows=rows, cols=2, specs=specs, column_widths=[0.45, 0.55], subplot_titles=titles,
                        horizontal_spacing=0.08, vertical_spacing=min(60 / height_px, 0.9 / max(rows - 1, 1)))
    path = data.path
    frames_n = max(2, min(MAX_FRAMES, len(path)))
    fractions = np.linspace(0.0, 1.0, frames_n)
    frame_times = fractions * data.t_end
    _draw_world(fig, go, data)
    cursors: list[tuple[int, callable]] = []  # (trace index, fraction -> trace update)
    if data.scene_yaw is not None:  # the objects turn with the scene
        cursors += [(i, lambda f, objects=objects: _objects_at(data, objects, f)) for i, (_, objects) in
                    zip([k for k, t in enumerate(fig.data) if t.name in dict(data.world_objects)], data.world_objects)]
    thin = _thin_index(len(path))
    fig.add_trace(go.Scatter(x=path[thin, 0], y=path[thin, 1], mode="lines", name="path",
                             line={"color": PATH_COLOUR, "width": 2}), row=1, col=1)
    fig.add_trace(go.Scatter(x=path[:1, 0], y=path[:1, 1], mode="markers", name="start",
                             marker={"color": PATH_COLOUR, "symbol": "circle-open", "size": 10}), row=1, col=1)
    span = float(np.nanmax(np.ptp(path, axis=0))) if len(path) > 1 else 0.0
    if span <= 0:  # no path: a heading tick in a fixed frame (holding the world's objects, if any)
        reach = max([1.0] + [float(np.nanmax(np.abs(o[:, :2]).max(axis=1) + o[:, 2])) for _, o in data.world_objects
                             if np.isfinite(o).all(axis=1).any()])
        span = (0.9 if reach == 1.0 else 0.25 * reach) / 0.06  # the tick: 0.9 of the unit frame, or a quarter
        fig.update_xaxes(range=[-1.1 * reach, 1.1 * reach], row=1, col=1)
        fig.update_yaxes(range=[-1.1 * reach, 1.1 * reach], row=1, col=1)
    elif data.world_objects:  # a forest reaching far beyond the walk: open on the path and the world's points
        low, high = _view_box(data)
        fig.update_xaxes(range=[low[0], high[0]], row=1, col=1)
        fig.update_yaxes(range=[low[1], high[1]], row=1, col=1)
    tick = 0.06 * span
    fig.add_trace(go.Scatter(mode="lines+markers", name="ant", showlegend=False,
                             line={"color": CURSOR_COLOUR, "width": 3},
                             marker={"color": CURSOR_COLOUR, "size": [11, 0]}, **_pose(data, 0.0, tick)),
                  row=1, col=1)
    cursors.append((len(fig.data) - 1, lambda f: _pose(data, f, tick)))
    if data.agents is not None:
        fig.add_trace(go.Scatter(mode="lines", name="agents' paths", hoverinfo="skip", **_agent_paths(data.agents),
                                 line={"color": "rgba(90,90,90,0.35)", "width": 1}), row=1, col=1)
        fig.add_trace(go.Scatter(mode="markers", name="agents", showlegend=False,
                                 marker={"color": CURSOR_COLOUR, "size": 4}, **_agents(data.agents, 0.0)), row=1, col=1)
        cursors.append((len(fig.data) - 1, lambda f: _agents(data.agents, f)))
    metres = data.path_name.endswith("_m") or bool(data.world_objects)
    fig.update_xaxes(title_text="x (m)" if metres else "x", row=1, col=1)
    fig.update_yaxes(title_text="y (m)" if metres else "y", scaleanchor="x", scaleratio=1,
                     row=1, col=1)
    _time_panels(fig, go, data, cursors)
    _images(fig, data, first_row=body_rows + 1)
    fig.update_layout(
        title={"text": title or f"trial {data.trial}", "x": 0.01},
        height=height_px + 110, margin={"l": 50, "r": 20, "t": 60, "b": 150},
        legend={"orientation": "h", "yref": "container", "y": 0.0, "yanchor": "bottom", "x": 0.0},
        meta={"frame_times": [float(t) for t in frame_times], "time_unit": data.time_unit},
        **_controls(frame_times, data.time_unit))
    # The frames only move the cursors: plain dicts, as Plotly's JSON has them (building them as
    # validated graph objects took most of a report's time).
    indices = [i for i, _ in cursors]
    spec = fig.to_plotly_json()
    spec["frames"] = [{"name": str(k), "traces": indices,
                       "data": [{"type": "scatter", **update(f)} for _, update in cursors]}
                      for k, f in enumerate(fractions)]
    return spec


def _controls(frame_times: np.ndarray, unit: str) -> dict:
    """The slider (one step per frame, labelled by its time) and the play/pause buttons.

    Frames are shown with redraw off (smooth playing): only the cursors' traces change.
    """
    animate = {"mode": "immediate", "frame": {"duration": 0, "redraw": False}, "transition": {"duration": 0}}
    steps = [{"method": "animate", "label": f"{t:.3g}", "args": [[str(k)], animate]} for k, t in enumerate(frame_times)]
    play = {**animate, "frame": {"duration": 60, "redraw": False}, "fromcurrent": True}
    return {"sliders": [{"active": 0, "steps": steps, "pad": {"t": 45}, "len": 0.88, "x": 0.12,
                         "currentvalue": {"prefix": f"time ({unit}): ", "font": {"color": "#222", "size": 13}},
                         "font": {"color": "rgba(0,0,0,0)"}, "ticklen": 0, "minorticklen": 0}],  # no step labels
            "updatemenus": [{"type": "buttons", "direction": "left", "x": 0.0, "y": 0, "xanchor": "left",
                             "yanchor": "top", "pad": {"t": 50}, "showactive": False, "buttons": [
                                 {"label": "play", "method": "animate", "args": [None, play]},
                                 {"label": "pause", "method": "animate", "args": [[None], animate]}]}]}


def is_angle(name: str) -> bool:
    """Whether a recorded series is an angle that wraps at ±π (a heading or phase in radians)."""
    return name.endswith("_rad") and any(word in name for word in ("heading", "phase", "yaw", "bearing"))


def _time_panels(fig, go, data: TrialData, cursors: list) -> None:
    """The right column: each population as a heatmap, each other series as lines, over one time axis,
    each with a vertical time cursor (appended to ``cursors``)."""
    first_time_axis = None
    for row, (name, values) in enumerate(data.panels, start=1):
        times = _times_of(data, len(values))
        keep = _thin_index(len(values))
        if values.ndim == 2 and values.shape[1] > 4:
            low, high = -0.5, values.shape[1] - 0.5
            _raster(fig, values[keep].T, (float(times[0]), float(times[-1])), (low, high), row, 2, "viridis")
            fig.update_xaxes(showgrid=False, row=row, col=2)
            fig.update_yaxes(showgrid=False, zeroline=False, row=row, col=2)
        else:
            columns = values if values.ndim == 2 else values[:, None]
            for j in range(columns.shape[1]):
                label = name if columns.shape[1] == 1 else f"{name}[{j}]"
                x, y = times[keep], columns[keep, j]
                if is_angle(name):
                    x, y = break_at_wraps(x, y)
                fig.add_trace(go.Scatter(x=x, y=y, mode="lines", name=label,
                                         showlegend=False, line={"width": 1}), row=row, col=2)
            finite = columns[np.isfinite(columns)]
            low, high = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
            if high <= low:
                low, high = low - 0.5, high + 0.5
        colour = HEATMAP_CURSOR_COLOUR if values.ndim == 2 and values.shape[1] > 4 else CURSOR_COLOUR
        fig.add_trace(go.Scatter(x=[0.0, 0.0], y=[low, high], mode="lines", showlegend=False, name=f"{name} cursor",
                                 line={"color": colour, "width": 2}), row=row, col=2)
        cursors.append((len(fig.data) - 1, lambda f, low=low, high=high: {
            "x": [f * data.t_end, f * data.t_end], "y": [low, high]}))
        axis = fig.get_subplot(row, 2).xaxis.plotly_name.replace("axis", "")
        first_time_axis = first_time_axis or axis
        fig.update_xaxes(range=[0, data.t_end], matches=None if axis == first_time_axis else first_time_axis,
                         row=row, col=2)
        fig.update_yaxes(range=[low, high], row=row, col=2)
    if data.panels:
        fig.update_xaxes(title_text=f"time ({data.time_unit})", row=len(data.panels), col=2)


def _images(fig, data: TrialData, first_row: int) -> None:
    """The recorded images (eye views, a plume snapshot), two per row from ``first_row``, pixel axes."""
    for i, (name, image) in enumerate(data.images):
        row, col = first_row + i // 2, 1 + i % 2
        height, width = image.shape
        _raster(fig, image, (-0.5, width - 0.5), (-0.5, height - 0.5), row, col,
                "gray" if "eye" in name or "view" in name else "viridis", origin="upper")
        fig.update_xaxes(range=[-0.5, width - 0.5], showgrid=False, zeroline=False, row=row, col=col)
        fig.update_yaxes(range=[-0.5, height - 0.5], showticklabels=False, showgrid=False, zeroline=False,
                         row=row, col=col)


def _draw_world(fig, go, data: TrialData) -> None:
    for name, z, x, y in data.world_maps:
        x_half, y_half = _half_step(x), _half_step(y)
        x_span = (float(np.min(x)) - x_half, float(np.max(x)) + x_half)
        y_span = (float(np.min(y)) - y_half, float(np.max(y)) + y_half)
        _raster(fig, z, x_span, y_span, 1, 1, "Blues", opacity=0.6, own_range=True,
                origin="upper" if len(y) > 1 and y[0] > y[-1] else "lower")
        fig.add_trace(go.Scatter(x=list(x_span), y=list(y_span), mode="markers", name=name, showlegend=False,
                                 hoverinfo="skip", marker={"opacity": 0}), row=1, col=1)  # the map in the view
    for name, line in data.world_lines:
        keep = _thin_index(len(line))
        if name in data.line_widths_m:  # the band the line is the centre of, under it
            band = band_outline(line[keep], data.line_widths_m[name])
            fig.add_trace(go.Scatter(x=band[:, 0].tolist(), y=band[:, 1].tolist(), mode="lines", name=f"{name} band",
                                     fill="toself", fillcolor="rgba(160,110,40,0.25)", hoverinfo="skip",
                                     line={"color": "rgba(160,110,40,0.5)", "width": 0.5}), row=1, col=1)
        fig.add_trace(go.Scatter(x=line[keep, 0], y=line[keep, 1], mode="lines", name=name,
                                 line={"color": WORLD_COLOUR, "width": 1, "dash": "dot"}), row=1, col=1)
    for name, objects in data.world_objects:  # circles of their radius, one trace
        fig.add_trace(go.Scatter(mode="lines", name=name, fill="toself", fillcolor="rgba(127,127,127,0.25)",
                                 line={"color": WORLD_COLOUR, "width": 1}, **_objects_at(data, objects, 0.0)),
                      row=1, col=1)
    for k, (name, points) in enumerate(data.world_points):
        few = len(points) <= 5  # a source, a home: stars, each named point its own colour; puffs, many homes: dots
        colour = POINT_COLOURS[k % len(POINT_COLOURS)] if few else "#9ecae1"
        fig.add_trace(go.Scatter(x=points[:, 0], y=points[:, 1], mode="markers", name=name,
                                 marker={"color": colour, "size": 12 if few else 5,
                                         "symbol": "star" if few else "circle"}), row=1, col=1)


def band_outline(line_m: np.ndarray, width_m: float) -> np.ndarray:
    """The closed outline (2 V + 1, 2) of a band ``width_m`` wide along a polyline (V, 2): each side is the
    line moved half the width along its segments' normals, mitred at the vertices (so that every edge of the
    outline runs half the width from its segment; a mitre at a turn sharper than about 150° is cut at
    :data:`MAX_MITRE` times the half width; a full reversal gets a square cap). Repeated vertices are dropped."""
    line = np.asarray(line_m, float)[:, :2]
    line = line[np.r_[True, np.hypot(*np.diff(line, axis=0).T) > 0]]
    if len(line) < 2:
        return line
    segment = np.diff(line, axis=0)
    segment /= np.hypot(segment[:, 0], segment[:, 1])[:, None]
    normal = np.column_stack([-segment[:, 1], segment[:, 0]])  # (V - 1, 2), to the left of each segment
    mitre = np.vstack([normal[:1], normal[:-1] + normal[1:], normal[-1:]])
    length = np.hypot(mitre[:, 0], mitre[:, 1])
    along = np.vstack([normal[:1], normal])  # the normal of the segment each vertex ends (the first: starts)
    # Where the line turns back on itself the normals cancel: a square cap there, each side half the width
    # on across the turn (ahead of it on the left, behind it on the right), not a band pinched to nothing.
    back = length < 1e-9
    mitre[back] = segment[np.flatnonzero(back) - 1]
    mitre[~back] /= length[~back, None]
    scale = np.where(back, 1.0, 1.0 / np.maximum((mitre * along).sum(axis=1), 1.0 / MAX_MITRE))
    offset = mitre * (scale * width_m / 2.0)[:, None]
    left, right = line + offset, line - offset
    return np.vstack([left, right[::-1], left[:1]])


def _objects_at(data: TrialData, objects: np.ndarray, fraction: float) -> dict:
    """Circles (x, y, radius_m rows) as one line trace's ``x``/``y``, None between circles; turned by the
    scene's yaw at ``fraction`` of the trial when it was recorded (then coarser: they move in every frame)."""
    turning = data.scene_yaw is not None
    angle = np.append(np.linspace(0.0, 2.0 * np.pi, 13 if turning else 25), np.nan)
    circles = objects[np.isfinite(objects).all(axis=1)]
    if turning:  # counter-clockwise about the origin, as Backend.set_scene_yaw turns the objects
        yaw = float(np.nan_to_num(_at(data.scene_yaw, fraction)))
        centres = circles[:, :2] @ np.array([[np.cos(yaw), np.sin(yaw)], [-np.sin(yaw), np.cos(yaw)]])
        circles = np.c_[centres, circles[:, 2]]
    x = (circles[:, :1] + circles[:, 2:3] * np.cos(angle)).ravel()
    y = (circles[:, 1:2] + circles[:, 2:3] * np.sin(angle)).ravel()
    decimals = 2 if turning else 3  # to the cm or mm: hundreds of trees, or a turning scene's frames, stay light
    return {axis: [None if np.isnan(v) else round(float(v), decimals) for v in values]
            for axis, values in (("x", x), ("y", y))}


def _raster(fig, z: np.ndarray, x_span: tuple[float, float], y_span: tuple[float, float], row: int, col: int,
            colormap: str, opacity: float = 1.0, origin: str = "lower", own_range: bool = False) -> None:
    """``z`` drawn as a PNG under the axes of panel (row, col), spanning ``x_span`` × ``y_span``.

    A layout image rather than a heatmap trace: Plotly clears heatmap traces when an animation
    (redraw off, which keeps playing smooth) moves other traces (plotly.js issue 4491). ``origin``
    "lower": row 0 of ``z`` at the bottom (a population's unit 0, a map's lowest y); "upper": at the top.
    ``own_range``: coloured over its own finite range even inside 0..1 (a world map: a faint plume).
    """
    subplot = fig.get_subplot(row, col)
    fig.add_layout_image(source=_png(z, colormap, flip=origin == "lower", own_range=own_range),
                         xref=subplot.xaxis.plotly_name.replace("axis", ""),
                         yref=subplot.yaxis.plotly_name.replace("axis", ""),
                         x=x_span[0], y=y_span[1], sizex=x_span[1] - x_span[0], sizey=y_span[1] - y_span[0],
                         xanchor="left", yanchor="top", sizing="stretch", layer="below", opacity=opacity)


def _png(z: np.ndarray, colormap: str, flip: bool, own_range: bool = False) -> str:
    """``z`` coloured by the matplotlib colour map (its finite range, or 0..1 when it lies inside it and
    not ``own_range``; NaN transparent) as a PNG data URI."""
    import base64
    import io

    from matplotlib import colormaps
    from PIL import Image

    z = np.asarray(z, float)
    finite = np.isfinite(z)
    low, high = (float(z[finite].min()), float(z[finite].max())) if finite.any() else (0.0, 1.0)
    if 0.0 <= low and high <= 1.0 and not own_range:  # intensities (eye images): the same scale in every panel
        low, high = 0.0, 1.0
    scaled = np.where(finite, (z - low) / (high - low) if high > low else 0.5, 0.0)
    rgba = (colormaps[colormap](scaled) * 255).round().astype(np.uint8)
    rgba[..., 3] = np.where(finite, 255, 0)
    buffer = io.BytesIO()
    Image.fromarray(rgba[::-1] if flip else rgba, "RGBA").save(buffer, format="PNG", optimize=True)
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")


def _half_step(axis: np.ndarray) -> float:
    return float(np.abs(np.diff(axis)).mean()) / 2 if len(axis) > 1 else 0.5


def _pose(data: TrialData, fraction: float, tick: float) -> dict:
    """The ant's cursor at ``fraction`` of the trial: its position and a heading tick."""
    x, y = _at(data.path, fraction)
    if data.heading is not None and np.isfinite(_at(data.heading, fraction)):
        angle = float(_at(data.heading, fraction))
        # Clockwise from +y, as the backends' heading sensor (neuronav.engine.backend) and every scenario log it.
        return {"x": [float(x), float(x + tick * np.sin(angle))], "y": [float(y), float(y + tick * np.cos(angle))]}
    return {"x": [float(x), float(x)], "y": [float(y), float(y)]}


def _agent_paths(agents: np.ndarray) -> dict:
    """Every agent's path (A, T, 2) as one line trace's ``x``/``y``, None between agents, each thinned to at most
    :data:`MAX_AGENT_POINTS` points."""
    keep = np.unique(np.linspace(0, agents.shape[1] - 1, min(agents.shape[1], MAX_AGENT_POINTS)).round().astype(int))
    x, y = [], []
    for path in agents[:, keep].astype(float):
        x += [*path[:, 0].tolist(), None]
        y += [*path[:, 1].tolist(), None]
    return {"x": x, "y": y}


def _agents(agents: np.ndarray, fraction: float) -> dict:
    index = int(round(fraction * (agents.shape[1] - 1)))
    return {"x": agents[:, index, 0].astype(float).tolist(), "y": agents[:, index, 1].astype(float).tolist()}


def _at(values: np.ndarray, fraction: float):
    return values[int(round(fraction * (len(values) - 1)))]


def _times_of(data: TrialData, length: int) -> np.ndarray:
    if length in data.times:
        return np.asarray(data.times[length], float)
    return np.linspace(0.0, data.t_end, length)


def _thin_index(length: int) -> np.ndarray:
    return np.unique(np.linspace(0, length - 1, min(length, MAX_POINTS)).round().astype(int))


def _trimmed(a: np.ndarray) -> np.ndarray:
    """``a`` without the NaN padding after a trial's last sample (along its first axis)."""
    if a.ndim == 0 or not np.issubdtype(a.dtype, np.floating) or len(a) == 0:
        return a
    finite = np.isfinite(a.reshape(len(a), -1)).any(axis=1)
    last = np.flatnonzero(finite)
    return a[: last[-1] + 1] if len(last) else a[:0]


def _is_path(name: str, a: np.ndarray) -> bool:
    """A path: ``position*`` (T, 2), or (T, 3) in metres (x, y, z: drawn from above)."""
    return name.startswith("position") and a.ndim == 2 and (
        a.shape[-1] == 2 or (a.shape[-1] == 3 and name.endswith("_m")))


def _view_box(data: TrialData) -> tuple[np.ndarray, np.ndarray]:
    """The (x, y) corners of the box holding the path, the world's lines and points and maps (not its
    objects), with a margin of a tenth of its size (at least 0.5 m)."""
    pieces = [data.path, *(line for _, line in data.world_lines), *(points for _, points in data.world_points)]
    pieces += [np.array([[np.min(x), np.min(y)], [np.max(x), np.max(y)]]) for _, _, x, y in data.world_maps]
    every = np.concatenate([np.asarray(p, float).reshape(-1, 2) for p in pieces])
    every = every[np.isfinite(every).all(axis=1)]
    low, high = every.min(axis=0), every.max(axis=0)
    margin = max(0.1 * float(np.max(high - low)), 0.5)
    return low - margin, high + margin


def _map_axes(name: str, own: dict) -> tuple[str, str] | None:
    """The names of a map's axis vectors, ``NAME_x_m``/``NAME_y_m`` or ``STEM_x_m``/``STEM_y_m``, if recorded."""
    for base in (name, _stem(name)):
        if f"{base}_x_m" in own and f"{base}_y_m" in own:
            return f"{base}_x_m", f"{base}_y_m"
    return None


def _stem(name: str) -> str:
    for suffix in ("_novelty", "_m", "_rad"):
        if name.endswith(suffix):
            return name[: -len(suffix)]
    return name.rsplit("_", 1)[0] if "_" in name else name


def _config_points(config: dict, path_name: str) -> list[tuple[str, np.ndarray]]:
    """World points a scenario's settings name (in metres, so only beside a path in metres)."""
    if not path_name.endswith("_m"):
        return []
    found = []
    for key in config:
        if key.endswith("_x_m") and key[:-4] in ("source", "goal", "beacon", "nest", "feeder", "landmark"):
            y = config.get(key[:-4] + "_y_m", 0.0)
            if isinstance(config[key], (int, float)) and isinstance(y, (int, float)):
                found.append((key[:-4], np.array([[float(config[key]), float(y)]])))
    return found
