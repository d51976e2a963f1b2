/* law.h: what a sampled control law gives the generic law model (law_model.c).
 *
 * A law FMU is three pieces on the one FMI wrapper: fmi2_wrapper.c (the FMI
 * side), law_model.c (the sample-and-hold clock of controllers/law.py, the
 * run's time, the held outputs, the checks of a restored state) and one law
 * file that defines the functions below: pid_law.c, encoder_law.c,
 * trajectory_law.c, or a user's own (grubler export-law).  Nothing here
 * knows FMI: a law sees arrays of doubles.
 *
 *   param    the law's LAW_N_PARAMS parameters, in the FMU's order (a String
 *            parameter as the index of its value, a Boolean as 0 or 1)
 *   in       its LAW_N_INPUTS inputs, finite (law_model.c checks them)
 *   out      its MODEL_N_OUTPUTS outputs, held between samples
 *   state    LAW_N_STATE doubles the FMU state saves and restores: all the
 *            law remembers between samples
 *   scratch  LAW_N_SCRATCH doubles the FMU instance owns (heap, not the
 *            stack): what law_prepare derives from param (spline
 *            coefficients, a plan), and working memory law_sample may
 *            overwrite (a kernel's workspace, a copy of the state for all or
 *            nothing); rebuilt, never saved.  A law keeps no array larger
 *            than a few hundred doubles on the stack: an importer may step
 *            the FMU on a thread with a small stack (512 kB on macOS's
 *            secondary threads), so anything sized by the law's state or
 *            outputs lives here.
 *
 * The law's clock comes from config.h: LAW_CONTINUOUS 1 for a law of time
 * alone (evaluated at t + h), else LAW_TS_SLOT, the parameter holding the
 * sample time [s] (0: once per communication step).
 *
 * Every function returns a ctl_status (ctl_law.h): CTL_OK, or a reason.
 */
#ifndef GRB_LAW_H
#define GRB_LAW_H

#include "ctl_law.h"
#include "config.h"

/* CTL_BAD_PARAMETER with *field the index of the offending parameter and *why the rule, or
 * *field LAW_FIELD_IN_WHY and *why the whole refusal, the field first ("link2.m: mass must be
 * positive, got -1.0": a rule the kernel words, as the library does).
 * work: LAW_N_CHECK doubles of working memory the FMU instance owns, apart
 * from the scratch (the check also judges a state to restore, while the
 * scratch serves the run): a check that runs the kernel (the computed
 * torque's loop closed at the sketch) works there, not on the stack. */
#define LAW_FIELD_IN_WHY (-2)
int law_check(const double *param, double *work, int *field, const char **why);
/* CTL_BAD_STATE with *field naming a part of the state (law_state_name) and *why the rule. */
int law_check_state(const double *param, const double *state, int *field, const char **why);
const char *law_state_name(int field);
/* Derived constants, once the parameters passed law_check: only a law with
 * scratch (LAW_N_SCRATCH > 0) defines it. */
int law_prepare(const double *param, double *scratch);
/* The state at the start time t0 and the outputs before the first sample. */
int law_start(const double *param, const double *scratch, double t0, double *state, double *out);
/* One sample at time t: state advanced, out the new outputs.  All or nothing:
 * on any status but CTL_OK, state and out are as they were. */
int law_sample(const double *param, double *scratch, double *state, double t, const double *in, double *out);
/* Optional, for a law whose state ends in a store sized for its largest
 * parameters (the encoder's delay line: LAW_N_STATE holds the longest delay):
 * how many leading doubles of the state a run under param reads or writes
 * (at most LAW_N_STATE); the rest stays as law_start left it.  A system FMU
 * (grubler.system.native) backs up only these before each step; a law
 * without it has its whole state backed up. */
long law_state_used(const double *param);

#endif
