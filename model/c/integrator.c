/* Dormand-Prince 5(4) and 8(5,3) with dense output; polynomial root isolation. */
#include "integrator.h"

#include <float.h>
#include <math.h>
#include <string.h>

/* Butcher tableau of Dormand and Prince (1980). */
static const double C2 = 1.0 / 5, C3 = 3.0 / 10, C4 = 4.0 / 5, C5 = 8.0 / 9;
static const double A21 = 1.0 / 5;
static const double A31 = 3.0 / 40, A32 = 9.0 / 40;
static const double A41 = 44.0 / 45, A42 = -56.0 / 15, A43 = 32.0 / 9;
static const double A51 = 19372.0 / 6561, A52 = -25360.0 / 2187,
                    A53 = 64448.0 / 6561, A54 = -212.0 / 729;
static const double A61 = 9017.0 / 3168, A62 = -355.0 / 33,
                    A63 = 46732.0 / 5247, A64 = 49.0 / 176,
                    A65 = -5103.0 / 18656;
static const double A71 = 35.0 / 384, A73 = 500.0 / 1113, A74 = 125.0 / 192,
                    A75 = -2187.0 / 6784, A76 = 11.0 / 84;
/* error coefficients: 5th minus embedded 4th order weights */
static const double E1 = 71.0 / 57600, E3 = -71.0 / 16695, E4 = 71.0 / 1920,
                    E5 = -17253.0 / 339200, E6 = 22.0 / 525, E7 = -1.0 / 40;
/* dense output (Hairer's contd5) */
static const double D1 = -12715105075.0 / 11282082432.0,
                    D3 = 87487479700.0 / 32700410799.0,
                    D4 = -10690763975.0 / 1880347072.0,
                    D5 = 701980252875.0 / 199316789632.0,
                    D6 = -1453857185.0 / 822651844.0,
                    D7 = 69997945.0 / 29380423.0;

