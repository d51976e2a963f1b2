/* The mechanism's rules, once (grb_scene.h): the library and the native FMU
 * both refuse a scene here, with the same field and the same sentence.
 *
 * Numbers in a reason are written as Python's repr writes a float (the
 * shortest text that reads back to the same double: -1.0, 0.25, 1e-05), so a
 * message reads the same from the library, its CLI and app, and the FMU. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "grb_scene.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ---- numbers as text ---------------------------------------------------------- */

/* x as Python's repr(float) writes it: the shortest digits that round-trip,
 * fixed notation for decimal exponents -4 .. 15, else d.ddde+XX. */
static void real_text(double x, char *buf, size_t size) {
    char e[40], digits[20];
    int prec, n = 0, exponent, i, neg;
    const char *c;
    size_t used = 0;
    if (isnan(x)) { snprintf(buf, size, "nan"); return; }
    if (isinf(x)) { snprintf(buf, size, x < 0 ? "-inf" : "inf"); return; }
    for (prec = 1; prec < 17; prec++) {
        snprintf(e, sizeof e, "%.*e", prec - 1, x);
        if (strtod(e, NULL) == x) break;
    }
    snprintf(e, sizeof e, "%.*e", prec - 1, x);
    neg = e[0] == '-';
    for (c = e; *c && *c != 'e' && *c != 'E'; c++)  /* the digits, whatever the locale's decimal point */
        if (*c >= '0' && *c <= '9' && n < (int)sizeof digits - 1) digits[n++] = *c;
    digits[n] = '\0';
    exponent = *c ? atoi(c + 1) : 0;
    while (n > 1 && digits[n - 1] == '0') digits[--n] = '\0';
#define PUT(...) do { int w_ = snprintf(buf + used, used < size ? size - used : 0, __VA_ARGS__); \
                      if (w_ > 0) used += (size_t)w_; } while (0)
    if (size == 0) return;
    buf[0] = '\0';
    if (neg) PUT("-");
    if (exponent < -4 || exponent >= 16) {
        PUT("%c", digits[0]);
        if (n > 1) PUT(".%s", digits + 1);
        PUT("e%c%02d", exponent < 0 ? '-' : '+', abs(exponent));
    } else if (exponent < 0) {
        PUT("0.");
        for (i = 0; i < -exponent - 1; i++) PUT("0");
        PUT("%s", digits);
    } else {
        for (i = 0; i <= exponent; i++) PUT("%c", i < n ? digits[i] : '0');
        PUT(".%s", n > exponent + 1 ? digits + exponent + 1 : "0");
    }
#undef PUT
}

/* a link number as the user gave it: a whole number as one, anything else as a real */
static void link_text(double x, char *buf, size_t size) {
    if (isfinite(x) && x == floor(x) && fabs(x) < 1e15)
        snprintf(buf, size, "%.0f", x);
    else
        real_text(x, buf, size);
}

/* whether x is one of the links lo .. hi */
static int link_in(double x, int lo, int hi) { return x >= lo && x <= hi && x == floor(x); }

/* ---- refusals -------------------------------------------------------------------- */

typedef struct tally {
    grb_problem *found;
    int capacity, count;
} tally;

static void refuse(tally *t, const char *field, const char *format, ...) {
    if (t->count < t->capacity) {
        va_list args;
        grb_problem *p = t->found + t->count;
        snprintf(p->field, sizeof p->field, "%s", field);
        va_start(args, format);
        vsnprintf(p->reason, sizeof p->reason, format, args);
        va_end(args);
    }
    t->count++;
}

static int finish(const tally *t, int *count) {
    if (count) *count = t->count;
    return t->count ? GRB_BAD_ARGUMENT : GRB_OK;
}

/* ---- one link ---------------------------------------------------------------------- */

