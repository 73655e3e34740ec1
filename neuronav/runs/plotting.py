"""Circuit introspection plots and small helpers shared by the scenarios' figures (matplotlib).

Figures are built as :class:`matplotlib.figure.Figure` objects without pyplot: no global figure
registry, no backend switch, nothing to close. A figure function draws one figure and returns it, so
a test can read what was drawn; :func:`save` writes it.

Trials per condition, as every scenario's summary figures draw them: :func:`condition_strip` (each trial a
point, the condition's mean, median or circular mean with its seeded bootstrap 95 % interval, n in the tick
labels, optionally over a box plot) and :func:`proportion_points` (each outcome at 1 or 0, the proportion
with its Wilson 95 % interval); the statistics are :mod:`neuronav.runs.stats`'s.

The circuit diagram is laid out by :func:`circuit_layout` (deterministic: a function of the
populations' names, kinds and undelayed connections only) and its edges are routed by
:func:`edge_route` so that no edge crosses a population it does not connect.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.rundir import write_atomic

KIND_COLOURS = {"input": "#8dd3c7", "rate": "#80b1d3", "leaky": "#bebada", "integrator": "#fdb462",
                "output": "#fb8072"}
KIND_ORDER = ("input", "rate", "leaky", "integrator", "output")
EDGE_COLOURS = {"excitatory": "tab:red", "inhibitory": "tab:blue", "mixed sign": "0.45"}
# Node radius (data units; columns and rows are 1 apart) for the smallest and the largest population.
MIN_RADIUS, MAX_RADIUS = 0.12, 0.24
# Curvatures tried in turn for an edge (control point offset, as a fraction of the edge's length).
CURVATURES = (0.0, 0.15, -0.15, 0.3, -0.3, 0.45, -0.45, 0.6, -0.6, 0.8, -0.8, 1.0, -1.0, 1.3, -1.3)
CLEARANCE = 1.15  # an edge keeps this many radii away from every population it does not connect
GAP = 0.06  # an arrow starts and ends this far (data units) outside the rims it joins, heads included


def new_figure(figsize=(6.0, 4.0), nrows: int = 1, ncols: int = 1, **subplot_kw):
    """A pyplot-free Figure and its axes (as ``plt.subplots`` returns them)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)  # a real canvas: layout reuses its renderer instead of a throw-away print
    axes = fig.subplots(nrows, ncols, **subplot_kw)
    return fig, axes


def save(fig, path, tight: bool = True) -> Path:
    """Lay out (unless ``tight`` is False: a figure with a shared colourbar) and write a PNG, drawn once,
    atomically (:func:`neuronav.runs.rundir.write_atomic`).

    At the figure's own 100 dpi (a 6 × 4 in figure is 600 × 400 px), so the text extents the layout
    measured are the ones the save draws. The layout engine ``tight_layout`` leaves behind is dropped:
    with it, ``savefig`` runs one more full draw (without output) before the real one. A 1 s
    locomotion run's three figures took 0.21 s to lay out and save at 120 dpi, 0.18 s at 100 dpi and
    0.15 s drawn once (matplotlib already imported; 3 runs each, the same PNGs byte for byte for the
    last change).
    """
    if tight:
        fig.tight_layout()
        fig.set_layout_engine(None)  # else savefig draws it once more to run a placeholder engine
    path = Path(path)
    # As the data files are written: a temporary file renamed over the name, so a link standing
    # there is replaced, never written through, and a reader never sees half a figure.
    write_atomic(path, lambda stream: fig.savefig(stream, format=path.suffix[1:] or "png", dpi=100,
                                                  pil_kwargs={"compress_level": 1}))
    return path


