"""Circuit introspection plots: the connectivity matrix and the circuit diagram (matplotlib)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import networkx as nx  # noqa: E402
import numpy as np  # noqa: E402

KIND_COLOURS = {"input": "#8dd3c7", "rate": "#80b1d3", "leaky": "#bebada", "integrator": "#fdb462",
                "output": "#fb8072"}


def plot_connectivity(circuit, ax=None):
    """The whole circuit's weight matrix (targets x sources) with population blocks labelled."""
    matrix, blocks = circuit.weight_matrix()
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 6))
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


def plot_circuit(circuit, ax=None):
    """The circuit as a diagram: populations by layer (topological), excitatory and inhibitory arrows."""
    graph = circuit.graph
    undelayed = nx.DiGraph((s, t) for s, t, d in graph.edges(data=True) if not d["delay"])
    undelayed.add_nodes_from(graph)
    for layer, nodes in enumerate(nx.topological_generations(undelayed)):
        for node in nodes:
            undelayed.nodes[node]["layer"] = layer
    position = nx.multipartite_layout(undelayed, subset_key="layer")
    if ax is None:
        _, ax = plt.subplots(figsize=(8, 5))
    colours = [KIND_COLOURS[graph.nodes[n]["population"].kind] for n in graph]
    sizes = [300 + 40 * graph.nodes[n]["population"].size for n in graph]
    nx.draw_networkx_nodes(graph, position, ax=ax, node_color=colours, node_size=sizes)
    nx.draw_networkx_labels(graph, position, ax=ax, font_size=8)
    excitatory = [(s, t) for s, t, d in graph.edges(data=True) if d["weights"].sum() >= 0 and s != t]
    inhibitory = [(s, t) for s, t, d in graph.edges(data=True) if d["weights"].sum() < 0 and s != t]
    nx.draw_networkx_edges(graph, position, edgelist=excitatory, ax=ax, edge_color="tab:red", arrows=True,
                           connectionstyle="arc3,rad=0.1", node_size=sizes)
    nx.draw_networkx_edges(graph, position, edgelist=inhibitory, ax=ax, edge_color="tab:blue", arrows=True,
                           arrowstyle="-[", connectionstyle="arc3,rad=0.1", node_size=sizes)
    loops = [s for s, t in graph.edges if s == t]
    if loops:
        ax.text(0.01, 0.01, "self-connections: " + ", ".join(loops), transform=ax.transAxes, fontsize=7)
    ax.set_title(f"{circuit.name}: red excitatory, blue inhibitory")
    ax.axis("off")
    return ax


def save(fig, path) -> None:
    """Save and close a figure."""
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