static void link_rules(tally *t, int k, const double *row, const int *column) {
    static const struct { int column; const char *name, *rule; int positive; } rules[] = {
        {GRB_SK_A, "a", "length must be >= 0", 0},
        {GRB_SK_M, "m", "mass must be positive", 1},
        {GRB_SK_I, "I", "moment of inertia must be >= 0", 0},
        {GRB_SK_DAMP, "damping", "damping must be >= 0", 0},
    };
    char field[64], v[40];
    double parent = row[column[GRB_SK_PARENT]];
    size_t r;
    for (r = 0; r < sizeof rules / sizeof rules[0]; r++) {
        double x = row[column[rules[r].column]];
        if (rules[r].positive ? !(x > 0) : !(x >= 0)) {
            snprintf(field, sizeof field, "link%d.%s", k, rules[r].name);
            real_text(x, v, sizeof v);
            refuse(t, field, "%s, got %s", rules[r].rule, v);
        }
    }
    /* the kernel walks parents towards the ground: each must be an earlier link */
    if (!link_in(parent, 1, k - 1)) {
        snprintf(field, sizeof field, "link%d.parent", k);
        link_text(parent, v, sizeof v);
        refuse(t, field, "must be the ground (1) or an earlier link 2..%d (the chain's predecessor), got %s", k - 1,
               v);
    }
}

int grb_link_check(int k, const double *row, const int *column, grb_problem *found, int capacity, int *count) {
    tally t;
    t.found = found;
    t.capacity = found ? capacity : 0;
    t.count = 0;
    if (!row || !column || k < 2) return GRB_BAD_ARGUMENT;
    link_rules(&t, k, row, column);
    return finish(&t, count);
}

/* ---- coordinates ------------------------------------------------------------------- */

static const char *coordinate_name(int q, char *buf, size_t size) {
    if (q % 2 == 0)
        snprintf(buf, size, "B%d", q / 2 + 1);
    else
        snprintf(buf, size, "theta%d", q / 2 + 2);
    return buf;
}

static void coordinate_rule(tally *t, int q, int revolute, const char *field) {
    char name[32], real[32];
    int real_q = 2 * (q / 2) + (revolute ? 1 : 0);
    if (q != real_q)
        refuse(t, field, "%s is a locked (fictitious) coordinate: link%d's real joint is %s",
               coordinate_name(q, name, sizeof name), q / 2 + 2, coordinate_name(real_q, real, sizeof real));
}

int grb_coordinate_check(int q, int revolute, const char *field, grb_problem *found) {
    tally t;
    t.found = found;
    t.capacity = found ? 1 : 0;
    t.count = 0;
    if (q < 0 || !field) return GRB_BAD_ARGUMENT;
    coordinate_rule(&t, q, revolute, field);
    return finish(&t, NULL);
}

/* ---- the scene --------------------------------------------------------------------- */

static double link_field(const grb_scene_view *s, int i, int f) {
    return s->links[i * s->link_stride + s->link_column[f]];
}
static double closure_field(const grb_scene_view *s, int j, int f) {
    return s->closures[j * s->closure_stride + s->closure_column[f]];
}
static double actuator_field(const grb_scene_view *s, int j, int f) {
    return s->actuators[j * s->actuator_stride + s->actuator_column[f]];
}
/* the predecessor of link k (thesis numbering, valid once the links passed), thesis numbering */
static int parent_link(const grb_scene_view *s, int k) { return (int)link_field(s, k - 2, GRB_SK_PARENT); }
static int is_revolute(const grb_scene_view *s, int i) { return (int)link_field(s, i, GRB_SK_JOINT) == 1; }

static void closure_name(const grb_scene_view *s, int j, const char *what, char *buf, size_t size) {
    if (s->n_closures == 1)
        snprintf(buf, size, "closure%s", what);
    else
        snprintf(buf, size, "closure[%d]%s", j, what);
}

static void actuator_name(const grb_scene_view *s, int j, const char *what, char *buf, size_t size) {
    if (s->actuator_names && s->actuator_names[j])
        snprintf(buf, size, "%s%s", s->actuator_names[j], what);
    else
        snprintf(buf, size, "actuator[%d]%s", j, what);
}

