/* cylinder: what a hydraulic and a pneumatic cylinder share: the piston's
 * geometry and seals, its end stops, and the spool of its proportional valve.
 * C99, libm only; no globals.
 *
 * The piston is the mechanism's: its position s = length - retracted_length
 * and speed come in as the actuator's length and rate; the cylinder's chambers
 * see the volumes and the displacement they give, and the rod returns the
 * force of the pressures less the seals' friction, plus the end stops'.
 */
#ifndef CYLINDER_H
#define CYLINDER_H

/* The first fields of either cylinder's parameters, in this order. */
typedef struct cyl_piston {
    double bore;               /* piston diameter D [m] */
    double rod;                /* rod diameter d < D [m] */
    double stroke;             /* L [m] */
    double retracted_length;   /* actuator length between its attachment points at s = 0 [m] */
    double dead_volume_a;      /* cap-side volume at s = 0, hoses or tubes included [m3] */
    double dead_volume_b;      /* rod-side volume at s = L [m3] */
    double viscous_friction;   /* b [N s/m] */
    double coulomb_friction;   /* F_c [N], smoothed as F_c tanh(s' / v_s) */
    double smoothing_speed;    /* v_s [m/s] */
    double stop_stiffness;     /* end stops: k [N/m] ... */
    double stop_damping;       /* ... and c [N s/m], acting only while compressed */
} cyl_piston;
#define CYL_PISTON_FIELDS 11

/* The chambers as the piston leaves them at one instant. */
typedef struct cyl_chambers {
    double area_a, area_b;     /* cap-side and rod-side piston areas [m2] */
    double position;           /* s [m], beyond [0, L] in an end stop */
    double displacement_rate;  /* s' where the piston moves, 0 where it stands in a stop [m/s] */
    double volume_a, volume_b; /* [m3] */
} cyl_chambers;

/* The first CYL_PISTON_FIELDS doubles of a parameter block: the rules they
 * break, as (field, reason), or field -1. */
void cyl_check_piston(const cyl_piston *p, int *field, const char **why);

cyl_chambers cyl_chambers_at(const cyl_piston *p, double length, double rate);

/* The rod's force from the pressures' force pressure_force [N] at this length
 * and rate: less the seals' friction, plus the end stop's. */
double cyl_rod_force(const cyl_piston *p, double pressure_force, double length, double rate);

/* The spool: its acceleration toward the command (clipped to [-1, 1]), and
 * the relative openings of the edges that open with positive and negative
 * travel, after the overlap. */
double cyl_spool_acceleration(double x, double x_rate, double command, double frequency, double damping);
void cyl_openings(double x, double overlap, double *plus, double *minus);

#endif
