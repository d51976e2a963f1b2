"""Cost of the native Mechanism.fmu per communication step in a C host, over the kernel's own stepping.

    python benchmarks/native_fmu_cost.py [--steps 20000] [--block 500] [--repeat 5]

One C program (written and compiled here with ``cc``) does both, in the same
process, in alternating blocks of communication steps of 1 ms on the thesis
four-bar, with a drive torque that changes every step (0, 0.5, ... 3 N m):

- ``kernel``: the kernel's sources (the FMU's own ``sources/``) called directly:
  grb_advance to the next communication point, the held derivative dropped when
  the torque changes, as the FMU's model does;
- ``fmu``: the FMU's binary through dlopen: fmi2SetReal(motor_torque),
  fmi2DoStep, fmi2GetReal(drive_angle, drive_speed) (what a motor and an encoder
  read), and the same plus Fx (one forward-dynamics evaluation more).

The machine is shared and drifts, so the variants alternate block by block and
the figures are medians of per-block times; the difference is the median of
paired block differences.  Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import numpy as np  # noqa: E402

import build_fmu  # noqa: E402
import grubler  # noqa: E402
from grubler.fmi.build import fmi_headers_dir  # noqa: E402

PROGRAM = r"""
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "fmi2Functions.h"
#include "grubler.h"
#include "bench_data.h"

static double now(void) { struct timespec ts; clock_gettime(CLOCK_MONOTONIC, &ts); return ts.tv_sec + 1e-9 * ts.tv_nsec; }
static void logger(fmi2ComponentEnvironment e, fmi2String n, fmi2Status s, fmi2String c, fmi2String m, ...) {
    (void)e; (void)n; (void)s; (void)c; fprintf(stderr, "%s\n", m); }