static void ground_rules(tally *t, const grb_scene_view *s) {
    char v[40];
    int n = s->n_links;
    if (n < 1) {
        refuse(t, "links", "a chain needs at least one moving link");
        return;
    }
    if (n > GRB_MAX_LINKS) {
        refuse(t, "links", "a chain has at most %d moving links (the kernel's GRB_MAX_LINKS), got %d", GRB_MAX_LINKS,
               n);
        return;
    }
    if (!(s->a1 >= 0)) {
        real_text(s->a1, v, sizeof v);
        refuse(t, "ground.a1", "length must be >= 0, got %s", v);
        return;
    }
    if (!(s->gravity >= 0)) {
        real_text(s->gravity, v, sizeof v);
        refuse(t, "gravity", "must be >= 0 (it acts along -y), got %s", v);
    }
}

static void closure_rules(tally *t, const grb_scene_view *s) {
    char field[64], v[40];
    int j, n = s->n_links;
    for (j = 0; j < s->n_closures && !t->count; j++) {
        double link = closure_field(s, j, GRB_SC_LINK), to = closure_field(s, j, GRB_SC_TO);
        double gain = closure_field(s, j, GRB_SC_GAIN), damping = closure_field(s, j, GRB_SC_DAMP);
        if (!link_in(link, 2, n + 1)) {
            closure_name(s, j, ".link", field, sizeof field);
            link_text(link, v, sizeof v);
            refuse(t, field, "must be a moving link 2..%d, got %s", n + 1, v);
        } else if (!link_in(to, 1, n + 1) || to == link) {
            closure_name(s, j, ".to_link", field, sizeof field);
            link_text(to, v, sizeof v);
            refuse(t, field, "must be another link 1..%d, got %s", n + 1, v);
        } else if (!(gain > 0)) {
            closure_name(s, j, ".gain", field, sizeof field);
            real_text(gain, v, sizeof v);
            refuse(t, field, "penalty gain must be positive, got %s", v);
        } else if (!(damping >= 0)) {
            closure_name(s, j, ".damping", field, sizeof field);
            real_text(damping, v, sizeof v);
            refuse(t, field, "penalty damping must be >= 0, got %s", v);
        }
    }
}

static void actuator_rules(tally *t, const grb_scene_view *s) {
    static const int ends[2] = {GRB_A_FROM_LINK, GRB_A_TO_LINK};
    static const char *const end_names[2] = {".from_link", ".to_link"};
    char field[64], v[40];
    int j, e, n = s->n_links;
    if (s->n_actuators > GRB_MAX_ACTUATORS) {
        refuse(t, "actuator", "a mechanism has at most %d actuators (the kernel's GRB_MAX_ACTUATORS), got %d",
               GRB_MAX_ACTUATORS, s->n_actuators);
        return;
    }
    for (j = 0; j < s->n_actuators && !t->count; j++) {
        for (e = 0; e < 2 && !t->count; e++) {
            double k = actuator_field(s, j, ends[e]);
            if (!link_in(k, 1, n + 1)) {
                actuator_name(s, j, end_names[e], field, sizeof field);
                link_text(k, v, sizeof v);
                refuse(t, field, "link %s does not exist: the mechanism has the ground (1) and links 2..%d", v, n + 1);
            }
        }
        if (!t->count && actuator_field(s, j, GRB_A_FROM_LINK) == actuator_field(s, j, GRB_A_TO_LINK)) {
            actuator_name(s, j, ".to_link", field, sizeof field);
            refuse(t, field, "must be another link than from_link (%d): an actuator within one link has a constant "
                   "length and does nothing", (int)actuator_field(s, j, GRB_A_FROM_LINK));
        }
    }
}

static double force_field(const grb_scene_view *s, int j, int f) {
    return s->forces[j * s->force_stride + s->force_column[f]];
}

static void force_name(const grb_scene_view *s, int j, const char *what, char *buf, size_t size) {
    if (s->force_names && s->force_names[j])
        snprintf(buf, size, "%s%s", s->force_names[j], what);
    else
        snprintf(buf, size, "force[%d]%s", j, what);
}

/* One force element's rules (grubler.h, GRB_FORCE_*): the links it acts on
 * exist, a spring joins two links, and no number makes it a source of energy
 * or of nonsense (a negative stiffness, length, damping or friction). */