void dopri5_step(RhsFn f, const void *ctx, int n, double t, const double *y,
                 const double *f0, double h, double *y1, double *f1,
                 double *err, Dense *d) {
    double(*cont)[NMAX] = d->r;
    d->method = RK_DOPRI5;
    d->rows = 5;
    double k2[NMAX], k3[NMAX], k4[NMAX], k5[NMAX], k6[NMAX], yt[NMAX] = {0};
    int i;
    for (i = 0; i < n; i++) yt[i] = y[i] + h * A21 * f0[i];
    f(ctx, t + C2 * h, yt, k2);
    for (i = 0; i < n; i++) yt[i] = y[i] + h * (A31 * f0[i] + A32 * k2[i]);
    f(ctx, t + C3 * h, yt, k3);
    for (i = 0; i < n; i++)
        yt[i] = y[i] + h * (A41 * f0[i] + A42 * k2[i] + A43 * k3[i]);
    f(ctx, t + C4 * h, yt, k4);
    for (i = 0; i < n; i++)
        yt[i] = y[i] + h * (A51 * f0[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
    f(ctx, t + C5 * h, yt, k5);
    for (i = 0; i < n; i++)
        yt[i] = y[i] + h * (A61 * f0[i] + A62 * k2[i] + A63 * k3[i] +
                            A64 * k4[i] + A65 * k5[i]);
    f(ctx, t + h, yt, k6);
    for (i = 0; i < n; i++)
        y1[i] = y[i] + h * (A71 * f0[i] + A73 * k3[i] + A74 * k4[i] +
                            A75 * k5[i] + A76 * k6[i]);
    f(ctx, t + h, y1, f1);
    for (i = 0; i < n; i++) {
        double ydiff = y1[i] - y[i];
        double bspl = h * f0[i] - ydiff;
        err[i] = h * (E1 * f0[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] +
                      E6 * k6[i] + E7 * f1[i]);
        cont[0][i] = y[i];
        cont[1][i] = ydiff;
        cont[2][i] = bspl;
        cont[3][i] = ydiff - h * f1[i] - bspl;
        cont[4][i] = h * (D1 * f0[i] + D3 * k3[i] + D4 * k4[i] + D5 * k5[i] +
                          D6 * k6[i] + D7 * f1[i]);
    }
}

/* DOP853's coefficients (Dormand and Prince; Hairer, Norsett and Wanner 1993, section II.5: the values of their
 * dop853.f, as SciPy transcribes them; tests/c/integrator_order.c checks the orders they give):
 * the nodes, the stages' rows (the 12 of the step, row 12 the weights, and the 3 of the dense output), the error
 * weights of orders 5 and 3 (on the 12 stages and f(t + h, y1)) and the dense output's rows 4..7. */
static const double D8_C[16] = {0.0, 0.05260015195876773, 0.0789002279381516, 0.1183503419072274,
    0.2816496580927726, 0.3333333333333333, 0.25, 0.3076923076923077, 0.6512820512820513, 0.6, 0.8571428571428571,
    1.0, 1.0, 0.1, 0.2, 0.7777777777777778};
static const double D8_A[16][16] = {
    {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.05260015195876773, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.0197250569845379, 0.0591751709536137, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.02958758547680685, 0.0, 0.08876275643042054, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.2413651341592667, 0.0, -0.8845494793282861, 0.924834003261792, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, 0.0},
    {0.037037037037037035, 0.0, 0.0, 0.17082860872947386, 0.12546768756682242, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, 0.0, 0.0},
    {0.037109375, 0.0, 0.0, 0.17025221101954405, 0.06021653898045596, -0.017578125, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, 0.0, 0.0},
    {0.03709200011850479, 0.0, 0.0, 0.17038392571223998, 0.10726203044637328, -0.015319437748624402,
        0.008273789163814023, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.6241109587160757, 0.0, 0.0, -3.3608926294469414, -0.868219346841726, 27.59209969944671, 20.154067550477894,
        -43.48988418106996, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.47766253643826434, 0.0, 0.0, -2.4881146199716677, -0.590290826836843, 21.230051448181193, 15.279233632882423,
        -33.28821096898486, -0.020331201708508627, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {-0.9371424300859873, 0.0, 0.0, 5.186372428844064, 1.0914373489967295, -8.149787010746927, -18.52006565999696,
        22.739487099350505, 2.4936055526796523, -3.0467644718982196, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {2.273310147516538, 0.0, 0.0, -10.53449546673725, -2.0008720582248625, -17.9589318631188, 27.94888452941996,
        -2.8589982771350235, -8.87285693353063, 12.360567175794303, 0.6433927460157636, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.054293734116568765, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003, -5.801203960010585,
        0.3111643669578199, -0.1521609496625161, 0.20136540080403034, 0.04471061572777259, 0.0, 0.0, 0.0, 0.0},
    {0.056167502283047954, 0.0, 0.0, 0.0, 0.0, 0.0, 0.25350021021662483, -0.2462390374708025, -0.12419142326381637,
        0.15329179827876568, 0.00820105229563469, 0.007567897660545699, -0.008298, 0.0, 0.0, 0.0},
    {0.03183464816350214, 0.0, 0.0, 0.0, 0.0, 0.028300909672366776, 0.053541988307438566, -0.05492374857139099, 0.0,
        0.0, -0.00010834732869724932, 0.0003825710908356584, -0.00034046500868740456, 0.1413124436746325, 0.0, 0.0},
    {-0.42889630158379194, 0.0, 0.0, 0.0, 0.0, -4.697621415361164, 7.683421196062599, 4.06898981839711,
        0.3567271874552811, 0.0, 0.0, 0.0, -0.0013990241651590145, 2.9475147891527724, -9.15095847217987, 0.0}};
static const double D8_E5[13] = {0.01312004499419488, 0.0, 0.0, 0.0, 0.0, -1.2251564463762044, -0.4957589496572502,
    1.6643771824549864, -0.35032884874997366, 0.3341791187130175, 0.08192320648511571, -0.022355307863886294, 0.0};
static const double D8_E3[13] = {-0.18980075407240762, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003,
    -5.801203960010585, -0.4226823213237919, -0.1521609496625161, 0.20136540080403034, 0.02265179219836082, 0.0};
static const double D8_D[4][16] = {
    {-8.428938276109013, 0.0, 0.0, 0.0, 0.0, 0.5667149535193777, -3.0689499459498917, 2.38466765651207,
        2.117034582445028, -0.871391583777973, 2.2404374302607883, 0.6315787787694688, -0.08899033645133331,
        18.148505520854727, -9.194632392478356, -4.436036387594894},
    {10.427508642579134, 0.0, 0.0, 0.0, 0.0, 242.28349177525817, 165.20045171727028, -374.5467547226902,
        -22.113666853125306, 7.733432668472264, -30.674084731089398, -9.332130526430229, 15.697238121770845,
        -31.139403219565178, -9.35292435884448, 35.81684148639408},
    {19.985053242002433, 0.0, 0.0, 0.0, 0.0, -387.0373087493518, -189.17813819516758, 527.8081592054236,
        -11.57390253995963, 6.8812326946963, -1.0006050966910838, 0.7777137798053443, -2.778205752353508,
        -60.19669523126412, 84.32040550667716, 11.99229113618279},
    {-25.69393346270375, 0.0, 0.0, 0.0, 0.0, -154.18974869023643, -231.5293791760455, 357.6391179106141,
        93.40532418362432, -37.45832313645163, 104.0996495089623, 29.8402934266605, -43.53345659001114,
        96.32455395918828, -39.17726167561544, -149.72683625798564}};


/* out = y + h sum_j A[s][j] k[j] on the components lo..hi-1 (row s's nonzero coefficients written out, so that the
 * loop over the components vectorises) */
static void stage_row(int s, int lo, int hi, const double *y, double h, double k[][NMAX], double *out) {
    switch (s) {
    case 1:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[1][0] * k[0][i]);
        break;
    case 2:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[2][0] * k[0][i] + D8_A[2][1] * k[1][i]);
        break;
    case 3:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[3][0] * k[0][i] + D8_A[3][2] * k[2][i]);
        break;
    case 4:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[4][0] * k[0][i] + D8_A[4][2] * k[2][i] + D8_A[4][3] * k[3][i]);
        break;
    case 5:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[5][0] * k[0][i] + D8_A[5][3] * k[3][i] + D8_A[5][4] * k[4][i]);
        break;
    case 6:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[6][0] * k[0][i] + D8_A[6][3] * k[3][i] + D8_A[6][4] * k[4][i] +
                         D8_A[6][5] * k[5][i]);
        break;
    case 7:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[7][0] * k[0][i] + D8_A[7][3] * k[3][i] + D8_A[7][4] * k[4][i] +
                         D8_A[7][5] * k[5][i] + D8_A[7][6] * k[6][i]);
        break;
    case 8:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[8][0] * k[0][i] + D8_A[8][3] * k[3][i] + D8_A[8][4] * k[4][i] +
                         D8_A[8][5] * k[5][i] + D8_A[8][6] * k[6][i] + D8_A[8][7] * k[7][i]);
        break;
    case 9:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[9][0] * k[0][i] + D8_A[9][3] * k[3][i] + D8_A[9][4] * k[4][i] +
                         D8_A[9][5] * k[5][i] + D8_A[9][6] * k[6][i] + D8_A[9][7] * k[7][i] +
                         D8_A[9][8] * k[8][i]);
        break;
    case 10:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[10][0] * k[0][i] + D8_A[10][3] * k[3][i] + D8_A[10][4] * k[4][i] +
                         D8_A[10][5] * k[5][i] + D8_A[10][6] * k[6][i] + D8_A[10][7] * k[7][i] +
                         D8_A[10][8] * k[8][i] + D8_A[10][9] * k[9][i]);
        break;
    case 11:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[11][0] * k[0][i] + D8_A[11][3] * k[3][i] + D8_A[11][4] * k[4][i] +
                         D8_A[11][5] * k[5][i] + D8_A[11][6] * k[6][i] + D8_A[11][7] * k[7][i] +
                         D8_A[11][8] * k[8][i] + D8_A[11][9] * k[9][i] + D8_A[11][10] * k[10][i]);
        break;
    case 12:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[12][0] * k[0][i] + D8_A[12][5] * k[5][i] + D8_A[12][6] * k[6][i] +
                         D8_A[12][7] * k[7][i] + D8_A[12][8] * k[8][i] + D8_A[12][9] * k[9][i] +
                         D8_A[12][10] * k[10][i] + D8_A[12][11] * k[11][i]);
        break;
    case 13:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[13][0] * k[0][i] + D8_A[13][6] * k[6][i] + D8_A[13][7] * k[7][i] +
                         D8_A[13][8] * k[8][i] + D8_A[13][9] * k[9][i] + D8_A[13][10] * k[10][i] +
                         D8_A[13][11] * k[11][i] + D8_A[13][12] * k[12][i]);
        break;
    case 14:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[14][0] * k[0][i] + D8_A[14][5] * k[5][i] + D8_A[14][6] * k[6][i] +
                         D8_A[14][7] * k[7][i] + D8_A[14][10] * k[10][i] + D8_A[14][11] * k[11][i] +
                         D8_A[14][12] * k[12][i] + D8_A[14][13] * k[13][i]);
        break;
    case 15:
        for (int i = lo; i < hi; i++)
            out[i] = y[i] + h * (D8_A[15][0] * k[0][i] + D8_A[15][5] * k[5][i] + D8_A[15][6] * k[6][i] +
                         D8_A[15][7] * k[7][i] + D8_A[15][8] * k[8][i] + D8_A[15][12] * k[12][i] +
                         D8_A[15][13] * k[13][i] + D8_A[15][14] * k[14][i]);
        break;
    default:
        break;
    }
}

