"""Figures of a sizing study: what the cycle needs against what each candidate gives.

The study (:mod:`grubler.studies.cylinder_sizing`) computes; this module only
draws what it computed, as python-control's ``timeplot`` draws ``timeresp``'s
data.  Pressures are in bar and forces in kN, as the CLI's lines print them.
"""

from __future__ import annotations

import numpy as np

from grubler.views.plotting import plt

MARGIN_FLOOR = 1e-3  # a margin of 0 (no force at all) has no logarithm: drawn at the floor, and said


def save_cylinder_sizing(study, path) -> None:
    """Save :func:`cylinder_sizing_figure` of ``study`` to ``path`` (PNG or any format matplotlib writes)."""
    fig = cylinder_sizing_figure(study)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def cylinder_sizing_figure(study):
    """Three panels of a :class:`~grubler.studies.cylinder_sizing.CylinderStudy`.

    The force the piston must give over the cycle beside what the best candidate
    (or, when none fits, the nearest) gives at each instant; each limit's margin
    against the bore, the force's at each supply pressure (log axis, 1 is
    exactly enough); and
    the hydraulic power each installs, the ranking's key (filled: it fits).
    """
    d = study.demand
    shown = study.best or (study.rejected[0] if study.rejected else None)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8), layout="constrained")
    ax = axes[0]
    if shown is not None and shown.needed is not None:
        ax.plot(d.t, shown.needed / 1e3, label="needed (load and seal friction)")
        ax.plot(d.t, shown.available / 1e3, "--", label=f"{shown.candidate.label} gives")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("piston force along the actuator [kN]")
    ax.set_title(("best: " if study.best is not None else "none fits; nearest: ")
                 + (shown.candidate.label if shown is not None else "-"), fontsize=9)
    ax.legend(fontsize=8, loc="best")
    pressures = sorted({a.candidate.pressure for a in study.assessments})
    floored = False

    def margin_line(group, limit, label, style):
        nonlocal floored
        bores = np.array([a.candidate.bore * 1e3 for a in group])
        m = np.array([a.margins[limit] for a in group], dtype=float)
        floored |= bool(np.any(m < MARGIN_FLOOR))
        return axes[1].plot(bores, np.clip(np.where(np.isfinite(m), m, np.nan), MARGIN_FLOOR, None), style,
                            label=label)[0]

    for k, p in enumerate(pressures):
        group = sorted((a for a in study.assessments if a.candidate.pressure == p), key=lambda a: a.candidate.bore)
        # the force's margin is the supply pressure's; flow, stroke and buckling are the bore's alone
        line = margin_line(group, "force", f"force, {p / 1e5:g} bar", "o-")
        if k == 0:
            for limit, style in (("flow", "s--"), ("stroke", "^:"), ("buckling", "d-.")):
                margin_line(group, limit, limit, style).set_color(("0.45", "0.3", "0.15")[("flow", "stroke",
                                                                                            "buckling").index(limit)])
        bores = np.array([a.candidate.bore * 1e3 for a in group])
        power = np.array([a.power / 1e3 for a in group])
        fits = np.array([a.feasible for a in group])
        axes[2].plot(bores, power, "-", color=line.get_color(), label=f"{p / 1e5:g} bar")
        axes[2].plot(bores[fits], power[fits], "o", color=line.get_color())
        axes[2].plot(bores[~fits], power[~fits], "o", mfc="none", color=line.get_color())
    ax = axes[1]
    ax.set_yscale("log")
    ax.axhline(1.0, color="k", lw=1.0, label="exactly enough")
    ax.set_xlabel("bore [mm]")
    ax.set_ylabel("margin of each limit (available / needed)")
    ax.set_title("a candidate fits where every limit is above 1"
                 + (f"; a margin of 0 is drawn at {MARGIN_FLOOR:g}" if floored else ""), fontsize=9)
    ax.legend(fontsize=8, loc="best")
    ax = axes[2]
    ax.set_xlabel("bore [mm]")
    ax.set_ylabel("installed power at the peak flow [kW]")
    ax.set_title("filled: fits, hollow: rejected", fontsize=9)
    ax.legend(fontsize=8, title="supply", title_fontsize=8, loc="best")
    if study.best is not None:
        b = study.best
        axes[2].plot(b.candidate.bore * 1e3, b.power / 1e3, "o", ms=14, mfc="none", color="k", label="_best")
    for a in axes:
        a.grid(True, alpha=0.3)
    name = getattr(d, "name", "")
    fig.suptitle("cylinder sizing" + (f": {name}" if name else "") + f", {len(study.ranked)} of "
                 f"{len(study.assessments)} bore x supply pressure combinations fit")
    return fig


__all__ = ["cylinder_sizing_figure", "save_cylinder_sizing"]
