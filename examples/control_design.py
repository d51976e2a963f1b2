"""Control design on the thesis four-bar driven by its DC motor, checked in co-simulation.

    python build_fmu.py Mechanism DCMotor Trajectory Encoder    # the plant's FMUs, into dist/
    python examples/control_design.py                           # docs/img/control-*.png and a table

1. Linearise the four-bar with a maxon RE 40 through 50:1 (input: voltage; states:
   crank angle, crank speed, winding current) at rest across the crank range: the
   pole map shows gravity's stiffness move the slow pole from stable to unstable.
2. Design (a) a PID by loop shaping on the model at the design angle, and (b) an
   LQR state feedback with integral action on its sampled model.
3. Turn each into an FMU through the user-law route (examples/control_laws.py,
   grubler.controllers.fmu.build_controller_fmu), co-simulate it on the nonlinear
   plant (mechanism, motor and a 14-bit encoder FMUs) for a setpoint step at
   several crank angles, and compare with the linear prediction: overshoot,
   settling time and tracking error, in a table and a plot.

docs/control.md walks through it.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path

import control
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # control_laws is a module file the FMU builder bundles

from control_laws import LoopShapedPID, LQRServo  # noqa: E402

from grubler.controllers import Sampler  # noqa: E402
from grubler.controllers.fmu import build_controller_fmu  # noqa: E402
from grubler.system.cosim import run  # noqa: E402
from grubler.fmi.build import scene_fmu  # noqa: E402
from grubler.fmi.motor import motor_parameters  # noqa: E402
from grubler.studies.linearize import linearize  # noqa: E402
from grubler.motors import DCMotor, Drive, Gearbox, load_motor  # noqa: E402
from grubler.mechanism.scene import load_scene  # noqa: E402
from grubler.system.ssp import System  # noqa: E402

SCENE = "thesis-fourbar"
MOTOR_NAME, RATIO, EFFICIENCY, SUPPLY, CURRENT_LIMIT = "maxon-re40-148877", 50.0, 0.9, 48.0, 10.0
MOTOR = DCMotor(load_motor(MOTOR_NAME), Gearbox(RATIO, EFFICIENCY), Drive(SUPPLY, CURRENT_LIMIT))
# the same motor without dry friction and with a lossless gearbox: its linear model
# holds in motion as at rest (see docs/control.md); co-simulated with an encoder
# that does not quantise, it isolates what the linearisation itself predicts
IDEAL_TEXT = "\n".join(line for line in (Path(__file__).resolve().parent.parent / "motors" / "data" /
                                          f"{MOTOR_NAME}.toml").read_text().splitlines()
                        if not line.startswith("no_load_current_mA"))
IDEAL = DCMotor(load_motor(IDEAL_TEXT), Gearbox(RATIO, 1.0), Drive(SUPPLY, CURRENT_LIMIT))
TS = 1e-3  # controller and encoder sample time = communication step, s
COUNTS = 16384  # 14-bit encoder on the crank
DESIGN_ANGLE = 0.0  # crank level: the worst gravity stiffness is near here (pole map)
CHECK_ANGLES = (math.radians(-90.0), 0.0, math.radians(90.0))
STEP, T_STEP, T_END = 0.008, 0.3, 1.5  # setpoint step (rad): small enough not to saturate the drive
WC = 40.0  # loop-shaping crossover, rad/s
FMU_DIR = HERE.parent / "dist"
IMG = HERE.parent / "docs" / "img"


def plant(angle: float, motor: DCMotor = MOTOR):
    """Voltage to (crank angle, current), at rest at `angle` held by the motor."""
    return linearize(SCENE, at={"theta2": angle}, motor=motor, outputs=["theta2", "current"])


# -- 1. how the plant moves ----------------------------------------------------------
def sweep(step_deg: float = 5.0) -> tuple[np.ndarray, list]:
    """Linear models at rest over the crank range, continued from the design angle both ways.

    Each point starts from its neighbour's configuration (``near``), so the
    whole sweep stays on the assembly branch of the scene's sketch.
    """
    up = np.radians(np.arange(0.0, 180.0 + step_deg / 2, step_deg))
    models = {}
    for direction in (up, -up[1:]):
        near = None
        for a in direction:
            P = linearize(SCENE, at={"theta2": float(a)}, motor=MOTOR, outputs=["theta2", "current"], near=near)
            near = P.operating_point
            models[float(a)] = P
    angles = np.array(sorted(models))
    return angles, [models[a] for a in angles]


def pole_map(path: Path, designs: list) -> None:
    angles, plants = sweep()
    deg = np.degrees(angles)
    poles = np.array([np.sort_complex(P.poles()) for P in plants])
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4))
    ax = axes[0]
    ax.plot(deg, poles[:, -1].real, label="slow pole (gravity stiffness)")
    ax.plot(deg, poles[:, -2].real, label="mechanical pole (back-EMF damping)")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("crank angle theta2 [deg]")
    ax.set_ylabel("pole [1/s]")
    ax.legend(fontsize=8)
    ax.set_title(f"open-loop poles at rest (the winding's, at {poles[0, 0].real:.0f}/s, off scale)", fontsize=10)
    ax = axes[1]
    for design, marker in zip(designs, "ox"):
        cl = []
        for P in plants:
            loop = design.loop(P)
            cl.append(np.log(loop.poles().astype(complex)) / TS)
        cl = np.array(cl)
        dominant = np.abs(cl.real).argsort(axis=1)[:, :3]
        pts = np.take_along_axis(cl, dominant, axis=1)
        sc = ax.scatter(pts.real.ravel(), pts.imag.ravel(), c=np.repeat(deg, pts.shape[1]), cmap="twilight",
                        marker=marker, s=14, label=design.name)
    ax.axvline(0, color="k", lw=0.5)
    ax.set_xlabel("Re [1/s]")
    ax.set_ylabel("Im [rad/s]")
    ax.set_title("closed loop over the crank range: the three slowest poles", fontsize=10)
    ax.legend(fontsize=8)
    fig.colorbar(sc, ax=ax, label="theta2 [deg]")
    ax = axes[2]
    ax.plot(deg, [P.operating_point.drive for P in plants], label="holding torque at the crank [N m]")
    ax.plot(deg, [P.operating_point.current for P in plants], label="holding current [A]")
    ax.set_xlabel("crank angle theta2 [deg]")
    ax.legend(fontsize=8)
    ax.set_title("operating points", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# -- 2. designs ------------------------------------------------------------------------
@dataclass
class Design:
    name: str
    law: type
    parameters: dict  # the FMU's parameters, operating-point terms set per angle
    wiring: dict  # law input -> system signal

    def at(self, angle: float, motor: DCMotor = MOTOR) -> dict:
        op = plant(angle, motor).operating_point
        p = dict(self.parameters, bias=op.voltage)
        if self.law is LQRServo:
            p["current0"] = op.current
        return p

    def predicted(self, angle: float, motor: DCMotor = MOTOR):
        """The sampled loop on the linear model at `angle`: setpoint to crank angle."""
        return self.loop(plant(angle, motor))

    def loop(self, P):
        """The sampled loop on the linear model P: setpoint to crank angle."""
        Pd = control.c2d(control.ss(P), TS, "zoh")
        if self.law is LoopShapedPID:
            C = LoopShapedPID.transfer_function(*(self.parameters[k] for k in ("K", "Ti", "Td", "N")), TS)
            return control.feedback(C * Pd[0, 0], 1)
        gains = [self.parameters[k] for k in ("k_position", "k_speed", "k_current", "k_integral")]
        return LQRServo.closed_loop(Pd, gains, TS)


def design_pid(P) -> tuple[Design, dict]:
    """Loop shaping: PI zero a decade... below crossover, lead centred on it, gain for |L(j wc)| = 1."""
    s = control.tf("s")
    Ti, Td, N = 8.0 / WC, 1.0 / WC, 10.0
    shape = (1 + 1 / (Ti * s)) * (1 + Td * s) / (1 + Td * s / N)
    L0 = shape * control.tf(control.ss(P)[0, 0])
    K = 1.0 / abs(L0(1j * WC))
    gm, pm, wg, wp = control.margin(K * L0)
    params = {"K": float(K), "Ti": Ti, "Td": Td, "N": N, "u_max": SUPPLY, "Ts": TS}
    return (Design("PID (loop shaping)", LoopShapedPID, params, {"measurement": "encoder.measured_position"}),
            {"crossover": WC, "phase_margin": pm, "gain_margin": gm})


def design_lqr(P) -> tuple[Design, dict]:
    """Discrete LQR on the sampled model with an integrator of the position error (Bryson's weights)."""
    Pd = control.c2d(control.ss(P), TS, "zoh")
    A, B, C = np.asarray(Pd.A), np.asarray(Pd.B), np.asarray(Pd.C)
    n = A.shape[0]
    Aa = np.block([[A, np.zeros((n, 1))], [TS * C[:1], np.ones((1, 1))]])
    Ba = np.vstack([B, [[0.0]]])
    # states theta, omega, current, integral: the largest deviation each may take
    Q = np.diag(1.0 / np.array([0.04, 5.0, 20.0, 0.01]) ** 2)
    R = np.array([[1.0 / 24.0 ** 2]])
    K, _, cl_poles = control.dlqr(Aa, Ba, Q, R)
    kp, kw, ki, kz = (float(v) for v in K[0])
    params = {"k_position": kp, "k_speed": kw, "k_current": ki, "k_integral": kz, "u_max": SUPPLY, "Ts": TS}
    wiring = {"position": "encoder.measured_position", "current": "motor.current"}
    return (Design("LQR + integral", LQRServo, params, wiring),
            {"closed_loop_poles_s": np.log(cl_poles.astype(complex)) / TS})


def check_law_against_model(design: Design) -> float:
    """Largest difference between the law's samples and its linear form on the same error signal."""
    # a smooth error, small enough that no output saturates
    tk = np.arange(300) * TS
    e = 0.002 * np.sin(2 * np.pi * 3 * tk) + 0.0005 * np.sin(2 * np.pi * 17 * tk + 1.0)
    p = {k: v for k, v in design.parameters.items()}
    law = design.law(**p)
    sampler = Sampler(law)
    if design.law is LoopShapedPID:
        u = [sampler.step(k * TS, TS, {"setpoint": ek, "measurement": 0.0})["u"] for k, ek in enumerate(e)]
        lin = control.forced_response(LoopShapedPID.transfer_function(p["K"], p["Ti"], p["Td"], p["N"], TS),
                                      np.arange(e.size) * TS, e).outputs
        return float(np.abs(np.array(u) - lin).max() / np.abs(lin).max())
    pos, cur = e, 0.5 * np.roll(e, 3)
    u = [sampler.step(k * TS, TS, {"setpoint": 0.0, "position": pk, "current": ck})["u"]
         for k, (pk, ck) in enumerate(zip(pos, cur))]
    kp, kw, ki, kz = (p[k] for k in ("k_position", "k_speed", "k_current", "k_integral"))
    speed = np.r_[0.0, np.diff(pos) / TS]
    integral = np.r_[0.0, np.cumsum(TS * pos)[:-1]]
    ref = -kp * pos - kw * speed - ki * cur - kz * integral
    return float(np.abs(np.array(u) - ref).max() / np.abs(ref).max())


# -- 3. co-simulation ------------------------------------------------------------------
def system(design: Design, angle: float, fmu: Path, ideal: bool = False) -> System:
    """The loop as FMUs; ``ideal``: the friction-free motor and an encoder without quantisation."""
    motor = IDEAL if ideal else MOTOR
    op = plant(angle, motor).operating_point
    s = System(f"{design.law.__name__}_at_{math.degrees(angle):+.0f}deg", start_time=0.0, stop_time=T_END, step=TS)
    s.add("trajectory", FMU_DIR / "Trajectory.fmu", kind="trapezoid", start=angle, distance=STEP, v_max=1e3,
          a_max=1e6, delay=T_STEP - TS, repeat=1)
    s.add("encoder", FMU_DIR / "Encoder.fmu", counts_per_rev=0 if ideal else COUNTS, Ts=TS)
    s.add("controller", fmu, **design.at(angle, motor))
    # the native FMUs are made this motor and this scene through their parameters
    s.add("motor", FMU_DIR / "DCMotor.fmu", **{**motor_parameters(motor.data), "gear_ratio": RATIO,
                                               "gear_efficiency": motor.gear.efficiency, "supply_voltage": SUPPLY,
                                               "current_limit": CURRENT_LIMIT, "initial_current": op.current})
    mech_fmu, scene_params = scene_fmu(load_scene(SCENE), FMU_DIR)
    s.add("mechanism", mech_fmu, **{**scene_params, "drive.inertia": MOTOR.reflected_inertia,
                                    "initial.theta2": angle})
    s.connect("trajectory.position", "controller.setpoint")
    s.connect("mechanism.drive_angle", "encoder.position")
    for law_input, signal in design.wiring.items():
        s.connect(signal, f"controller.{law_input}")
    s.connect("controller.u", "motor.voltage")
    s.connect("motor.shaft_torque", "mechanism.motor_torque")
    s.connect("mechanism.drive_speed", "motor.shaft_speed")
    # sampled blocks read the plant's values at the sample instant: before the plant steps
    s.order = ["encoder", "controller", "motor", "mechanism", "trajectory"]
    return s


SETTLING_BAND = 0.05  # of the step: 0.4 mrad, one encoder count (a 2 % band is below the quantum)


def metrics(t: np.ndarray, y: np.ndarray) -> dict:
    """Of a response y (deviation from the start) to a step of STEP at T_STEP."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    after = t >= T_STEP - 1e-12
    tt, yy = t[after] - T_STEP, y[after]
    outside = np.abs(yy - STEP) > SETTLING_BAND * STEP
    settle = tt[np.nonzero(outside)[0][-1] + 1] if outside.any() and outside.nonzero()[0][-1] + 1 < tt.size else (
        0.0 if not outside.any() else math.nan)
    return {"overshoot_%": float(max(0.0, (yy.max() - STEP) / STEP * 100)), "settling_s": float(settle),
            "rms_error_rad": float(np.sqrt(np.mean((STEP - yy) ** 2))), "final_error_rad": float(abs(STEP - yy[-1]))}


def main() -> list[dict]:
    IMG.mkdir(parents=True, exist_ok=True)
    P0 = plant(DESIGN_ANGLE)
    pid, pid_info = design_pid(P0)
    lqr, lqr_info = design_lqr(P0)
    pole_map(IMG / "control-pole-map.png", [pid, lqr])
    print(f"PID: K = {pid.parameters['K']:.4g} V/rad, Ti = {pid.parameters['Ti']:.4g} s, "
          f"Td = {pid.parameters['Td']:.4g} s, N = {pid.parameters['N']:g}: crossover {WC:g} rad/s, "
          f"phase margin {pid_info['phase_margin']:.1f} deg")
    print("LQR: " + ", ".join(f"{k} = {v:.4g}" for k, v in lqr.parameters.items() if k.startswith("k_")))
    rows, curves = [], {}
    t = np.round(np.arange(0.0, T_END + TS / 2, TS), 12)
    for design in (pid, lqr):
        print(f"{design.name}: law vs its linear form, largest relative difference "
              f"{check_law_against_model(design):.1e}")
        fmu = build_controller_fmu(design.law, FMU_DIR)
        for angle, ideal in [(a, False) for a in CHECK_ANGLES] + [(DESIGN_ANGLE, True)]:
            loop = design.predicted(angle, IDEAL if ideal else MOTOR)
            r = np.where(t >= T_STEP - 1e-12, STEP, 0.0)
            y_pred = np.ravel(control.forced_response(loop, t, r).outputs)
            res = run(system(design, angle, fmu, ideal), t_end=T_END, step=TS,
                      record=["mechanism.theta2", "trajectory.position", "motor.current", "controller.u"])
            y_co = np.asarray(res["mechanism.theta2"]) - angle
            gap = float(np.abs(np.interp(t, np.asarray(res.t), y_co) - y_pred).max())
            for source, tt, yy in (("predicted", t, y_pred), ("co-simulated", np.asarray(res.t), y_co)):
                rows.append({"design": design.name, "angle_deg": round(math.degrees(angle)), "source": source,
                             "plant": "ideal" if ideal else "datasheet", **metrics(tt, yy),
                             "gap_rad": gap if source == "co-simulated" else math.nan})
            if not ideal:
                curves[(design.name, angle)] = (t, y_pred, np.asarray(res.t), y_co)
    print(table(rows))
    plot(curves, IMG / "control-step-responses.png")
    return rows


def table(rows: list[dict]) -> str:
    head = ("| design | plant | crank angle | source | overshoot | settling (5 %) | RMS error | final error "
            "| largest gap to prediction |")
    lines = [head, "|" + "---|" * 9]
    for r in rows:
        gap = "" if math.isnan(r["gap_rad"]) else f"{r['gap_rad'] * 1e3:.3f} mrad"
        lines.append(f"| {r['design']} | {r['plant']} | {r['angle_deg']:+d} deg | {r['source']} | "
                     f"{r['overshoot_%']:.1f} % | {r['settling_s'] * 1e3:.0f} ms | {r['rms_error_rad'] * 1e3:.3f} mrad | "
                     f"{r['final_error_rad'] * 1e3:.3f} mrad | {gap} |")
    return "\n".join(lines)


def plot(curves: dict, path: Path) -> None:
    designs = sorted({k[0] for k in curves}, key=lambda d: d.startswith("LQR"))
    fig, axes = plt.subplots(len(designs), len(CHECK_ANGLES), figsize=(14, 7), sharex=True, sharey=True)
    for i, d in enumerate(designs):
        for j, a in enumerate(CHECK_ANGLES):
            t, yp, tc, yc = curves[(d, a)]
            ax = axes[i, j]
            ax.plot(t - T_STEP, yp * 1e3, label="predicted (linear, sampled)")
            ax.plot(tc - T_STEP, yc * 1e3, "--", label="co-simulated (FMUs, encoder)")
            ax.axhline(STEP * 1e3, color="k", lw=0.5)
            ax.set_xlim(-0.05, T_END - T_STEP)
            ax.set_title(f"{d} at theta2 = {math.degrees(a):+.0f} deg", fontsize=10)
            if j == 0:
                ax.set_ylabel("crank angle from start [mrad]")
            if i == len(designs) - 1:
                ax.set_xlabel("time after the step [s]")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{STEP * 1e3:.0f} mrad setpoint steps: thesis four-bar, {MOTOR_NAME} through {RATIO:g}:1, "
                 f"14-bit encoder, {TS * 1e3:g} ms sampling")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    import argparse
    import json
    import os

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fmu-dir", type=Path, default=FMU_DIR, help="where the plant's FMUs are (and the laws' go)")
    ap.add_argument("--img-dir", type=Path, default=IMG, help="where the figures go")
    ap.add_argument("--json", type=Path, help="write the table's rows to this JSON file")
    args = ap.parse_args()
    FMU_DIR, IMG = args.fmu_dir, args.img_dir
    result = main()
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))
    # pythonfmu FMUs that ran numpy can corrupt the heap at interpreter exit
    # (upstream PythonFMU issue 228, as grubler.cli notes): leave without teardown
    sys.stdout.flush()
    os._exit(0)