/* the error estimates of orders 5 and 3 on the components lo..hi-1 */
static void step_errors(int lo, int hi, double h, double k[][NMAX], double *err5, double *err3) {
    for (int i = lo; i < hi; i++) {
        err5[i] = h * (D8_E5[0] * k[0][i] + D8_E5[5] * k[5][i] + D8_E5[6] * k[6][i] +
                       D8_E5[7] * k[7][i] + D8_E5[8] * k[8][i] + D8_E5[9] * k[9][i] +
                       D8_E5[10] * k[10][i] + D8_E5[11] * k[11][i]);
        err3[i] = h * (D8_E3[0] * k[0][i] + D8_E3[5] * k[5][i] + D8_E3[6] * k[6][i] +
                       D8_E3[7] * k[7][i] + D8_E3[8] * k[8][i] + D8_E3[9] * k[9][i] +
                       D8_E3[10] * k[10][i] + D8_E3[11] * k[11][i]);
    }
}

/* the dense output's rows 4..7 on the components lo..hi-1 */
static void dense_rows(int lo, int hi, double h, double k[][NMAX], Dense *d) {
    for (int i = lo; i < hi; i++) {
        d->r[4][i] = h * (D8_D[0][0] * k[0][i] + D8_D[0][5] * k[5][i] + D8_D[0][6] * k[6][i] +
                          D8_D[0][7] * k[7][i] + D8_D[0][8] * k[8][i] + D8_D[0][9] * k[9][i] +
                          D8_D[0][10] * k[10][i] + D8_D[0][11] * k[11][i] + D8_D[0][12] * k[12][i] +
                          D8_D[0][13] * k[13][i] + D8_D[0][14] * k[14][i] + D8_D[0][15] * k[15][i]);
        d->r[5][i] = h * (D8_D[1][0] * k[0][i] + D8_D[1][5] * k[5][i] + D8_D[1][6] * k[6][i] +
                          D8_D[1][7] * k[7][i] + D8_D[1][8] * k[8][i] + D8_D[1][9] * k[9][i] +
                          D8_D[1][10] * k[10][i] + D8_D[1][11] * k[11][i] + D8_D[1][12] * k[12][i] +
                          D8_D[1][13] * k[13][i] + D8_D[1][14] * k[14][i] + D8_D[1][15] * k[15][i]);
        d->r[6][i] = h * (D8_D[2][0] * k[0][i] + D8_D[2][5] * k[5][i] + D8_D[2][6] * k[6][i] +
                          D8_D[2][7] * k[7][i] + D8_D[2][8] * k[8][i] + D8_D[2][9] * k[9][i] +
                          D8_D[2][10] * k[10][i] + D8_D[2][11] * k[11][i] + D8_D[2][12] * k[12][i] +
                          D8_D[2][13] * k[13][i] + D8_D[2][14] * k[14][i] + D8_D[2][15] * k[15][i]);
        d->r[7][i] = h * (D8_D[3][0] * k[0][i] + D8_D[3][5] * k[5][i] + D8_D[3][6] * k[6][i] +
                          D8_D[3][7] * k[7][i] + D8_D[3][8] * k[8][i] + D8_D[3][9] * k[9][i] +
                          D8_D[3][10] * k[10][i] + D8_D[3][11] * k[11][i] + D8_D[3][12] * k[12][i] +
                          D8_D[3][13] * k[13][i] + D8_D[3][14] * k[14][i] + D8_D[3][15] * k[15][i]);
    }
}

