/*
 * Optional compiled kernel of liebridge's IMU preintegration: the per-sample sums of one block
 * (block_sums, window_sums: the manifold preintegration) and, at the end of this file, GTSAM's
 * tangent combined preintegration (combined_integrate).
 *
 * It computes exactly what the numpy kernel (liebridge/factors/_imu_kernel.py, fast path:
 * isotropic noise, no lever arm) computes per block, in two passes over the samples instead of
 * about a hundred numpy passes. The formulas, frames and conventions are those of that module's
 * docstring; tests/test_imu_kernel.py checks this kernel against the numpy one on every output.
 *
 * Forward pass, k = 0 .. n-1 (frame i = body frame at the first sample):
 *   a_k = bRs (acc_k - b_a), w_k = bRs (gyro_k - b_g), th_k = w_k dt_k,
 *   R_k = ΔR_k (prefix product of Exp(th_j), j < k, as a unit quaternion, normalised when read),
 *   ra_k = R_k a_k, u_k = R_k th_k, alpha_k = (tau_k + dt_k/2) dt_k with tau_k = sum_{j>k} dt_j,
 *   E_k = (ra_k alpha_k, ra_k dt_k), Y_k = R_k J_l(th_k) dt_k = c0 dt R + [B dt u]x R + C dt u th^T,
 *   wa_k = dt (c0^2 + B^2 th^2), wb_k = dt (C (2 c0 + C th^2) - B^2).
 * Backward pass, k = n-1 .. 0, with the exclusive suffix sums pt_k = sum_{i>k} E_i (p~, v~):
 *   S = sum W_k (x) Y_k with W_k = (1, p~_k, v~_k), covV = sum wb V V^T with V = (u, p~ x u, v~ x u),
 *   M = sum wa pv pv^T and s = sum wa pv with pv = (p~, v~).
 *
 * The Python function takes buffers (any object with the buffer protocol: C-contiguous float64
 * numpy arrays) and writes into `out` and `scratch`; it allocates nothing and holds the GIL only
 * while parsing its arguments.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>

/* layout of `out` (doubles); mirrored as the _C_* slices in _imu_kernel.py */
#define O_R 0      /* 9: ΔR_N, row-major */
#define O_P 9      /* 3: Δp_N */
#define O_V 12     /* 3: Δv_N */
#define O_T 15     /* 1: T */
#define O_S 16     /* 63: S[m][i][j], m over (1, p~0, p~1, p~2, v~0, v~1, v~2) */
#define O_JA 79    /* 18: sum alpha R (9), sum dt R (9) */
#define O_COVV 97  /* 81: sum wb V V^T */
#define O_M 178    /* 36: sum wa pv pv^T */
#define O_SPV 214  /* 6: sum wa pv */
#define O_SWA 220  /* 1: sum wa */
#define O_SA2 221  /* 1: sum alpha^2 / dt */
#define O_SA 222   /* 1: sum alpha */
#define N_OUT 223
#define N_SCRATCH 21 /* per sample: tau, E(6), Y(9), u(3), wa, wb */
#define N_TERMS 9

static void quat_to_R(const double q[4], double R[9]) {
    double w = q[0], x = q[1], y = q[2], z = q[3];
    double s = 2.0 / (w * w + x * x + y * y + z * z);
    double sx = s * x, sy = s * y, sz = s * z;
    double xx = sx * x, yy = sy * y, zz = sz * z;
    double xy = sx * y, xz = sx * z, yz = sy * z;
    double wx = sx * w, wy = sy * w, wz = sz * w;
    R[0] = 1.0 - (yy + zz); R[1] = xy - wz;         R[2] = xz + wy;
    R[3] = xy + wz;         R[4] = 1.0 - (xx + zz); R[5] = yz - wx;
    R[6] = xz - wy;         R[7] = yz + wx;         R[8] = 1.0 - (xx + yy);
}

/* c0 = sin t/t, B = (1 - cos t)/t^2, C = (t - sin t)/t^3, cos(t/2), sin(t/2)/(t/2) */
static void coefficients(double t2, const double *coef, int K, double small2, double c[5]) {
    if (t2 < small2) {
        for (int r = 0; r < 5; r++) {
            const double *cr = coef + r * N_TERMS;
            double acc = cr[K - 1];
            for (int k = K - 2; k >= 0; k--) acc = acc * t2 + cr[k];
            c[r] = acc;
        }
    } else {
        double t = sqrt(t2), h = 0.5 * t;
        double st = sin(t), sh = sin(h);
        c[0] = st / t;
        c[1] = 2.0 * (sh / t) * (sh / t);
        c[2] = (t - st) / (t2 * t);
        c[3] = cos(h);
        c[4] = sh / h;
    }
}

/* The sums of one block of n samples (the comment at the top of this file), written to out[N_OUT];
   scr holds N_SCRATCH doubles per sample. */
