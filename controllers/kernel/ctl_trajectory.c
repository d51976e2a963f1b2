/* ctl_trajectory: the trajectories of ctl_trajectory.h. */
#include "ctl_trajectory.h"

#include <math.h>
#include <stddef.h>

#define TWO_PI 6.283185307179586

static const char *const FIELD_NAMES[] = {
    "kind", "start", "delay", "speed", "distance", "v_max", "a_max", "j_max", "dwell", "repeat", "reverse",
    "amplitude", "frequency", "times", "positions"};

const char *ctl_trajectory_field_name(int field)
{
    return ctl_name(FIELD_NAMES, (int)(sizeof FIELD_NAMES / sizeof FIELD_NAMES[0]), field);
}

static int refuse(int f, const char *rule, int *field, const char **why)
{
    return ctl_refuse(f, CTL_TRJ_N_PARAMS, rule, field, why);
}

static int is_move(double kind)
{
    return kind == CTL_TRAPEZOID || kind == CTL_SCURVE;
}

int ctl_trajectory_check(const ctl_trajectory_params *p, const ctl_table *tab, int *field, const char **why)
{
    if (!p) return CTL_BAD_ARGUMENT;
    if (!(p->kind == CTL_CONSTANT || p->kind == CTL_TRAPEZOID || p->kind == CTL_SCURVE || p->kind == CTL_SINE ||
          p->kind == CTL_TABLE))
        return refuse(CTL_TRJ_KIND, "must be one of constant, trapezoid, scurve, sine, table", field, why);
    if (!isfinite(p->start)) return refuse(CTL_TRJ_START, "must be finite", field, why);
    if (!(p->delay >= 0.0) || !isfinite(p->delay)) return refuse(CTL_TRJ_DELAY, "must be finite and >= 0", field, why);
    if (p->kind == CTL_CONSTANT && !isfinite(p->speed)) return refuse(CTL_TRJ_SPEED, "must be finite", field, why);
    if (is_move(p->kind)) {
        if (!isfinite(p->distance)) return refuse(CTL_TRJ_DISTANCE, "must be finite", field, why);
        if (p->distance == 0.0) return refuse(CTL_TRJ_DISTANCE, "a move needs a non-zero distance", field, why);
        if (!(p->v_max > 0.0) || !isfinite(p->v_max)) return refuse(CTL_TRJ_V_MAX, "must be finite and > 0", field, why);
        if (!(p->a_max > 0.0) || !isfinite(p->a_max)) return refuse(CTL_TRJ_A_MAX, "must be finite and > 0", field, why);
        if (p->kind == CTL_SCURVE && (!(p->j_max > 0.0) || !isfinite(p->j_max)))
            return refuse(CTL_TRJ_J_MAX, "must be finite and > 0", field, why);
        if (!(p->dwell >= 0.0) || !isfinite(p->dwell)) return refuse(CTL_TRJ_DWELL, "must be finite and >= 0", field, why);
        if (!(p->repeat >= 0.0 && p->repeat == floor(p->repeat) && p->repeat <= 9007199254740991.0))
            return refuse(CTL_TRJ_REPEAT, "must be a whole number >= 0", field, why);
        if (p->reverse != 0.0 && p->reverse != 1.0) return refuse(CTL_TRJ_REVERSE, "must be 0 or 1", field, why);
    }
    if (p->kind == CTL_SINE) {
        if (!isfinite(p->amplitude)) return refuse(CTL_TRJ_AMPLITUDE, "must be finite", field, why);
        if (!(p->frequency >= 0.0) || !isfinite(p->frequency))
            return refuse(CTL_TRJ_FREQUENCY, "must be finite and >= 0", field, why);
    }
    if (p->kind == CTL_TABLE) {
        if (!tab || tab->n < 2 || !tab->times || !tab->positions)
            return refuse(CTL_TRJ_POSITIONS, "needs one position per time and at least two points", field, why);
        for (long k = 0; k < tab->n; k++) {
            if (!isfinite(tab->times[k])) return refuse(CTL_TRJ_TIMES, "must be a list of finite numbers", field, why);
            if (!isfinite(tab->positions[k]))
                return refuse(CTL_TRJ_POSITIONS, "must be a list of finite numbers", field, why);
            if (k > 0 && !(tab->times[k] > tab->times[k - 1]))
                return refuse(CTL_TRJ_TIMES, "must be strictly increasing", field, why);
        }
    }
    return CTL_OK;
}

static void put_phase(double *phases, int k, double duration, double a0, double jerk)
{
    phases[3 * k] = duration;
    phases[3 * k + 1] = a0;
    phases[3 * k + 2] = jerk;
}

