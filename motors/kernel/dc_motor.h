/* dc_motor: a permanent-magnet DC motor with gearbox, current-limited drive
 * and one-node winding thermal model.  C99, libm only.
 *
 * One implementation: the Python library (grubler.motors.dc_motor, through
 * ctypes in grubler.motors.native) and the native DCMotor.fmu both run these
 * functions; the equations are stated in motors/dc_motor.py's docstring.
 *
 * API (every function but the two that name things returns a dcm_status;
 * no globals, no allocation: the caller owns every struct):
 *
 *   dcm_params  p  = { the constants: motor data, gearbox, drive, ambient };
 *   dcm_state   s  = { winding current, winding temperature };
 *   dcm_outputs o;
 *
 *   dcm_check_params(&p, &field, &why)   once, after the parameters are set:
 *       DCM_BAD_PARAMETER names the offending field (dcm_field_name(field))
 *       and why it is refused.  The functions below assume p passed it and
 *       do not check again (an FMU checks when it leaves initialisation).
 *   dcm_check_state(&p, &s, &field, &why)  a start state set from outside.
 *   dcm_step(&p, &s, voltage, shaft_speed, dt, &o)   one communication step
 *       with the inputs held; s is updated and o holds the outputs at the
 *       step's end, or, on any status but DCM_OK, s and o are left as they
 *       were (a rejected step can simply be retried with other inputs).
 *   dcm_observe(&p, &s, voltage, shaft_speed, &o)    the outputs now, for
 *       these inputs (what an FMU returns between steps).
 *   dcm_shaft_torque, dcm_current_for_torque, dcm_reflected_inertia: the
 *       torque law, its inverse over arrays (motor sizing), and J_rotor N^2
 *       (an FMU output: the mechanism's drive.inertia).
 *   dcm_chatter_free_step: the step above which an FMU should warn that the
 *       friction may chatter with the speed held.
 *   dcm_status_message(status): a sentence for a log.
 *
 * dcm_state is all the motor remembers: an FMU's get/set/serialise state is
 * these two doubles (plus its inputs).  No current limit is INFINITY here (the
 * FMU's "0: none" is the wrapper's convention).
 *
 * Units: SI, temperatures in degC, torque and speed at the gearbox output
 * unless named motor_.
 */
#ifndef DC_MOTOR_H
#define DC_MOTOR_H

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32) && defined(GRB_SHARED)
#define DCM_API __declspec(dllexport)
#else
#define DCM_API
#endif

typedef enum dcm_status {
    DCM_OK = 0,
    DCM_BAD_PARAMETER,        /* dcm_check_params: field and why say which and how */
    DCM_BAD_STATE,            /* a state not finite, beyond the current limit, or where R(T) <= 0 */
    DCM_BAD_VOLTAGE,          /* the commanded voltage is not finite */
    DCM_BAD_SHAFT_SPEED,      /* the shaft speed is not finite */
    DCM_BAD_STEP_SIZE,        /* dt not positive and finite, or more than DCM_MAX_SUBSTEPS sub-steps */
    DCM_RESISTANCE_VANISHED,  /* the winding cooled to where R(T) = R_ref (1 + alpha (T - T_ref)) <= 0 */
    DCM_BAD_ARGUMENT          /* a NULL pointer or a negative count */
} dcm_status;

/* A step is cut into ceil(dt / max_substep) sub-steps; more than this many is
 * refused rather than run for minutes (an importer's runaway step size). */
#define DCM_MAX_SUBSTEPS 100000000.0

/* Largest accepted relative mismatch between k_e and k_t: in SI units they are
 * the same constant, and a model with k_e != k_t creates or destroys power
 * (grubler.motors.motor_data.KE_KT_TOLERANCE, the same figure). */
#define DCM_KE_KT_TOLERANCE 0.02

/* The ambient temperatures a motor may be run in [degC]: beyond them the data
 * sets' thermal figures mean nothing (grubler.motors.motor_data.AMBIENT_RANGE,
 * the same figures; a test holds them equal). */
#define DCM_AMBIENT_MIN (-50.0)
#define DCM_AMBIENT_MAX 200.0

/* The constants of a step.  Field order is the order of enum dcm_field. */
typedef struct dcm_params {
    /* the motor, at its own shaft */
    double resistance;              /* R_ref, terminal resistance at reference_temperature [Ohm] */
    double inductance;              /* L [H] */
    double torque_constant;         /* k_t [N m/A] */
    double back_emf_constant;       /* k_e [V s/rad], within DCM_KE_KT_TOLERANCE of k_t */
    double rotor_inertia;           /* J_rotor [kg m2]: not stepped here, it belongs to the mechanism */
    double viscous_friction;        /* b [N m s/rad] */
    double coulomb_friction;        /* tau_c [N m], smoothed as tau_c tanh(omega_m / omega_s) */
    double smoothing_speed;         /* omega_s [rad/s]: dry friction and the gearbox's direction of power flow change sign over it */
    double thermal_resistance;      /* R_th winding to ambient [K/W] */
    double thermal_time_constant;   /* tau_th [s]; heat capacity C_th = tau_th / R_th */
    double temperature_coefficient; /* alpha [1/K]: R(T) = R_ref (1 + alpha (T - T_ref)) */
    double reference_temperature;   /* T_ref [degC] */
    /* the gearbox */
    double gear_ratio;              /* N >= 1: motor speed / output speed */
    double gear_efficiency;         /* eta in (0, 1], applied in the direction of power flow */
    /* the drive */
    double supply_voltage;          /* V_supply [V]: the terminal voltage is clamped to +-V_supply */
    double current_limit;           /* I_max [A]; INFINITY: no limiter */
    /* the surroundings and the stepping */
    double ambient_temperature;     /* T_amb [degC] */
    double max_substep;             /* longest internal step [s]: refreshes R(T) and the thermal coupling */
} dcm_params;

