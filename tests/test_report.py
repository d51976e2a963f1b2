"""The run report reads like a datasheet: no two texts overlap, the scene's name is the
title, the key numbers carry units, a co-simulation's residue is called what it is,
the PDF is a PDF, and a scene that does not fit the CSV is refused."""

import itertools
import re
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.text import Text  # noqa: E402

import grubler  # noqa: E402
from grubler.cli import main  # noqa: E402
from grubler.views.report import PAGE, energy_balance, key_numbers, report_figure  # noqa: E402
from grubler.views.runs import read_run  # noqa: E402


def overlapping_texts(fig):
    """Pairs of texts, of those a draw of ``fig`` draws, whose boxes intersect (by more than a pixel)."""
    drawn = []
    original = Text.draw

    def draw(self, renderer):  # record what is drawn: ticks outside the view are Text objects too, not drawn
        original(self, renderer)
        if self.get_visible() and self.get_text().strip():
            bb = self.get_window_extent(renderer)
            if bb.width > 0 and bb.height > 0:
                drawn.append((self.get_text(), bb.padded(-1.0)))

    Text.draw = draw
    try:
        fig.canvas.draw()
    finally:
        Text.draw = original
    assert len(drawn) > 30  # the page's texts were seen
    return [(a, b) for (a, ba), (b, bb) in itertools.combinations(drawn, 2) if ba.overlaps(bb)]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """simulate CSVs of a four-bar, a slider-crank and a six-bar preset."""
    folder = tmp_path_factory.mktemp("runs")
    out = {}
    for preset, extra in (("fourbar-crank-rocker", []), ("thesis-slider-crank", []),
                          ("watt-ii", ["--torque", "0.2"])):
        path = folder / f"{preset}.csv"
        assert main(["simulate", preset, "--t-end", "2", "--dt-out", "0.002", "--csv", str(path), *extra]) == 0
        out[preset] = path
    return out


@pytest.mark.parametrize("preset", ["fourbar-crank-rocker", "thesis-slider-crank", "watt-ii"])
@pytest.mark.parametrize("with_scene", [True, False])
def test_no_two_texts_of_the_page_overlap_and_the_title_is_the_scene(runs, preset, with_scene):
    model = grubler.load_scene(preset).mechanism if with_scene else None
    raw, cols = read_run(str(runs[preset]), model)
    fig = report_figure(cols, model, source=str(runs[preset]))
    assert overlapping_texts(fig) == []
    title = fig.subfigs[0].get_suptitle()
    assert title == (preset if with_scene else f"{preset}.csv")  # the file's name, never its path
    texts = [t.get_text() for t in fig.findobj(Text)]
    assert not any(str(runs[preset].parent) in t for t in texts)
    # one quantity per axis: every time panel's label names one unit
    for ax in fig.findobj(matplotlib.axes.Axes):
        label = ax.get_ylabel()
        if label and ax.get_xlabel() != "x [m]" and "[" in label:
            assert label.count("[") == 1, label


@pytest.mark.slow
def test_the_servo_record_page_names_its_residue_and_gives_speeds_in_rad_per_s_and_rpm(tmp_path, mechanism_record):
    raw, cols = read_run(str(mechanism_record), grubler.load_scene("thesis-fourbar").mechanism)
    fig = report_figure(cols, grubler.load_scene("thesis-fourbar").mechanism, source=str(mechanism_record),
                        cosim=True)
    assert overlapping_texts(fig) == []
    labels = [ax.get_ylabel() for ax in fig.findobj(matplotlib.axes.Axes)]
    assert "coupling residue [J]" in labels and not any("balance" in lb for lb in labels)
    numbers = dict(key_numbers(cols, "theta2", grubler.load_scene("thesis-fourbar").mechanism, cosim=True))
    assert "max |coupling residue|" in numbers
    assert re.fullmatch(r"[0-9.]+ rad/s \([0-9.]+ rpm\)", numbers["peak |drive speed|"])
    w = np.max(np.abs(cols["theta2_d"]))
    assert numbers["peak |drive speed|"] == f"{w:.4g} rad/s ({w * 60 / (2 * np.pi):.4g} rpm)"


@pytest.fixture
def mechanism_record(tmp_path):
    """A cosim CSV: the mechanism FMU driven by a constant torque from the runner (no motor)."""
    from grubler import cosim, ssp

    import builds

    fmu = builds.export("thesis-fourbar", tmp_path / "Mechanism.fmu")
    s = ssp.System("alone", stop_time=0.5, step=0.01)
    s.add("arm", fmu)
    res = cosim.run(s)
    res.to_csv(tmp_path / "run.csv")
    return tmp_path / "run.csv"