static void sums(const double *acc, const double *gyro, const double *dt, Py_ssize_t n,
                 const double *bias, int rotate, const double *bRs, const double *coef, int K,
                 double small2, double *scr, double *out) {
    for (int i = 0; i < N_OUT; i++) out[i] = 0.0;
    /* tau_k = sum_{j>k} dt_j */
    double T = 0.0;
    for (Py_ssize_t k = n - 1; k >= 0; k--) {
        scr[k * N_SCRATCH] = T;
        T += dt[k];
    }
    out[O_T] = T;
    double q[4] = {1.0, 0.0, 0.0, 0.0};
    double R[9];
    for (Py_ssize_t k = 0; k < n; k++) {
        double *s = scr + k * N_SCRATCH;
        double d = dt[k];
        double a[3], w[3], th[3];
        for (int i = 0; i < 3; i++) {
            a[i] = acc[3 * k + i] - bias[i];
            w[i] = gyro[3 * k + i] - bias[3 + i];
        }
        if (rotate) {
            double a2[3], w2[3];
            for (int i = 0; i < 3; i++) {
                a2[i] = bRs[3 * i] * a[0] + bRs[3 * i + 1] * a[1] + bRs[3 * i + 2] * a[2];
                w2[i] = bRs[3 * i] * w[0] + bRs[3 * i + 1] * w[1] + bRs[3 * i + 2] * w[2];
            }
            for (int i = 0; i < 3; i++) { a[i] = a2[i]; w[i] = w2[i]; }
        }
        for (int i = 0; i < 3; i++) th[i] = w[i] * d;
        double t2 = th[0] * th[0] + th[1] * th[1] + th[2] * th[2];
        double c[5];
        coefficients(t2, coef, K, small2, c);
        quat_to_R(q, R);
        double ra[3], u[3];
        for (int i = 0; i < 3; i++) {
            ra[i] = R[3 * i] * a[0] + R[3 * i + 1] * a[1] + R[3 * i + 2] * a[2];
            u[i] = R[3 * i] * th[0] + R[3 * i + 1] * th[1] + R[3 * i + 2] * th[2];
        }
        double alpha = (s[0] + 0.5 * d) * d;
        for (int i = 0; i < 3; i++) {
            s[1 + i] = ra[i] * alpha;
            s[4 + i] = ra[i] * d;
            out[O_P + i] += s[1 + i];
            out[O_V + i] += s[4 + i];
        }
        for (int i = 0; i < 9; i++) {
            out[O_JA + i] += alpha * R[i];
            out[O_JA + 9 + i] += d * R[i];
        }
        out[O_SA2] += alpha * alpha / d;
        out[O_SA] += alpha;
        /* Y = c0 dt R + [g]x R + Cu th^T, g = B dt u, Cu = C dt u */
        double c0dt = c[0] * d, g[3], Cu[3];
        for (int i = 0; i < 3; i++) { g[i] = c[1] * d * u[i]; Cu[i] = c[2] * d * u[i]; }
        double *Y = s + 7;
        for (int i = 0; i < 3; i++) {
            int j1 = (i + 1) % 3, j2 = (i + 2) % 3;
            for (int j = 0; j < 3; j++)
                Y[3 * i + j] = c0dt * R[3 * i + j] + g[j1] * R[3 * j2 + j] - g[j2] * R[3 * j1 + j]
                               + Cu[i] * th[j];
        }
        for (int i = 0; i < 3; i++) s[16 + i] = u[i];
        double B2 = c[1] * c[1];
        double wa = d * (c[0] * c[0] + B2 * t2);
        s[19] = wa;
        s[20] = d * (c[2] * (2.0 * c[0] + c[2] * t2) - B2);
        out[O_SWA] += wa;
        /* q <- q * Exp(th): increment (cos(t/2), sin(t/2) th/t) */
        double hs = 0.5 * c[4];
        double w2 = c[3], x2 = hs * th[0], y2 = hs * th[1], z2 = hs * th[2];
        double w1 = q[0], x1 = q[1], y1 = q[2], z1 = q[3];
        q[0] = w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2;
        q[1] = w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2;
        q[2] = w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2;
        q[3] = w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2;
    }
    quat_to_R(q, out + O_R);
    /* backward pass: suffix sums p~ (pv[0..2]) and v~ (pv[3..5]) */
    double pv[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    double *S = out + O_S, *cv = out + O_COVV, *M = out + O_M, *spv = out + O_SPV;
    for (Py_ssize_t k = n - 1; k >= 0; k--) {
        const double *s = scr + k * N_SCRATCH;
        const double *Y = s + 7, *u = s + 16;
        double wa = s[19], wb = s[20];
        for (int j = 0; j < 9; j++) S[j] += Y[j];
        for (int m = 0; m < 6; m++) {
            double x = pv[m];
            double *Sm = S + 9 * (m + 1);
            for (int j = 0; j < 9; j++) Sm[j] += x * Y[j];
        }
        double V[9];
        V[0] = u[0]; V[1] = u[1]; V[2] = u[2];
        for (int r = 0; r < 2; r++) {
            const double *x = pv + 3 * r;
            V[3 + 3 * r] = x[1] * u[2] - x[2] * u[1];
            V[4 + 3 * r] = x[2] * u[0] - x[0] * u[2];
            V[5 + 3 * r] = x[0] * u[1] - x[1] * u[0];
        }
        for (int i = 0; i < 9; i++) {
            double wv = wb * V[i];
            for (int j = i; j < 9; j++) cv[9 * i + j] += wv * V[j];
        }
        for (int i = 0; i < 6; i++) {
            double wx = wa * pv[i];
            spv[i] += wx;
            for (int j = i; j < 6; j++) M[6 * i + j] += wx * pv[j];
        }
        for (int i = 0; i < 6; i++) pv[i] += s[1 + i];
    }
    for (int i = 0; i < 9; i++)
        for (int j = 0; j < i; j++) cv[9 * i + j] = cv[9 * j + i];
    for (int i = 0; i < 6; i++)
        for (int j = 0; j < i; j++) M[6 * i + j] = M[6 * j + i];
}

static PyObject *block_sums(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer acc_b, gyro_b, dt_b, bias_b, bRs_b, coef_b, scratch_b, out_b;
    int K, rotate;
    double small2;
    if (!PyArg_ParseTuple(args, "y*y*y*y*py*y*idw*w*", &acc_b, &gyro_b, &dt_b, &bias_b, &rotate,
                          &bRs_b, &coef_b, &K, &small2, &scratch_b, &out_b))
        return NULL;
    Py_ssize_t n = dt_b.len / (Py_ssize_t)sizeof(double);
    const char *bad = NULL;
    /* every buffer is read and written as double: a misaligned pointer is undefined behaviour
       (it happens to work on x86), so refuse it; the Python caller passes aligned copies */
    const Py_buffer *all[8] = {&acc_b, &gyro_b, &dt_b, &bias_b, &bRs_b, &coef_b, &scratch_b, &out_b};
    int misaligned = 0;
    for (int b = 0; b < 8; b++) misaligned |= (uintptr_t)all[b]->buf % _Alignof(double) != 0;
    if (misaligned) bad = "a buffer is not aligned to a double boundary (pass aligned float64)";
    else if (n < 1) bad = "dt: no samples";
    else if (dt_b.len % (Py_ssize_t)sizeof(double) != 0) bad = "dt: not a whole number of doubles";
    else if (acc_b.len != 3 * dt_b.len || gyro_b.len != 3 * dt_b.len) bad = "acc/gyro: not (n, 3)";
    else if (bias_b.len != 6 * (Py_ssize_t)sizeof(double)) bad = "bias: not 6 doubles";
    else if (bRs_b.len != 9 * (Py_ssize_t)sizeof(double)) bad = "bRs: not 9 doubles";
    else if (coef_b.len != 5 * N_TERMS * (Py_ssize_t)sizeof(double)) bad = "coef: not 5x9";
    else if (K < 1 || K > N_TERMS) bad = "K: not in 1..9";
    else if (scratch_b.len < N_SCRATCH * dt_b.len) bad = "scratch: too small";
    else if (out_b.len != N_OUT * (Py_ssize_t)sizeof(double)) bad = "out: wrong size";
    if (bad == NULL) {
        const double *acc = acc_b.buf, *gyro = gyro_b.buf, *dt = dt_b.buf, *bias = bias_b.buf;
        const double *bRs = bRs_b.buf, *coef = coef_b.buf;
        double *scr = scratch_b.buf, *out = out_b.buf;
        Py_BEGIN_ALLOW_THREADS
        sums(acc, gyro, dt, n, bias, rotate, bRs, coef, K, small2, scr, out);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&acc_b);
    PyBuffer_Release(&gyro_b);
    PyBuffer_Release(&dt_b);
    PyBuffer_Release(&bias_b);
    PyBuffer_Release(&bRs_b);
    PyBuffer_Release(&coef_b);
    PyBuffer_Release(&scratch_b);
    PyBuffer_Release(&out_b);
    if (bad != NULL) {
        PyErr_SetString(PyExc_ValueError, bad);
        return NULL;
    }
    Py_RETURN_NONE;
}

/* window_sums: the sums of many windows of one sequence in one call. Window w holds the samples
   [starts[w], starts[w+1]) (the last runs to n), integrated from the identity with its own bias
   bias[6w .. 6w+5]; its sums go to out[N_OUT w .. N_OUT (w+1) - 1]. starts (int64) must be
   strictly increasing in [0, n); scratch holds N_SCRATCH doubles per sample of the longest window. */
static PyObject *window_sums(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer acc_b, gyro_b, dt_b, starts_b, bias_b, bRs_b, coef_b, scratch_b, out_b;
    int K, rotate;
    double small2;
    if (!PyArg_ParseTuple(args, "y*y*y*y*y*py*y*idw*w*", &acc_b, &gyro_b, &dt_b, &starts_b,
                          &bias_b, &rotate, &bRs_b, &coef_b, &K, &small2, &scratch_b, &out_b))
        return NULL;
    Py_ssize_t n = dt_b.len / (Py_ssize_t)sizeof(double);
    Py_ssize_t nw = starts_b.len / (Py_ssize_t)sizeof(int64_t);
    const char *bad = NULL;
    const Py_buffer *all[9] = {&acc_b, &gyro_b, &dt_b, &starts_b, &bias_b,
                               &bRs_b, &coef_b, &scratch_b, &out_b};
    int misaligned = 0;
    for (int b = 0; b < 9; b++) misaligned |= (uintptr_t)all[b]->buf % _Alignof(double) != 0;
    if (misaligned) bad = "a buffer is not aligned to a double boundary (pass aligned float64)";
    else if (n < 1) bad = "dt: no samples";
    else if (dt_b.len % (Py_ssize_t)sizeof(double) != 0) bad = "dt: not a whole number of doubles";
    else if (acc_b.len != 3 * dt_b.len || gyro_b.len != 3 * dt_b.len) bad = "acc/gyro: not (n, 3)";
    else if (nw < 1 || starts_b.len % (Py_ssize_t)sizeof(int64_t) != 0) bad = "starts: not int64 (>= 1)";
    else if (bias_b.len != 6 * nw * (Py_ssize_t)sizeof(double)) bad = "bias: not 6 doubles a window";
    else if (bRs_b.len != 9 * (Py_ssize_t)sizeof(double)) bad = "bRs: not 9 doubles";
    else if (coef_b.len != 5 * N_TERMS * (Py_ssize_t)sizeof(double)) bad = "coef: not 5x9";
    else if (K < 1 || K > N_TERMS) bad = "K: not in 1..9";
    else if (out_b.len != N_OUT * nw * (Py_ssize_t)sizeof(double)) bad = "out: wrong size";
    if (bad == NULL) {
        const int64_t *st = starts_b.buf;
        Py_ssize_t longest = 0;
        for (Py_ssize_t w = 0; w < nw && bad == NULL; w++) {
            int64_t e = w + 1 < nw ? st[w + 1] : (int64_t)n;
            if (st[w] < 0 || st[w] >= e || e > (int64_t)n) bad = "starts: not increasing in [0, n)";
            else if (e - st[w] > longest) longest = (Py_ssize_t)(e - st[w]);
        }
        if (bad == NULL && scratch_b.len < N_SCRATCH * longest * (Py_ssize_t)sizeof(double))
            bad = "scratch: too small";
    }
    if (bad == NULL) {
        const double *acc = acc_b.buf, *gyro = gyro_b.buf, *dt = dt_b.buf, *bias = bias_b.buf;
        const double *bRs = bRs_b.buf, *coef = coef_b.buf;
        const int64_t *st = starts_b.buf;
        double *scr = scratch_b.buf, *out = out_b.buf;
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t w = 0; w < nw; w++) {
            Py_ssize_t s0 = (Py_ssize_t)st[w], e = w + 1 < nw ? (Py_ssize_t)st[w + 1] : n;
            sums(acc + 3 * s0, gyro + 3 * s0, dt + s0, e - s0, bias + 6 * w, rotate, bRs, coef, K,
                 small2, scr, out + N_OUT * w);
        }
        Py_END_ALLOW_THREADS
    }
    for (int b = 0; b < 9; b++) PyBuffer_Release((Py_buffer *)all[b]);
    if (bad != NULL) {
        PyErr_SetString(PyExc_ValueError, bad);
        return NULL;
    }
    Py_RETURN_NONE;
}

