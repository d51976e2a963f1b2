/* A PI controller with a clamped output, written as one C function and made a
 * native FMU by
 *
 *     grubler export-law examples/pi_law.c -o dist/PILaw.fmu
 *
 * (see docs/control.md, "Your own law, in Python or in C"). */
#include "grubler_law.h"

GRUBLER_PARAMETER(K, 2.0, "proportional gain [V/rad]")
GRUBLER_PARAMETER(Ti, 0.1, "integral time [s]")
GRUBLER_PARAMETER(u_max, 12.0, "output limit, both signs [V]")
GRUBLER_PARAMETER(Ts, 1e-3, "sample time [s]")
GRUBLER_INPUT(setpoint, "position setpoint [rad]")
GRUBLER_INPUT(measurement, "measured position [rad]")
GRUBLER_OUTPUT(u, "voltage command [V]")
GRUBLER_STATE(1)

int law_step(const double *param, double *state, double t, const double *in, double *out)
{
    double e = in[INPUT_setpoint] - in[INPUT_measurement];
    double v = param[PARAM_K] * e + state[0];
    double limit = param[PARAM_u_max];
    double u = v > limit ? limit : (v < -limit ? -limit : v);
    (void)t;
    if (param[PARAM_Ti] <= 0.0 || limit <= 0.0) return 1;  /* refuse what the law cannot run */
    if (u == v)  /* conditional integration: the integral holds while the output is clamped */
        state[0] += param[PARAM_K] * param[PARAM_Ts] / param[PARAM_Ti] * e;
    out[OUTPUT_u] = u;
    return 0;
}