def break_at_wraps(time, angle_rad):
    """Angles wrapped to [-π, π), carried to the edge at each wrap, for a line plot without a gap or a false jump.

    Where consecutive samples wrap (they differ by more than π), the line between them (the shorter way
    round, linear in time) meets the edge ±π at a crossing time: the piece before ends there on one edge,
    a NaN breaks the line, and the next piece starts at the same time on the other edge. Samples are kept
    as they are; a NaN sample breaks the line as before.

    Parameters
    ----------
    time : array_like, shape (n,)
    angle_rad : array_like, shape (n,)

    Returns
    -------
    time, angle_rad : ndarray, shape (n + 3 * wraps,)
    """
    time = np.asarray(time, float)
    wrapped = np.mod(np.asarray(angle_rad, float) + np.pi, 2 * np.pi) - np.pi
    steps = np.diff(wrapped)
    with np.errstate(invalid="ignore"):
        wraps = np.flatnonzero(np.abs(steps) > np.pi)
    delta = np.mod(steps[wraps] + np.pi, 2 * np.pi) - np.pi  # the shorter way round, across the edge
    edge = np.copysign(np.pi, delta)
    fraction = (edge - wrapped[wraps]) / delta
    crossing_s = time[wraps] + fraction * (time[wraps + 1] - time[wraps])
    at = np.repeat(wraps + 1, 3)
    angles = np.stack([edge, np.full_like(edge, np.nan), -edge], axis=1).ravel()
    return np.insert(time, at, np.repeat(crossing_s, 3)), np.insert(wrapped, at, angles)


def heading_panel(ax, time, heading_rad, turn_at, time_label: str) -> None:
    """Heading (degrees, broken at ±180°) against time on ``ax``, a dashed line at ``turn_at``."""
    t, heading = break_at_wraps(time, heading_rad)
    ax.plot(t, np.degrees(heading), lw=0.8, gid="heading")
    ax.axvline(turn_at, color="k", ls="--")
    ax.set_ylim(-180, 180)
    ax.set_ylabel("heading (deg)")
    ax.set_xlabel(time_label)


def trial_colour(i: int) -> str:
    """The colour of trial ``i`` (matplotlib's ten-colour cycle)."""
    return f"C{i % 10}"


# -- trials per condition: points, a centre and its interval -----------------------------------------
CENTRE_LABELS = {"mean": "mean, 95 % CI", "median": "median, 95 % CI", "circular": "circular mean, 95 % CI"}


def strip_offsets(n: int, width: float = 0.3, seed: int = 0) -> np.ndarray:
    """Horizontal offsets of ``n`` points of one group: evenly spread over ``[-width/2, width/2]`` and put
    in a seeded random order (so that sorted values do not draw a diagonal). The same every time."""
    if n <= 1:
        return np.zeros(n)
    return np.random.default_rng(seed).permutation(np.linspace(-width / 2, width / 2, n))


def _centre(values: np.ndarray, centre: str, seed: int) -> tuple[float, list[float]]:
    """The group's centre and its 95 % percentile-bootstrap interval (:mod:`neuronav.runs.stats`, seeded);
    NaNs for an empty group, a NaN interval for one value. ``circular``: values in degrees."""
    from neuronav.runs.stats import circular_summary, describe
    from neuronav.runs.summary_statistics import resamples_for

    resamples = resamples_for(max(values.size, 1))
    if centre == "circular":
        block = circular_summary(np.radians(values), seed=seed, n_resamples=resamples)
        return float(np.degrees(block["mean_rad"])), [float(np.degrees(v)) for v in block["mean_ci_rad"]]
    block = describe(values, seed=seed, n_resamples=resamples)
    return block[centre], list(block[f"{centre}_ci"])


