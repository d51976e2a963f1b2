/* ctl_trajectory: the setpoint generator of grubler.controllers.trajectory
 * (kinds and rules in controllers/trajectory.py's docstring): position,
 * velocity and acceleration as exact piecewise polynomials of time.
 *
 *   ctl_trajectory_params p = { kind, start, delay, speed, distance, v_max,
 *       a_max, j_max, dwell, repeat, reverse, amplitude, frequency };
 *   ctl_table  tab = { n, times, positions, second } (caller-owned arrays of n);
 *   ctl_trajectory_check(&p, &tab, &field, &why)   the fields its kind uses;
 *   ctl_move_plan(&p, &move)         a move's constant-jerk segments;
 *   ctl_table_prepare(&tab, work)    the clamped cubic spline's second
 *       derivatives (work: n doubles);
 *   ctl_trajectory_evaluate(&p, &move, &tab, t, out)   out = p, v, a at t.
 */
#ifndef CTL_TRAJECTORY_H
#define CTL_TRAJECTORY_H

#include "ctl_law.h"

#ifdef __cplusplus
extern "C" {
#endif

enum ctl_trajectory_kind { CTL_CONSTANT = 0, CTL_TRAPEZOID, CTL_SCURVE, CTL_SINE, CTL_TABLE };

typedef struct ctl_trajectory_params {
    double kind;        /* enum ctl_trajectory_kind */
    double start;       /* position at rest before the motion [rad] */
    double delay;       /* time the motion starts [s], >= 0 */
    double speed;       /* constant: speed [rad/s] */
    double distance;    /* moves: signed length of each move [rad], non-zero */
    double v_max, a_max, j_max;  /* moves: limits [rad/s, rad/s2, rad/s3], > 0 (j_max: scurve) */
    double dwell;       /* moves: rest after each move [s], >= 0 */
    double repeat;      /* moves: number of moves, a whole number, 0 for endless */
    double reverse;     /* moves: 1 back and forth, 0 onwards */
    double amplitude;   /* sine [rad] */
    double frequency;   /* sine [Hz], >= 0 */
} ctl_trajectory_params;

enum ctl_trajectory_field {
    CTL_TRJ_KIND, CTL_TRJ_START, CTL_TRJ_DELAY, CTL_TRJ_SPEED, CTL_TRJ_DISTANCE, CTL_TRJ_V_MAX, CTL_TRJ_A_MAX,
    CTL_TRJ_J_MAX, CTL_TRJ_DWELL, CTL_TRJ_REPEAT, CTL_TRJ_REVERSE, CTL_TRJ_AMPLITUDE, CTL_TRJ_FREQUENCY,
    CTL_TRJ_N_PARAMS, CTL_TRJ_TIMES = CTL_TRJ_N_PARAMS, CTL_TRJ_POSITIONS
};

/* Constant jerk over duration from the state (p0, v0, a0) at its start t0. */
typedef struct ctl_segment {
    double t0, duration, p0, v0, a0, jerk;
} ctl_segment;

#define CTL_MAX_SEGMENTS 7
typedef struct ctl_move {
    int n;                               /* segments (phases of zero length are left out) */
    ctl_segment seg[CTL_MAX_SEGMENTS];
    double move_time;                    /* [s] */
} ctl_move;

/* A recorded profile: n >= 2 strictly increasing times and their positions,
 * through a cubic spline with zero end velocities. */
typedef struct ctl_table {
    long n;
    const double *times;     /* [s] after delay */
    const double *positions; /* [rad] */
    double *second;          /* the spline's second derivatives at the points (ctl_table_prepare) */
} ctl_table;

CTL_API const char *ctl_trajectory_field_name(int field);
/* tab may be NULL unless kind is CTL_TABLE. */
CTL_API int ctl_trajectory_check(const ctl_trajectory_params *p, const ctl_table *tab, int *field, const char **why);
/* A move's raw phases (duration, acceleration at start, jerk): 3 for a
 * trapezoid, 7 for an S-curve, in phases[3 * k ..]; *n their count. */
CTL_API int ctl_move_phases(const ctl_trajectory_params *p, double *phases, int *n);
CTL_API int ctl_move_plan(const ctl_trajectory_params *p, ctl_move *move);
/* out = position, velocity and acceleration tau [s] into the segment. */
CTL_API int ctl_segment_at(const ctl_segment *s, double tau, double *out);
CTL_API int ctl_table_prepare(ctl_table *tab, double *work);
/* move: planned for moves (else unused, may be NULL); tab: prepared for tables. */
CTL_API int ctl_trajectory_evaluate(const ctl_trajectory_params *p, const ctl_move *move, const ctl_table *tab,
                                    double t, double *out);

#ifdef __cplusplus
}
#endif
#endif
