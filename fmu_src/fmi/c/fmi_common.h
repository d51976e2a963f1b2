/* What the FMI adapters (fmi2_wrapper.c, fmi3_wrapper.c) share: the FMI side
 * of every native grubler FMU, written once in fmi_common.c.
 *
 * An adapter checks the call's state against its mask, converts its standard's
 * types to the contract's (a double per value, grb_value_reference, status
 * numbers equal to fmiXStatus's), and calls these.  Each function takes the
 * calling FMI function's name for its messages; a refusal is logged, puts the
 * instance in the error state (GRB_ERROR) and returns GRB_FMI_ERROR, or 0 / NULL
 * for a predicate.
 */
#ifndef GRB_FMI_COMMON_H
#define GRB_FMI_COMMON_H

#include "fmi_model.h"

/* every state but the error state */
#define GRB_ANY_LIVE (GRB_INSTANTIATED | GRB_INITIALIZATION | GRB_STEP_COMPLETE | GRB_TERMINATED)
/* the FMU state calls (get, set, serialise, deserialise; free takes no mask): every state, the error
 * state too.  FMI 2.0 section 2.1.3 and its co-simulation state table (section 4.2.4), FMI 3.0
 * section 2.2.3: after an Error the importer may restore an FMU state saved before it, and the run
 * goes on from there (a master that rolls back needs it); Reset and FreeInstance stay the other way out. */
#define GRB_FMU_STATE_CALLS (GRB_ANY_LIVE | GRB_ERROR)

/* the independent variable's value reference (FMI 3.0 declares time there; it
 * is no model variable, whose references start at 1) */
#define GRB_VR_TIME 0u

grb_fmi_status grb_fail(grb_instance *inst, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/* A model's status as the call's: worse than Discard puts the instance in the
 * error state (a Discard leaves it able to go on). */
grb_fmi_status grb_raise(grb_instance *inst, grb_fmi_status s);
/* The checks every call starts with: a live instance in one of the mask's states. */
int grb_allowed(grb_instance *inst, const char *call, int mask);

/* A new instance from the adapter's fields of `adapter` (fmi, allocate,
 * release, logger, host, host_log), or NULL after logging why (an empty name, a
 * token that is not this binary's, no memory). */
grb_instance *grb_instantiate(const grb_instance *adapter, const char *call, const char *name, const char *token,
                              int logging);
void grb_free_instance(grb_instance *inst);
/* Back to instantiated, every value at its start (fmi2Reset, fmi3Reset). */
void grb_reset(grb_instance *inst);
grb_fmi_status grb_set_debug_logging(grb_instance *inst, const char *call, int on, size_t n,
                                     const char *const categories[]);
grb_fmi_status grb_set_start_time(grb_instance *inst, const char *call, double start_time);
grb_fmi_status grb_exit_initialization(grb_instance *inst);
/* The run's time: the start time until the run starts. */
double grb_time(const grb_instance *inst);

/* Values.  grb_lookup: the variable of a value reference, of the type asked
 * (GRB_VR_TIME is FMI 3.0's time for the Real type). */
const grb_variable *grb_lookup(grb_instance *inst, const char *call, grb_value_reference vr, int type);
int grb_check_array(grb_instance *inst, const char *call, const void *vr, size_t nvr, const void *value);
/* The variable a value x is for, if it may be set now and x is a value it can hold. */
const grb_variable *grb_settable(grb_instance *inst, const char *call, grb_value_reference vr, int type, double x);
void grb_store(grb_instance *inst, const grb_variable *v, double x);
grb_fmi_status grb_get_real(grb_instance *inst, const char *call, const grb_value_reference vr[], size_t nvr,
                            double value[]);
grb_fmi_status grb_set_real(grb_instance *inst, const char *call, const grb_value_reference vr[], size_t nvr,
                            const double value[]);
/* Integer, Boolean and enumeration values (stored as doubles) as doubles. */
grb_fmi_status grb_get_stored(grb_instance *inst, const char *call, const grb_value_reference vr[], size_t nvr,
                              int type, double value[]);
grb_fmi_status grb_get_string(grb_instance *inst, const char *call, const grb_value_reference vr[], size_t nvr,
                              const char *value[]);
grb_fmi_status grb_set_string(grb_instance *inst, const char *call, const grb_value_reference vr[], size_t nvr,
                              const char *const value[]);

grb_fmi_status grb_do_step(grb_instance *inst, const char *call, double t, double h);
/* The outputs' derivatives along the inputs (unknowns Real outputs, knowns Real inputs). */
grb_fmi_status grb_directional_derivative(grb_instance *inst, const char *call, const grb_value_reference unknown[],
                                          size_t n_unknown, const grb_value_reference known[], size_t n_known,
                                          const double seed[], double sensitivity[]);

/* FMU state: an opaque copy of the persistent block, and its serialised bytes. */
grb_fmi_status grb_get_state(grb_instance *inst, const char *call, void **state);
grb_fmi_status grb_set_state(grb_instance *inst, const char *call, const void *state);
grb_fmi_status grb_free_state(grb_instance *inst, const char *call, void **state);
grb_fmi_status grb_serialized_size(grb_instance *inst, const char *call, const void *state, size_t *size);
grb_fmi_status grb_serialize(grb_instance *inst, const char *call, const void *state, unsigned char *bytes,
                             size_t size);
grb_fmi_status grb_deserialize(grb_instance *inst, const char *call, const unsigned char *bytes, size_t size,
                               void **state);

#endif