def condition_strip(ax, groups, *, positions=None, colours=None, centre: str = "mean", box: bool = False,
                    width: float = 0.3, seed: int = 0, gid: str = "values", tick_labels: bool = True,
                    marker_size: float = 5.0, legend: bool = True) -> dict[str, dict]:
    """Every trial of each condition as a point, and the condition's centre with its 95 % interval.

    Parameters
    ----------
    ax : matplotlib Axes
    groups : mapping of str to sequence of float
        Condition name -> one value per trial (NaN or None: missing, e.g. the time of an ant that never
        arrived; left out of the points and the statistics, and counted in the tick label).
    positions : sequence of float, optional
        x of each group (default 0, 1, 2, ...).
    colours : mapping of str to colour, optional
        Point colour per group (default: matplotlib's cycle).
    centre : {"mean", "median", "circular"}
        The statistic drawn (a black diamond ``0.85 width`` right of the group's x) with its seeded
        percentile-bootstrap 95 % interval (:func:`neuronav.runs.stats.describe`; ``circular``: values
        are angles in degrees, :func:`neuronav.runs.stats.circular_summary`, its interval not wrapped).
    box : bool
        Draw a box plot (median, quartiles, whiskers; no fliers) under the points.
    width : float
        Horizontal spread of a group's points (data units); their offsets are :func:`strip_offsets`.
    seed : int
        Seed of the offsets and of the bootstrap.
    gid : str
        The points of group ``name`` are the line with gid ``"{gid} {name}"``; its centre the errorbar
        line with gid ``"{gid} {name} {centre}"``.
    tick_labels : bool
        Label the x ticks ``name (n = k)``, or ``name (n = k of m)`` when values were missing.
    legend : bool
        Name the centre marker in the legend (once).

    Returns
    -------
    dict
        Name -> ``{"n", "n_missing", "position", "centre", "ci"}``.
    """
    if centre not in CENTRE_LABELS:
        raise ValueError(f"centre must be one of {', '.join(CENTRE_LABELS)}, got {centre!r}")
    names = list(groups)
    positions = list(range(len(names))) if positions is None else [float(p) for p in positions]
    drawn: dict[str, dict] = {}
    for k, (name, position) in enumerate(zip(names, positions)):
        raw = np.array([np.nan if v is None else v for v in groups[name]], float).reshape(-1)
        values = raw[np.isfinite(raw)]
        colour = (colours or {}).get(name, f"C{k % 10}")
        if box and values.size:
            ax.boxplot([values], positions=[position], widths=width * 1.5, showfliers=False, manage_ticks=False,
                       medianprops=dict(color="0.3"), zorder=1)
        ax.plot(position + strip_offsets(values.size, width, seed), values, "o", color=colour, alpha=0.65,
                ms=marker_size, mec="none", zorder=2, gid=f"{gid} {name}")
        middle, interval = _centre(values, centre, seed)
        error = np.nan_to_num([[middle - interval[0]], [interval[1] - middle]])
        bars = ax.errorbar(position + 0.85 * width, middle, yerr=error, fmt="D", color="k", ms=5, capsize=3,
                           zorder=3, label=CENTRE_LABELS[centre] if legend and k == 0 else None)
        bars.lines[0].set_gid(f"{gid} {name} {centre}")  # the marker only, not its caps
        drawn[name] = {"n": int(values.size), "n_missing": int(raw.size - values.size), "position": position,
                       "centre": middle, "ci": interval}
    if tick_labels and names:
        ax.set_xticks(positions, [f"{name}\n(n = {d['n']}" + (f" of {d['n'] + d['n_missing']})" if d["n_missing"]
                                                              else ")") for name, d in drawn.items()])
        ax.set_xlim(min(positions) - 0.5, max(positions) + 0.5 + width / 2)
    return drawn


def success_text(outcomes) -> str:
    """``"success k of n = p % (Wilson 95 % CI low–high %)"`` for a sequence of true/false outcomes (None
    or NaN left out), for a title (:func:`neuronav.runs.stats.success_rate`)."""
    from neuronav.runs.stats import success_rate

    known = [bool(v) for v in outcomes if v is not None and not (isinstance(v, float) and np.isnan(v))]
    block = success_rate(sum(known), len(known))
    low, high = block["ci"]
    return (f"success {block['successes']} of {block['n']} = {100 * block['rate']:.0f} % "
            f"(Wilson 95 % CI {100 * low:.0f}–{100 * high:.0f} %)")


