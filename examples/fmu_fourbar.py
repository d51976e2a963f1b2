"""The main job: run the mechanism FMU under fmpy with a torque schedule and plot it.

    python build_fmu.py && python examples/fmu_fourbar.py [--fmu dist/Mechanism.fmu] [--out out]

The thesis four-bar's crank gets 3 N m for 3 s, then coasts; fmpy drives the FMU
at a 1 ms communication step.  The same run of the library is drawn
beside it, so the plot also shows that the FMU is the library.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import fmpy
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import grubler  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def torque_schedule(t):
    return np.where(t < 3.0, 3.0, 0.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fmu", default=str(ROOT / "dist" / "Mechanism.fmu"))
    ap.add_argument("--out", default="out")
    ap.add_argument("--t-end", type=float, default=6.0)
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    # piecewise-constant input: fmpy interpolates between rows, so each jump is two rows
    times = [0.0, 3.0, 3.0, args.t_end]
    values = [3.0, 3.0, 0.0, 0.0]
    signal = np.array([(t, v, 0.0) for t, v in zip(times, values)],
                      dtype=[("time", float), ("motor_torque", float), ("load_torque", float)])
    names = ["theta2", "theta3", "theta4", "theta2_d", "Fx", "Fy", "closure_error", "KE", "PE"]
    res = fmpy.simulate_fmu(args.fmu, stop_time=args.t_end, step_size=1e-3, output_interval=1e-3,
                            input=signal, output=names)
    lib = grubler.simulate("thesis-fourbar", t_end=args.t_end, dt_out=1e-3,
                           torque=lambda t: float(torque_schedule(np.floor(t * 1e3 + 1e-6) / 1e3)))
    fmpy.write_csv(str(out / "fmu_fourbar.csv"), res)
    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5), sharex=True)
    ax[0, 0].plot(res["time"], res["theta2"], label="crank theta2 (FMU)")
    ax[0, 0].plot(lib.t, lib["theta2"], "--", label="crank theta2 (library)")
    ax[0, 0].set_ylabel("crank angle [rad]")
    ax[0, 0].legend(fontsize=8)
    ax[0, 1].plot(res["time"], res["Fx"], label="Fx")
    ax[0, 1].plot(res["time"], res["Fy"], label="Fy")
    ax[0, 1].set_ylabel("closing-joint force on link 4 [N]")
    ax[0, 1].legend(fontsize=8)
    ax[1, 0].plot(res["time"], torque_schedule(res["time"]), label="motor_torque input")
    ax[1, 0].set_ylabel("crank torque [N m]")
    ax[1, 0].set_xlabel("t [s]")
    ax[1, 1].semilogy(res["time"], np.abs(res["theta2"] - lib["theta2"]) + 1e-18, label="|FMU - library| theta2")
    ax[1, 1].semilogy(res["time"], res["closure_error"] + 1e-18, label="closure error [m]")
    ax[1, 1].set_ylabel("difference / violation")
    ax[1, 1].set_xlabel("t [s]")
    ax[1, 1].legend(fontsize=8)
    for a in ax.flat:
        a.grid(True, alpha=0.3)
    fig.suptitle("Mechanism.fmu under fmpy: thesis four-bar, 3 N m on the crank for 3 s, 1 ms steps")
    fig.tight_layout()
    fig.savefig(out / "fmu_fourbar.png", dpi=110)
    diff = float(np.max(np.abs(res["theta2"] - lib["theta2"])))
    print(f"wrote {out / 'fmu_fourbar.csv'} and {out / 'fmu_fourbar.png'}; "
          f"max |FMU - library| in theta2 = {diff:.2e} rad, max closure error {np.max(res['closure_error']):.2e}")


if __name__ == "__main__":
    main()
