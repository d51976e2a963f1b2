/* A whole SSP system of grubler FMUs as one model on the FMI wrapper
 * (fmi_model.h): grubler export SYSTEM.ssd (grubler.system.native).
 *
 * The components are the models their FMUs were built from, each compiled
 * under its own prefix (system_model.h), and the communication steps are
 * made by the master's own loop, system/c/master.c, included here: the same C
 * that steps the FMUs in grubler cosim, with the master its parameter "master"
 * names (Gauss-Seidel, Jacobi, extrapolating) and, with "tol", the same
 * error-controlled sub-steps, in the same order (with a tolerance, the sampled
 * components first, as cosim's adaptive_plan orders them), so the system FMU
 * matches grubler cosim run with the same step and settings.  Initialisation
 * is cosim's too: the coupled inputs settled in the stepping order while the
 * components are in initialisation mode, then every component started.
 *
 * The system's variables (config.h, model_variables.c, generated): its
 * communication step (slot SYSTEM_SLOT_STEP: a doStep of the importer's is
 * made of equal steps no longer than it), its master and tol (fixed
 * parameters), then every component's parameters, unconnected inputs and
 * outputs as "component.name".  Its persistent block: those parameters and
 * inputs, then
 *   P_STARTED     1: the block holds a started run
 *   P_T           the run's time
 *   P_VALUES      the connections' values (one per connected output), as the
 *                 master's loop leaves them after a step
 *   P_START, P_PREV, P_H_LAST  the extrapolating master's history: the values
 *                 at the last step's start and the point before it, and that
 *                 step's length (0: no past point yet)
 *   P_SUBSTEP, P_SUBSTEP_PREV  the adaptive master's sub-step clock (grb_adapt)
 *   P_COMPONENTS  each component's own persistent block, in stepping order
 * so the FMU state (a copy of the block) is the components' states together,
 * and a restored one is checked by each component's own checks.
 *
 * The scratch holds the component instances (the wrapper's grb_instance, their
 * blocks inside this one's), the master's view of them, its buffers, a copy of
 * the block taken before each step (a component's Discard puts the whole
 * system back), and each component's scratch.  The copy holds the system's own
 * part and each component's live part (its calls' live_size): the encoder's
 * delay line is sized for the longest delay, 10 000 readings, of which a run
 * uses delay + 1, and copying all of it was most of the copy (87 kB a step).
 */
#define GRB_MASTER_NO_CLOCK
#include "master.c"

#include <limits.h>
#include <math.h>
#include <string.h>

#include "system_model.h"

extern const grb_component system_components[SYSTEM_N_COMPONENTS];
extern const int system_adaptive_order[SYSTEM_N_COMPONENTS];  /* the sampled components first */
extern const char *const system_value_names[SYSTEM_N_VALUES + 1];
extern const int system_newton_unknowns[SYSTEM_N_UNKNOWN + 1];  /* the Newton master's unknowns' slots, */
extern const int system_newton_index[SYSTEM_N_VALUES + 1];      /* each slot's unknown or -1, */
extern const double system_newton_tol;                          /* and its tolerance (cosim's NEWTON_TOL) */

/* the Newton master's work (master.c's grb_newton.work): guess, base, y (a value each), r and two spare (an
   unknown each), then the factored Jacobian */
#define SYSTEM_NEWTON_WORK (3 * SYSTEM_N_VALUES + 3 * SYSTEM_N_UNKNOWN + SYSTEM_N_UNKNOWN * SYSTEM_N_UNKNOWN)

