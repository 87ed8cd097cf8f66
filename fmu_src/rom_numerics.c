/*
 * The dense numerics the model kinds and the error bounds share: the matrix exponential of a small dense
 * matrix (the exact linear model's step maps, rom_exact.c; the error bounds' plane and block maps,
 * rom_bound.c), and the growth factor of the truth's e^{At} (rom_bound.c, rom_port.c).  It calls no other file of
 * the core.
 */
#include "rom_numerics.h"

#define ROM_TAYLOR_DEGREE 16            /* ||X||_1 <= 1/2: remainder < 0.5^17/17! ~ 2e-20 */
#define ROM_TAYLOR_NORM 0.5
#define ROM_MAX_SQUARINGS 1100

static double norm1(size_t n, const double *M) {
    double best = 0.0;
    for (size_t j = 0; j < n; j++) {
        double sum = 0.0;
        for (size_t i = 0; i < n; i++) sum += fabs(M[i * n + j]);
        if (!(sum <= best)) best = sum;          /* NaN propagates */
    }
    return best;
}

static void matmul(size_t n, const double *restrict A, const double *restrict B, double *restrict C) {
    for (size_t i = 0; i < n * n; i++) C[i] = 0.0;
    for (size_t i = 0; i < n; i++) {
        for (size_t l = 0; l < n; l++) {
            const double a = A[i * n + l];
            if (a == 0.0) continue;
            const double *restrict row = B + l * n;
            double *restrict out = C + i * n;
            for (size_t j = 0; j < n; j++) out[j] += a * row[j];
        }
    }
}

/* E = e^M (n x n, row-major) by scaling and squaring with a Taylor polynomial
 * (Horner form) on M / 2^s, ||M / 2^s||_1 <= 1/2.  X, T: n x n scratch.
 * Returns 0 when M or the result is not finite. */
int rom_expm_taylor(size_t n, const double *M, double *E, double *X, double *T) {
    if (n == 0 || !M || !E || !X || !T) return 0;
    const double nrm = norm1(n, M);
    if (!isfinite(nrm)) return 0;
    int squarings = 0;
    if (nrm > ROM_TAYLOR_NORM) squarings = (int)ceil(log2(nrm / ROM_TAYLOR_NORM));
    if (squarings > ROM_MAX_SQUARINGS) return 0;
    const double scale = ldexp(1.0, -squarings);
    for (size_t i = 0; i < n * n; i++) X[i] = M[i] * scale;
    for (size_t i = 0; i < n * n; i++) E[i] = 0.0;
    for (size_t i = 0; i < n; i++) E[i * n + i] = 1.0;
    for (int j = ROM_TAYLOR_DEGREE; j >= 1; j--) {      /* E = I + X E / j */
        matmul(n, X, E, T);
        const double inv = 1.0 / (double)j;
        for (size_t i = 0; i < n * n; i++) E[i] = T[i] * inv;
        for (size_t i = 0; i < n; i++) E[i * n + i] += 1.0;
    }
    for (int q = 0; q < squarings; q++) {
        matmul(n, E, E, T);
        memcpy(E, T, n * n * sizeof(double));
    }
    return rom_all_finite(E, n * n);
}

double rom_growth_factor(double rate, double t) {
    const double x = rate * (t > 0 ? t : 0.0);
    return x <= 1.0 ? 1.0 + x * (1.0 + x) : exp(x);
}