/* ----------------------------------------------------------------------------------------------
 * combined_integrate: GTSAM's PreintegratedCombinedMeasurements (tangent preintegration, 15x15
 * covariance) as one sequential loop. Mirrors GTSAM 4.3 TangentPreintegration::update /
 * UpdatePreintegrated and PreintegratedCombinedMeasurements::integrateMeasurement (the theta
 * recursion theta += Jr(theta)^-1 w dt is nonlinear, so it stays sequential). Per sample, with
 * A = I + dt d(Jr^-1 w)/dtheta, C = Jr^-1 dt, M = R [-a]x Jr dt, Bv = R dt, h = dt/2:
 *   theta' = A theta + C b_g + nu,   X = M theta + Bv b_a + eta,   v' = v + X,
 *   p' = p + dt v + h X + iota,      b_a' = b_a + w_a,             b_g' = b_g + w_g
 * (GTSAM's F: its p row is h times its v row plus dt v, and the acc noise enters p as h times v).
 * The covariance is propagated in 3x3 blocks that use this structure: Cov(theta, b_a) = 0 and
 * Cov(b_a, b_g) = 0 stay zero, Cov(b_a, b_a) = T Q_ba and Cov(b_g, b_g) = T Q_bg are closed form,
 * and p, v are integrators, so F P F^T is about 30 3x3 products instead of ~6,750 multiply-adds
 * (the Python loop in combined.py is the dense reference this loop is tested against). Noise per
 * sample as GTSAM: Cov(nu) = Jr^-1 wCov Jr^-T dt, Cov(eta) = R aCov R^T dt (it enters p as h eta),
 * Cov(iota) = iCov dt, Cov(w_a) = Q_ba dt, Cov(w_g) = Q_bg dt. Output layout (doubles):
 *   0..8 preintegrated (theta, p, v), 9 T, 10..234 cov (15x15, (theta, p, v, b_a, b_g)),
 *   235..261 H_biasAcc (9x3), 262..288 H_biasOmega (9x3).
 * Covariances `cv`: acc, gyro, int, bias_acc, bias_omega (3x3 each, row-major; 45 doubles).
 */