typedef struct system_scratch {
    grb_instance comp[SYSTEM_N_COMPONENTS];  /* in the system's stepping order */
    grb_fmu fmus[SYSTEM_N_COMPONENTS];       /* the master's view, in the run's order (wire) */
    int order[SYSTEM_N_COMPONENTS];          /* the component at each place of the run's order */
    double *saved[SYSTEM_N_COMPONENTS];      /* each component's block at a sub-step's start (rollback) */
    double work[4 * SYSTEM_N_VALUES + 1];    /* the adaptive master's */
    grb_adapt adapt;
    grb_newton newton;                       /* the Newton master's, its Jacobian loaded from the block */
    double newton_work[SYSTEM_NEWTON_WORK + 1];
    int newton_pivot[SYSTEM_N_UNKNOWN + 1];
    double in_buf[SYSTEM_N_IN + 1];
    double read_buf[SYSTEM_N_CONN + 1];
    double free_buf[SYSTEM_N_FREE + 1];
    double out[MODEL_N_OUTPUTS + 1];
    unsigned int ask_vr[SYSTEM_N_OUT_MAX + 1];  /* one component's outputs asked for, */
    double ask_value[SYSTEM_N_OUT_MAX + 1];     /* their values */
    double *backup;  /* the block before the step under way, at the block's offsets: */
    size_t live[SYSTEM_N_COMPONENTS];  /* each component's leading doubles in it (the rest untouched by a step) */
#if MODEL_DIRECTIONAL_DERIVATIVE
    unsigned int dd_vr[MODEL_N_OUTPUTS + 1];  /* one component's outputs asked for, */
    size_t dd_at[MODEL_N_OUTPUTS + 1];        /* where each goes among the importer's, */
    double dd_value[MODEL_N_OUTPUTS + 1];     /* their derivatives */
#endif
} system_scratch;

#define BAD(...) do { grb_log(inst, GRB_FMI_ERROR, __VA_ARGS__); return GRB_FMI_ERROR; } while (0)

static size_t aligned(size_t n) { return (n + 15u) & ~(size_t)15u; }

static size_t components_size(void) {
    size_t n = 0;
    int k;
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++) n += system_components[k].calls->persistent_size();
    return n;
}

size_t model_persistent_size(void) { return (size_t)P_COMPONENTS + components_size(); }

size_t model_scratch_bytes(void) {
    size_t n = aligned(sizeof(system_scratch)) + aligned(model_persistent_size() * sizeof(double));
    int k;
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++)
        n += aligned(system_components[k].calls->scratch_bytes())
             + aligned(system_components[k].calls->persistent_size() * sizeof(double));
    return n;
}

int model_input_free_level(void) { return 0; }
const double *model_outputs(const grb_instance *inst) { return ((const system_scratch *)inst->model)->out; }
double model_time(const grb_instance *inst) { return inst->p[P_T]; }

/* A component's message, in the system's log with the component's name. */
static void component_log(const grb_instance *ci, grb_fmi_status status, const char *category, const char *message) {
    (void)category;
    grb_log((grb_instance *)(size_t)ci->host, status, "%s: %s", ci->name, message);
}

/* The adaptive master's FMU state calls on a component: its block copied to and from its saved one
 * (as its FMU's fmi2GetFMUstate and fmi2SetFMUstate copy it, which grubler cosim calls). */
static int save_part(void *instance, void **state) {
    grb_instance *ci = (grb_instance *)instance;
    system_scratch *s = (system_scratch *)((grb_instance *)(size_t)ci->host)->model;
    memcpy(*state, ci->p, system_components[ci - s->comp].calls->persistent_size() * sizeof(double));
    return 0;
}

static int restore_part(void *instance, void *state) {
    grb_instance *ci = (grb_instance *)instance;
    system_scratch *s = (system_scratch *)((grb_instance *)(size_t)ci->host)->model;
    memcpy(ci->p, state, system_components[ci - s->comp].calls->persistent_size() * sizeof(double));
    ci->state = GRB_STEP_COMPLETE;
    ci->dirty = 1;
    ci->level = 0;
    return 0;
}

static int adaptive(const double *p) {
    return (int)p[SYSTEM_SLOT_MASTER] == GRB_EXTRAPOLATE && p[SYSTEM_SLOT_TOL] > 0.0;
}

/* The run's order is the sampled components first (cosim's adaptive_plan and newton_plan order them so). */
static int sampled_first(const double *p) { return adaptive(p) || (int)p[SYSTEM_SLOT_MASTER] == GRB_NEWTON; }

/* The master's view of the components, in the order the run steps them (with a tolerance the sampled
 * ones first: cosim's adaptive_plan), each with its input modes under the extrapolating master; cosim's
 * wiring (instance.py), nothing else read. */
