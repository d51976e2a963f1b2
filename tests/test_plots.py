"""What the plots draw, read back from the figures: identical curves once, dense
series as a min/max band, no identically zero columns, no floored zeros on a log
axis, and the drive's work beside the energies it explains."""

import re
from pathlib import Path

import matplotlib
import matplotlib.collections
import numpy as np
import pytest

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
    assert "dampers" in energy.get_legend().get_title().get_text()  # the legend's heading: never under it


# -- issue 29, item 18: curves that coincide, pressures, turning cranks, notes, titles, sampling --------------
def _visible_pixels(fig, ax, line):
    """Pixels of ``ax`` drawn in ``line``'s colour (to within anti-aliasing), after the whole figure is drawn."""
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())[:, :, :3].astype(int)
    bb = ax.get_window_extent()
    h = img.shape[0]
    inside = img[int(h - bb.y1) + 2:int(h - bb.y0) - 2, int(bb.x0) + 2:int(bb.x1) - 2]
    target = np.array(matplotlib.colors.to_rgb(line.get_color())) * 255
    return int(np.all(np.abs(inside - target) < 25, axis=2).sum())


@pytest.mark.parametrize("samples", [401, 4001])  # drawn as they are, and as the mean of a dense record
def test_setpoint_response_and_encoder_all_stay_visible_where_they_coincide(samples):
    t = np.linspace(0.0, 4.0, samples)
    setpoint = np.pi / 2 * (1 - np.cos(np.pi * t / 2))
    response = setpoint - 0.004                                      # a servo that tracks to 4 mrad
    encoder = np.floor(response / (2 * np.pi / 1024)) * (2 * np.pi / 1024)  # 1024 counts per turn
    panel = ("crank angle [rad]", [("crank angle, setpoint", setpoint, "rad"), ("crank angle, response", response, "rad"),
                                   ("crank angle, encoder", encoder, "rad")])
    fig = panels_figure(t, [panel])
    ax = fig.axes[0]
    lines = {line.get_label().split(", ")[-1]: line for line in ax.get_lines()}
    assert set(lines) == {"setpoint", "response", "encoder"}
    # the response under the others and wider than they are; the setpoint dashed
    assert lines["response"].get_zorder() < min(lines["setpoint"].get_zorder(), lines["encoder"].get_zorder())
    assert lines["response"].get_linewidth() > max(lines["setpoint"].get_linewidth(), lines["encoder"].get_linewidth())
    assert lines["setpoint"].get_linestyle() not in ("-", "solid")
    # what a reader sees: each curve's colour covers a good part of its length in pixels
    alone = {}
    for name, line in lines.items():
        for other in lines.values():
            other.set_visible(other is line)
        alone[name] = _visible_pixels(fig, ax, line)
    for other in lines.values():
        other.set_visible(True)
    for name, line in lines.items():
        assert _visible_pixels(fig, ax, line) > 0.2 * alone[name], name


def test_a_pressure_in_pa_is_drawn_in_bar_with_no_offset_and_its_supply_line_in_bar_too():
    t = np.linspace(0.0, 1.0, 101)
    p_a = 1.0e7 + 2e6 * np.sin(t)
    fig = panels_figure(t, [("pressure [Pa]", [("cap side A", p_a, "Pa"), ("rod side B", 0.5 * p_a, "Pa")])],
                        limits={"pressure [Pa]": [("160 bar supply", 1.6e7)]})
    ax = fig.axes[0]
    fig.canvas.draw()
    assert ax.get_ylabel() == "pressure [bar]"
    assert ax.yaxis.get_offset_text().get_text() == ""  # no "1e7" over the axis
    curves = ax.get_lines()
    assert np.max(curves[0].get_ydata()) == pytest.approx(np.max(p_a) / 1e5)
    assert [c.get_label() for c in curves][-1] == "160 bar supply" and curves[-1].get_ydata()[0] == 160.0
    lo, hi = ax.get_ylim()
    assert 0 < hi < 200  # bar, not Pa


