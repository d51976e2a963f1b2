/* The trajectory law file (law.h) over controllers/kernel/ctl_trajectory.c:
 * the FMU's parameters are ctl_trajectory_params' doubles in order, then (a
 * table FMU) TRAJECTORY_POINTS times and as many positions; no inputs; its
 * outputs position, velocity and acceleration at the end of each step; no
 * state (a function of time).  The scratch holds the move's plan and the
 * table spline's second derivatives. */
#include <string.h>

#include "ctl_trajectory.h"
#include "law.h"

#define PLAN_DOUBLES ((sizeof(ctl_move) + sizeof(double) - 1) / sizeof(double))
typedef char params_fit[LAW_N_PARAMS * sizeof(double) == sizeof(ctl_trajectory_params) +
                        2 * TRAJECTORY_POINTS * sizeof(double) ? 1 : -1];
typedef char scratch_fits[LAW_N_SCRATCH == PLAN_DOUBLES + 2 * TRAJECTORY_POINTS ? 1 : -1];

/* the table in the block (times, positions) and the scratch (second derivatives, work) */
static ctl_table table_of(const double *param, double *second) {
    ctl_table tab;
    tab.n = TRAJECTORY_POINTS;
    tab.times = param + CTL_TRJ_N_PARAMS;
    tab.positions = param + CTL_TRJ_N_PARAMS + TRAJECTORY_POINTS;
    tab.second = second;
    return tab;
}

int law_check(const double *param, double *work, int *field, const char **why) {
    ctl_trajectory_params p;
    ctl_table tab = table_of(param, NULL);
    int st;
    (void)work;
    memcpy(&p, param, sizeof p);
    st = ctl_trajectory_check(&p, &tab, field, why);
    /* a table's field is the first of its times or positions */
    if (st == CTL_BAD_PARAMETER && field && *field == CTL_TRJ_POSITIONS) *field = CTL_TRJ_N_PARAMS + TRAJECTORY_POINTS;
    return st;
}

int law_check_state(const double *param, const double *state, int *field, const char **why) {
    (void)param;
    (void)state;
    (void)field;
    (void)why;
    return CTL_OK;  /* no state */
}

const char *law_state_name(int field) { return ctl_trajectory_field_name(field); }

int law_prepare(const double *param, double *scratch) {
    ctl_trajectory_params p;
    ctl_move move;
    int st;
    memcpy(&p, param, sizeof p);
    memset(&move, 0, sizeof move);
    if (p.kind == CTL_TRAPEZOID || p.kind == CTL_SCURVE) {
        if ((st = ctl_move_plan(&p, &move)) != CTL_OK) return st;
    }
    memcpy(scratch, &move, sizeof move);
    if (p.kind == CTL_TABLE) {
        ctl_table tab = table_of(param, scratch + PLAN_DOUBLES);
        return ctl_table_prepare(&tab, scratch + PLAN_DOUBLES + TRAJECTORY_POINTS);
    }
    return CTL_OK;
}

static int evaluate(const double *param, const double *scratch, double t, double *out) {
    ctl_trajectory_params p;
    ctl_move move;
    ctl_table tab = table_of(param, (double *)(scratch + PLAN_DOUBLES));
    memcpy(&p, param, sizeof p);
    memcpy(&move, scratch, sizeof move);
    return ctl_trajectory_evaluate(&p, &move, &tab, t, out);
}

int law_start(const double *param, const double *scratch, double t0, double *state, double *out) {
    (void)state;
    return evaluate(param, scratch, t0, out);
}

int law_sample(const double *param, double *scratch, double *state, double t, const double *in, double *out) {
    (void)state;
    (void)in;
    return evaluate(param, scratch, t, out);
}