static void wire(grb_instance *inst) {
    system_scratch *s = (system_scratch *)inst->model;
    int scheme = (int)inst->p[SYSTEM_SLOT_MASTER], adapt = adaptive(inst->p), first = sampled_first(inst->p), j;
    double *in = s->in_buf, *read = s->read_buf;
    for (j = 0; j < SYSTEM_N_COMPONENTS; j++) {
        int k = first ? system_adaptive_order[j] : j;
        const grb_component *c = &system_components[k];
        grb_fmu *f = &s->fmus[j];
        s->order[j] = k;
        memset(f, 0, sizeof *f);
        f->instance = &s->comp[k];
        f->set_real = c->calls->set_real;
        f->get_real = c->calls->get_real;
        f->do_step = c->calls->do_step;
        f->n_in = c->n_in;
        f->in_vr = c->in_vr;
        f->in_slot = c->in_slot;
        f->in_buf = in;
        f->n_conn = f->n_read = c->n_conn;
        f->read_vr = c->conn_vr;
        f->read_buf = read;
        f->out_slot = c->out_slot;
        f->in_mode = scheme == GRB_NEWTON ? c->in_mode_adaptive
                     : scheme != GRB_EXTRAPOLATE ? NULL : adapt ? c->in_mode_adaptive : c->in_mode;
        f->sampled = c->sampled;
        /* rolled back: the adaptive master's sub-stepped components, the Newton master's iterated ones */
        if (adapt ? !c->sampled : scheme == GRB_NEWTON && iterated(f)) {
            f->get_state = save_part;
            f->set_state = restore_part;
            f->state = s->saved[k];
        }
        in += c->n_in;
        read += c->n_conn;
    }
}

/* The components' instances laid out in the scratch, their blocks in this block; each block fresh. */
void model_reset(grb_instance *inst) {
    system_scratch *s = (system_scratch *)inst->model;
    unsigned char *next = (unsigned char *)inst->model + aligned(sizeof *s);
    double *block = inst->p + P_COMPONENTS;
    int k;
    s->backup = (double *)(void *)next;
    next += aligned(model_persistent_size() * sizeof(double));
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++) {
        const grb_component *c = &system_components[k];
        grb_instance *ci = &s->comp[k];
        memset(ci, 0, sizeof *ci);
        ci->fmi = inst->fmi;
        ci->allocate = inst->allocate;
        ci->release = inst->release;
        ci->logger = component_log;
        ci->host = inst;
        ci->name = (char *)(size_t)c->name;
        ci->state = GRB_INSTANTIATED;
        ci->logging = inst->logging;
        ci->p = block;
        ci->model = next;
        block += c->calls->persistent_size();
        next += aligned(c->calls->scratch_bytes());
        s->saved[k] = (double *)(void *)next;
        next += aligned(c->calls->persistent_size() * sizeof(double));
        c->calls->fresh(ci);
    }
    inst->p[P_STARTED] = 0.0;
    inst->p[P_T] = 0.0;
    wire(inst);
}