#define C_OUT 289
#define C_COV 45

/* 3x3 blocks as three rows of a 4-lane vector (lane 3 unused, kept 0): a product L R is three
   broadcast-multiply-adds per row, which the compiler maps to SIMD (2 SSE2 or 1 AVX op a row). */
#if (defined(__GNUC__) || defined(__clang__)) && !defined(LIEBRIDGE_PORTABLE_VEC)
#pragma GCC diagnostic ignored "-Wpsabi" /* the vector helpers are always inlined: no ABI */
typedef double vec __attribute__((vector_size(32)));
#define VX(a, i) ((a)[i])
#define INLINE static inline __attribute__((always_inline))
INLINE vec vmk(double a, double b, double c) {
    vec r = {a, b, c, 0.0};
    return r;
}
#define VADD(a, b) ((a) + (b))
#define VSUB(a, b) ((a) - (b))
#define VSCALE(s, a) ((s) * (a))
#else
typedef struct { double x[4]; } vec;
#define VX(a, i) ((a).x[i])
#if defined(_MSC_VER)
#define INLINE static __forceinline
#else
#define INLINE static inline
#endif
static inline vec vmk(double a, double b, double c) { vec r = {{a, b, c, 0.0}}; return r; }
static inline vec vadd_(vec a, vec b) { for (int i = 0; i < 4; i++) a.x[i] += b.x[i]; return a; }
static inline vec vsub_(vec a, vec b) { for (int i = 0; i < 4; i++) a.x[i] -= b.x[i]; return a; }
static inline vec vscale_(double s, vec a) { for (int i = 0; i < 4; i++) a.x[i] *= s; return a; }
#define VADD(a, b) vadd_((a), (b))
#define VSUB(a, b) vsub_((a), (b))
#define VSCALE(s, a) vscale_((s), (a))
#endif