/* the ranges of components a step varies: st's, or all n */
static int ranges(const Dop853Stages *st, int n, int lo[2], int hi[2]) {
    if (st->nRanges <= 0) {
        lo[0] = 0;
        hi[0] = n;
        return 1;
    }
    for (int r = 0; r < st->nRanges; r++) {
        lo[r] = st->lo[r];
        hi[r] = st->hi[r];
    }
    return st->nRanges;
}

void dop853_step(RhsFn f, const void *ctx, int n, double t, const double *y, const double *f0, double h, double *y1,
                 double *f1, double *err5, double *err3, Dense *d, Dop853Stages *st) {
    double yt[NMAX] = {0};
    int lo[2], hi[2], nr = ranges(st, n, lo, hi);
    st->n = n;
    st->t = t;
    st->h = h;
    memcpy(yt, y, sizeof(double) * (size_t)n);
    memcpy(y1, y, sizeof(double) * (size_t)n);
    memcpy(st->k[0], f0, sizeof(double) * (size_t)n);
    for (int i = 0; i < n; i++) err5[i] = err3[i] = 0.0;
    for (int s = 1; s < 12; s++) {
        for (int r = 0; r < nr; r++) stage_row(s, lo[r], hi[r], y, h, st->k, yt);
        f(ctx, t + D8_C[s] * h, yt, st->k[s]);
    }
    for (int r = 0; r < nr; r++) stage_row(12, lo[r], hi[r], y, h, st->k, y1);
    f(ctx, t + h, y1, f1);
    memcpy(st->k[12], f1, sizeof(double) * (size_t)n);
    for (int r = 0; r < nr; r++) step_errors(lo[r], hi[r], h, st->k, err5, err3);
    d->method = RK_DOP853;
    d->rows = 4; /* (of 8 once dop853_dense completes it) */
    memcpy(d->r[0], y, sizeof(double) * (size_t)n);
    for (int j = 1; j < DENSE_ROWS; j++) /* (the first n alone: a whole row's memset cost more than the rows' sums) */
        for (int i = 0; i < n; i++) d->r[j][i] = 0.0;
    for (int r = 0; r < nr; r++)
        for (int i = lo[r]; i < hi[r]; i++) {
            double dy = y1[i] - y[i];
            d->r[1][i] = dy;
            d->r[2][i] = h * f0[i] - dy;
            d->r[3][i] = 2.0 * dy - h * (f1[i] + f0[i]);
        }
}