def proportion_points(ax, groups, *, positions=None, colours=None, width: float = 0.3, seed: int = 0,
                      gid: str = "success", tick_labels: bool = True, legend: bool = True) -> dict[str, dict]:
    """Each trial's outcome as a point at 1 (success) or 0, and each condition's proportion with its
    Wilson 95 % interval (:func:`neuronav.runs.stats.success_rate`).

    Parameters
    ----------
    ax : matplotlib Axes
    groups : mapping of str to sequence of bool
        Condition name -> one outcome per trial (None or NaN: unknown, left out).
    positions, colours, width, seed, tick_labels, legend
        As in :func:`condition_strip`.
    gid : str
        The outcomes of group ``name`` are the line with gid ``"{gid} {name}"``, the proportion the
        errorbar line ``"{gid} {name} rate"``.

    Returns
    -------
    dict
        Name -> :func:`neuronav.runs.stats.success_rate`'s block plus ``position``.
    """
    from neuronav.runs.stats import success_rate

    names = list(groups)
    positions = list(range(len(names))) if positions is None else [float(p) for p in positions]
    drawn: dict[str, dict] = {}
    for k, (name, position) in enumerate(zip(names, positions)):
        raw = np.array([np.nan if v is None else float(v) for v in groups[name]], float).reshape(-1)
        outcomes = raw[np.isfinite(raw)]
        colour = (colours or {}).get(name, f"C{k % 10}")
        ax.plot(position + strip_offsets(outcomes.size, width, seed), outcomes, "o", color=colour, alpha=0.5,
                ms=5, mec="none", zorder=2, gid=f"{gid} {name}")
        block = success_rate(int(outcomes.sum()), int(outcomes.size))
        low, high = block["ci"]  # Wilson's bound at 0 of n can sit 1e-17 past the rate: no negative bar
        rate = block["rate"]
        error = np.clip(np.nan_to_num([[rate - low], [high - rate]]), 0.0, None)
        bars = ax.errorbar(position + 0.85 * width, rate, yerr=error,
                           fmt="s", color="k", ms=5, capsize=3, zorder=3,
                           label="proportion, Wilson 95 % CI" if legend and k == 0 else None)
        bars.lines[0].set_gid(f"{gid} {name} rate")
        drawn[name] = dict(block, position=position)
    if tick_labels and names:
        ax.set_xticks(positions, [f"{name}\n({d['successes']} of {d['n']})" for name, d in drawn.items()])
        ax.set_xlim(min(positions) - 0.5, max(positions) + 0.5 + width / 2)
    ax.set_ylim(-0.08, 1.08)
    return drawn


# -- connectivity matrix -------------------------------------------------------------------------
def plot_connectivity(circuit, ax=None):
    """The whole circuit's weight matrix (targets x sources) with population blocks labelled."""
    matrix, blocks = circuit.weight_matrix()
    if ax is None:
        _, ax = new_figure((7, 6))
    limit = float(np.abs(matrix).max()) or 1.0
    image = ax.imshow(matrix, cmap="RdBu_r", vmin=-limit, vmax=limit, interpolation="nearest")
    centres = [(a + b - 1) / 2 for _, a, b in blocks]
    for _, a, _b in blocks[1:]:
        ax.axhline(a - 0.5, color="0.6", lw=0.5)
        ax.axvline(a - 0.5, color="0.6", lw=0.5)
    ax.set_xticks(centres, [name for name, _, _ in blocks], rotation=90, fontsize=7)
    ax.set_yticks(centres, [name for name, _, _ in blocks], fontsize=7)
    ax.set_xlabel("source")
    ax.set_ylabel("target")
    ax.set_title(f"{circuit.name}: connectivity")
    ax.figure.colorbar(image, ax=ax, shrink=0.8, label="weight")
    return ax


# -- circuit diagram -----------------------------------------------------------------------------
def edge_class(weights: np.ndarray) -> str:
    """``excitatory`` (no negative weight), ``inhibitory`` (no positive weight) or ``mixed sign``."""
    if np.all(weights >= 0):
        return "excitatory"
    if np.all(weights <= 0):
        return "inhibitory"
    return "mixed sign"