typedef struct { vec r[3]; } m3x;

INLINE m3x mz(void) {
    m3x o;
    for (int i = 0; i < 3; i++) o.r[i] = vmk(0.0, 0.0, 0.0);
    return o;
}
INLINE m3x mload(const double *a) { /* row-major 3x3 */
    m3x o;
    for (int i = 0; i < 3; i++) o.r[i] = vmk(a[3 * i], a[3 * i + 1], a[3 * i + 2]);
    return o;
}
INLINE void mstore(m3x a, double *o) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) o[3 * i + j] = VX(a.r[i], j);
}
/* L R */
INLINE m3x mm(m3x L, m3x R) {
    m3x o;
    for (int i = 0; i < 3; i++)
        o.r[i] = VADD(VADD(VSCALE(VX(L.r[i], 0), R.r[0]), VSCALE(VX(L.r[i], 1), R.r[1])),
                      VSCALE(VX(L.r[i], 2), R.r[2]));
    return o;
}
/* O + L R */
INLINE m3x mma(m3x O, m3x L, m3x R) {
    for (int i = 0; i < 3; i++)
        O.r[i] = VADD(O.r[i], VADD(VADD(VSCALE(VX(L.r[i], 0), R.r[0]), VSCALE(VX(L.r[i], 1), R.r[1])),
                                   VSCALE(VX(L.r[i], 2), R.r[2])));
    return O;
}
INLINE m3x mt(m3x a) {
    m3x o;
    for (int i = 0; i < 3; i++) o.r[i] = vmk(VX(a.r[0], i), VX(a.r[1], i), VX(a.r[2], i));
    return o;
}
/* [x]x: rows (0, -z, y), (z, 0, -x), (-y, x, 0) */
INLINE m3x skew(double x, double y, double z) {
    m3x o;
    o.r[0] = vmk(0.0, -z, y);
    o.r[1] = vmk(z, 0.0, -x);
    o.r[2] = vmk(-y, x, 0.0);
    return o;
}
INLINE m3x madd(m3x a, m3x b) {
    for (int i = 0; i < 3; i++) a.r[i] = VADD(a.r[i], b.r[i]);
    return a;
}
INLINE m3x mscale(double s, m3x a) {
    for (int i = 0; i < 3; i++) a.r[i] = VSCALE(s, a.r[i]);
    return a;
}

/* The loop. Block names: P<row><col> = Cov(row, col) of the state before the sample, rows/cols
   t = theta, g = b_g, a = b_a, p, v; Cov(a, a) = T Qa and Cov(g, g) = T Qg are not stored. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__GLIBC__) \
    && !defined(LIEBRIDGE_NO_CLONES)
/* one build for every x86-64 CPU: a clone for AVX2 CPUs is picked at load time (an ifunc, hence
   glibc). GCC >= 12: the x86-64-v3 level (AVX2 + FMA, ~100 ns a sample on the benchmark VM);
   older GCC (manylinux2014's GCC 10): AVX2 without FMA (~120 ns); the baseline clone ~600 ns. */
