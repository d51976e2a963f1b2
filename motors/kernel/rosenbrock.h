/* rosenbrock: one communication step of a small stiff system, by ROS2.
 *
 * ROS2 (Verwer, Spee, Blom and Hundsdorfer 1999) is a two-stage Rosenbrock
 * method, L-stable, and of order two whatever matrix stands in for the
 * Jacobian: so the Jacobian comes from finite differences and serves several
 * sub-steps. The error of each sub-step (the embedded first-order solution's
 * difference) is held below tolerance times each state's scale, and every
 * sub-step's end is projected onto the states' lower bounds (a pressure cannot
 * fall below a vacuum). Time is carried as one more state, so a right-hand side
 * that moves with time (an input ramp) needs no special term.
 *
 * The drives' models with fluid or gas stiffness use it: the hydraulic and the
 * pneumatic cylinder. C99, libm only; no globals, no allocation.
 */
#ifndef ROSENBROCK_H
#define ROSENBROCK_H

#define ROS_MAX_STATES 7 /* states of a problem; time makes one more */
#define ROS_MAX_SUBSTEPS 1000000L

/* dy = f(t, y) for t within the step (from 0), y of n states. */
typedef void (*ros_rhs)(const void *ctx, double t, const double *y, double *dy);

typedef struct ros_problem {
    int n;                  /* states, 1 .. ROS_MAX_STATES */
    ros_rhs rhs;
    const void *ctx;        /* handed to rhs */
    const double *scale;    /* per state: the error is relative to max(scale, |y|) */
    const double *lower;    /* per state: lower bound the states are projected onto, or NULL */
    double tolerance;       /* relative error per sub-step */
} ros_problem;

/* Advance y over dt; *substep is the step size control's memory (0: choose
 * one; on return the last full sub-step accepted). 0 on success; 1 when the
 * control gave up (more than ROS_MAX_SUBSTEPS sub-steps, or one below 1e-14 s),
 * and then y and *substep are untouched. */
int ros_advance(const ros_problem *pr, double *y, double dt, double *substep);

#endif
