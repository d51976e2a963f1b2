"""Draw the six-bar topology figures of docs/model.md (docs/img/topology-*.png).

Each figure shows an inversion's link graph (links as nodes, ternary ones as
triangles, joints as edges, the ground dark) and, where the model's series chain
can hold it, the shipped preset drawn at its assembled start.

    python examples/sixbar_figures.py [OUT_DIR]
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import grubler  # noqa: E402
from grubler.views.animation import Drawer, fit_view, frame_geometry  # noqa: E402

WATT = {"nodes": {"T1": (0, 0), "T2": (1, 0), "b1": (0, 1), "b2": (1, 1), "b3": (0, -1), "b4": (1, -1)},
        "edges": [("T1", "T2"), ("T1", "b1"), ("b1", "b2"), ("b2", "T2"), ("T1", "b3"), ("b3", "b4"),
                  ("b4", "T2")]}
STEPHENSON = {"nodes": {"T1": (0, 0), "T2": (2, 0), "b1": (1, 0.9), "b2": (1, 0), "b3": (0.5, -0.9),
                        "b4": (1.5, -0.9)},
              "edges": [("T1", "b1"), ("b1", "T2"), ("T1", "b2"), ("b2", "T2"), ("T1", "b3"), ("b3", "b4"),
                        ("b4", "T2")]}
INVERSIONS = {  # name: (chain, ground, what it is)
    "watt-i": (WATT, "b1", "Watt I: a binary link fixed"),
    "watt-ii": (WATT, "T1", "Watt II: a ternary link fixed"),
    "stephenson-i": (STEPHENSON, "b1", "Stephenson I: the binary\nbetween the ternaries fixed"),
    "stephenson-ii": (STEPHENSON, "b3", "Stephenson II: a binary of\nthe two-link path fixed"),
    "stephenson-iii": (STEPHENSON, "T1", "Stephenson III: a ternary fixed"),
}


def draw_graph(ax, chain, ground, title):
    pos = chain["nodes"]
    for a, b in chain["edges"]:
        ax.plot([pos[a][0], pos[b][0]], [pos[a][1], pos[b][1]], "-", color="#7f7f7f", lw=2, zorder=1)
    for name, (x, y) in pos.items():
        ternary = name.startswith("T")
        fixed = name == ground
        ax.plot(x, y, "^" if ternary else "o", ms=22 if ternary else 16, mfc="#333333" if fixed else "white",
                mec="#1f4e79", mew=2, zorder=2)
        ax.annotate("ground" if fixed else name, (x, y), xytext=(0, -22 if y <= 0 else 16),
                    textcoords="offset points", ha="center", va="top" if y <= 0 else "bottom", fontsize=10)
    ax.set_title(title, fontsize=11)
    xs, ys = [x for x, _ in pos.values()], [y for _, y in pos.values()]
    # room for the labels over the top nodes and under the bottom ones, clear of the title
    ax.update_datalim([(min(xs) - 0.4, min(ys) - 0.6), (max(xs) + 0.4, max(ys) + 0.6)])
    ax.margins(0.0)
    ax.autoscale_view()
    ax.set_aspect("equal", adjustable="datalim")  # the box fills what the layout gave it: titles stay on the page
    ax.axis("off")


DPI = 100
SIZE = {True: (9.6, 4.6), False: (4.8, 4.6)}  # inches with and without the preset drawn beside the graph


def figure(name: str):
    """The figure of one inversion: its link graph, and the shipped preset at its start if there is one."""
    chain, ground, title = INVERSIONS[name]
    has_preset = name in set(grubler.preset_names())
    # constrained layout makes room for every title and label: none clipped at the edge
    fig, axes = plt.subplots(1, 2 if has_preset else 1, figsize=SIZE[has_preset], dpi=DPI, layout="constrained",
                             gridspec_kw={"width_ratios": [1, 1.25]} if has_preset else None)
    fig.get_layout_engine().set(w_pad=0.1, h_pad=0.1)
    axes = axes if has_preset else [axes]
    draw_graph(axes[0], chain, ground, title)
    if has_preset:
        m = grubler.load_scene(name).mechanism
        z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
        xlim, ylim = fit_view(m, [z])
        Drawer(axes[1], m, xlim, ylim).draw(frame_geometry(m, z))
        axes[1].set_title(f"preset {name}", fontsize=11)
        axes[1].tick_params(labelsize=9)
    return fig


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for name in INVERSIONS:
        fig = figure(name)
        fig.savefig(out / f"topology-{name}.png")
        plt.close(fig)
        print(f"wrote {out / f'topology-{name}.png'}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[1] / "docs" / "img")