void dop853_dense(RhsFn f, const void *ctx, Dop853Stages *st, Dense *d) {
    int n = st->n, lo[2], hi[2], nr = ranges(st, n, lo, hi);
    double yt[NMAX] = {0}, h = st->h;
    memcpy(yt, d->r[0], sizeof(double) * (size_t)n);
    for (int s = 13; s < 16; s++) {
        for (int r = 0; r < nr; r++) stage_row(s, lo[r], hi[r], d->r[0], h, st->k, yt);
        f(ctx, st->t + D8_C[s] * h, yt, st->k[s]);
    }
    for (int r = 0; r < nr; r++) dense_rows(lo[r], hi[r], h, st->k, d);
    d->rows = 8;
}

double dopri5_error_norm(int n, const double *y0, const double *y1,
                         const double *err, double rtol, double atol) {
    double sum = 0.0;
    for (int i = 0; i < n; i++) {
        double sc = atol + rtol * fmax(fabs(y0[i]), fabs(y1[i]));
        double e = err[i] / sc;
        sum += e * e;
    }
    return sqrt(sum / n);
}

double dop853_error_norm(int n, const double *scale, const double *y0, const double *y1, const double *err5,
                         const double *err3, double rtol, double atol) {
    double s5 = 0.0, s3 = 0.0;
    int counted = 0;
    for (int i = 0; i < n; i++) {
        if (scale && scale[i] == 0.0) continue;
        double sc = atol * (scale ? scale[i] : 1.0) + rtol * fmax(fabs(y0[i]), fabs(y1[i]));
        double a = err5[i] / sc, b = err3[i] / sc;
        s5 += a * a;
        s3 += b * b;
        counted++;
    }
    if (s5 == 0.0 && s3 == 0.0) return 0.0;
    return s5 / sqrt((s5 + 0.01 * s3) * counted);
}

