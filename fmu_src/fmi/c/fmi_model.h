/* What the generic FMI co-simulation wrapper and a model file
 * (mechanism_model.c, motor_model.c, ...) share: the model contract, neutral to
 * the FMI version.
 *
 * The wrapper owns the FMI side: the instance, the state machine, every
 * argument and state check, value references, types, logging, and the FMU
 * state (get/set/serialise), written once in fmi_common.c; fmi2_wrapper.c and
 * fmi3_wrapper.c are thin adapters from each standard's functions and types to
 * it, as the FMI Reference FMUs serve both standards from one model.c.  An FMU
 * is compiled with one adapter; the model file is the same for both.  The model owns the physics: it keeps everything
 * that must survive a rollback in the instance's persistent block of doubles
 * (parameters and inputs first, in the slots config.h and model_variables.c
 * give, then its own state), and whatever it can rebuild from that block in its
 * scratch memory.  Both files are plain C99; nothing is global.
 */
#ifndef GRB_FMI_MODEL_H
#define GRB_FMI_MODEL_H

#include <stddef.h>

#include "config.h"

/* A call's outcome, numbered as fmi2Status and fmi3Status number theirs
 * (OK, Warning, Discard, Error, Fatal), so an adapter passes it on by a cast. */
typedef enum { GRB_FMI_OK = 0, GRB_FMI_WARNING = 1, GRB_FMI_DISCARD = 2, GRB_FMI_ERROR = 3, GRB_FMI_FATAL = 4 } grb_fmi_status;
/* A value reference (fmi2ValueReference and fmi3ValueReference are both 32-bit unsigned) */
typedef unsigned int grb_value_reference;

/* variable types and causalities, as grubler.fmi.variables codes them */
enum { GRB_T_REAL = 0, GRB_T_INTEGER = 1, GRB_T_BOOLEAN = 2, GRB_T_STRING = 3 };
enum { GRB_C_PARAMETER = 0, GRB_C_INPUT = 1, GRB_C_OUTPUT = 2, GRB_C_INDEPENDENT = 3 };

typedef struct grb_variable {
    const char *name;
    int type, causality;
    int slot;          /* parameter, input: index in the persistent block; output: in the model's output vector */
    int level;         /* output: the model's output level that computes it */
    int n_choices;     /* string parameter: accepted values, stored as their index */
    const char *const *choices;
    int enum_items;    /* enumeration: items 1 .. enum_items */
    int min, max;      /* integer parameter bounds (both 0: none) */
} grb_variable;

extern const grb_variable model_variables[MODEL_N_VARIABLES];

/* The persistent block: the parameters' and inputs' values (slots 0 ..
 * MODEL_N_STORED - 1), then for each slot 1.0 if the importer set it (a model
 * may default one parameter to another's value unless it was set), then the
 * model's own part from GRB_MODEL_BASE on. */
#define GRB_WAS_SET(inst, slot) ((inst)->p[MODEL_N_STORED + (slot)] != 0.0)
#define GRB_MODEL_BASE (2 * MODEL_N_STORED)
extern const double model_starts[MODEL_N_STORED];

/* Co-simulation states (FMI 2.0 and 3.0 without event mode have the same
 * ones: step complete is FMI 3.0's step mode), as bits so a call's allowed
 * states are a mask */
enum {
    GRB_INSTANTIATED = 1 << 0,
    GRB_INITIALIZATION = 1 << 1,
    GRB_STEP_COMPLETE = 1 << 2,
    GRB_TERMINATED = 1 << 3,
    GRB_ERROR = 1 << 4
};

typedef struct grb_instance grb_instance;

/* How an adapter hands a message to its importer (the instance's adapter fields say where). */
typedef void (*grb_logger)(const grb_instance *inst, grb_fmi_status status, const char *category, const char *message);

