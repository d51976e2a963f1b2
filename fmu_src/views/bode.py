"""Bode plots of a linear model: the frequency response of every input-output pair, drawn.

Computation apart from the figure, as python-control keeps them:
:func:`frequency_response` and :func:`phase_deg` give the numbers,
:func:`bode_figure` draws them.

Examples
--------
>>> import numpy as np, control
>>> sys = control.ss([[0.0, 1.0], [-4.0, -0.4]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]])
>>> g = frequency_response(sys, np.array([0.01, 2.0]))
>>> round(float(abs(g[0, 0, 0])), 4), round(float(phase_deg(g[0, 0])[-1]), 1)
(0.25, -90.0)
"""

from __future__ import annotations

import numpy as np

from grubler.mechanism.scene import coordinate_text

BODE_SUFFIXES = (".png", ".pdf", ".svg")  # what --bode writes


def frequency_response(sys, omega: np.ndarray) -> np.ndarray:
    """G(j w) = C (j w I - A)^-1 B + D at each ``omega`` (rad/s): outputs x inputs x frequencies."""
    A, B, C, D = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D))
    eye = np.eye(A.shape[0])
    return np.stack([C @ np.linalg.solve(1j * w * eye - A, B) + D for w in omega], axis=-1)


def phase_deg(g: np.ndarray) -> np.ndarray:
    """The phase of a frequency response, deg, unwrapped along frequency and placed by its
    low-frequency end: near 0 where the gain there is positive, near -180 where it is
    negative (and -90 under an integrator), rather than wherever the arctangent left it."""
    phase = np.degrees(np.unwrap(np.angle(g)))
    target = 0.0 if g[0].real >= 0 else -180.0
    return phase - 360.0 * np.round((phase[0] - target) / 360.0)


def plot_bode(sys, path: str) -> None:
    """Bode plot of every input-output pair (:func:`bode_figure`) to a PNG, PDF or SVG file."""
    import matplotlib.pyplot as plt

    fig = bode_figure(sys)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def bode_figure(sys):
    """The Bode plot of every input-output pair as a matplotlib Figure: magnitude in dB of
    the pair's own unit, phase in degrees (:func:`phase_deg`), the poles' natural
    frequencies marked, a title with the operating point, the motor and its ratio, and
    under it a note when the plant is open-loop unstable."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator, MultipleLocator

    units = getattr(sys, "units", {})
    poles = np.asarray(sys.poles())
    # a decade beyond the slowest and the fastest pole: python-control's own
    # choice misses the winding's pole three decades above the mechanism's
    corners = np.abs(poles)
    corners = corners[corners > 1e-9] if np.any(corners > 1e-9) else np.array([1.0])
    omega = np.logspace(np.log10(corners.min() / 10), np.log10(corners.max() * 10), 800)
    G = frequency_response(sys, omega)
    growing = poles.real > 1e-9 * max(1.0, corners.max())  # (a rounding's worth right of the axis is not)
    outs, ins = list(sys.output_labels), list(sys.input_labels)
    fig, axes = plt.subplots(2 * len(outs), len(ins), sharex=True, squeeze=False, layout="constrained",
                             figsize=(7.5 * len(ins), 1.4 + 3.6 * len(outs)))
    for i, out in enumerate(outs):
        for j, inp in enumerate(ins):
            g, ax_mag, ax_ph = G[i, j], axes[2 * i, j], axes[2 * i + 1, j]
            per = units.get(inp, "")
            unit = f"{units.get(out, '')}/{f'({per})' if ' ' in per else per}"
            with np.errstate(divide="ignore"):
                ax_mag.semilogx(omega, 20 * np.log10(np.abs(g)), color="C0", lw=1.6)
            phase = phase_deg(g)
            ax_ph.semilogx(omega, phase, color="C1", lw=1.6)
            ax_mag.set_title(f"{inp} -> {out}", fontsize=10)
            ax_mag.set_ylabel(f"magnitude, dB re 1 {unit}", fontsize=9)
            ax_ph.set_ylabel("phase, deg", fontsize=9)
            ax_mag.yaxis.set_major_locator(MaxNLocator(nbins=7, steps=[1, 2, 2.5, 5, 10]))
            ax_ph.yaxis.set_major_locator(MultipleLocator(45 if np.ptp(phase) <= 270 else 90))
            for ax in (ax_mag, ax_ph):
                ax.grid(True, which="major", alpha=0.5)
                ax.grid(True, which="minor", alpha=0.15)
                for p, bad in zip(poles, growing):  # an unstable pole's in red
                    ax.axvline(abs(p), color="firebrick" if bad else "0.4", ls=":", lw=0.9)
    for ax in axes[-1]:
        ax.set_xlabel("frequency, rad/s  (dotted: the poles' natural frequencies, an unstable one's red)",
                      fontsize=9)
    fig.suptitle(_bode_title(sys), fontsize=10)
    unstable = poles[growing]
    if len(unstable):
        import textwrap

        note = ("open-loop unstable: pole" + ("s" if len(unstable) > 1 else "") + " at "
                + ", ".join(f"{p.real:+.4g}{p.imag:+.4g}j" if p.imag else f"{p.real:+.4g}" for p in unstable)
                + " rad/s; no gain or phase margin can be read from this plot (use the Nyquist criterion "
                "or the closed loop's poles)")
        fig.supxlabel("\n".join(textwrap.wrap(note, 95)), fontsize=9, color="firebrick")
    return fig


def _bode_title(sys) -> str:
    """Scene, operating point, and motor with its ratio, for the plot's title."""
    op = getattr(sys, "operating_point", None)
    lines = [f"{sys.name}: linear model"]
    if op is not None:
        at = op.kind + (f" at t = {op.time:g} s" if op.time is not None else "")
        coords = ", ".join(f"{k} = {coordinate_text(k, op.coordinates[k], 4)}" for k in op.independent)
        lines[0] += f" about the {at}, {coords}, drive effort {op.drive:.4g} {op.effort_units['drive']}"
    motor = getattr(sys, "motor", None)
    if motor is not None:
        lines.append(f"motor {motor.data.name} through {motor.gear.ratio:g}:1 ({motor.gear.efficiency:.0%}), "
                     f"{op.current:.3g} A at {op.voltage:.3g} V" if op is not None else "")
    return "\n".join(lines)


__all__ = ["BODE_SUFFIXES", "frequency_response", "phase_deg", "bode_figure", "plot_bode"]