/* The system's own values, then (a block to restore) each component's by its own checks. */
grb_fmi_status model_check(grb_instance *inst, const double *p) {
    system_scratch *s = (system_scratch *)inst->model;
    const double *block = p + P_COMPONENTS;
    int k;
    double tol = p[SYSTEM_SLOT_TOL];
    int master = (int)p[SYSTEM_SLOT_MASTER];  /* (an index of its choices: the wrapper checked it) */
    if (!(p[SYSTEM_SLOT_STEP] > 0.0 && isfinite(p[SYSTEM_SLOT_STEP])))
        BAD("communication_step: must be positive and finite, got %.17g", p[SYSTEM_SLOT_STEP]);
    /* grubler cosim --tol's range (grubler.system.native.TOL_RANGE), or 0: no error control */
    if (!(tol == 0.0 || (tol >= 1e-14 && tol <= 0.5)))
        BAD("tol: must be 0 (no error control) or a number from 1e-14 to 0.5, got %.17g", tol);
    if (tol > 0.0 && master != GRB_EXTRAPOLATE)
        BAD("tol: error control is the extrapolating master's (master = \"%s\"), but master is \"%s\": set "
            "master to \"%s\" or tol to 0", model_variables[SYSTEM_SLOT_MASTER].choices[GRB_EXTRAPOLATE],
            model_variables[SYSTEM_SLOT_MASTER].choices[master], model_variables[SYSTEM_SLOT_MASTER].choices[GRB_EXTRAPOLATE]);
    if (p[P_STARTED] != 0.0 && p[P_STARTED] != 1.0) BAD("state.started: must be 0 or 1, got %g", p[P_STARTED]);
    if (p[P_STARTED] == 1.0) {
        if (!isfinite(p[P_T])) BAD("state.t: the time must be finite, got %g", p[P_T]);
        for (k = 0; k < SYSTEM_N_VALUES; k++)
            if (!isfinite(p[P_VALUES + k]) || !isfinite(p[P_START + k]) || !isfinite(p[P_PREV + k]))
                BAD("state.values: a connection's value must be finite, got %g (history %g, %g)", p[P_VALUES + k],
                    p[P_START + k], p[P_PREV + k]);
        if (!(p[P_H_LAST] >= 0.0 && isfinite(p[P_H_LAST])) || !(p[P_SUBSTEP] > 0.0 && isfinite(p[P_SUBSTEP])) ||
            !(p[P_SUBSTEP_PREV] >= 0.0 && isfinite(p[P_SUBSTEP_PREV])))
            BAD("state.substep: the master's step lengths must be finite and positive, got %g, %g, %g",
                p[P_H_LAST], p[P_SUBSTEP], p[P_SUBSTEP_PREV]);
        /* the Newton master's kept Jacobian: lu_solve reads it as factored, so a usable one must be (finite, a
         * non-zero pivot on the diagonal, each row swap within the rows below its own) */
        if (p[P_HAVE_JACOBIAN] != 0.0 && p[P_HAVE_JACOBIAN] != 1.0)
            BAD("state.have_jacobian: must be 0 or 1, got %g", p[P_HAVE_JACOBIAN]);
        if (p[P_HAVE_JACOBIAN] == 1.0)
            for (k = 0; k < SYSTEM_N_UNKNOWN; k++) {
                double pv = p[P_PIVOT + k];
                int j;
                if (!(pv >= (double)k && pv < (double)SYSTEM_N_UNKNOWN && pv == floor(pv)))
                    BAD("state.pivot: row %d's pivot must be a row from %d to %d, got %g", k, k,
                        SYSTEM_N_UNKNOWN - 1, pv);
                if (!(p[P_JACOBIAN + k * SYSTEM_N_UNKNOWN + k] != 0.0))
                    BAD("state.jacobian: its factored diagonal must be non-zero, got %g at row %d",
                        p[P_JACOBIAN + k * SYSTEM_N_UNKNOWN + k], k);
                for (j = 0; j < SYSTEM_N_UNKNOWN; j++)
                    if (!isfinite(p[P_JACOBIAN + k * SYSTEM_N_UNKNOWN + j]))
                        BAD("state.jacobian: must be finite, got %g", p[P_JACOBIAN + k * SYSTEM_N_UNKNOWN + j]);
            }
    }
    if (p == inst->p) return GRB_FMI_OK;  /* the components check theirs as they prepare */
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++) {
        const grb_component *c = &system_components[k];
        if (!c->calls->block_ok(&s->comp[k], "the system's state", block))
            BAD("%s: its part of the state is refused (see its reason above)", c->name);
        block += c->calls->persistent_size();
    }
    return GRB_FMI_OK;
}

/* Each component takes its parameters and unconnected inputs from the system's block, and its
 * mode from the system's run; then it prepares (its own checks name what it refuses). */
grb_fmi_status model_prepare(grb_instance *inst) {
    system_scratch *s = (system_scratch *)inst->model;
    int started = inst->p[P_STARTED] == 1.0, k;
    size_t j;
    if (model_check(inst, inst->p) != GRB_FMI_OK) return GRB_FMI_ERROR;
    wire(inst);  /* the master and tol as set */
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++) {
        const grb_component *c = &system_components[k];
        grb_instance *ci = &s->comp[k];
        for (j = 0; j < c->n_bound; j++) {
            const grb_binding *b = &c->bound[j];
            ci->p[b->component_slot] = inst->p[b->system_slot];
            ci->p[c->n_stored + b->component_slot] = b->given || GRB_WAS_SET(inst, b->system_slot) ? 1.0 : 0.0;
        }
        ci->start_time = inst->start_time;
        ci->logging = inst->logging;
        ci->state = started ? GRB_STEP_COMPLETE : GRB_INSTANTIATED;
        ci->resume = 0;
        ci->dirty = 1;
        ci->level = 0;
        if (c->calls->prepare(ci) > GRB_FMI_WARNING) BAD("%s: refused its parameters (see its reason above)", c->name);
    }
    return GRB_FMI_OK;
}

