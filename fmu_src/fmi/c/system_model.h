/* What the system model (system_model.c: a whole SSP system of grubler FMUs as
 * one native FMU, grubler.system.native) knows of each component model.
 *
 * Each component's model is the model file its own FMU was built from, with
 * its own config.h, variable table and copy of fmi_common.c, compiled under a
 * prefix of its own (a generated symbols.h renames every symbol the model
 * layer defines), so that several models share one binary.  A generated glue
 * at the end of its fmi_common.c unit hands the system its calls in this
 * struct: the same calls its FMU's adapter makes (set, step, get, the state's
 * checks), on instances whose persistent block lies inside the system's, so the
 * system's FMU state is the concatenation of its components' states.
 */
#ifndef GRB_SYSTEM_MODEL_H
#define GRB_SYSTEM_MODEL_H

#include "fmi_model.h"

typedef struct grb_component_calls {
    size_t (*persistent_size)(void);
    size_t (*scratch_bytes)(void);
    /* a fresh block: every value at its start, the model's part "not started" */
    void (*fresh)(grb_instance *ci);
    /* the checks a state's block passes before it is restored (each variable's value, the model's check) */
    int (*block_ok)(grb_instance *ci, const char *call, const double *block);
    /* the scratch agrees with the block (the model's check of its parameters first) */
    grb_fmi_status (*prepare)(grb_instance *ci);
    grb_fmi_status (*exit_initialization)(grb_instance *ci);
    /* as master.c calls an FMU (system/c/master.c: grb_set_real_fn, grb_get_real_fn, grb_do_step_fn) */
    int (*set_real)(void *ci, const unsigned int *vr, size_t n, const double *value);
    int (*get_real)(void *ci, const unsigned int *vr, size_t n, double *value);
    int (*do_step)(void *ci, double t, double h, int no_set_fmu_state_prior);
    /* its outputs' derivatives along its inputs at the present state (its FMU's getDirectionalDerivative;
     * an Error where its model provides none) */
    int (*directional)(void *ci, const unsigned int *unknown, size_t n_unknown, const unsigned int *known,
                       size_t n_known, const double *seed, double *sensitivity);
    /* the leading doubles of a block a run under the block's parameters reads or writes (a law's store sized
     * for its largest parameters is not all of it: law.h's law_state_used), what a rollback restores */
    size_t (*live_size)(const double *block);
} grb_component_calls;

/* A value the system's block gives a component's: one of its parameters or unconnected inputs. */
typedef struct grb_binding {
    int system_slot;     /* in the system's block */
    int component_slot;  /* in the component's */
    int given;           /* 1: the system file sets it (the component takes it as set by its importer) */
} grb_binding;

/* One component instance: its model's calls and its wiring, in the system's stepping order. */
typedef struct grb_component {
    const char *name;
    const grb_component_calls *calls;
    int n_stored;                      /* its model's MODEL_N_STORED: where its was-set flags start */
    size_t n_bound;
    const grb_binding *bound;
    size_t n_free;                     /* unconnected inputs: value references, and slots in the system's block */
    const unsigned int *free_vr;
    const int *free_slot;
    size_t n_in;                       /* connected inputs: value references, and slots in the connection values */
    const unsigned int *in_vr;
    const int *in_slot;
    size_t n_conn;                     /* connected outputs: value references, and their slots */
    const unsigned int *conn_vr;
    const int *out_slot;
    size_t n_out;                      /* outputs the system shows: value references, first index in its outputs, */
    const unsigned int *out_vr;
    int out_base;
    const int *out_level;              /* and the system's output level of each (1 + the component's own level) */
    int sampled;                       /* reads its inputs at sample instants (grubler.system.coupling) */
    const int *in_mode;                /* the extrapolating master's mode of each connected input (grb_input_mode), */
    const int *in_mode_adaptive;       /* and with a tolerance, in the adaptive stepping order */
} grb_component;

#endif