def test_the_pneumatic_system_plot_draws_its_supply_pressure():
    from grubler.system.cosim import CosimResult
    from grubler.system.ssp import read

    system = read(Path(__file__).parent.parent / "examples" / "toggle_clamp.ssd")
    t = np.linspace(0.0, 0.1, 11)
    res = CosimResult(t, ["cylinder.pressure_a"], t[:, None], system, [], "gauss-seidel", 0.01, 0.0)
    assert res.limits()["pressure [Pa]"] == [("6 bar supply", 6e5)]


def test_a_turning_crank_is_drawn_wrapped_and_leaves_the_other_angles_their_scale():
    res = grubler.simulate("fourbar-crank-rocker", t_end=10.0, dt_out=0.01)
    assert np.ptp(res["theta2"]) > 100  # what it is about: 18 turns
    fig = result_figure(res)
    ax = fig.axes[0]
    lines = dict(zip(_legend_labels(ax), ax.get_lines()))
    (crank,) = [line for label, line in lines.items() if label.startswith("theta2")]
    assert "wrapped" in crank.get_label() and "18.3 turns" in crank.get_label()
    y = crank.get_ydata()
    assert np.nanmin(y) >= -np.pi and np.nanmax(y) < np.pi
    assert np.count_nonzero(np.isnan(y)) >= 17  # broken at each wrap, not joined across the axes
    lo, hi = ax.get_ylim()
    assert hi - lo < 8.0  # the rocker's and coupler's swings keep their scale
    # the same in a panel plot of a record
    panel = panels_figure(res.t, [("crank angle [rad]", [("crank", res["theta2"], "rad")])]).axes[0]
    assert np.nanmax(np.abs(panel.get_lines()[0].get_ydata())) <= np.pi


def test_the_energy_note_heads_its_legend_and_no_text_overlaps():
    from test_report import overlapping_texts

    res = grubler.simulate("luffing-boom", t_end=3.0, dt_out=0.01)
    fig = result_figure(res)
    energy = fig.axes[3]
    assert energy.get_title() == "" and "no drive work" in energy.get_legend().get_title().get_text()
    assert overlapping_texts(fig) == []


def test_a_scene_without_a_type_is_titled_by_what_it_is(tmp_path):
    text = (Path(grubler.__file__).parent / "presets" / "fourbar-crank-rocker.toml").read_text()
    assert not re.search(r"(?m)^kind\s*=", text)  # a scene that says what it is made of, not what it is
    scene = tmp_path / "my-crank-rocker.toml"
    scene.write_text(text.replace('name = "fourbar-crank-rocker"', 'name = "my-crank-rocker"'))
    res = grubler.simulate(grubler.load_scene(str(scene)), t_end=0.2, dt_out=0.01)
    assert res.model.kind == ""  # what it is about: the file declares no type
    assert result_figure(res)._suptitle.get_text() == "my-crank-rocker: four-bar (crank-rocker) (exact closure)"


def test_a_plot_coarser_than_the_crank_turns_warns_naming_dt_out(tmp_path, capsys):
    from grubler.cli import main

    assert main(["simulate", "thesis-fourbar", "--torque", "10", "--t-end", "3", "--plot", str(tmp_path / "p.png")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    (line,) = [e for e in err if "stroboscop" in e]
    assert line.startswith("warning: --dt-out: theta") and "1/8 turn" in line and "use --dt-out" in line
    # a fine enough grid, or a slow crank, says nothing
    assert main(["simulate", "thesis-fourbar", "--torque", "10", "--t-end", "3", "--dt-out", "0.001",
                 "--plot", str(tmp_path / "q.png")]) == 0
    assert "stroboscop" not in capsys.readouterr().err
    assert main(["simulate", "thesis-fourbar", "--torque", "3", "--t-end", "3", "--plot", str(tmp_path / "r.png")]) == 0
    assert "stroboscop" not in capsys.readouterr().err