/* The importer's values of the unconnected inputs, set on each component that has some. */
static grb_fmi_status push_free_inputs(grb_instance *inst) {
    system_scratch *s = (system_scratch *)inst->model;
    int k, st;
    size_t j;
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++) {
        const grb_component *c = &system_components[k];
        if (c->n_free == 0) continue;
        for (j = 0; j < c->n_free; j++) s->free_buf[j] = inst->p[c->free_slot[j]];
        st = c->calls->set_real(&s->comp[k], c->free_vr, c->n_free, s->free_buf);
        if (st > GRB_FMI_WARNING) BAD("%s: its unconnected inputs were refused (see its reason above)", c->name);
    }
    return GRB_FMI_OK;
}

/* grubler cosim's initialisation (cosim._initialise): the coupled inputs propagated in the stepping
 * order until they settle, every component in initialisation mode; then each one started. */
grb_fmi_status model_start(grb_instance *inst) {
    system_scratch *s = (system_scratch *)inst->model;
    double *values = inst->p + P_VALUES;
    int k, sweep, st;
    size_t i;
    if (inst->p[P_STARTED] == 1.0) return GRB_FMI_OK;  /* a restored run: each component resumes from its block */
    for (k = 0; k < SYSTEM_N_VALUES; k++) values[k] = inst->p[P_START + k] = inst->p[P_PREV + k] = 0.0;
    inst->p[P_H_LAST] = 0.0;  /* no past point yet */
    inst->p[P_SUBSTEP] = inst->p[SYSTEM_SLOT_STEP];  /* the adaptive master's first try: the whole step */
    inst->p[P_SUBSTEP_PREV] = 0.0;
    for (k = 0; k < SYSTEM_N_UNKNOWN * SYSTEM_N_UNKNOWN; k++) inst->p[P_JACOBIAN + k] = 0.0;
    for (k = 0; k < SYSTEM_N_UNKNOWN; k++) inst->p[P_PIVOT + k] = (double)k;
    inst->p[P_HAVE_JACOBIAN] = 0.0;  /* made at the first step that needs it, as cosim's */
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++) s->comp[k].state = GRB_INITIALIZATION;
    for (sweep = 0; sweep < SYSTEM_N_COMPONENTS + 2; sweep++) {
        double change = 0.0;
        for (k = 0; k < SYSTEM_N_COMPONENTS; k++) {
            grb_fmu *f = &s->fmus[k];  /* in the run's order, as cosim initialises */
            const char *name = system_components[s->order[k]].name;
            if (f->n_in) {
                for (i = 0; i < f->n_in; i++) f->in_buf[i] = values[f->in_slot[i]];
                if (f->set_real(f->instance, f->in_vr, f->n_in, f->in_buf) > GRB_FMI_WARNING)
                    BAD("%s: setting its coupled inputs at initialisation failed (see its reason above)", name);
            }
            if (f->n_conn && f->get_real(f->instance, f->read_vr, f->n_conn, f->read_buf) > GRB_FMI_WARNING)
                BAD("%s: reading its coupled outputs at initialisation failed (see its reason above)", name);
            for (i = 0; i < f->n_conn; i++) {
                double v = f->read_buf[i], old = values[f->out_slot[i]], scale = 1.0;
                if (!isfinite(v)) BAD("%s: an initial output is %g at t = %g s", name, v, inst->start_time);
                if (fabs(v) > scale) scale = fabs(v);
                if (fabs(old) > scale) scale = fabs(old);
                if (fabs(v - old) / scale > change) change = fabs(v - old) / scale;
                values[f->out_slot[i]] = v;
            }
        }
        if (sweep > 0 && change < 1e-12) break;
    }
    if (sweep == SYSTEM_N_COMPONENTS + 2)
        BAD("initial values of the coupled inputs did not settle after %d sweeps: an algebraic loop the components "
            "do not declare?", SYSTEM_N_COMPONENTS + 2);
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++)
        if (system_components[s->order[k]].calls->exit_initialization(&s->comp[s->order[k]]) > GRB_FMI_WARNING)
            BAD("%s: could not start (see its reason above)", system_components[s->order[k]].name);
    /* the first communication point's values, read after every component started (as cosim's first row) */
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++) {
        grb_fmu *f = &s->fmus[k];
        if (f->n_conn == 0) continue;
        st = f->get_real(f->instance, f->read_vr, f->n_conn, f->read_buf);
        if (st > GRB_FMI_WARNING) BAD("%s: reading its coupled outputs failed (see its reason above)",
                                      system_components[s->order[k]].name);
        for (i = 0; i < f->n_conn; i++) values[f->out_slot[i]] = f->read_buf[i];
    }
    inst->p[P_STARTED] = 1.0;
    inst->p[P_T] = inst->start_time;
    return GRB_FMI_OK;
}