struct grb_instance {
    int fmi;                    /* the adapter's FMI major version, 2 or 3: names calls in messages */
    void *(*allocate)(size_t n, size_t size);  /* zeroed memory: the importer's (FMI 2.0) or calloc (FMI 3.0) */
    void (*release)(void *p);
    grb_logger logger;          /* the adapter's */
    const void *host;           /* the adapter's: the importer's componentEnvironment (FMI 2.0) or
                                 * instanceEnvironment (FMI 3.0), handed back with each message */
    void (*host_log)(void);     /* the adapter's: the importer's logger (FMI 2.0) or logMessage (FMI 3.0),
                                 * copied at instantiation (cast back to call it) */
    char *name;
    int state;                  /* one of the bits above */
    int resume;                 /* a state saved while stepping, restored while instantiated: GRB_STEP_COMPLETE,
                                 * entered by the first call that needs it unless the importer initialises */
    int logging;                /* fmi2SetDebugLogging, fmi3SetDebugLogging */
    double start_time;          /* fmi2SetupExperiment, fmi3EnterInitializationMode */
    int dirty;                  /* a parameter changed since the model last prepared */
    int level;                  /* outputs valid for this state and inputs: the model's levels up to this */
    double *p;                  /* persistent block, model_persistent_size() doubles */
    void *model;                /* the model's scratch, model_scratch_bytes() */
};

/* Log a message (printf format) with a status; Warning and worse are logged
 * whether debug logging is on or not: they carry the reason an importer needs. */
void grb_log(grb_instance *inst, grb_fmi_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* ---- provided by the model file ---------------------------------------- */

/* Doubles of the persistent block (at least MODEL_N_STORED). */
size_t model_persistent_size(void);
/* Bytes of scratch memory. */
size_t model_scratch_bytes(void);
/* The model's part of a fresh persistent block (after the parameters and inputs
 * got their start values): "not started". */
void model_reset(grb_instance *inst);
/* The model's checks of a persistent block's values: its parameters (those
 * values the wrapper's per-variable checks cannot judge: a length's sign, a
 * loop's joints, ...) and, when the block holds a started run, the run's state
 * (every number the model will compute with, ranges and finiteness).  GRB_FMI_ERROR
 * with a logged reason naming the field.  The one check for both ways values
 * arrive: model_prepare runs it on values the importer set, the wrapper on a
 * state before restoring it, so nothing in a block reaches the kernel unchecked. */
grb_fmi_status model_check(grb_instance *inst, const double *block);
/* Make the scratch (tables, the initial state unless the block holds a started
 * run) agree with the persistent block; called when inst->dirty.  GRB_FMI_ERROR with
 * a logged reason naming the parameter when model_check refuses the block. */
grb_fmi_status model_prepare(grb_instance *inst);
/* The run starts: from now on the persistent block holds a started run. */
grb_fmi_status model_start(grb_instance *inst);
/* Compute the outputs up to level (inst->level says what is valid). */
grb_fmi_status model_compute(grb_instance *inst, int level);
/* The output vector (MODEL_N_OUTPUTS doubles), valid up to inst->level. */
const double *model_outputs(const grb_instance *inst);
/* Highest output level that does not depend on the inputs. */
int model_input_free_level(void);
/* The time of the run (a started run). */
double model_time(const grb_instance *inst);
/* Does the model provide directional derivatives (fmi2GetDirectionalDerivative,
 * fmi3GetDirectionalDerivative; config.h, from its ModelSpec)? */
#ifndef MODEL_DIRECTIONAL_DERIVATIVE
#define MODEL_DIRECTIONAL_DERIVATIVE 0
#endif
#if MODEL_DIRECTIONAL_DERIVATIVE
/* The outputs' derivative along a direction of the inputs at the present state
 * and inputs: dv_unknown[k] for output unknown[k], the direction dv_known[j] of
 * input known[j] (value references the wrapper has checked: Real outputs and
 * Real inputs, seeds finite, the model prepared). */
grb_fmi_status model_directional_derivative(grb_instance *inst, const grb_value_reference unknown[],
                                            size_t n_unknown, const grb_value_reference known[], size_t n_known,
                                            const double dv_known[], double dv_unknown[]);
#endif
/* One communication step of h from t (the run's time, as the importer states
 * it); GRB_FMI_DISCARD with a logged reason when the inputs are not finite or the
 * integration fails (the run stays where it was).  On success the model sets
 * inst->level to what is valid for the new state. */
grb_fmi_status model_do_step(grb_instance *inst, double t, double h);

#endif