void dense_copy(Dense *to, const Dense *from, int n) {
    to->method = from->method;
    to->rows = from->rows;
    for (int j = 0; j < from->rows; j++) memcpy(to->r[j], from->r[j], sizeof(double) * (size_t)n);
}

void dense_eval(const Dense *d, int n, double s, double *y) {
    double s1 = 1.0 - s;
    if (d->method == RK_DOPRI5) {
        const double(*cont)[NMAX] = d->r;
        for (int i = 0; i < n; i++)
            y[i] = cont[0][i] +
                   s * (cont[1][i] +
                        s1 * (cont[2][i] + s * (cont[3][i] + s1 * cont[4][i])));
        return;
    }
    for (int i = 0; i < n; i++) {
        double v = d->r[d->rows - 1][i];
        for (int j = d->rows - 2; j >= 1; j--) v = d->r[j][i] + (j % 2 ? s1 : s) * v; /* (after r1: 1 - s) */
        y[i] = d->r[0][i] + s * v;
    }
}

int dense_poly(const Dense *d, int i, double c[DENSE_ROWS]) {
    if (d->method == RK_DOPRI5) {
        const double(*cont)[NMAX] = d->r;
        /* r1 + s r2 + (s - s^2) r3 + (s^2 - s^3) r4 + (s^2 - 2 s^3 + s^4) r5 */
        c[0] = cont[0][i];
        c[1] = cont[1][i] + cont[2][i];
        c[2] = -cont[2][i] + cont[3][i] + cont[4][i];
        c[3] = -cont[3][i] - 2.0 * cont[4][i];
        c[4] = cont[4][i];
        return 4;
    }
    /* the nested form from its innermost row: v <- r_j + (s or 1 - s) v, then c = r0 + s v */
    int deg = d->rows - 1;
    double v[DENSE_ROWS] = {0};
    v[0] = d->r[deg][i];
    for (int j = deg - 1, dv = 0; j >= 1; j--, dv++) {
        if (j % 2) { /* times 1 - s (after r1, r3, ...) */
            for (int k = dv + 1; k >= 1; k--) v[k] -= v[k - 1];
        } else { /* times s */
            for (int k = dv + 1; k >= 1; k--) v[k] = v[k - 1];
            v[0] = 0.0;
        }
        v[0] += d->r[j][i];
    }
    c[0] = d->r[0][i];
    for (int k = 1; k <= deg; k++) c[k] = v[k - 1];
    return deg;
}

double poly_eval(const double *c, int deg, double s) {
    double p = c[deg];
    for (int i = deg - 1; i >= 0; i--) p = p * s + c[i];
    return p;
}

/* Root of a polynomial that changes sign on [a, b] (fa * fb < 0):
 * Illinois-modified regula falsi, with a bisection fallback. */