/* The shown outputs up to a level (a system output's level is 1 + its component's: an importer that
 * reads the crank angle does not pay for the joint forces), after the unconnected inputs took the
 * importer's values. */
grb_fmi_status model_compute(grb_instance *inst, int level) {
    system_scratch *s = (system_scratch *)inst->model;
    grb_fmi_status worst = GRB_FMI_OK;
    int k, st;
    size_t j, n;
    if (push_free_inputs(inst) != GRB_FMI_OK) return GRB_FMI_ERROR;
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++) {
        const grb_component *c = &system_components[k];
        for (j = 0, n = 0; j < c->n_out; j++)
            if (c->out_level[j] <= level) s->ask_vr[n++] = c->out_vr[j];
        if (n == 0) continue;
        st = c->calls->get_real(&s->comp[k], s->ask_vr, n, s->ask_value);
        if (st > GRB_FMI_WARNING) BAD("%s: its outputs could not be computed (see its reason above)", c->name);
        if (st > (int)worst) worst = (grb_fmi_status)st;
        for (j = 0, n = 0; j < c->n_out; j++)
            if (c->out_level[j] <= level) s->out[c->out_base + (int)j] = s->ask_value[n++];
    }
    return worst;
}

/* The block before a step, for roll_back: the system's own part, and each component's part that a run under its
 * parameters reads or writes (they do not change within a step). */
static void back_up(grb_instance *inst) {
    system_scratch *s = (system_scratch *)inst->model;
    int k;
    memcpy(s->backup, inst->p, (size_t)P_COMPONENTS * sizeof(double));
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++) {
        const grb_component_calls *c = system_components[k].calls;
        size_t at = (size_t)(s->comp[k].p - inst->p), n = c->live_size(s->comp[k].p);
        s->live[k] = n < c->persistent_size() ? n : c->persistent_size();
        memcpy(s->backup + at, s->comp[k].p, s->live[k] * sizeof(double));
    }
}

/* The system back where the step began (a component refused it); each component prepares from its block again. */
static void roll_back(grb_instance *inst) {
    system_scratch *s = (system_scratch *)inst->model;
    int k;
    memcpy(inst->p, s->backup, (size_t)P_COMPONENTS * sizeof(double));
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++) {
        size_t at = (size_t)(s->comp[k].p - inst->p);
        memcpy(s->comp[k].p, s->backup + at, s->live[k] * sizeof(double));
        s->comp[k].state = GRB_STEP_COMPLETE;
        s->comp[k].dirty = 1;
        s->comp[k].level = 0;
    }
}

/* One doStep of h from t: ceil(h / communication_step) equal communication steps of master.c's loop,
 * under the master and tol the parameters name.  The extrapolating master's history and the adaptive
 * master's sub-step clock live in the block (the FMU state carries them), so a run of doSteps is one run of
 * cosim's: the loop is told it is past its first step (first = 1, its clock moved back a step) when a past
 * point exists, and a past point a step of another length back is moved to this step's length (the same
 * slope: the loop extrapolates over equal steps). */