static void force_rules(tally *t, const grb_scene_view *s) {
    static const struct { int column; const char *name, *rule; int positive; } spring_rules[] = {
        {GRB_F_STIFFNESS, ".stiffness", "stiffness must be >= 0", 0},
        {GRB_F_FREE, ".free_length", "free length must be >= 0", 0},
        {GRB_F_DAMPING, ".damping", "damping must be >= 0", 0},
        {GRB_F_GAS_FORCE, ".gas_force", "the gas force (p0 A) must be >= 0", 0},
    }, joint_rules[] = {
        {GRB_F_STIFFNESS, ".stiffness", "stiffness must be >= 0", 0},
        {GRB_F_FRICTION, ".friction", "friction must be >= 0", 0},
    };
    char field[64], v[40];
    int j, n = s->n_links;
    size_t r;
    for (j = 0; j < s->n_forces && !t->count; j++) {
        double kind = force_field(s, j, GRB_F_KIND), link = force_field(s, j, GRB_F_LINK);
        if (kind != GRB_FORCE_SPRING && kind != GRB_FORCE_JOINT && kind != GRB_FORCE_LOAD) {
            force_name(s, j, ".kind", field, sizeof field);
            real_text(kind, v, sizeof v);
            refuse(t, field, "must be 0 (a spring), 1 (a joint's spring and friction) or 2 (a load), got %s", v);
            continue;
        }
        if (kind == GRB_FORCE_SPRING) {
            double to = force_field(s, j, GRB_F_TO_LINK);
            if (!link_in(link, 1, n + 1) || !link_in(to, 1, n + 1)) {
                force_name(s, j, link_in(link, 1, n + 1) ? ".to_link" : ".from_link", field, sizeof field);
                link_text(link_in(link, 1, n + 1) ? to : link, v, sizeof v);
                refuse(t, field, "link %s does not exist: the mechanism has the ground (1) and links 2..%d", v, n + 1);
                continue;
            }
            if (link == to) {
                force_name(s, j, ".to_link", field, sizeof field);
                refuse(t, field, "must be another link than from_link (%d): a spring within one link keeps its "
                       "length and does nothing", (int)link);
                continue;
            }
            for (r = 0; r < sizeof spring_rules / sizeof spring_rules[0]; r++) {
                double x = force_field(s, j, spring_rules[r].column);
                if (!(x >= 0)) {
                    force_name(s, j, spring_rules[r].name, field, sizeof field);
                    real_text(x, v, sizeof v);
                    refuse(t, field, "%s, got %s", spring_rules[r].rule, v);
                }
            }
            if (!t->count && force_field(s, j, GRB_F_GAS_FORCE) > 0) {
                double column = force_field(s, j, GRB_F_GAS_COLUMN), n_exp = force_field(s, j, GRB_F_GAS_EXPONENT);
                if (!(column > 0)) {
                    force_name(s, j, ".gas_column", field, sizeof field);
                    real_text(column, v, sizeof v);
                    refuse(t, field, "a gas spring's gas column (V0 / A at the free length) must be positive, got %s",
                           v);
                } else if (!(n_exp > 0)) {
                    force_name(s, j, ".gas_exponent", field, sizeof field);
                    real_text(n_exp, v, sizeof v);
                    refuse(t, field, "the polytropic exponent must be positive (1 isothermal, 1.4 adiabatic air), "
                           "got %s", v);
                }
            }
            continue;
        }
        if (!link_in(link, 2, n + 1)) {
            force_name(s, j, kind == GRB_FORCE_JOINT ? ".joint" : ".link", field, sizeof field);
            link_text(link, v, sizeof v);
            refuse(t, field, kind == GRB_FORCE_JOINT ? "link %s does not exist: a joint's element acts at the joint of "
                   "a moving link 2..%d" : "link %s does not exist or is the ground: a load acts on a moving link "
                   "2..%d", v, n + 1);
            continue;
        }
        if (kind == GRB_FORCE_LOAD) continue;
        for (r = 0; r < sizeof joint_rules / sizeof joint_rules[0]; r++) {
            double x = force_field(s, j, joint_rules[r].column);
            if (!(x >= 0)) {
                force_name(s, j, joint_rules[r].name, field, sizeof field);
                real_text(x, v, sizeof v);
                refuse(t, field, "%s, got %s", joint_rules[r].rule, v);
            }
        }
        if (!t->count && force_field(s, j, GRB_F_FRICTION) > 0 && !(force_field(s, j, GRB_F_FRICTION_SPEED) > 0)) {
            force_name(s, j, ".friction_speed", field, sizeof field);
            real_text(force_field(s, j, GRB_F_FRICTION_SPEED), v, sizeof v);
            refuse(t, field, "friction's regularising speed must be positive, got %s", v);
        }
    }
}