def circuit_layout(circuit) -> dict[str, np.ndarray]:
    """Positions of the populations: one column per layer, inputs left, outputs right.

    A population's column is the length of the longest undelayed path reaching it (inputs in column
    0); outputs all sit in the last column. Within a column, populations are ordered by the mean
    height of their undelayed sources in the columns before (the barycentre), ties broken by kind
    (input, rate, leaky, integrator, output) and name, so the layout depends only on the circuit's
    names, kinds and connections, never on the order they were declared in.

    Returns
    -------
    dict of str to ndarray, shape (2,)
        Centre of each population; columns and rows are 1 apart, each column centred on y = 0.
    """
    graph = circuit.graph
    kind = {n: graph.nodes[n]["population"].kind for n in graph}
    import networkx as nx  # here: figures without a circuit need not import it

    undelayed = nx.DiGraph()
    undelayed.add_nodes_from(sorted(graph))
    undelayed.add_edges_from(sorted((s, t) for s, t, d in graph.edges(data=True) if not d["delay"] and s != t))
    depth = {}
    for node in nx.lexicographical_topological_sort(undelayed):
        sources = list(undelayed.predecessors(node))
        depth[node] = 0 if kind[node] == "input" or not sources else 1 + max(depth[s] for s in sources)
    last = max([d for n, d in depth.items() if kind[n] != "output"], default=0) + 1
    for node in depth:
        if kind[node] == "output":
            depth[node] = last
    position: dict[str, np.ndarray] = {}
    for column in range(max(depth.values(), default=-1) + 1):
        members = [n for n in sorted(depth) if depth[n] == column]

        def barycentre(node):
            placed = [position[s][1] for s in undelayed.predecessors(node) if s in position]
            return np.mean(placed) if placed else 0.0

        members.sort(key=lambda n: (-barycentre(n), KIND_ORDER.index(kind[n]), n))
        for row, node in enumerate(members):
            position[node] = np.array([float(column), (len(members) - 1) / 2 - row])
    return position


def node_radii(circuit) -> dict[str, float]:
    """Radius of each population's disc (data units), growing with the square root of its size."""
    sizes = {n: circuit.graph.nodes[n]["population"].size for n in circuit.graph}
    largest = max(sizes.values(), default=1)
    return {n: MIN_RADIUS + (MAX_RADIUS - MIN_RADIUS) * np.sqrt(s / largest) for n, s in sizes.items()}


def bezier_points(start, control, end, samples: int = 64) -> np.ndarray:
    """Points of the quadratic Bézier curve start-control-end, shape (samples, 2)."""
    t = np.linspace(0.0, 1.0, samples)[:, None]
    return (1 - t) ** 2 * np.asarray(start) + 2 * (1 - t) * t * np.asarray(control) + t**2 * np.asarray(end)


def _route(p0, p1, r0, r1, curvature):
    """The curve from the edge of disc (p0, r0) to the edge of disc (p1, r1) bent by ``curvature``."""
    d = p1 - p0
    control = (p0 + p1) / 2 + curvature * np.array([d[1], -d[0]])
    start = p0 + (r0 + GAP) * (control - p0) / np.linalg.norm(control - p0)
    end = p1 + (r1 + GAP) * (control - p1) / np.linalg.norm(control - p1)
    return start, control, end


def edge_route(source: str, target: str, position, radius, prefer_bent: bool = False):
    """Start, control and end points of the edge's quadratic Bézier curve.

    The first curvature of :data:`CURVATURES` whose curve stays :data:`CLEARANCE` radii away from
    every other population (and leaves its own two discs only at their rims) is taken; when none
    does, the one that comes least close. ``prefer_bent`` skips the straight line (for a pair
    connected both ways, so the two arrows do not overlap).
    """
    p0, p1 = position[source], position[target]
    others = [(position[n], radius[n]) for n in position if n not in (source, target)]
    best, best_margin = None, -np.inf
    for curvature in CURVATURES[1:] if prefer_bent else CURVATURES:
        route = _route(p0, p1, radius[source], radius[target], curvature)
        points = bezier_points(*route)[1:-1]
        margin = min([np.min(np.linalg.norm(points - c, axis=1)) / (CLEARANCE * r) for c, r in others]
                     + [np.min(np.linalg.norm(points - p0, axis=1)) / radius[source],
                        np.min(np.linalg.norm(points - p1, axis=1)) / radius[target]])
        if margin >= 1.0:
            return route
        if margin > best_margin:
            best, best_margin = route, margin
    return best