grb_fmi_status model_do_step(grb_instance *inst, double t, double h) {
    static const char *const calls[] = {"setReal", "doStep", "getReal", "FMU state"};
    system_scratch *s = (system_scratch *)inst->model;
    double *p = inst->p, *values = p + P_VALUES;
    double steps = ceil(h / p[SYSTEM_SLOT_STEP] - 1e-9), tn = t, when = t;
    long n, row = 0, first = 0;
    int k, adapt = adaptive(p);
    grb_run run;
    grb_failure fail;
    if (steps < 1.0) steps = 1.0;
    if (steps > 1e9) {
        grb_log(inst, GRB_FMI_DISCARD, "a step of %g s is %.3g communication steps of at most %g s; at most 1e9 "
                "per doStep (raise communication_step)", h, steps, p[SYSTEM_SLOT_STEP]);
        return GRB_FMI_DISCARD;
    }
    n = (long)steps;
    for (k = 0; k < SYSTEM_N_COMPONENTS; k++) s->comp[k].logging = inst->logging;  /* fmi2SetDebugLogging since */
    back_up(inst);
    if (push_free_inputs(inst) != GRB_FMI_OK) return GRB_FMI_ERROR;
    memset(&run, 0, sizeof run);
    run.scheme = (int)p[SYSTEM_SLOT_MASTER];
    run.step = h / (double)n;
    if (run.scheme == GRB_EXTRAPOLATE || run.scheme == GRB_NEWTON) {
        run.n_slots = SYSTEM_N_VALUES;
        run.start = p + P_START;
        run.prev = p + P_PREV;
        if (adapt) {
            memset(&s->adapt, 0, sizeof s->adapt);
            s->adapt.h = p[P_SUBSTEP];
            s->adapt.h_prev = p[P_SUBSTEP_PREV];
            s->adapt.worst_slot = -1;
            run.tol = p[SYSTEM_SLOT_TOL];
            run.work = s->work;
            run.adapt = &s->adapt;
        } else if (p[P_H_LAST] > 0.0) {  /* (the Newton master's guess extrapolates as this master does) */
            first = 1;
            if (run.step != p[P_H_LAST])
                for (k = 0; k < SYSTEM_N_VALUES; k++)
                    run.start[k] = values[k] - (values[k] - run.start[k]) * (run.step / p[P_H_LAST]);
        }
    }
    if (run.scheme == GRB_NEWTON) {  /* its settings, and the Jacobian kept in the block */
        grb_newton *nw = &s->newton;
        double *jac = s->newton_work + 3 * SYSTEM_N_VALUES + 3 * SYSTEM_N_UNKNOWN;
        memset(nw, 0, sizeof *nw);
        nw->tol = system_newton_tol;
        nw->max_iter = SYSTEM_NEWTON_MAX_ITER;
        nw->n_unknown = SYSTEM_N_UNKNOWN;
        nw->unknown_slot = system_newton_unknowns;
        nw->index = system_newton_index;
        nw->work = s->newton_work;
        nw->pivot = s->newton_pivot;
        nw->worst_slot = -1;
        nw->have_jacobian = p[P_HAVE_JACOBIAN] == 1.0;
        for (k = 0; k < SYSTEM_N_UNKNOWN * SYSTEM_N_UNKNOWN; k++) jac[k] = p[P_JACOBIAN + k];
        for (k = 0; k < SYSTEM_N_UNKNOWN; k++)  /* (checked when usable: model_check; else never read) */
            s->newton_pivot[k] = nw->have_jacobian ? (int)p[P_PIVOT + k] : k;
        run.newton = nw;
    }
    run.t0 = first ? t - run.step : t;
    run.t_end = t + h;
    run.n_steps = first + n + 1;  /* never the run's last step: each of the n is h / n long */
    run.record_every = LONG_MAX;  /* nothing recorded: the importer reads the outputs */
    run.times = &when;
    if (grb_master_steps(s->fmus, SYSTEM_N_COMPONENTS, values, &run, first, n, &tn, &row, &fail)) {
        const char *name = system_components[s->order[fail.fmu]].name;
        if (fail.call == CALL_TOL) {
            long w = s->adapt.worst_slot;
            double hs = s->adapt.h;
            roll_back(inst);
            grb_log(inst, GRB_FMI_DISCARD, "tol %g: the coupling's error estimate stays above the tolerance down to "
                    "a sub-step of %.3g s at t = %.17g s, largest at %s (the components' own accuracy may be the "
                    "floor): give a larger tol; the system is back at t = %.17g s", run.tol, hs, fail.t,
                    w >= 0 && w < SYSTEM_N_VALUES ? system_value_names[w] : "?", t);
            return GRB_FMI_DISCARD;
        }
        if (fail.status == GRB_FMI_DISCARD) {
            roll_back(inst);
            grb_log(inst, GRB_FMI_DISCARD, "%s: %s refused in the step from t = %.17g s (see its reason above); the "
                    "system is back at t = %.17g s", name, calls[fail.call], fail.t, t);
            return GRB_FMI_DISCARD;
        }
        BAD("%s: %s failed in the step from t = %.17g s (status %d, see its reason above)", name, calls[fail.call],
            fail.t, fail.status);
    }
    if ((run.scheme == GRB_EXTRAPOLATE && !adapt) || run.scheme == GRB_NEWTON) p[P_H_LAST] = run.step;
    if (run.scheme == GRB_NEWTON) {
        const double *jac = s->newton_work + 3 * SYSTEM_N_VALUES + 3 * SYSTEM_N_UNKNOWN;
        for (k = 0; k < SYSTEM_N_UNKNOWN * SYSTEM_N_UNKNOWN; k++) p[P_JACOBIAN + k] = jac[k];
        for (k = 0; k < SYSTEM_N_UNKNOWN; k++) p[P_PIVOT + k] = (double)s->newton_pivot[k];
        p[P_HAVE_JACOBIAN] = s->newton.have_jacobian ? 1.0 : 0.0;
    }
    if (adapt) {
        p[P_SUBSTEP] = s->adapt.h;
        p[P_SUBSTEP_PREV] = s->adapt.h_prev;
    }
    p[P_T] = t + h;
    inst->level = 0;
    if (run.scheme == GRB_NEWTON && s->newton.unconverged > 0) {  /* what grubler cosim warns of, said here */
        long w = s->newton.worst_slot;
        grb_log(inst, GRB_FMI_WARNING, "master newton: %ld of %ld steps from t = %.17g s kept after %ld evaluations "
                "with a coupling residual above %g (largest %.3g, relative, at %s): the components' own accuracy may "
                "be the floor, or the coupling too nonlinear at the step (a shorter communication_step)",
                s->newton.unconverged, s->newton.steps, t, s->newton.max_iter, system_newton_tol,
                s->newton.worst * system_newton_tol, w >= 0 && w < SYSTEM_N_VALUES ? system_value_names[w] : "?");
        return GRB_FMI_WARNING;
    }
    return GRB_FMI_OK;
}

