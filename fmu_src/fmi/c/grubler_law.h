/* grubler_law.h: a control law written in C, made a native FMU by
 *
 *     grubler export-law law.c -o MyLaw.fmu
 *
 * The file declares the law's variables with the four macros below (each on
 * a line of its own, in any order; they expand to nothing) and defines one
 * function, law_step: one sample of the law.
 *
 *   GRUBLER_PARAMETER(name, start, "description [unit]")   a Real parameter;
 *       one must be Ts, the sample time [s] (0: once per communication step)
 *   GRUBLER_INPUT(name, "description [unit]")              a Real input
 *   GRUBLER_OUTPUT(name, "description [unit]")             a Real output (one at least)
 *   GRUBLER_STATE(n)                                        n doubles the law keeps
 *
 * law_step(param, state, t, in, out) is called once per sample at time t [s]
 * with the parameters, the inputs (finite), the state and the last outputs in
 * declaration order (PARAM_<name>, INPUT_<name>, OUTPUT_<name> index them);
 * it updates state and out and returns 0, or anything else to refuse the
 * sample (the FMU then answers fmi2Error with a logged message).  Before the
 * first sample state and outputs are 0.  The FMU runs it on the same sample
 * clock, wrapper and checks as the shipped laws: the outputs held between
 * samples, the state saved, serialised and restored with the FMU state, a
 * non-finite input discarded, a non-finite result refused.
 */
#ifndef GRUBLER_LAW_H
#define GRUBLER_LAW_H

#include "config.h"

#define GRUBLER_PARAMETER(name, start, description)
#define GRUBLER_INPUT(name, description)
#define GRUBLER_OUTPUT(name, description)
#define GRUBLER_STATE(count)

int law_step(const double *param, double *state, double t, const double *in, double *out);

#endif
