"""What the plots draw, read back from the figures: identical curves once, dense
series as a min/max band, no identically zero columns, no floored zeros on a log
axis, and the drive's work beside the energies it explains."""

import matplotlib.collections
import numpy as np

import grubler
from grubler.views.plotting import ENVELOPE_BINS, panels_figure, result_figure


def _legend_labels(ax):
    legend = ax.get_legend()
    return [t.get_text() for t in legend.get_texts()] if legend else []


def test_identical_curves_are_drawn_once_and_a_dense_series_as_its_band():
    t = np.linspace(0.0, 4.0, 4001)                       # 1 kHz
    chatter = np.sin(t) + 0.5 * (-1.0) ** np.arange(t.size)  # a sample-to-sample zig-zag
    fig = panels_figure(t, [("motor voltage [V]", [("commanded", chatter, "V"), ("applied", chatter.copy(), "")])])
    ax = fig.axes[0]
    (line,) = ax.get_lines()
    assert _legend_labels(ax) == ["commanded = applied"]
    assert len(line.get_xdata()) == ENVELOPE_BINS        # not 4001 zig-zags
    # the band reaches the series' extremes, the line is each bin's mean (the zig-zag averages out)
    (band,) = [c for c in ax.collections if isinstance(c, matplotlib.collections.PolyCollection)]
    ys = band.get_paths()[0].vertices[:, 1]
    assert ys.max() == chatter.max() and ys.min() == chatter.min()
    assert np.max(np.abs(line.get_ydata() - np.sin(line.get_xdata()))) < 0.1
    assert ax.get_ylabel() == "motor voltage [V]"
    assert "min to max" in fig.axes[-1].get_xlabel()

    sparse = np.linspace(0.0, 1.0, 101)
    ax = panels_figure(sparse, [("x [m]", [("a", sparse ** 2, "m")])]).axes[0]
    assert len(ax.get_lines()[0].get_xdata()) == 101 and not ax.collections


def test_simulate_plot_leaves_out_zero_columns_and_floored_zeros_and_shows_the_drive_work():
    res = grubler.simulate(grubler.load_scene("thesis-fourbar"), t_end=1.5, dt_out=0.005, torque=3.0)
    assert np.all(res["Mz"] == 0.0) and np.any(res["closure_error"] == 0.0)  # what the checks are about
    fig = result_figure(res)
    force, violation, energy = fig.axes[1], fig.axes[2], fig.axes[3]
    assert _legend_labels(force) == ["Fx [N]", "Fy [N]"] and "Mz" in force.get_title(loc="right")
    assert force.get_ylabel() == "closing-pin force on the rocker"  # not "the last link"
    assert violation.get_yscale() == "log"
    (points,) = violation.get_lines()
    assert np.all(points.get_ydata() > 0) and len(points.get_ydata()) == np.count_nonzero(res["closure_error"])
    labels = _legend_labels(energy)
    assert "work done by the drive" in labels
    # the drawn work accounts for the change of E (7.2 J here): this scene has no
    # losses; what is left, 3e-4 J, is the trapezoid rule on a 5 ms grid
    lines = dict(zip(labels, energy.get_lines()))
    without_losses = lines["E(0) + drive work (E without losses)"].get_ydata()
    assert np.ptp(lines["work done by the drive"].get_ydata()) > 7.0
    assert np.max(np.abs(without_losses - res["E"])) < 1e-3


def test_a_damped_run_without_drive_says_so_instead_of_drawing_zero_work():
    res = grubler.simulate(grubler.load_scene("thesis-fourbar-damped"), t_end=1.0, dt_out=0.01)
    energy = result_figure(res).axes[3]
    assert "work done by the drive" not in _legend_labels(energy)
    assert "dampers" in energy.get_title()
