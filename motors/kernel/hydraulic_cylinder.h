/* hydraulic_cylinder: a valve-controlled double-acting hydraulic cylinder with
 * its supply.  C99, libm only.
 *
 * One implementation: the Python library (grubler.motors.hydraulic, through
 * ctypes) and the native HydraulicCylinder.fmu both run these functions.
 *
 * The circuit (lumped fluid volumes, after Watton's and Merritt's textbook
 * models):
 *
 *   pump (constant flow Q_pump) -> supply node S (volume V_S, relief valve)
 *   -> proportional 4/3 valve (spool with second-order dynamics, overlap,
 *      turbulent orifices with a laminar transition, laminar leakage)
 *   -> chamber A (cap side, area A_A) and chamber B (rod side, A_B)
 *   -> tank at p_T.
 *
 * States: spool position x in [-1, 1] (fraction of full opening) and its rate,
 * the gauge pressures p_A, p_B and p_S.  The piston is not a state: its
 * position and speed are the mechanism's (inputs: the actuator's length and
 * rate; the length moves at the held rate over a step), and the cylinder
 * returns the force on the rod.
 *
 *   dp_A/dt = beta(p_A) / V_A (Q_PA - Q_AT - Q_L - A_A s')
 *   dp_B/dt = beta(p_B) / V_B (Q_PB - Q_BT + Q_L + A_B s')
 *   dp_S/dt = beta(p_S) / V_S (Q_pump - Q_relief - Q_PA - Q_PB)
 *   x'' = w^2 (u - x) - 2 zeta w x'
 *   Q_edge = K a(x) dp / (dp^2 + p_tr^2)^(1/4) + c_v dp,  K = Q_N / sqrt(dp_N)
 *   F = p_A A_A - p_B A_B - b s' - F_c tanh(s' / v_s) + F_stop
 *
 * beta(p) is the oil's bulk modulus softened by entrained air (isothermal,
 * volume fraction air_fraction at atmospheric pressure), times
 * p_abs^2 / (p_abs^2 + (1000 Pa)^2) (p_abs no less than 100 Pa there): near
 * a vacuum the oil cavitates, so a chamber the piston pulls from approaches it
 * smoothly and, once there, stays at it (each sub-step's end is projected onto
 * p_abs >= 0) until oil flows in again.  Fluid stiffness
 * makes the equations stiff (eigenvalues of 1e4 1/s are common), so a step is
 * integrated by an L-stable Rosenbrock method with error control (rosenbrock.h).
 *
 * API (every function but the two that name things returns a hyd_status; no
 * globals, no allocation: the caller owns every struct):
 *
 *   hyd_check_params(&p, &field, &why)    once, after the parameters are set;
 *   hyd_check_state(&p, &s, &field, &why) a start state set from outside;
 *   hyd_step(&p, &s, &in, dt, &o)         one communication step, the inputs
 *       held (the length moving at the held rate); all or nothing;
 *   hyd_observe(&p, &s, &in, &o)          the outputs now;
 *   hyd_status_message, hyd_field_name.
 *
 * Units: SI; pressures are gauge [Pa] (absolute = gauge + 101325 Pa).
 */
#ifndef HYDRAULIC_CYLINDER_H
#define HYDRAULIC_CYLINDER_H

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32) && defined(GRB_SHARED)
#define HYD_API __declspec(dllexport)
#else
#define HYD_API
#endif

#include "cylinder.h"

#define HYD_ATMOSPHERE 101325.0 /* Pa: absolute pressure at gauge zero, for the entrained air */

typedef enum hyd_status {
    HYD_OK = 0,
    HYD_BAD_PARAMETER,   /* hyd_check_params: field and why say which and how */
    HYD_BAD_STATE,       /* a state not finite, or a pressure below vacuum */
    HYD_BAD_INPUT,       /* the command, length or rate is not finite */
    HYD_BAD_STEP_SIZE,   /* dt not positive and finite */
    HYD_STEP_FAILED,     /* the step size control gave up (more than 1e6 sub-steps, or one below 1e-14 s) */
    HYD_BAD_ARGUMENT     /* a NULL pointer */
} hyd_status;