/* (jerk time, whole acceleration time) to reach speed v from rest */
static void accel_time(double v, double a_max, double j_max, double *tj, double *ta)
{
    if (v * j_max >= a_max * a_max) {
        *tj = a_max / j_max;
        *ta = a_max / j_max + v / a_max;
    } else {
        *tj = sqrt(v / j_max);
        *ta = 2 * *tj;
    }
}

int ctl_move_phases(const ctl_trajectory_params *p, double *phases, int *n)
{
    double d, v, tj, ta, tv, tc, a_peak, a_max = p ? p->a_max : 0.0, j_max = p ? p->j_max : 0.0;
    if (!p || !phases || !n) return CTL_BAD_ARGUMENT;
    if (!is_move(p->kind)) return CTL_BAD_PARAMETER;
    d = fabs(p->distance);
    if (p->kind == CTL_TRAPEZOID) {
        /* accelerate at a_max, cruise at v_max, brake: a triangle when v_max is out of reach */
        v = fmin(p->v_max, sqrt(d * a_max));
        ta = v / a_max;
        tv = d / v - ta;
        put_phase(phases, 0, ta, a_max, 0.0);
        put_phase(phases, 1, tv, 0.0, 0.0);
        put_phase(phases, 2, ta, -a_max, 0.0);
        *n = 3;
        return CTL_OK;
    }
    /* seven phases of jerk +J, 0, -J, 0, -J, 0, +J (Biagiotti and Melchiorri, 3.4) */
    v = p->v_max;
    accel_time(v, a_max, j_max, &tj, &ta);
    if (v * ta > d) {  /* v_max out of reach: the peak speed whose move is exactly the distance */
        v = (-a_max / j_max + sqrt((a_max / j_max) * (a_max / j_max) + 4 * d / a_max)) * a_max / 2;
        if (v * j_max < a_max * a_max) v = pow(d * sqrt(j_max) / 2, 2.0 / 3.0);
        accel_time(v, a_max, j_max, &tj, &ta);
    }
    a_peak = j_max * tj;
    tv = d / v - ta;
    tc = ta - 2 * tj;
    put_phase(phases, 0, tj, 0.0, j_max);
    put_phase(phases, 1, tc, a_peak, 0.0);
    put_phase(phases, 2, tj, a_peak, -j_max);
    put_phase(phases, 3, tv, 0.0, 0.0);
    put_phase(phases, 4, tj, 0.0, -j_max);
    put_phase(phases, 5, tc, -a_peak, 0.0);
    put_phase(phases, 6, tj, -a_peak, j_max);
    *n = 7;
    return CTL_OK;
}

int ctl_segment_at(const ctl_segment *s, double tau, double *out)
{
    double j;
    if (!s || !out) return CTL_BAD_ARGUMENT;
    j = s->jerk;
    out[0] = s->p0 + tau * (s->v0 + tau * (s->a0 / 2 + tau * j / 6));
    out[1] = s->v0 + tau * (s->a0 + tau * j / 2);
    out[2] = s->a0 + tau * j;
    return CTL_OK;
}

int ctl_move_plan(const ctl_trajectory_params *p, ctl_move *move)
{
    double phases[3 * CTL_MAX_SEGMENTS], t = 0.0, pos = 0.0, vel = 0.0, end[3];
    int n, k, st;
    if (!p || !move) return CTL_BAD_ARGUMENT;
    if ((st = ctl_move_phases(p, phases, &n)) != CTL_OK) return st;
    move->n = 0;
    for (k = 0; k < n; k++) {  /* chained from rest at 0, phases of no length left out */
        ctl_segment *s = &move->seg[move->n];
        if (!(phases[3 * k] > 0.0)) continue;
        s->t0 = t;
        s->duration = phases[3 * k];
        s->p0 = pos;
        s->v0 = vel;
        s->a0 = phases[3 * k + 1];
        s->jerk = phases[3 * k + 2];
        ctl_segment_at(s, s->duration, end);
        pos = end[0];
        vel = end[1];
        t += s->duration;
        move->n++;
    }
    if (move->n == 0) return CTL_BAD_PARAMETER;
    move->move_time = move->seg[move->n - 1].t0 + move->seg[move->n - 1].duration;
    return CTL_OK;
}

int ctl_table_prepare(ctl_table *tab, double *work)
{
    /* clamped cubic spline: zero slope at both ends; the tridiagonal system of
     * the second derivatives M solved by the Thomas algorithm */
    long n, i;
    const double *x, *y;
    double *M, *c = work;
    if (!tab || !work || !tab->second || !tab->times || !tab->positions || tab->n < 2) return CTL_BAD_ARGUMENT;
    n = tab->n;
    x = tab->times;
    y = tab->positions;
    M = tab->second;
    for (i = 0; i < n; i++) {
        double h0 = i > 0 ? x[i] - x[i - 1] : 0.0, h1 = i < n - 1 ? x[i + 1] - x[i] : 0.0;
        double s0 = i > 0 ? (y[i] - y[i - 1]) / h0 : 0.0, s1 = i < n - 1 ? (y[i + 1] - y[i]) / h1 : 0.0;
        double diag = 2 * (h0 + h1), rhs = 6 * (s1 - s0), sub = h0, denom;
        /* eliminate the sub-diagonal: row i less sub / (previous pivot) times row i - 1 */
        denom = i > 0 ? diag - sub * c[i - 1] : diag;
        c[i] = h1 / denom;
        M[i] = (i > 0 ? rhs - sub * M[i - 1] : rhs) / denom;
    }
    for (i = n - 2; i >= 0; i--) M[i] -= c[i] * M[i + 1];
    return CTL_OK;
}

