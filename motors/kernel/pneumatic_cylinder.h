/* pneumatic_cylinder: a valve-controlled double-acting pneumatic cylinder.
 * C99, libm only.
 *
 * One implementation: the Python library (grubler.motors.pneumatic, through
 * ctypes) and the native PneumaticCylinder.fmu both run these functions.
 *
 * The circuit: a supply at constant pressure -> a proportional 5/3 valve (spool
 * with second-order dynamics and overlap; each metering edge an ISO 6358 flow
 * path) -> chamber A (cap side) and chamber B (rod side) -> exhaust.
 *
 *   dp_A/dt = n / V_A (R T_s m'_A - p_A A_A s')
 *   dp_B/dt = n / V_B (R T_s m'_B + p_B A_B s')      (absolute pressures here)
 *   m' = a(x) C rho_0 p_up sqrt(T_0 / T_s) phi(p_down / p_up)          (ISO 6358)
 *   phi(r) = 1 for r <= b (choked), sqrt(1 - ((r - b) / (1 - b))^2) above,
 *            falling linearly to 0 at r = 1 above the laminar ratio r_l
 *   F = p_A A_A - p_B A_B - b s' - F_c tanh(s' / v_s) + F_stop (gauge pressures)
 *
 * The gas is air (R = 287.05 J/(kg K)); its temperature in the chambers is
 * taken as the supply's T_s for the flows, and the chamber's change of state
 * is polytropic with exponent n: 1 isothermal (slow, good heat exchange) to
 * 1.4 adiabatic (fast, none). States: spool x and its rate, the gauge
 * pressures p_A, p_B; the piston's position and speed are the mechanism's
 * (inputs length and rate). A step is integrated by ROS2 (rosenbrock.h).
 *
 * API as hydraulic_cylinder.h: pnc_check_params, pnc_check_state, pnc_step,
 * pnc_observe, pnc_derivatives, pnc_field_name, pnc_status_message; every
 * function but the two that name things returns a pnc_status.
 *
 * Units: SI; pressures are gauge [Pa] (absolute = gauge + 101325 Pa).
 */
#ifndef PNEUMATIC_CYLINDER_H
#define PNEUMATIC_CYLINDER_H

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32) && defined(GRB_SHARED)
#define PNC_API __declspec(dllexport)
#else
#define PNC_API
#endif

#include "cylinder.h"

#define PNC_ATMOSPHERE 101325.0   /* Pa: absolute pressure at gauge zero */
#define PNC_GAS_CONSTANT 287.05   /* J/(kg K), dry air */
#define PNC_ADIABATIC 1.4         /* dry air's ratio of specific heats */
#define PNC_REFERENCE_DENSITY 1.185     /* kg/m3, ISO 8778 reference atmosphere (ISO 6358's rho_0) */
#define PNC_REFERENCE_TEMPERATURE 293.15 /* K, its T_0 */

typedef enum pnc_status {
    PNC_OK = 0,
    PNC_BAD_PARAMETER,   /* pnc_check_params: field and why say which and how */
    PNC_BAD_STATE,       /* a state not finite, or a pressure below vacuum */
    PNC_BAD_INPUT,       /* the command, length or rate is not finite */
    PNC_BAD_STEP_SIZE,   /* dt not positive and finite */
    PNC_STEP_FAILED,     /* the step size control gave up */
    PNC_BAD_ARGUMENT     /* a NULL pointer */
} pnc_status;

/* The constants.  Field order is the order of enum pnc_field. */
typedef struct pnc_params {
    cyl_piston piston;             /* bore, rod, stroke, ..., end stops (cylinder.h) */
    double leakage;                /* past the piston, m' = c (p_A - p_B) [kg/(s Pa)] */
    double sonic_conductance;      /* ISO 6358 C of one metering edge fully open [m3/(s Pa)] */
    double critical_pressure_ratio; /* ISO 6358 b, [0, 1) */
    double laminar_ratio;          /* pressure ratio above which an edge's flow turns laminar, (b, 1) */
    double valve_frequency;        /* [rad/s] */
    double valve_damping;          /* [1] */
    double overlap;                /* [0, 1) of full travel */
    double supply_pressure;        /* gauge [Pa] */
    double exhaust_pressure;       /* gauge [Pa] */
    double supply_temperature;     /* T_s [K] */
    double polytropic_exponent;    /* n in [1, 1.4]: isothermal to adiabatic */
    double tolerance;              /* relative error per sub-step (pressures: of 1 bar at least) */
} pnc_params;

enum pnc_field {
    PNC_BORE, PNC_ROD, PNC_STROKE, PNC_RETRACTED_LENGTH, PNC_DEAD_VOLUME_A, PNC_DEAD_VOLUME_B,
    PNC_VISCOUS_FRICTION, PNC_COULOMB_FRICTION, PNC_SMOOTHING_SPEED, PNC_STOP_STIFFNESS, PNC_STOP_DAMPING,
    PNC_LEAKAGE, PNC_SONIC_CONDUCTANCE, PNC_CRITICAL_PRESSURE_RATIO, PNC_LAMINAR_RATIO,
    PNC_VALVE_FREQUENCY, PNC_VALVE_DAMPING, PNC_OVERLAP, PNC_SUPPLY_PRESSURE, PNC_EXHAUST_PRESSURE,
    PNC_SUPPLY_TEMPERATURE, PNC_POLYTROPIC_EXPONENT, PNC_TOLERANCE,
    PNC_N_PARAMS,
    PNC_SPOOL = PNC_N_PARAMS, PNC_SPOOL_RATE, PNC_PRESSURE_A, PNC_PRESSURE_B
};

typedef struct pnc_state {
    double spool, spool_rate;      /* x [1], x' [1/s] */
    double pressure_a, pressure_b; /* gauge [Pa] */
    double substep;                /* the step size control's memory [s] (0: choose one) */
} pnc_state;

typedef struct pnc_inputs {
    double command;                /* valve command, clipped to [-1, 1]: +1 opens S->A and B->E */
    double length, rate;           /* actuator length [m] and rate [m/s] */
} pnc_inputs;

typedef struct pnc_outputs {
    double force;                  /* on the rod, positive pushing the attachment points apart [N] */
    double pressure_a, pressure_b; /* gauge [Pa] */
    double mass_flow_a, mass_flow_b; /* valve into chamber A, B [kg/s] */
    double air_consumption;        /* mass flow drawn from the supply [kg/s] */
    double position;               /* s [m] */
    double spool;                  /* x [1] */
    double mechanical_power;       /* force x rate [W] */
} pnc_outputs;

PNC_API const char *pnc_field_name(int field);
PNC_API const char *pnc_status_message(int status);
PNC_API int pnc_check_params(const pnc_params *p, int *field, const char **why);
PNC_API int pnc_check_state(const pnc_params *p, const pnc_state *s, int *field, const char **why);
PNC_API int pnc_step(const pnc_params *p, pnc_state *s, const pnc_inputs *in, double dt, pnc_outputs *out);
PNC_API int pnc_observe(const pnc_params *p, const pnc_state *s, const pnc_inputs *in, pnc_outputs *out);
PNC_API int pnc_derivatives(const pnc_params *p, const pnc_state *s, const pnc_inputs *in, double *dydt);

#ifdef __cplusplus
}
#endif
#endif