#if __GNUC__ >= 12
__attribute__((target_clones("arch=x86-64-v3", "default")))
#elif __GNUC__ >= 6
__attribute__((target_clones("avx2", "default")))
#endif
#endif
static void combined_loop(const double *acc, const double *gyro, const double *dt, Py_ssize_t n,
                          const double *bias, const double *cv, double *out) {
    const m3x aCov = mload(cv), wCov = mload(cv + 9), iCov = mload(cv + 18), Qa = mload(cv + 27),
              Qg = mload(cv + 36);
    double th[3] = {0.0, 0.0, 0.0}, T = 0.0;
    vec p = vmk(0.0, 0.0, 0.0), v = vmk(0.0, 0.0, 0.0);
    m3x Ptt = mz(), Ptg = mz(), Pgt = mz(), Ptv = mz(), Ptp = mz(), Pgv = mz(), Pgp = mz();
    m3x Pav = mz(), Pap = mz(), Pvv = mz(), Ppv = mz(), Ppp = mz();
    m3x Hav = mz(), Hap = mz(), Hgt = mz(), Hgp = mz(), Hgv = mz();
    for (Py_ssize_t k = 0; k < n; k++) {
        const double d = dt[k], h = 0.5 * d;
        double a[3], w[3];
        for (int i = 0; i < 3; i++) {
            a[i] = acc[3 * k + i] - bias[i];
            w[i] = gyro[3 * k + i] - bias[3 + i];
        }
        /* Exp(th) = I + A1 W + B W^2, Jl = R Jr = I + B W + C W^2, Jr^-1 = I + W/2 + D W^2;
           dB, dC are B'/t, C'/t (the same branches as the Python reference) */
        double t2 = th[0] * th[0] + th[1] * th[1] + th[2] * th[2];
        double A1, B, C, dB, dC, D;
        if (t2 < 1e-4) {
            double t4 = t2 * t2, t6 = t4 * t2;
            A1 = 1.0 - t2 / 6.0 + t4 / 120.0 - t6 / 5040.0;
            B = 0.5 - t2 / 24.0 + t4 / 720.0 - t6 / 40320.0;
            C = 1.0 / 6.0 - t2 / 120.0 + t4 / 5040.0 - t6 / 362880.0;
            dB = -1.0 / 12.0 + t2 / 180.0 - t4 / 6720.0;
            dC = -1.0 / 60.0 + t2 / 1260.0 - t4 / 60480.0;
            D = 1.0 / 12.0 + t2 / 720.0 + t4 / 30240.0 + t6 / 1209600.0;
        } else {
            double t = sqrt(t2), it = 1.0 / t, it2 = it * it, st = sin(t), ct = cos(t);
            double omc = 1.0 - ct;
            A1 = st * it;
            B = omc * it2;
            C = (t - st) * it2 * it;
            dB = (t * st - 2.0 * omc) * it2 * it2;
            dC = (omc - 3.0 * C * t2) * it2 * it2;
            D = (1.0 - 0.5 * A1 / B) * it2;
        }
        /* rows of W = [th]x, W^2 = th th^T - t2 I and I; transposes from W^T = -W */
        const vec thv = vmk(th[0], th[1], th[2]);
        const m3x Wm = skew(th[0], th[1], th[2]);
        m3x R, RT, Jl, Jr, iJm, iJT;
        for (int i = 0; i < 3; i++) {
            vec I = vmk(i == 0, i == 1, i == 2), W2 = VSUB(VSCALE(th[i], thv), VSCALE(t2, I));
            vec Wi = Wm.r[i];
            R.r[i] = VADD(I, VADD(VSCALE(A1, Wi), VSCALE(B, W2)));
            RT.r[i] = VADD(I, VSUB(VSCALE(B, W2), VSCALE(A1, Wi)));
            Jl.r[i] = VADD(I, VADD(VSCALE(B, Wi), VSCALE(C, W2))); /* = R Jr = Jr^T */
            Jr.r[i] = VADD(I, VSUB(VSCALE(C, W2), VSCALE(B, Wi)));
            iJm.r[i] = VADD(I, VADD(VSCALE(0.5, Wi), VSCALE(D, W2)));
            iJT.r[i] = VADD(I, VSUB(VSCALE(D, W2), VSCALE(0.5, Wi)));
        }
        /* c = Jr^-1 w, an = R a: combinations of the rows of the transposes */
        const vec cv3 = VADD(VADD(VSCALE(w[0], iJT.r[0]), VSCALE(w[1], iJT.r[1])), VSCALE(w[2], iJT.r[2]));
        const vec anv = VADD(VADD(VSCALE(a[0], RT.r[0]), VSCALE(a[1], RT.r[1])), VSCALE(a[2], RT.r[2]));
        const double c[3] = {VX(cv3, 0), VX(cv3, 1), VX(cv3, 2)};
        const double an[3] = {VX(anv, 0), VX(anv, 1), VX(anv, 2)};
        /* H = d(Jr(th) c)/dth = B [c]x + u th^T + C((th.c) I + th c^T - 2 c th^T) with
           u = dB (c x th) + dC th x (th x c); with Jr^-1 th = th, A = I - dt Jr^-1 H where
           Jr^-1 H = B Jr^-1 [c]x + C (th.c) Jr^-1 + C th c^T + f th^T, f = Jr^-1 (u - 2 C c) */
        const double tc = th[0] * c[0] + th[1] * c[1] + th[2] * c[2];
        double e[3] = {dB * (c[1] * th[2] - c[2] * th[1]), dB * (c[2] * th[0] - c[0] * th[2]),
                       dB * (c[0] * th[1] - c[1] * th[0])};
        for (int i = 0; i < 3; i++) e[i] += dC * (th[i] * tc - c[i] * t2) - 2.0 * C * c[i];
        const vec fv = VADD(VADD(VSCALE(e[0], iJT.r[0]), VSCALE(e[1], iJT.r[1])), VSCALE(e[2], iJT.r[2]));
        const m3x Kc = skew(c[0], c[1], c[2]), Ka = skew(an[0], an[1], an[2]);
        const m3x iJKc = mm(iJm, Kc), KciJT = mm(Kc, iJT);
        const double Ctc = C * tc;
        m3x A, AT;
        for (int i = 0; i < 3; i++) {
            vec I = vmk(i == 0, i == 1, i == 2);
            /* row i of Jr^-1 H and of its transpose (B [c]x^T Jr^-T = -B [c]x Jr^-T) */
            vec wh = VADD(VADD(VSCALE(B, iJKc.r[i]), VSCALE(Ctc, iJm.r[i])),
                          VADD(VSCALE(C * th[i], cv3), VSCALE(VX(fv, i), thv)));
            vec wht = VADD(VSUB(VSCALE(Ctc, iJT.r[i]), VSCALE(B, KciJT.r[i])),
                           VADD(VSCALE(C * c[i], thv), VSCALE(th[i], fv)));
            A.r[i] = VSUB(I, VSCALE(d, wh));
            AT.r[i] = VSUB(I, VSCALE(d, wht));
        }
        /* M = R [-a]x Jr dt = -dt [R a]x Jl, M^T = dt Jr [R a]x */
        const m3x M = mscale(-d, mm(Ka, Jl)), MT = mscale(d, mm(Jr, Ka));
        const m3x Cm = mscale(d, iJm), CT = mscale(d, iJT), Bv = mscale(d, R), BvT = mscale(d, RT);
        /* bias Jacobians (old values on the right); H_biasAcc's theta rows stay 0 */
        {
            m3x MHg = mm(M, Hgt);
            Hgt = mm(A, Hgt);
            for (int i = 0; i < 3; i++) {
                Hap.r[i] = VADD(Hap.r[i], VSUB(VSCALE(d, Hav.r[i]), VSCALE(h, Bv.r[i])));
                Hav.r[i] = VSUB(Hav.r[i], Bv.r[i]);
                Hgp.r[i] = VADD(Hgp.r[i], VADD(VSCALE(d, Hgv.r[i]), VSCALE(h, MHg.r[i])));
                Hgv.r[i] = VADD(Hgv.r[i], MHg.r[i]);
                Hgt.r[i] = VSUB(Hgt.r[i], Cm.r[i]);
            }
        }
        /* covariance */
        const m3x TQg = mscale(T, Qg);
        const m3x Z = mma(mm(A, Ptt), Cm, Pgt);       /* A Ptt + C Pgt */
        const m3x Wn = mma(mm(A, Ptg), Cm, TQg);      /* Cov(theta', b_g') */
        const m3x Yv = mma(mm(A, Ptv), Cm, Pgv);
        const m3x Yp = mma(mm(A, Ptp), Cm, Pgp);
        const m3x Xt = mm(M, Ptt);                    /* Cov(X, theta) */
        const m3x XgT = mm(Pgt, MT);                  /* Cov(b_g, X) */
        const m3x Xv = mma(mm(M, Ptv), Bv, Pav);      /* Cov(X, v) */
        const m3x Xp = mma(mm(M, Ptp), Bv, Pap);      /* Cov(X, p) */
        const m3x XaT = mm(mscale(T, Qa), BvT);       /* Cov(b_a, X) */
        const m3x ZM = mm(Z, MT);                     /* Cov(theta', X) */
        /* XX = M Ptt M^T + dt R (T dt Qa + aCov) R^T */
        const m3x Q1 = mscale(d, madd(aCov, mscale(T * d, Qa)));
        const m3x XX = mma(mm(Xt, MT), mm(R, Q1), RT);
        /* Ptt' = Z A^T + W C^T + dt Jr^-1 wCov Jr^-T */
        Ptt = mma(mma(mm(Z, AT), Wn, CT), mm(Cm, wCov), iJT);
        Ptg = Wn;
        Pgt = mt(Wn);
        const m3x XvT = mt(Xv), XpT = mt(Xp), PpvT = mt(Ppv);
        for (int i = 0; i < 3; i++) {
            vec xv = Xv.r[i], xvt = XvT.r[i], xp = Xp.r[i], xpt = XpT.r[i], xx = XX.r[i];
            vec pvv = Pvv.r[i], ppv = Ppv.r[i];
            Ppp.r[i] = VADD(Ppp.r[i],
                            VADD(VADD(VSCALE(d, VADD(ppv, PpvT.r[i])), VSCALE(d * d, pvv)),
                                 VADD(VADD(VSCALE(h, VADD(xpt, xp)), VSCALE(h * d, VADD(xvt, xv))),
                                      VADD(VSCALE(h * h, xx), VSCALE(d, iCov.r[i])))));
            Ppv.r[i] = VADD(VADD(ppv, xpt), VADD(VSCALE(d, VADD(pvv, xvt)), VSCALE(h, VADD(xv, xx))));
            Pvv.r[i] = VADD(pvv, VADD(VADD(xvt, xv), xx));
            Ptv.r[i] = VADD(Yv.r[i], ZM.r[i]);
            Ptp.r[i] = VADD(Yp.r[i], VADD(VSCALE(d, Yv.r[i]), VSCALE(h, ZM.r[i])));
            Pgp.r[i] = VADD(Pgp.r[i], VADD(VSCALE(d, Pgv.r[i]), VSCALE(h, XgT.r[i])));
            Pgv.r[i] = VADD(Pgv.r[i], XgT.r[i]);
            Pap.r[i] = VADD(Pap.r[i], VADD(VSCALE(d, Pav.r[i]), VSCALE(h, XaT.r[i])));
            Pav.r[i] = VADD(Pav.r[i], XaT.r[i]);
        }
        /* state: theta += Jr^-1 w dt, p += v dt + R a dt^2/2, v += R a dt */
        p = VADD(p, VADD(VSCALE(d, v), VSCALE(h * d, anv)));
        v = VADD(v, VSCALE(d, anv));
        for (int i = 0; i < 3; i++) th[i] += c[i] * d;
        T += d;
    }
    for (int i = 0; i < 3; i++) {
        out[i] = th[i];
        out[3 + i] = VX(p, i);
        out[6 + i] = VX(v, i);
    }
    out[9] = T;
    double *S = out + 10;
    for (int i = 0; i < 225; i++) S[i] = 0.0;
    /* the 15x15 in (theta, p, v, b_a, b_g): block (r, c) and its transpose (c, r) */
    const m3x blocks[13] = {Ptt, Ptp, Ptv, Ptg, Ppp, Ppv, mt(Pap), mt(Pgp), Pvv, mt(Pav), mt(Pgv),
                            mscale(T, Qa), mscale(T, Qg)};
    const int where[13][2] = {{0, 0}, {0, 1}, {0, 2}, {0, 4}, {1, 1}, {1, 2}, {1, 3}, {1, 4},
                              {2, 2}, {2, 3}, {2, 4}, {3, 3}, {4, 4}};
    for (int b = 0; b < 13; b++)
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                double x = VX(blocks[b].r[i], j);
                int r = 3 * where[b][0], cc = 3 * where[b][1];
                S[15 * (r + i) + cc + j] = x;
                S[15 * (cc + j) + r + i] = x;
            }
    /* bias Jacobians, rows (theta, p, v): H_biasAcc's theta rows are 0 */
    for (int i = 0; i < 9; i++) out[235 + i] = 0.0;
    mstore(Hap, out + 235 + 9);
    mstore(Hav, out + 235 + 18);
    mstore(Hgt, out + 262);
    mstore(Hgp, out + 262 + 9);
    mstore(Hgv, out + 262 + 18);
}