static void table_at(const ctl_table *tab, double tt, double *out)
{
    const double *x = tab->times, *y = tab->positions, *M = tab->second;
    long lo = 0, hi = tab->n - 1, i;
    double h, tau, b, dM;
    while (hi - lo > 1) {  /* x[lo] <= tt < x[hi] */
        long mid = lo + (hi - lo) / 2;
        if (x[mid] <= tt) lo = mid;
        else hi = mid;
    }
    i = lo;
    h = x[i + 1] - x[i];
    tau = tt - x[i];
    dM = M[i + 1] - M[i];
    b = (y[i + 1] - y[i]) / h - h * (2 * M[i] + M[i + 1]) / 6;
    out[0] = y[i] + tau * (b + tau * (M[i] / 2 + tau * dM / (6 * h)));
    out[1] = b + tau * (M[i] + tau * dM / (2 * h));
    out[2] = M[i] + tau * dM / h;
}

/* Python's float floor division (a // b), so the move count agrees with it at a boundary */
static double floor_div(double a, double b)
{
    double mod = fmod(a, b), div = (a - mod) / b, fl;
    if (mod != 0.0 && ((b < 0) != (mod < 0))) div -= 1.0;
    if (div == 0.0) return copysign(0.0, a / b);
    fl = floor(div);
    if (div - fl > 0.5) fl += 1.0;
    return fl;
}

int ctl_trajectory_evaluate(const ctl_trajectory_params *p, const ctl_move *move, const ctl_table *tab, double t,
                            double *out)
{
    double tau, period, k, local, sign, base, direction, seg_out[3];
    const ctl_segment *seg;
    int i;
    if (!p || !out) return CTL_BAD_ARGUMENT;
    tau = t - p->delay;
    if (p->kind == CTL_TABLE) {
        if (!tab || !tab->second || tab->n < 2) return CTL_BAD_ARGUMENT;
        if (tau <= tab->times[0] || tau >= tab->times[tab->n - 1]) {
            out[0] = tau <= tab->times[0] ? tab->positions[0] : tab->positions[tab->n - 1];
            out[1] = out[2] = 0.0;
        } else {
            table_at(tab, tau, out);
        }
        return CTL_OK;
    }
    if (tau < 0) {
        out[0] = p->start;
        out[1] = out[2] = 0.0;
        return CTL_OK;
    }
    if (p->kind == CTL_CONSTANT) {
        out[0] = p->start + p->speed * tau;
        out[1] = p->speed;
        out[2] = 0.0;
        return CTL_OK;
    }
    if (p->kind == CTL_SINE) {
        double w = TWO_PI * p->frequency, s = sin(w * tau), c = cos(w * tau);
        out[0] = p->start + p->amplitude * s;
        out[1] = p->amplitude * w * c;
        out[2] = -p->amplitude * w * w * s;
        return CTL_OK;
    }
    if (!move || move->n < 1) return CTL_BAD_ARGUMENT;
    period = move->move_time + p->dwell;
    k = period > 0 ? floor_div(tau, period) : 0.0;
    if (p->repeat != 0.0 && k >= p->repeat) {
        k = p->repeat - 1;  /* finished: rest at the end of the last move */
        local = period;
    } else {
        local = tau - k * period;
    }
    if (p->reverse != 0.0) {
        int even = fmod(k, 2.0) == 0.0;
        sign = even ? 1.0 : -1.0;
        base = p->start + (even ? 0.0 : p->distance);
    } else {
        sign = 1.0;
        base = p->start + k * p->distance;
    }
    direction = copysign(1.0, p->distance) * sign;
    if (local >= move->move_time) {
        out[0] = base + direction * fabs(p->distance);
        out[1] = out[2] = 0.0;
        return CTL_OK;
    }
    seg = &move->seg[move->n - 1];
    for (i = 0; i < move->n; i++) {
        if (local < move->seg[i].t0 + move->seg[i].duration) {
            seg = &move->seg[i];
            break;
        }
    }
    ctl_segment_at(seg, local - seg->t0, seg_out);
    out[0] = base + direction * seg_out[0];
    out[1] = direction * seg_out[1];
    out[2] = direction * seg_out[2];
    return CTL_OK;
}
