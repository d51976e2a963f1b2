#include "tableaus_dop853.inc"

static const double DOPRI5_A[36] = {
    0, 0, 0, 0, 0, 0,
    1.0 / 5, 0, 0, 0, 0, 0,
    3.0 / 40, 9.0 / 40, 0, 0, 0, 0,
    44.0 / 45, -56.0 / 15, 32.0 / 9, 0, 0, 0,
    19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729, 0, 0,
    9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656, 0};
static const double DOPRI5_B[6] = {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84};
static const double DOPRI5_C[6] = {0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1};
/* b - b_hat, the 4th-order weights b_hat over the seven FSAL stages */
static const double DOPRI5_E[7] = {35.0 / 384 - 5179.0 / 57600,    0,
                                   500.0 / 1113 - 7571.0 / 16695,  125.0 / 192 - 393.0 / 640,
                                   -2187.0 / 6784 + 92097.0 / 339200, 11.0 / 84 - 187.0 / 2100,
                                   -1.0 / 40};

static const double RK4_A[16] = {0, 0, 0, 0, 0.5, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, 1.0, 0};
static const double RK4_B[4] = {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6};
static const double RK4_C[4] = {0, 0.5, 0.5, 1.0};

static const grb_tableau_data TABLEAUS[] = {
    {"dop853", 12, 1, 7, DOP853_A, 16, DOP853_B, DOP853_C, DOP853_E5, DOP853_E3, 3, DOP853_A + 13 * 16,
     DOP853_C + 13, 4, DOP853_D},
    {"rk45", 6, 1, 4, DOPRI5_A, 6, DOPRI5_B, DOPRI5_C, DOPRI5_E, 0, 0, 0, 0, 0, 0},
    {"rk4", 4, 0, 4, RK4_A, 4, RK4_B, RK4_C, 0, 0, 0, 0, 0, 0, 0},
};

const grb_tableau_data *grb_tableau(int tableau) {
    if (tableau < 0 || tableau >= (int)(sizeof TABLEAUS / sizeof TABLEAUS[0])) return 0;
    return &TABLEAUS[tableau];
}