def plot_circuit(circuit, ax=None):
    """The circuit as a diagram: populations as discs by layer, connections as arrows, a legend.

    Disc colour: the population's kind; disc area: its size. Arrow colour: excitatory (red, pointed
    head), inhibitory (blue, bar head) or mixed-sign weights (grey); a plastic connection (one that
    carries a learning rule, :mod:`neuronav.circuits.plasticity`) is dashed, and the legend names its rule.
    Self-connections are listed in the corner. Every disc is a :class:`~matplotlib.patches.Circle`
    with gid ``node:NAME`` and every arrow a :class:`~matplotlib.patches.FancyArrowPatch` with gid
    ``edge:SOURCE->TARGET``.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle, FancyArrowPatch, Patch
    from matplotlib.path import Path as MplPath

    graph = circuit.graph
    if ax is None:
        _, ax = new_figure((9, 5))
    position = circuit_layout(circuit)
    radius = node_radii(circuit)
    kinds = [k for k in KIND_ORDER if any(graph.nodes[n]["population"].kind == k for n in graph)]
    for node in sorted(graph):
        kind = graph.nodes[node]["population"].kind
        ax.add_patch(Circle(position[node], radius[node], facecolor=KIND_COLOURS[kind], edgecolor="0.3",
                            lw=0.8, zorder=2, gid=f"node:{node}"))
        ax.text(*position[node], node, ha="center", va="center", fontsize=7, zorder=3, gid=f"label:{node}",
                bbox=dict(boxstyle="round,pad=0.15", facecolor="white", edgecolor="none", alpha=0.6))
    classes, rules = [], []
    for source, target, data in sorted(graph.edges(data=True), key=lambda e: (e[0], e[1])):
        if source == target:
            continue
        kind = edge_class(data["weights"])
        classes.append(kind)
        start, control, end = edge_route(source, target, position, radius,
                                         prefer_bent=graph.has_edge(target, source))
        path = MplPath([start, control, end], [MplPath.MOVETO, MplPath.CURVE3, MplPath.CURVE3])
        head = "-[, widthB=0.8, lengthB=0.2" if kind == "inhibitory" else "-|>"
        learning = data.get("learning")
        if learning is not None and learning.name not in rules:
            rules.append(learning.name)
        ax.add_patch(FancyArrowPatch(path=path, arrowstyle=head,
                                     mutation_scale=9, color=EDGE_COLOURS[kind], lw=1.0, zorder=1,
                                     linestyle="--" if learning is not None else "-",
                                     gid=f"edge:{source}->{target}"))
    loops = sorted(s for s, t in graph.edges if s == t)
    if loops:
        ax.text(0.01, 0.01, "self-connections: " + ", ".join(loops), transform=ax.transAxes, fontsize=7)
    handles = [Patch(facecolor=KIND_COLOURS[k], edgecolor="0.3", label=k) for k in kinds]
    handles += [Line2D([], [], color=EDGE_COLOURS[c], label=c) for c in EDGE_COLOURS if c in classes]
    handles += [Line2D([], [], color="0.3", linestyle="--", label=f"plastic: {rule}") for rule in rules]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, title="kind / sign",
              title_fontsize=7, frameon=False)
    xy = np.array(list(position.values())) if position else np.zeros((1, 2))
    ax.set_xlim(xy[:, 0].min() - 0.6, xy[:, 0].max() + 0.6)
    ax.set_ylim(xy[:, 1].min() - 0.6, xy[:, 1].max() + 0.6)
    ax.set_aspect("equal")
    ax.set_title(f"{circuit.name}: populations by layer (inputs left, outputs right)")
    ax.axis("off")
    return ax
