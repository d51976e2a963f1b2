"""Units and names wherever a number is shown or written, and pictures a design
review can read: CSV headings carry units that the readers take back off, the
motors can be listed, the sizing picture has no blank panel, no legend over data
and no margin floored at 0, the servo plot shows the power stage's limits."""

import csv
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import grubler  # noqa: E402
from grubler.cli import main  # noqa: E402

MOTOR_DATA = Path(grubler.__file__).resolve().parent.parent / "motors" / "data"


@pytest.fixture(autouse=True)
def close_figures():
    """Each test's figures closed after it: pyplot keeps every figure it made until then."""
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


def data_points(ax):
    """Display coordinates of every drawn data point of ``ax`` (lines' vertices, not the axes' own)."""
    pts = []
    for line in ax.get_lines():
        xy = np.column_stack([line.get_xdata(), line.get_ydata()]).astype(float)
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if len(xy) and line.get_transform() == ax.transData:
            pts.append(ax.transData.transform(xy))
    return np.vstack(pts) if pts else np.empty((0, 2))


def legends_over_data(fig):
    """(axes label, points) of every legend that covers data points of any axes of ``fig``."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    found = []
    for leg_ax in fig.axes:
        legend = leg_ax.get_legend()
        if legend is None:
            continue
        box = legend.get_window_extent(renderer)
        for ax in fig.axes:
            pts = data_points(ax)
            inside = ((pts[:, 0] > box.x0) & (pts[:, 0] < box.x1) & (pts[:, 1] > box.y0) & (pts[:, 1] < box.y1))
            if inside.any():
                found.append((leg_ax.get_ylabel() or leg_ax.get_title(), int(inside.sum())))
    return found


# -- CSV headings carry units ----------------------------------------------------------
def test_a_cosim_csv_heading_carries_the_unit_and_animate_labels_its_strip_with_it(tmp_path):
    from grubler.system.cosim import CosimResult
    from grubler.views.runs import read_table, select_signals

    t = np.linspace(0.0, 1.0, 11)
    res = CosimResult(t, ["arm.theta2", "arm.closure_error", "motor.current"], np.column_stack([t, 0 * t, 2 * t]),
                      system=None, order=[], master="gauss-seidel", step=0.1, wall_time=0.0,
                      units={"arm.theta2": "rad", "arm.closure_error": "m", "motor.current": "A"})
    res.to_csv(tmp_path / "co.csv")
    header = (tmp_path / "co.csv").read_text().splitlines()[0]
    assert header == "t [s],arm.theta2 [rad],arm.closure_error [m],motor.current [A]"
    # numpy reads the file as it is; the one reader takes the units off the names
    assert np.loadtxt(tmp_path / "co.csv", delimiter=",", skiprows=1).shape == (11, 4)
    table = read_table(str(tmp_path / "co.csv"))
    assert list(table) == ["t", "arm.theta2", "arm.closure_error", "motor.current"]
    assert table.units["motor.current"] == "A"
    labels = [label for label, _ in select_signals("arm.theta2,motor.current", table)]
    assert labels == ["arm.theta2 [rad]", "motor.current [A]"]  # the motor's unit came from the file


def test_sizing_csv_and_console_give_motor_speed_in_rpm_and_say_so(capsys, tmp_path):
    out = tmp_path / "s.csv"
    assert main(["size", "thesis-fourbar", "--motors", "maxon-re40-148877", "--ratios", "50", "--supply", "48",
                 "--current-limit", "10", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    (row,) = list(csv.DictReader(open(out)))
    assert "peak_current [A]" in row and "rank" in row and "margin_voltage" in row
    rpm = float(row["peak_motor_speed [rpm]"])
    # the cycle's peak drive speed, 2 pi rad/s, through 50:1, in rpm: 3000
    assert rpm == pytest.approx(2 * math.pi * 50 * 30 / math.pi, rel=1e-3)
    assert f"{rpm:.0f} rpm" in text


def test_sweep_headings_carry_the_units_of_inputs_and_metrics(tmp_path):
    from grubler.studies.sweep import scene_point_units

    units = scene_point_units(grubler.load_scene("thesis-slider-crank"),
                              ["link3.m", "link2.damping", "closure.damping", "initial.theta2_d"])
    assert units["link3.m"] == "kg" and units["link2.damping"] == "N m s/rad"
    assert units["closure.damping"] == "N s/m or N m s/rad" and units["initial.theta2_d"] == "rad/s"
    assert units["energy_balance"] == "J" and units["peak_closure_force"] == "N"


# -- the motors ----------------------------------------------------------------------
def test_grubler_motors_lists_every_data_set_with_its_figures_units_and_source(capsys):
    assert main(["motors"]) == 0
    text = capsys.readouterr().out
    lines = text.splitlines()
    assert "[V]" in lines[2] and "[mN m]" in lines[2] and "[rpm]" in lines[2] and "[g cm2]" in lines[2]
    for path in sorted(MOTOR_DATA.glob("*.toml")):
        doc = tomllib.loads(path.read_text())
        sheet = doc["datasheet"]
        row = next(line.split() for line in lines if line.startswith(doc["name"] + " "))
        # figures read from the file itself, in the datasheet's units
        assert float(row[1]) == pytest.approx(sheet["nominal_voltage_V"], rel=1e-3)
        assert float(row[2]) == pytest.approx(sheet["nominal_torque_mNm"], rel=1e-3)
        assert float(row[4]) == pytest.approx(sheet["stall_torque_mNm"], rel=1e-3)
        assert float(row[6]) == pytest.approx(sheet["terminal_resistance_ohm"], rel=1e-3)
        assert float(row[7]) == pytest.approx(sheet["rotor_inertia_gcm2"], rel=1e-3)
        assert f"{doc['name']}: {doc['source']['manufacturer']}" in text
    assert main(["motors", "no-such-motor"]) == 2
    assert "no data set named 'no-such-motor'" in capsys.readouterr().err


def test_grubler_motors_is_an_attribute_after_import_grubler():
    code = "import grubler; print(grubler.motors.list_motors()[0])"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("maxon-")


# -- the sizing picture --------------------------------------------------------------
@pytest.fixture(scope="module")
def sizing_study():
    from grubler.controllers.trajectory import Trajectory
    from grubler.motors import list_motors, load_motor
    from grubler.studies.sizing import Control, DutyCycle, size

    model = grubler.load_scene("thesis-fourbar").mechanism
    traj = Trajectory("trapezoid", distance=math.pi, v_max=2 * math.pi, a_max=20.0, dwell=0.5, repeat=2,
                      reverse=True)
    cycle = DutyCycle.from_trajectory(traj, (traj.move_time + 0.5) * 2, start=0.0, name="trapezoid move")
    return size(model, cycle, [load_motor(n) for n in list_motors()], [5, 10, 20, 35, 50, 75, 100, 150],
                supply_voltage=48.0, current_limit=10.0, control=Control.servo())


def test_the_sizing_picture_has_the_winner_first_no_blank_panel_and_no_legend_over_data(sizing_study):
    from test_report import overlapping_texts

    fig = sizing_study.figure()
    axes = fig.axes
    assert len(axes) == 6  # four motors, the margins, the key: no blank panel
    assert axes[0].get_title().startswith(f"best: {sizing_study.best.candidate.motor.name} at "
                                          f"{sizing_study.best.candidate.ratio:g}:1")
    assert all(ax.get_lines() or ax.collections for ax in axes[:5])
    key = axes[5]
    assert key.get_legend() is not None and not data_points(key).size
    assert [ax.get_legend() for ax in axes[:5]] == [None] * 5  # one key, off the data
    assert legends_over_data(fig) == []
    assert overlapping_texts(fig) == []


def test_the_margin_panel_draws_no_runaway_as_a_zero(sizing_study):
    margin = sizing_study.figure().axes[4]
    assert margin.get_yscale() == "log"
    runaways = sum(a.runaway for a in sizing_study.assessments)
    assert runaways > 0  # what the check is about: small ratios overheat the winding without bound
    drawn = np.concatenate([line.get_ydata() for line in margin.get_lines() if line.get_marker() == "o"])
    assert np.all(np.isnan(drawn) | (drawn > 0))
    assert np.count_nonzero(np.isnan(drawn)) == runaways  # a gap in the line, and a cross on the axis
    crosses = sum(len(line.get_xdata()) for line in margin.get_lines() if line.get_marker() == "x")
    assert crosses == runaways


# -- the servo plot ------------------------------------------------------------------
def test_panels_draw_limit_lines_at_plus_and_minus_the_limit_in_the_legend():
    from grubler.views.plotting import panels_figure

    t = np.linspace(0.0, 1.0, 101)
    fig = panels_figure(t, [("motor current [A]", [("winding current", np.sin(t), "A")])],
                        limits={"motor current [A]": [("±10 A current limit", 10.0)]})
    ax = fig.axes[0]
    levels = sorted(line.get_ydata()[0] for line in ax.get_lines()[1:])
    assert levels == [-10.0, 10.0]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["winding current", "±10 A current limit"]
    assert legends_over_data(fig) == []  # beside the axes


def test_report_names_the_system_option_when_its_file_is_bad(capsys, tmp_path):
    run = tmp_path / "run.csv"
    run.write_text("t [s],theta2 [rad]\n0,0\n1,1\n")
    assert main(["report", str(run), "--system", str(tmp_path / "no.ssd"), "--out", str(tmp_path / "r.png")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("grubler: error: --system: ") and "\n" not in err


def test_the_servo_system_names_the_closing_force_in_plain_words():
    from grubler.system.servo import ServoDesign, servo_system

    s = servo_system(ServoDesign(), "dist")
    force = next(p for p in s.plots if p.title.startswith("force"))
    assert force.labels["mechanism.Fx"] == "closing-pin force on the rocker, x"
    for path in ("examples/servo_fourbar.ssd", "examples/servo_slider_crank.ssd"):
        text = (Path(__file__).parent.parent / path).read_text()
        assert "last link" not in text


# -- the run report and the simulate plot --------------------------------------------
def servo_like_columns():
    """A simulate run of the thesis four-bar with a setpoint, a current and a voltage beside it."""
    res = grubler.simulate("thesis-fourbar", t_end=1.0, dt_out=0.005, torque=3.0)
    cols = {c: res[c] for c in res.columns}
    cols["setpoint"] = cols["theta2"] + 0.01 * np.sin(7 * res.t)  # a response 0.01 rad off at most
    cols["current"], cols["voltage"] = np.cos(res.t), 12 * np.cos(res.t)
    return cols


def test_the_report_shows_the_servo_tracking_error_as_a_panel_and_a_key_number():
    from grubler.views.report import key_numbers, report_figure
    from test_report import overlapping_texts

    cols = servo_like_columns()
    model = grubler.load_scene("thesis-fourbar").mechanism
    numbers = dict(key_numbers(cols, "theta2", model))
    err = np.max(np.abs(cols["setpoint"] - cols["theta2"]))
    assert numbers["peak |tracking error|"] == f"{err:.3g} rad ({np.degrees(err):.3g} deg)"
    # energies that sweep their axes everywhere: a legend inside the axes, wherever put, would cover them
    cols["KE"], cols["PE"] = 5 + 5 * np.sin(40 * cols["t"]), 5 + 5 * np.cos(37 * cols["t"])
    cols["E"] = cols["KE"] + cols["PE"]
    fig = report_figure(cols, model, cosim=True)
    (ax,) = [a for a in fig.axes if a.get_ylabel() == "tracking error [rad]"]
    assert np.max(np.abs(ax.get_lines()[0].get_ydata())) == pytest.approx(err)
    assert overlapping_texts(fig) == []
    assert legends_over_data(fig) == []  # the energy legend above its axes, off the total's peaks


def test_the_report_names_the_motor_gearbox_power_stage_and_controller_of_the_system():
    from grubler.views.report import report_figure, system_numbers
    from grubler.system.servo import ServoDesign, servo_system

    design = ServoDesign()
    rows = dict(system_numbers(servo_system(design, "dist")))
    assert rows["motor"] == design.motor  # found by its figures among the shipped data sets
    assert rows["gearbox"] == f"{design.gear_ratio:g}:1, efficiency {design.gear_efficiency:g}"
    assert rows["power stage"] == f"{design.supply_voltage:g} V, {design.current_limit:g} A limit"
    assert rows["controller"].startswith(f"PID: K {design.pid['K']:g}, Ti {design.pid['Ti']:g}")
    texts = [t.get_text() for t in report_figure(servo_like_columns(), cosim=True).findobj(matplotlib.text.Text)]
    assert "give --system SSD" in texts  # a cosim record without its system says where the names come from


def test_the_simulate_plot_puts_no_legend_over_a_curve():
    from grubler.views.plotting import result_figure
    from test_report import overlapping_texts

    for scene, torque in (("watt-ii", 0.2), ("thesis-fourbar", 3.0)):
        fig = result_figure(grubler.simulate(scene, t_end=3.0, dt_out=0.01, torque=torque))
        assert legends_over_data(fig) == [], scene
        assert overlapping_texts(fig) == [], scene


# -- the servo's co-simulation record and plot ---------------------------------------
def test_the_servo_plot_puts_the_supply_and_current_limit_on_the_motor_panels():
    from grubler.system.cosim import CosimResult
    from grubler.system.servo import ServoDesign, servo_system

    design = ServoDesign()
    t = np.linspace(0.0, 0.1, 11)
    res = CosimResult(t, ["motor.current"], t[:, None], servo_system(design, "dist"), [], "gauss-seidel", 0.01, 0.0)
    limits = res.limits()
    assert limits["motor current [A]"] == [(f"±{design.current_limit:g} A current limit", design.current_limit)]
    assert limits["motor voltage [V]"] == [(f"±{design.supply_voltage:g} V supply voltage", design.supply_voltage)]
    assert not any("tracking" in title or "crank" in title for title in limits)


@pytest.fixture(scope="module")
def servo_record(tmp_path_factory):
    """A short co-simulation of the servo four-bar (FMUs built from this checkout), as its CSV."""
    sys.path.insert(0, str(Path(__file__).parent.parent))
    import builds
    from grubler.system.servo import ServoDesign, servo_system

    d = tmp_path_factory.mktemp("servo")
    builds.dist(d, ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory"])
    ssd = servo_system(ServoDesign(t_end=0.05), d).write(d / "servo.ssd")
    # in a process of its own: pythonfmu FMUs that ran numpy may corrupt the heap at exit
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "cosim", str(ssd), "--csv", str(d / "co.csv"),
                           "--plot", str(d / "co.png")], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return d


@pytest.mark.slow
def test_a_controller_output_of_any_unit_is_headed_in_the_unit_of_what_it_feeds(servo_record):
    header = next(csv.reader(open(servo_record / "co.csv")))
    assert "controller.u [V]" in header and "motor.voltage [V]" in header  # the PID's "any" is the motor's volts
    assert "motor.current [A]" in header and "mechanism.theta2 [rad]" in header and header[0] == "t [s]"
    assert (servo_record / "co.png").stat().st_size > 10_000


@pytest.mark.slow
def test_the_report_of_a_servo_record_and_its_system_names_what_drove_it(servo_record, capsys):
    from grubler.views.report import report_figure, system_numbers
    from grubler.views.runs import read_run
    from grubler.system.ssp import read

    model = grubler.load_scene("thesis-fourbar").mechanism
    raw, cols = read_run(str(servo_record / "co.csv"), model)
    assert "setpoint" in cols  # the controller's, in simulate vocabulary
    system = read(servo_record / "servo.ssd")
    assert dict(system_numbers(system))["motor"] == "maxon-re40-148877"
    fig = report_figure(cols, model, source="co.csv", cosim=True, system=system)
    assert any(ax.get_ylabel() == "tracking error [rad]" for ax in fig.axes)
    assert main(["report", str(servo_record / "co.csv"), "--scene", "thesis-fourbar", "--system",
                 str(servo_record / "servo.ssd"), "--out", str(servo_record / "r.png")]) == 0


def test_two_motors_draw_two_by_two_not_a_key_alone_on_a_row(sizing_study):
    import dataclasses

    two = {"maxon-re40-148877", "maxon-re25-118752"}
    study = dataclasses.replace(sizing_study, assessments=[a for a in sizing_study.assessments
                                                           if a.candidate.motor.name in two],
                                ranked=[a for a in sizing_study.ranked if a.candidate.motor.name in two])
    fig = study.figure()
    spec = [ax.get_subplotspec() for ax in fig.axes]
    assert [(s.rowspan.start, s.colspan.start) for s in spec] == [(0, 0), (0, 1), (1, 0), (1, 1)]


# -- issue 29, item 18: the six-bar topology figures ------------------------------------------------------------
@pytest.mark.parametrize("name", ["watt-i", "watt-ii", "stephenson-i", "stephenson-ii", "stephenson-iii"])
def test_the_topology_figures_are_large_enough_and_clip_no_text(name):
    import importlib.util

    path = Path(__file__).parent.parent / "examples" / "sixbar_figures.py"
    spec = importlib.util.spec_from_file_location("sixbar_figures", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    from matplotlib.text import Text

    fig = module.figure(name)
    drawn, original = [], Text.draw

    def draw(self, renderer):  # what a draw draws (a tick outside the view is a Text too, not drawn)
        original(self, renderer)
        if self.get_visible() and self.get_text().strip():
            drawn.append((self.get_text(), self.get_window_extent(renderer)))

    Text.draw = draw
    try:
        fig.canvas.draw()
    finally:
        Text.draw = original
    width, height = fig.canvas.get_width_height()
    assert width >= 900 and height >= 400  # was 576 x 297
    page = fig.bbox
    assert "ground" in [text for text, _ in drawn] and any(text.startswith("preset") for text, _ in drawn)
    for text, box in drawn:  # every title and label whole on the page
        assert box.x0 >= page.x0 and box.x1 <= page.x1 and box.y0 >= page.y0 and box.y1 <= page.y1, text
    import itertools

    overlaps = [(a, b) for (a, ba), (b, bb) in itertools.combinations(drawn, 2) if ba.padded(-1.0).overlaps(
        bb.padded(-1.0))]
    assert overlaps == []  # no node's label over the title