static PyObject *combined_integrate(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer acc_b, gyro_b, dt_b, bias_b, cov_b, out_b;
    if (!PyArg_ParseTuple(args, "y*y*y*y*y*w*", &acc_b, &gyro_b, &dt_b, &bias_b, &cov_b, &out_b))
        return NULL;
    Py_ssize_t n = dt_b.len / (Py_ssize_t)sizeof(double);
    const char *bad = NULL;
    const Py_buffer *all[6] = {&acc_b, &gyro_b, &dt_b, &bias_b, &cov_b, &out_b};
    int misaligned = 0;
    for (int b = 0; b < 6; b++) misaligned |= (uintptr_t)all[b]->buf % _Alignof(double) != 0;
    if (misaligned) bad = "a buffer is not aligned to a double boundary (pass aligned float64)";
    else if (n < 1 || dt_b.len % (Py_ssize_t)sizeof(double) != 0) bad = "dt: no samples";
    else if (acc_b.len != 3 * dt_b.len || gyro_b.len != 3 * dt_b.len) bad = "acc/gyro: not (n, 3)";
    else if (bias_b.len != 6 * (Py_ssize_t)sizeof(double)) bad = "bias: not 6 doubles";
    else if (cov_b.len != C_COV * (Py_ssize_t)sizeof(double)) bad = "cov: not 45 doubles";
    else if (out_b.len != C_OUT * (Py_ssize_t)sizeof(double)) bad = "out: wrong size";
    if (bad == NULL) {
        const double *acc = acc_b.buf, *gyro = gyro_b.buf, *dt = dt_b.buf, *bias = bias_b.buf;
        const double *cv = cov_b.buf;
        double *out = out_b.buf;
        Py_BEGIN_ALLOW_THREADS
        combined_loop(acc, gyro, dt, n, bias, cv, out);
        Py_END_ALLOW_THREADS
    }
    for (int b = 0; b < 6; b++) PyBuffer_Release((Py_buffer *)all[b]);
    if (bad != NULL) {
        PyErr_SetString(PyExc_ValueError, bad);
        return NULL;
    }
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"block_sums", block_sums, METH_VARARGS,
     "block_sums(acc, gyro, dt, bias, rotate, bRs, coef, K, small2, scratch, out) -> None\n\n"
     "Per-sample sums of one block of IMU samples (see liebridge/factors/_imu_kernel.py)."},
    {"window_sums", window_sums, METH_VARARGS,
     "window_sums(acc, gyro, dt, starts, bias, rotate, bRs, coef, K, small2, scratch, out) -> None\n\n"
     "block_sums of every window [starts[w], starts[w+1]) of one sequence, one row of out each."},
    {"combined_integrate", combined_integrate, METH_VARARGS,
     "combined_integrate(acc, gyro, dt, bias, cov, out) -> None\n\n"
     "GTSAM's PreintegratedCombinedMeasurements (tangent) over all samples; layout above."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_imu_ext",
    "Optional compiled per-sample sums of IMU preintegration (see _imu_kernel.py).", -1, methods,
    NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__imu_ext(void) { return PyModule_Create(&module); }