enum dcm_field {
    DCM_RESISTANCE, DCM_INDUCTANCE, DCM_TORQUE_CONSTANT, DCM_BACK_EMF_CONSTANT, DCM_ROTOR_INERTIA,
    DCM_VISCOUS_FRICTION, DCM_COULOMB_FRICTION, DCM_SMOOTHING_SPEED, DCM_THERMAL_RESISTANCE,
    DCM_THERMAL_TIME_CONSTANT, DCM_TEMPERATURE_COEFFICIENT, DCM_REFERENCE_TEMPERATURE, DCM_GEAR_RATIO,
    DCM_GEAR_EFFICIENCY, DCM_SUPPLY_VOLTAGE, DCM_CURRENT_LIMIT, DCM_AMBIENT_TEMPERATURE, DCM_MAX_SUBSTEP,
    DCM_N_PARAMS,
    /* fields of dcm_state, for dcm_check_state */
    DCM_CURRENT = DCM_N_PARAMS, DCM_TEMPERATURE
};

/* What the motor remembers between steps: everything a rollback restores. */
typedef struct dcm_state {
    double current;                 /* winding current i [A] */
    double temperature;             /* winding temperature T [degC] */
} dcm_state;

/* The outputs at one instant. */
typedef struct dcm_outputs {
    double shaft_torque;            /* gearbox output torque [N m], without the rotor's inertia torque */
    double current;                 /* winding current [A] */
    double winding_temperature;     /* [degC] */
    double electrical_power;        /* terminal voltage x current [W], negative when generating */
    double motor_speed;             /* N x shaft speed [rad/s] */
    double back_emf;                /* k_e x motor speed [V] */
    double terminal_voltage;        /* what the drive applies: the command clamped and current-limited [V] */
} dcm_outputs;

/* The field's name as the library and the FMU spell it ("gear_ratio",
 * "current", ...), or NULL for a number that names no field. */
DCM_API const char *dcm_field_name(int field);

/* A sentence describing a status, for a log. */
DCM_API const char *dcm_status_message(int status);

/* DCM_OK, or DCM_BAD_PARAMETER with *field the first offending field and *why
 * the rule it breaks (a static string).  field and why may be NULL. */
DCM_API int dcm_check_params(const dcm_params *p, int *field, const char **why);

/* DCM_OK, or DCM_BAD_STATE with *field DCM_CURRENT or DCM_TEMPERATURE: a start
 * state must be finite, within the current limit, and warm enough that R(T) > 0. */
DCM_API int dcm_check_state(const dcm_params *p, const dcm_state *s, int *field, const char **why);

/* Advance s by dt [s] holding voltage [V] and shaft_speed [rad/s]; out (may be
 * NULL) gets the outputs at the end.  All or nothing: on failure s and out are
 * untouched.  p must have passed dcm_check_params. */
DCM_API int dcm_step(const dcm_params *p, dcm_state *s, double voltage, double shaft_speed, double dt,
                     dcm_outputs *out);

/* The outputs in state s with inputs voltage and shaft_speed. */
DCM_API int dcm_observe(const dcm_params *p, const dcm_state *s, double voltage, double shaft_speed,
                        dcm_outputs *out);

/* Gearbox output torque [N m] at winding current [A] and motor speed [rad/s]. */
DCM_API int dcm_shaft_torque(const dcm_params *p, double current, double motor_speed, double *torque);

/* The motor's linear model about state s (current, temperature) at
 * shaft_speed [rad/s], for control design: jac[0..4] = d(di/dt)/di,
 * d(di/dt)/d(shaft speed), d(di/dt)/d(voltage), d(shaft torque)/di and
 * d(shaft torque)/d(shaft speed), the analytic derivatives of the winding
 * equation and of dcm_shaft_torque.  The winding temperature is held (it moves
 * on the thermal time constant), and the drive's clamp and current limiter are
 * taken as inactive: a caller checks the operating point lies inside them. */
DCM_API int dcm_linearize(const dcm_params *p, const dcm_state *s, double shaft_speed, double *jac);

/* The inverse of dcm_shaft_torque over n points: the winding current that
 * gives the output torque[k] at motor_speed[k] (non-finite entries propagate). */
DCM_API int dcm_current_for_torque(const dcm_params *p, long n, const double *torque, const double *motor_speed,
                                   double *current);

/* J_rotor N^2 [kg m2]: the rotor's inertia seen at the gearbox output, which
 * the mechanism carries in its mass matrix (its drive.inertia). */
DCM_API int dcm_reflected_inertia(const dcm_params *p, double *inertia);

/* The longest communication step [s] over which a master may hold the shaft
 * speed without the dry friction chattering, 2 omega_s J_rotor / tau_c: held
 * speed makes the smoothed friction act as a damper of up to tau_c / omega_s on
 * the rotor, and an explicit step of such a damper is stable below 2 J / damping
 * (worst case: nothing but the rotor on the shaft).  INFINITY without dry friction.
 * An FMU warns when a step exceeds it. */
DCM_API int dcm_chatter_free_step(const dcm_params *p, double *step);

#ifdef __cplusplus
}
#endif
#endif