/* The revolutes of closure j's loop: its own if revolute, and those of the
 * chain's pairs on the tree path between its two links (Mechanism.loop_pairs). */
static int loop_revolutes(const grb_scene_view *s, int j) {
    int a = (int)closure_field(s, j, GRB_SC_LINK), b = (int)closure_field(s, j, GRB_SC_TO);
    int count = (int)closure_field(s, j, GRB_SC_KIND) == 1;
    while (a != b) {
        int *up = a > b ? &a : &b;
        count += is_revolute(s, *up - 2);
        *up = parent_link(s, *up);
    }
    return count;
}

/* Prismatic axis `x` of the scene, in the frame of the link that carries it
 * (across a prismatic pair the relative angle is locked, so the direction is
 * fixed): each prismatic link gives two (on its predecessor, on itself), then
 * each prismatic closure two (on its target link, on its closing link), in
 * that order.  0 when there is no axis x. */
static int prismatic_axis(const grb_scene_view *s, int x, double *angle, int *owner, char *field, size_t size) {
    int i, j;
    for (i = 0; i < s->n_links; i++) {
        if (is_revolute(s, i)) continue;
        if (x < 2) {
            int pk = parent_link(s, i + 2);
            double prev = pk == 1 ? s->theta1 : s->q_ref[2 * pk - 3];
            *angle = x == 0 ? (pk == 1 ? s->theta1 : 0.0) + M_PI / 2 : M_PI / 2 - (s->q_ref[2 * i + 1] - prev);
            *owner = x == 0 ? pk : i + 2;
            snprintf(field, size, "link%d.joint", i + 2);
            return 1;
        }
        x -= 2;
    }
    for (j = 0; j < s->n_closures; j++) {
        if ((int)closure_field(s, j, GRB_SC_KIND) != 2) continue;
        if (x < 2) {
            double a = closure_field(s, j, GRB_SC_ANGLE);
            /* the closure holds link's orientation at psi relative to to_link */
            *angle = x == 0 ? a : a - closure_field(s, j, GRB_SC_PSI);
            *owner = (int)closure_field(s, j, x == 0 ? GRB_SC_TO : GRB_SC_LINK);
            closure_name(s, j, ".angle", field, size);
            return 1;
        }
        x -= 2;
    }
    return 0;
}

static void topology_rules(tally *t, const grb_scene_view *s) {
    char field[64], fx[64], fy[64];
    int j, k, x, y, n = s->n_links, mobility;
    /* a loop needs two revolutes to move (MODEL.md section 1) */
    for (j = 0; j < s->n_closures; j++) {
        int nrev = loop_revolutes(s, j), a = (int)closure_field(s, j, GRB_SC_LINK);
        int b = (int)closure_field(s, j, GRB_SC_TO);
        if (nrev < 2) {
            closure_name(s, j, ".type", field, sizeof field);
            refuse(t, field, "the loop from link %d to link %d has %d revolute joint(s); a loop needs at least two "
                   "revolutes to move", a < b ? a : b, a < b ? b : a, nrev);
            return;
        }
    }
    /* two prismatic joints with parallel axes on one link add a redundant freedom; the
     * pairs are taken link by link, each link's axes in the order above */
    for (k = 1; k <= n + 1; k++) {
        double ax, ay;
        int ox, oy;
        for (x = 0; prismatic_axis(s, x, &ax, &ox, fx, sizeof fx); x++) {
            if (ox != k) continue;
            for (y = x + 1; prismatic_axis(s, y, &ay, &oy, fy, sizeof fy); y++)
                if (oy == k && fabs(sin(ax - ay)) < 1e-9) {
                    refuse(t, fy, "link %d has two prismatic joints with parallel axes (%s and %s): that adds a "
                           "redundant freedom", k, fx, fy);
                    return;
                }
        }
    }
    /* Grübler/Kutzbach with one-freedom joints: 3 (N + 1 - 1) - 2 (N + C) */
    mobility = n - 2 * s->n_closures;
    if (mobility < 0) refuse(t, "closure", "the closures over-constrain the chain (mobility %d)", mobility);
}