/* The constants.  Field order is the order of enum hyd_field. */
typedef struct hyd_params {
    cyl_piston piston;            /* bore, rod, stroke, ..., end stops (cylinder.h) */
    /* the oil */
    double bulk_modulus;          /* beta [Pa] */
    double air_fraction;          /* entrained air by volume at atmospheric pressure, [0, 0.5) */
    double leakage;               /* internal leakage past the piston, Q_L = c_L (p_A - p_B) [m3/(s Pa)] */
    /* the valve */
    double nominal_flow;          /* Q_N per metering edge, fully open, at nominal_pressure_drop [m3/s] */
    double nominal_pressure_drop; /* dp_N per edge [Pa] */
    double valve_frequency;       /* spool's natural frequency w [rad/s] */
    double valve_damping;         /* spool's damping ratio zeta [1] */
    double overlap;               /* spool travel before an edge opens, fraction of full travel [0, 1) */
    double valve_leakage;         /* laminar leakage per edge, c_v [m3/(s Pa)] */
    double transition_pressure;   /* p_tr: below it an orifice's flow turns laminar [Pa] */
    /* the supply */
    double pump_flow;             /* Q_pump [m3/s] */
    double relief_pressure;       /* cracking pressure of the relief valve [Pa] */
    double relief_gradient;       /* its flow per pressure above cracking [m3/(s Pa)] */
    double supply_volume;         /* V_S, pump to valve [m3] */
    double tank_pressure;         /* p_T [Pa] */
    /* the stepping */
    double tolerance;             /* relative error per sub-step (pressures: of 1e5 Pa at least) */
} hyd_params;

enum hyd_field {
    HYD_BORE, HYD_ROD, HYD_STROKE, HYD_RETRACTED_LENGTH, HYD_DEAD_VOLUME_A, HYD_DEAD_VOLUME_B,
    HYD_VISCOUS_FRICTION, HYD_COULOMB_FRICTION, HYD_SMOOTHING_SPEED, HYD_STOP_STIFFNESS, HYD_STOP_DAMPING,
    HYD_BULK_MODULUS, HYD_AIR_FRACTION, HYD_LEAKAGE, HYD_NOMINAL_FLOW, HYD_NOMINAL_PRESSURE_DROP,
    HYD_VALVE_FREQUENCY, HYD_VALVE_DAMPING, HYD_OVERLAP, HYD_VALVE_LEAKAGE, HYD_TRANSITION_PRESSURE,
    HYD_PUMP_FLOW, HYD_RELIEF_PRESSURE, HYD_RELIEF_GRADIENT, HYD_SUPPLY_VOLUME, HYD_TANK_PRESSURE, HYD_TOLERANCE,
    HYD_N_PARAMS,
    /* fields of hyd_state, for hyd_check_state */
    HYD_SPOOL = HYD_N_PARAMS, HYD_SPOOL_RATE, HYD_PRESSURE_A, HYD_PRESSURE_B, HYD_SUPPLY_PRESSURE
};

/* What the cylinder remembers between steps: everything a rollback restores.
 * substep is the step size control's last accepted sub-step (0: choose one). */
typedef struct hyd_state {
    double spool, spool_rate;     /* x [1], x' [1/s] */
    double pressure_a, pressure_b, supply_pressure; /* gauge [Pa] */
    double substep;               /* [s] */
} hyd_state;

typedef struct hyd_inputs {
    double command;               /* valve command u, clipped to [-1, 1]: +1 opens P->A and B->T fully */
    double length;                /* actuator length [m] (s = length - retracted_length) */
    double rate;                  /* its rate [m/s], positive extending */
} hyd_inputs;

typedef struct hyd_outputs {
    double force;                 /* on the rod, positive pushing the attachment points apart [N] */
    double pressure_a, pressure_b, supply_pressure; /* gauge [Pa] */
    double flow_a, flow_b;        /* valve to chamber A and B [m3/s] */
    double relief_flow;           /* [m3/s] */
    double position;              /* piston position s [m] */
    double spool;                 /* x [1] */
    double pump_power;            /* (p_S - p_T) Q_pump [W] */
    double piston_power;          /* (p_A' A_A - p_B' A_B) s', pressures above tank: what the fluid does on the piston [W] */
    double mechanical_power;      /* F s': what the rod does on the mechanism [W] */
    double throttling_loss;       /* the valve's edges, the relief valve and the internal leakage [W] */
    double compression_power;     /* rate of the fluid's stored energy, sum V/beta p' p'' [W] */
} hyd_outputs;

HYD_API const char *hyd_field_name(int field);
HYD_API const char *hyd_status_message(int status);
HYD_API int hyd_check_params(const hyd_params *p, int *field, const char **why);
HYD_API int hyd_check_state(const hyd_params *p, const hyd_state *s, int *field, const char **why);
/* Advance s by dt [s]; out (may be NULL) gets the outputs at the end, with the
 * length moved by rate x dt.  All or nothing: on failure s and out are untouched. */
HYD_API int hyd_step(const hyd_params *p, hyd_state *s, const hyd_inputs *in, double dt, hyd_outputs *out);
HYD_API int hyd_observe(const hyd_params *p, const hyd_state *s, const hyd_inputs *in, hyd_outputs *out);
/* The state derivative (x', x'', p_A', p_B', p_S') at s with the inputs in. */
HYD_API int hyd_derivatives(const hyd_params *p, const hyd_state *s, const hyd_inputs *in, double *dydt);

#ifdef __cplusplus
}
#endif
#endif