def test_key_numbers_carry_units_and_the_energy_balance_closes(runs):
    cols = read_run(str(runs["fourbar-crank-rocker"]))[1]
    model = grubler.load_scene("fourbar-crank-rocker").mechanism
    numbers = dict(key_numbers(cols, "theta2", model))
    assert numbers["peak |drive torque|"] == "2 N m"  # the preset's constant torque
    peak_force = np.max(np.hypot(cols["Fx"], cols["Fy"]))
    assert numbers["peak closing-joint force"] == f"{peak_force:.4g} N"
    unit = r"(s|ms|rad|rad/s|rpm|m|m/s|N|N m|J|A|V|m, rad \(norm\))"
    for label, value in numbers.items():
        if label != "drive":  # a name; every other value is a number and its unit
            assert re.fullmatch(rf"-?[0-9.e+-]+ {unit}(, .*| \(.*\)|)|-?[0-9.e+-]+ to -?[0-9.e+-]+ {unit}", value), \
                (label, value)
    # the drive works against gravity and damping: E alone changes, the balance does not
    assert np.ptp(cols["E"]) > 1.0
    assert np.max(np.abs(energy_balance(cols, model))) < 1e-3


def test_report_cli_writes_png_and_pdf_and_refuses_a_scene_that_does_not_fit(runs, tmp_path, capsys):
    png, pdf = tmp_path / "r.png", tmp_path / "r.pdf"
    csv = str(runs["fourbar-crank-rocker"])
    assert main(["report", csv, "--scene", "fourbar-crank-rocker", "--out", str(png), "--out", str(pdf)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    data = pdf.read_bytes()
    assert data[:5] == b"%PDF-" and data.rstrip().endswith(b"%%EOF") and b"/Type /Page" in data
    from PIL import Image

    assert Image.open(png).size == (int(PAGE[0] * 110), int(PAGE[1] * 110))  # A4 landscape at 110 dpi
    capsys.readouterr()
    for wrong in ("thesis-slider-crank", "watt-ii"):
        assert main(["report", csv, "--scene", wrong, "--out", str(tmp_path / "x.png")]) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and err.startswith(f"grubler: error: --scene: {wrong} does not fit"), err
        if wrong == "thesis-slider-crank":  # the same columns: the geometry tells
            assert re.search(r"open by [0-9.e+-]+ (m|rad) at t = [0-9.e+-]+ s", err), err
        else:  # a six-bar has more coordinates than the four-bar's CSV
            assert "no columns B4, theta5" in err
    assert not (tmp_path / "x.png").exists()
    # the same refusal through the command line as a user runs it: exit status 2
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "report", csv, "--scene", "thesis-slider-crank",
                           "--out", str(tmp_path / "y.png")], capture_output=True, text=True)
    assert proc.returncode == 2 and "--scene" in proc.stderr


# -- issue 29, item 18 ----------------------------------------------------------------------------------------
def test_every_time_panel_has_its_time_axis_labelled_and_the_subtitle_keeps_to_its_column(runs):
    model = grubler.load_scene("fourbar-crank-rocker").mechanism
    raw, cols = read_run(str(runs["fourbar-crank-rocker"]), model)
    source = "fourbar-crank-rocker_with_a_long_descriptive_record_name.csv"
    fig = report_figure(cols, model, source=source, cosim=True)
    assert overlapping_texts(fig) == []
    right = fig.subfigs[1]
    panels = [ax for ax in right.axes if ax.get_ylabel()]
    assert len(panels) >= 5
    for ax in panels:
        assert ax.get_xlabel() == "t [s]", ax.get_ylabel()
        assert any(t.get_visible() and t.get_text() for t in ax.get_xticklabels()), ax.get_ylabel()
    renderer = fig.canvas.get_renderer()
    table = next(ax for ax in fig.subfigs[0].findobj(matplotlib.axes.Axes) if "record" in ax.get_title(loc="left"))
    box = table._left_title.get_window_extent(renderer)
    assert box.x1 <= fig.subfigs[0].bbox.x1 and box.x1 < min(ax.get_window_extent(renderer).x0 for ax in panels)
    # a scene with no declared type is named by what it is
    assert table.get_title(loc="left").startswith("four-bar (crank-rocker), co-simulation record")


def test_a_turning_drive_is_drawn_wrapped_and_says_how_many_turns(runs):
    model = grubler.load_scene("fourbar-crank-rocker").mechanism
    cols = read_run(str(runs["fourbar-crank-rocker"]), model)[1]
    assert np.ptp(cols["theta2"]) > 4 * np.pi  # what it is about: the crank turns
    fig = report_figure(cols, model)
    (ax,) = [a for a in fig.axes if a.get_ylabel().startswith("drive theta2")]
    assert ax.get_ylabel() == "drive theta2 [rad, wrapped to ±π]" and "turns" in ax.get_title(loc="right")
    y = ax.get_lines()[0].get_ydata()
    assert np.nanmax(y) - np.nanmin(y) < 2 * np.pi + 0.5


def test_the_pneumatic_report_draws_the_supply_pressure_of_its_system():
    from pathlib import Path

    from grubler.system.ssp import read

    system = read(Path(__file__).parent.parent / "examples" / "toggle_clamp.ssd")
    t = np.linspace(0.0, 1.0, 201)
    cols = {"t": t, "pressure_a": 4e4 + 1e4 * np.sin(t), "pressure_b": 3e4 + 0 * t}
    fig = report_figure(cols, cosim=True, system=system)
    (ax,) = [a for a in fig.axes if a.get_ylabel() == "cylinder pressure [bar]"]
    levels = [line.get_ydata()[0] for line in ax.get_lines()]
    assert 6.0 in levels  # the supply, 6 bar
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["cap side A", "rod side B", "supply"]
