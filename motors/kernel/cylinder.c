/* cylinder: the piston and the valve spool of cylinder.h. */
#include "cylinder.h"

#include <math.h>

#define PI 3.14159265358979323846

void cyl_check_piston(const cyl_piston *p, int *field, const char **why)
{
    const double *v = &p->bore; /* the struct is CYL_PISTON_FIELDS doubles */
    *field = -1;
    for (int f = 0; f < CYL_PISTON_FIELDS; f++) {
        const double x = v[f];
        if (!isfinite(x)) { *field = f; *why = "must be finite"; return; }
        /* lengths and volumes positive; the offset and the seals' friction and damping may be zero */
        int may_be_zero = f == 3 || f == 6 || f == 7 || f == 10;
        if (may_be_zero ? x < 0.0 : !(x > 0.0)) { *field = f; *why = may_be_zero ? "must be >= 0" : "must be positive"; return; }
    }
    if (!(p->rod < p->bore)) { *field = 1; *why = "must be narrower than the bore"; }
}

cyl_chambers cyl_chambers_at(const cyl_piston *p, double length, double rate)
{
    cyl_chambers c;
    double L = p->stroke;
    c.area_a = 0.25 * PI * p->bore * p->bore;
    c.area_b = 0.25 * PI * (p->bore * p->bore - p->rod * p->rod);
    c.position = length - p->retracted_length;
    /* in an end stop the piston stands: the mechanism's overtravel is the stop's
     * compression, not a volume change */
    double s = c.position < 0.0 ? 0.0 : (c.position > L ? L : c.position);
    c.displacement_rate = ((c.position <= 0.0 && rate < 0.0) || (c.position >= L && rate > 0.0)) ? 0.0 : rate;
    c.volume_a = p->dead_volume_a + c.area_a * s;
    c.volume_b = p->dead_volume_b + c.area_b * (L - s);
    return c;
}

double cyl_rod_force(const cyl_piston *p, double pressure_force, double length, double rate)
{
    double s = length - p->retracted_length, stop = 0.0;
    if (s < 0.0)              /* retracted stop pushes out, damping only while compressing */
        stop = -p->stop_stiffness * s - p->stop_damping * (rate < 0.0 ? rate : 0.0);
    else if (s > p->stroke)   /* extended stop pulls in */
        stop = -p->stop_stiffness * (s - p->stroke) - p->stop_damping * (rate > 0.0 ? rate : 0.0);
    double friction = p->viscous_friction * rate + p->coulomb_friction * tanh(rate / p->smoothing_speed);
    return pressure_force - friction + stop;
}

double cyl_spool_acceleration(double x, double x_rate, double command, double frequency, double damping)
{
    double u = command > 1.0 ? 1.0 : (command < -1.0 ? -1.0 : command);
    return frequency * frequency * (u - x) - 2.0 * damping * frequency * x_rate;
}

void cyl_openings(double x, double overlap, double *plus, double *minus)
{
    if (x > 1.0) x = 1.0;
    if (x < -1.0) x = -1.0;
    *plus = x - overlap > 0.0 ? (x - overlap) / (1.0 - overlap) : 0.0;
    *minus = -x - overlap > 0.0 ? (-x - overlap) / (1.0 - overlap) : 0.0;
}