static void drive_rules(tally *t, const grb_scene_view *s) {
    const int q[2] = {s->drive, s->load};
    const char *field[2];
    char v[40];
    int r;
    field[0] = s->drive_field ? s->drive_field : "drive.joint";
    field[1] = s->load_field ? s->load_field : "load.joint";
    if (!(s->drive_inertia >= 0)) {
        real_text(s->drive_inertia, v, sizeof v);
        refuse(t, "drive.inertia", "must be >= 0, got %s", v);
        return;
    }
    if (s->drive_inertia > 0 && s->drive < 0) {
        refuse(t, "drive.inertia", "a drive inertia needs the joint it acts on");
        return;
    }
    /* the efforts act on real joints */
    for (r = 0; r < 2 && !t->count; r++) {
        if (q[r] >= 2 * s->n_links)
            refuse(t, field[r], "coordinate %d does not exist: the chain has %d", q[r] + 1, 2 * s->n_links);
        else if (q[r] >= 0)
            coordinate_rule(t, q[r], is_revolute(s, q[r] / 2), field[r]);
    }
}

/* A locked coordinate cannot move: a locked slide's rate is 0, a locked angle's
 * absolute rate is its predecessor's (the ground's: 0).  A rate of 0 is the
 * scene's "not given" and passes (the real joints' rates decide the motion). */
static void rate_rules(tally *t, const grb_scene_view *s) {
    char field[64], name[32], pred[32], v[40], w[40];
    int i;
    for (i = 0; i < s->n_links; i++) {
        int revolute = is_revolute(s, i), q = revolute ? 2 * i : 2 * i + 1, pk = parent_link(s, i + 2);
        double rate = s->qd[q], follows = revolute || pk == 1 ? 0.0 : s->qd[2 * pk - 3];
        if (rate == 0.0 || fabs(rate - follows) <= 1e-12 * fmax(1.0, fmax(fabs(rate), fabs(follows)))) continue;
        coordinate_name(q, name, sizeof name);
        snprintf(field, sizeof field, "initial.%s_d", name);
        if (revolute || pk == 1) {
            refuse(t, field, "%s is a locked (fictitious) coordinate; it cannot move", name);
        } else {
            real_text(follows, v, sizeof v);
            real_text(rate, w, sizeof w);
            refuse(t, field, "%s is a locked (fictitious) coordinate; it cannot move (relative to link%d: its "
                   "absolute rate is initial.%s_d = %s, got %s)", name, pk, coordinate_name(2 * pk - 3, pred,
                                                                                             sizeof pred), v, w);
        }
    }
}

int grb_scene_check(const grb_scene_view *s, grb_problem *found, int capacity, int *count) {
    tally t;
    int i;
    t.found = found;
    t.capacity = found ? capacity : 0;
    t.count = 0;
    if (!s || (s->n_links > 0 && (!s->links || !s->q_ref)) || (s->n_closures > 0 && !s->closures) ||
        (s->n_actuators > 0 && !s->actuators) || s->n_closures < 0 || s->n_actuators < 0 || s->n_forces < 0 ||
        (s->n_forces > 0 && !s->forces))
        return GRB_BAD_ARGUMENT;
    ground_rules(&t, s);
    if (!t.count)  /* every problem of every link at once: they are independent */
        for (i = 0; i < s->n_links; i++) link_rules(&t, i + 2, s->links + i * s->link_stride, s->link_column);
    if (!t.count) closure_rules(&t, s);
    if (!t.count) actuator_rules(&t, s);
    if (!t.count) force_rules(&t, s);
    if (!t.count) topology_rules(&t, s);
    if (!t.count) drive_rules(&t, s);
    if (!t.count && s->qd) rate_rules(&t, s);
    return finish(&t, count);
}