#if MODEL_DIRECTIONAL_DERIVATIVE
/* The system's outputs' derivatives along its inputs: an input of the system is one component's
 * unconnected input, and at an instant it moves only that component's outputs (the others read the
 * connections' values of the last communication point, as model_compute reads them), so each known's
 * column is its component's own directional derivative, and zero for every other component's outputs.
 * (grubler.system.native declares it only when every component with an unconnected input gives its own.) */
grb_fmi_status model_directional_derivative(grb_instance *inst, const grb_value_reference unknown[],
                                            size_t n_unknown, const grb_value_reference known[], size_t n_known,
                                            const double dv_known[], double dv_unknown[]) {
    system_scratch *s = (system_scratch *)inst->model;
    size_t i, j, n, m;
    int k, at;
    if (push_free_inputs(inst) != GRB_FMI_OK) return GRB_FMI_ERROR;
    for (i = 0; i < n_unknown; i++) dv_unknown[i] = 0.0;
    for (j = 0; j < n_known; j++) {
        const grb_component *c = NULL;
        unsigned int vr = 0;
        int slot = model_variables[known[j] - 1].slot;
        for (k = 0; k < SYSTEM_N_COMPONENTS && c == NULL; k++)
            for (m = 0; m < system_components[k].n_free; m++)
                if (system_components[k].free_slot[m] == slot) {
                    c = &system_components[k];
                    vr = c->free_vr[m];
                    break;
                }
        if (c == NULL)
            BAD("getDirectionalDerivative: %s is not an input of a component", model_variables[known[j] - 1].name);
        if (dv_known[j] == 0.0) continue;
        /* this component's outputs among the unknowns, a buffer's worth at a time */
        for (i = 0; i < n_unknown;) {
            for (n = 0; i < n_unknown && n < MODEL_N_OUTPUTS; i++) {
                at = model_variables[unknown[i] - 1].slot - c->out_base;
                if (at >= 0 && (size_t)at < c->n_out) {
                    s->dd_vr[n] = c->out_vr[at];
                    s->dd_at[n++] = i;
                }
            }
            if (n == 0) continue;
            if (c->calls->directional(&s->comp[c - system_components], s->dd_vr, n, &vr, 1, &dv_known[j],
                                      s->dd_value) > GRB_FMI_WARNING)
                BAD("%s: its directional derivatives failed (see its reason above)", c->name);
            for (m = 0; m < n; m++) dv_unknown[s->dd_at[m]] += s->dd_value[m];
        }
    }
    return GRB_FMI_OK;
}
#endif