int main(int argc, char **argv) {
    int steps = atoi(argv[3]), block = atoi(argv[4]), i, b, v;
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2InstantiateTYPE *inst = (fmi2InstantiateTYPE *)dlsym(lib, "fmi2Instantiate");
    fmi2SetupExperimentTYPE *setup = (fmi2SetupExperimentTYPE *)dlsym(lib, "fmi2SetupExperiment");
    fmi2EnterInitializationModeTYPE *enter = (fmi2EnterInitializationModeTYPE *)dlsym(lib, "fmi2EnterInitializationMode");
    fmi2ExitInitializationModeTYPE *leave = (fmi2ExitInitializationModeTYPE *)dlsym(lib, "fmi2ExitInitializationMode");
    fmi2SetRealTYPE *setr = (fmi2SetRealTYPE *)dlsym(lib, "fmi2SetReal");
    fmi2GetRealTYPE *getr = (fmi2GetRealTYPE *)dlsym(lib, "fmi2GetReal");
    fmi2DoStepTYPE *step = (fmi2DoStepTYPE *)dlsym(lib, "fmi2DoStep");
    fmi2Component c[2];
    const fmi2ValueReference in = VR_TORQUE, out[3] = {VR_ANGLE, VR_SPEED, VR_FX};
    grb_model m = {N_LINKS, N_CLOSURES, LINKS, CLOSURES, THETA1, GRAVITY, DRIVE, -1, 0.0};
    grb_settings s = {GRB_DOP853, GRB_EXACT, 1, SCALE, 1e-9, 1e-9, INFINITY, 0.0, 10000000L, 0.0, 0.0, NULL, NULL};
    grb_clock clock = {0.0, 0.0, 0, 0, 0, 0};
    grb_failure why;
    double y[2 * N_LINKS], f[2 * N_LINKS], y_out[2 * N_LINKS], last = -1.0, values[3];
    double *work = calloc(grb_work_size(N_LINKS, N_CLOSURES), sizeof(double));
    double *stepper = calloc(grb_stepper_size(GRB_DOP853, 2 * N_LINKS), sizeof(double));
    for (i = 0; i < 2 * N_LINKS; i++) y[i] = Y0[i];
    for (v = 0; v < 2; v++) {
        c[v] = inst(v ? "b" : "a", fmi2CoSimulation, argv[2], "", &cb, fmi2False, fmi2False);
        if (!c[v] || setup(c[v], fmi2False, 0, 0, fmi2False, 0) || enter(c[v]) || leave(c[v])) return 2;
    }
    for (b = 0; b < steps / block; b++) {
        for (v = 0; v < 3; v++) {  /* the variants in a rotating order */
            int which = (v + b) % 3;
            double t0 = now();
            for (i = b * block; i < (b + 1) * block; i++) {
                double t = i * 1e-3, tau = 0.5 * (i % 7), t_out = t + 1e-3;
                if (which == 0) {
                    if (tau != last) { clock.have_f = 0; last = tau; }
                    s.tau_drive = tau;
                    clock.steps = clock.rejected = clock.evals = 0;
                    if (grb_advance(&m, &s, &clock, y, f, &t_out, 1, y_out, work, stepper, &why)) return 3;
                } else {
                    fmi2Component x = c[which - 1];
                    if (setr(x, &in, 1, &tau) || step(x, t, 1e-3, fmi2True) || getr(x, out, which == 1 ? 2 : 3, values))
                        return 4;
                }
            }
            printf("%d %d %.9f\n", b, which, (now() - t0) / block);
        }
    }
    return 0;
}
"""


def data_header(fmu_md) -> str:
    sc = grubler.load_scene("thesis-fourbar")
    m = sc.mechanism
    sim = grubler.Simulator(m)
    a = m.arrays
    vr = {v.name: v.valueReference for v in fmu_md.modelVariables}

    def arr(name, x):
        return f"static const double {name}[] = {{{', '.join(float(v).hex() for v in np.ravel(x))}}};"

    return "\n".join([
        f"#define N_LINKS {m.n_links}", f"#define N_CLOSURES {len(m.closures)}",
        arr("LINKS", a.links), arr("CLOSURES", a.closures), arr("Y0", np.concatenate([sim.z, sim.zd])),
        f"#define THETA1 {float(a.theta1).hex()}", f"#define GRAVITY {float(a.gravity).hex()}",
        f"#define DRIVE {a.drive}", f"#define SCALE {max([1.0] + [abs(l.a) for l in m.links]).hex()}",
        f"#define VR_TORQUE {vr['motor_torque']}", f"#define VR_ANGLE {vr['drive_angle']}",
        f"#define VR_SPEED {vr['drive_speed']}", f"#define VR_FX {vr['Fx']}", ""])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--block", type=int, default=500)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    from fmpy import read_model_description

    tmp = Path(tempfile.mkdtemp(prefix="native_fmu_bench_"))
    (fmu,) = build_fmu.build(tmp, ["Mechanism"])
    zipfile.ZipFile(fmu).extractall(tmp / "fmu")
    md = read_model_description(str(fmu))
    src = tmp / "fmu" / "sources"
    (tmp / "bench_data.h").write_text(data_header(md))
    (tmp / "bench.c").write_text(PROGRAM)
    kernel = [str(p) for p in sorted(src.glob("*.c"))
              if p.name not in ("fmi_common.c", "fmi2_wrapper.c", "mechanism_model.c", "model_variables.c")]
    exe = tmp / "bench"
    subprocess.run(["cc", "-std=c99", "-O2", "-D_POSIX_C_SOURCE=199309L", "-I", str(src), "-I", str(tmp),
                    "-I", str(fmi_headers_dir()), str(tmp / "bench.c"), *kernel, "-o", str(exe), "-ldl", "-lm"],
                   check=True)
    per = {0: [], 1: [], 2: []}
    for _ in range(args.repeat):
        out = subprocess.run([str(exe), str(tmp / "fmu" / "binaries" / "linux64" / "Mechanism.so"), md.guid,
                              str(args.steps), str(args.block)], capture_output=True, text=True, check=True, env={})
        for line in out.stdout.splitlines():
            b, which, t = line.split()
            per[int(which)].append(float(t))
    k, f2, f3 = (np.array(per[w]) * 1e6 for w in (0, 1, 2))
    print("| variant | fastest block us/step | median us/step | over the kernel: median of paired blocks, us/step |")
    print("|---|---|---|---|")
    print(f"| kernel's own stepping (grb_advance) | {k.min():.2f} | {np.median(k):.2f} | - |")
    print(f"| FMU: setReal, doStep, getReal(drive_angle, drive_speed) | {f2.min():.2f} | {np.median(f2):.2f} | "
          f"{np.median(f2 - k):.2f} |")
    print(f"| FMU: the same and Fx | {f3.min():.2f} | {np.median(f3):.2f} | {np.median(f3 - k):.2f} |")
    print(f"\n{args.repeat} runs x {args.steps // args.block} blocks of {args.block} steps of 1 ms, "
          "thesis four-bar, torque changing every step, env -i, one process.")


if __name__ == "__main__":
    main()