static double bracket_root(const double *c, int deg, double a, double b,
                           double fa, double fb) {
    int side = 0;
    for (int it = 0; it < 200; it++) {
        double m;
        if (it % 4 == 3)
            m = 0.5 * (a + b); /* guarantee shrinking */
        else
            m = (a * fb - b * fa) / (fb - fa);
        if (!(m > a && m < b)) m = 0.5 * (a + b);
        if (!(m > a && m < b)) break; /* interval at machine resolution */
        double fm = poly_eval(c, deg, m);
        if (fm == 0.0) return m;
        if ((fm < 0) == (fa < 0)) {
            a = m;
            fa = fm;
            if (side == -1) fb *= 0.5;
            side = -1;
        } else {
            b = m;
            fb = fm;
            if (side == 1) fa *= 0.5;
            side = 1;
        }
        if (b - a <= 4.0 * DBL_EPSILON * fmax(1.0, fabs(a))) break;
    }
    return fabs(fa) < fabs(fb) ? a : b;
}

int poly_roots(const double *c, int deg, double lo, double hi, double *roots) {
    while (deg > 0 && c[deg] == 0.0) deg--;
    if (deg <= 0) return 0;
    if (deg == 1) {
        double r = -c[0] / c[1];
        if (r >= lo && r <= hi) {
            roots[0] = r;
            return 1;
        }
        return 0;
    }
    /* critical points split [lo, hi] into pieces where c is monotone */
    double d[DENSE_ROWS], crit[DENSE_ROWS], pts[DENSE_ROWS + 2];
    for (int i = 1; i <= deg; i++) d[i - 1] = i * c[i];
    int nc = poly_roots(d, deg - 1, lo, hi, crit);
    int np = 0;
    pts[np++] = lo;
    for (int i = 0; i < nc; i++)
        if (crit[i] > pts[np - 1] && crit[i] < hi) pts[np++] = crit[i];
    pts[np++] = hi;
    int nr = 0;
    double fa = poly_eval(c, deg, pts[0]);
    if (fa == 0.0) roots[nr++] = pts[0];
    for (int j = 0; j + 1 < np; j++) {
        double a = pts[j], b = pts[j + 1];
        double fb = poly_eval(c, deg, b);
        if (fb == 0.0) {
            if (nr == 0 || roots[nr - 1] < b) roots[nr++] = b;
        } else if (fa != 0.0 && ((fa < 0) != (fb < 0))) {
            roots[nr++] = bracket_root(c, deg, a, b, fa, fb);
        }
        fa = fb;
        if (nr >= deg) break;
    }
    return nr;
}

double dopri5_initial_step(RhsFn f, const void *ctx, int n, double t,
                           const double *y, const double *f0, double rtol,
                           double atol, double hmax) {
    double d0 = 0, d1 = 0, d2 = 0, h0, h1, y1[NMAX] = {0}, f1[NMAX];
    for (int i = 0; i < n; i++) {
        double sc = atol + rtol * fabs(y[i]);
        d0 += (y[i] / sc) * (y[i] / sc);
        d1 += (f0[i] / sc) * (f0[i] / sc);
    }
    d0 = sqrt(d0 / n);
    d1 = sqrt(d1 / n);
    h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    if (h0 > hmax) h0 = hmax;
    for (int i = 0; i < n; i++) y1[i] = y[i] + h0 * f0[i];
    f(ctx, t + h0, y1, f1);
    for (int i = 0; i < n; i++) {
        double sc = atol + rtol * fabs(y[i]);
        double e = (f1[i] - f0[i]) / sc;
        d2 += e * e;
    }
    d2 = sqrt(d2 / n) / h0;
    double dm = fmax(d1, d2);
    h1 = dm <= 1e-15 ? fmax(1e-6, h0 * 1e-3) : pow(0.01 / dm, 0.2);
    double h = fmin(100.0 * h0, h1);
    return h > hmax ? hmax : h;
}

/* Largest |theta| of dense-output component comp over s in [0, sEnd]. */
double dense_abs_max(const Dense *dn, int comp, double sEnd) {
    double c[DENSE_ROWS], d[DENSE_ROWS], roots[DENSE_ROWS];
    int deg = dense_poly(dn, comp, c);
    double m = fmax(fabs(c[0]), fabs(poly_eval(c, deg, sEnd)));
    for (int i = 1; i <= deg; i++) d[i - 1] = i * c[i];
    int nr = poly_roots(d, deg - 1, 0.0, sEnd, roots);
    for (int j = 0; j < nr; j++) m = fmax(m, fabs(poly_eval(c, deg, roots[j])));
    return m;
}
