/*
 * Optional compiled batched SO(3)/SE(3) kernels of liebridge.lie: exp, log and the adjoint in one
 * validate-and-compute pass over the batch.
 *
 * The formulas are those of liebridge/lie/so3.py (_poly_into, _log) and se3.py (_exp_block,
 * _log_block, _adjoint), entry by entry, with the coefficient functions of series.py: the closed
 * forms above SMALL_ANGLE and the same Maclaurin series (their coefficients are passed in) below.
 * exp and log run in chunks of 256 elements, structure of arrays, with sin/cos/atan from the
 * fdlibm kernels and the arithmetic vectorized (see "Chunked structure-of-arrays passes" below);
 * the adjoint is one scalar loop. tests/test_lie_compiled.py compares every output with the numpy
 * kernels.
 *
 *   op 0  so3.exp      w (..., 3)      -> R (..., 3, 3)
 *   op 1  so3.log      R (..., 3, 3)   -> w (..., 3)
 *   op 2  se3.exp      xi (..., 6)     -> T (..., 4, 4)
 *   op 3  se3.log      T (..., 4, 4)   -> xi (..., 6)
 *   op 4  se3.adjoint  T (..., 4, 4)   -> Ad (..., 6, 6)
 *
 * Validation is the certificate liebridge/_validate.py runs first (it can only accept valid
 * input): a tangent is finite with every rotation component at most max_component (so its norm
 * is at most MAX_ANGLE); a rotation has ||R^T R - I||_F <= tol and det R > 0; a pose also its
 * bottom row exactly (0, 0, 0, 1) and a finite translation; the output is finite. An element
 * that is not certified stops the pass (chunks are certified in order; within a chunk the input
 * before the output) and its flat index is returned: the caller then
 * runs the numpy path, which accepts it or raises the error naming the argument, the batch index
 * and the size of the violation.
 *
 * kernel(op, x, out, coef, small_angle, tol, max_component) -> int: x and out C-contiguous,
 * aligned float64 buffers with shapes (numpy arrays), coef the 4 x 9 series coefficients (sinc,
 * (1 - cos)/t^2, (t - sin)/t^3, the J^-1 coefficient D). Returns -1 done, -2 not handled (dtype,
 * layout, shapes: the caller uses numpy), k >= 0 the first element not certified.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <float.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif
#include <math.h>
#include <stdint.h>
#include <string.h>

#define NS 9 /* terms of each series */
#if defined(__GNUC__) || defined(__clang__)
#define INLINE static inline __attribute__((always_inline))
#elif defined(_MSC_VER)
#define INLINE static __forceinline
#define restrict __restrict
#else
#define INLINE static inline
#endif

typedef struct {
    double c[4][NS];
    double small;
} Coef;

/* horner unrolled (the vectorized passes below: no inner loop) */
#define HORNER9(c, t2)                                                                             \
    ((((((((((c)[8] * (t2) + (c)[7]) * (t2) + (c)[6]) * (t2) + (c)[5]) * (t2) + (c)[4]) * (t2) +  \
          (c)[3]) *                                                                                \
             (t2) +                                                                                \
         (c)[2]) *                                                                                 \
            (t2) +                                                                                 \
        (c)[1]) *                                                                                  \
           (t2) +                                                                                  \
       (c)[0]))
static inline double horner(const double *c, double t2) {
    double acc = c[NS - 1];
    for (int k = NS - 2; k >= 0; k--) acc = acc * t2 + c[k];
    return acc;
}

/* series.py: sinc, one_minus_cos_over_t2, t_minus_sin_over_t3, jinv_coeff (the closed forms as
   there; exp_coefs evaluates A, B, C from one sin/cos pair of the half angle, sin t = 2 sh ch) */
static inline void exp_coefs(const Coef *C, double t, double *A, double *B, double *Cc) {
    if (t < C->small) {
        double t2 = t * t;
        *A = horner(C->c[0], t2);
        *B = horner(C->c[1], t2);
        if (Cc) *Cc = horner(C->c[2], t2);
        return;
    }
    double h = 0.5 * t, sh = sin(h), ch = cos(h); /* one sincos */
    double it = 1.0 / t, st = 2.0 * sh * ch, q = sh * it;
    *A = st * it;
    *B = 2.0 * (q * q);
    if (Cc) *Cc = (t - st) * (it * it * it);
}
/* D(t) = 1/t^2 - cot(t/2)/(2t) with cot(t/2) given (see so3_log: from R, no trig call) */
static inline double coef_D(const Coef *C, double t, double cot_half) {
    if (t < C->small) return horner(C->c[3], t * t);
    return 1.0 / (t * t) - cot_half / (2.0 * t);
}
/* ||R^T R - I||_F <= tol and det R > 0 (R with row stride s) */
static inline int rotation_ok(const double *R, int s, double tol) {
    double r00 = R[0], r01 = R[1], r02 = R[2];
    double r10 = R[s], r11 = R[s + 1], r12 = R[s + 2];
    double r20 = R[2 * s], r21 = R[2 * s + 1], r22 = R[2 * s + 2];
    double e0 = r00 * r00 + r10 * r10 + r20 * r20 - 1.0;
    double e1 = r01 * r01 + r11 * r11 + r21 * r21 - 1.0;
    double e2 = r02 * r02 + r12 * r12 + r22 * r22 - 1.0;
    double e3 = r00 * r01 + r10 * r11 + r20 * r21;
    double e4 = r00 * r02 + r10 * r12 + r20 * r22;
    double e5 = r01 * r02 + r11 * r12 + r21 * r22;
    if (!(e0 * e0 + e1 * e1 + e2 * e2 + 2.0 * (e3 * e3 + e4 * e4 + e5 * e5) <= tol * tol))
        return 0;
    double det = r00 * (r11 * r22 - r12 * r21) - r01 * (r10 * r22 - r12 * r20) +
                 r02 * (r10 * r21 - r11 * r20);
    return det > 0.0;
}

static inline int pose_ok(const double *X, double tol) {
    if (X[12] != 0.0 || X[13] != 0.0 || X[14] != 0.0 || X[15] != 1.0) return 0;
    if (!isfinite(X[3] + X[7] + X[11])) return 0;
    return rotation_ok(X, 4, tol);
}

static inline int finite_n(const double *a, int len) {
    double s[4] = {0.0, 0.0, 0.0, 0.0};
    int i = 0;
    for (; i + 4 <= len; i += 4)
        for (int j = 0; j < 4; j++) s[j] += a[i + j] - a[i + j];
    for (; i < len; i++) s[0] += a[i] - a[i];
    return (s[0] + s[1]) + (s[2] + s[3]) == 0.0;
}

/* I + a hat(w) + b hat(w)^2 into R (row stride s): so3._poly_into */
static inline void poly(const double *w, double a, double b, double *R, int s) {
    double w0 = w[0], w1 = w[1], w2 = w[2];
    double aw0 = a * w0, aw1 = a * w1, aw2 = a * w2;
    double bw0 = b * w0, bw1 = b * w1;
    double p01 = bw0 * w1, p02 = bw0 * w2, p12 = bw1 * w2;
    double s0 = w0 * w0, s1 = w1 * w1, s2 = w2 * w2;
    R[0] = 1.0 - b * (s1 + s2);
    R[s + 1] = 1.0 - b * (s0 + s2);
    R[2 * s + 2] = 1.0 - b * (s0 + s1);
    R[1] = p01 - aw2;
    R[s] = p01 + aw2;
    R[2] = p02 + aw1;
    R[2 * s] = p02 - aw1;
    R[s + 2] = p12 - aw0;
    R[2 * s + 1] = p12 + aw0;
}

/* so3._log of R (row stride s) into w; *cot_half = cot(theta/2) from y = |vee(R - R^T)/2|,
   c = (tr R - 1)/2 and r = hypot(y, c) (cos theta = c/r, sin theta = y/r): (r + c)/y for c >= 0,
   y/(r - c) otherwise, sums of two non-negative terms (no cancellation); 0 at theta = pi. */
static inline void so3_log(const Coef *C, const double *R, int s, double *w, double *cot_half) {
    double r00 = R[0], r01 = R[1], r02 = R[2];
    double r10 = R[s], r11 = R[s + 1], r12 = R[s + 2];
    double r20 = R[2 * s], r21 = R[2 * s + 1], r22 = R[2 * s + 2];
    double s0 = 0.5 * (r21 - r12), s1 = 0.5 * (r02 - r20), s2 = 0.5 * (r10 - r01);
    double c = 0.5 * (r00 + r11 + r22 - 1.0);
    double y = sqrt(s0 * s0 + s1 * s1 + s2 * s2);
    double theta = atan2(y, c);
    if (cot_half) {
        double r = sqrt(y * y + c * c);
        *cot_half = c >= 0.0 ? (r + c) / y : y / (r - c);
    }
    if (!(c < -0.5)) { /* generic and small angles: w = theta / sin(theta) s */
        /* sin(atan2(y, c)) = y / hypot(y, c): no second transcendental call (cos theta >= -1/2) */
        double k = theta < C->small ? 1.0 / horner(C->c[0], theta * theta)
                                    : theta * sqrt(y * y + c * c) / y;
        w[0] = s0 * k;
        w[1] = s1 * k;
        w[2] = s2 * k;
        return;
    }
    /* the axis from the symmetric part: its column with the largest diagonal entry */
    double d0 = r00 - c, d1 = r11 - c, d2 = r22 - c;
    double s01 = 0.5 * (r01 + r10), s02 = 0.5 * (r02 + r20), s12 = 0.5 * (r12 + r21);
    int k0 = d0 >= d1 && d0 >= d2;
    int k1 = !k0 && d1 >= d2;
    double u0 = k0 ? d0 : (k1 ? s01 : s02);
    double u1 = k0 ? s01 : (k1 ? d1 : s12);
    double u2 = k0 ? s02 : (k1 ? s12 : d2);
    double norm = sqrt(u0 * u0 + u1 * u1 + u2 * u2);
    double dot = u0 * s0 + u1 * s1 + u2 * s2;
    double scale = (dot < 0.0 ? -theta : theta) / norm;
    w[0] = scale * u0;
    w[1] = scale * u1;
    w[2] = scale * u2;
}

/* se3.log's output from the rotation vector w, D = coef_D(theta) and the translation of X
 * (row-major 4x4): (w, t - w x t / 2 + D w x (w x t)) */
static inline void se3_log_out(double w0, double w1, double w2, double D, const double *X,
                               double *o) {
    double t0 = X[3], t1 = X[7], t2 = X[11];
    double c0 = w1 * t2 - w2 * t1, c1 = w2 * t0 - w0 * t2, c2 = w0 * t1 - w1 * t0;
    o[0] = w0;
    o[1] = w1;
    o[2] = w2;
    o[3] = t0 - 0.5 * c0 + D * (w1 * c2 - w2 * c1);
    o[4] = t1 - 0.5 * c1 + D * (w2 * c0 - w0 * c2);
    o[5] = t2 - 0.5 * c2 + D * (w0 * c1 - w1 * c0);
}

static inline int tangent_ok(const double *x, int n, double maxc) {
    for (int i = 0; i < n; i++)
        if (!isfinite(x[i])) return 0;
    return fabs(x[0]) <= maxc && fabs(x[1]) <= maxc && fabs(x[2]) <= maxc;
}

INLINE Py_ssize_t run_op(int op, const Coef *C, const double *x, double *out, Py_ssize_t N,
                         double tol, double maxc) {
    static const int in_size[5] = {3, 9, 6, 16, 16}, out_size[5] = {9, 3, 16, 6, 36};
    const int is = in_size[op], os = out_size[op];
    for (Py_ssize_t e = 0; e < N; e++, x += is, out += os) {
        if (op == 0) {
            if (!tangent_ok(x, 3, maxc)) return e;
            double t = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]), A, B;
            exp_coefs(C, t, &A, &B, NULL);
            poly(x, A, B, out, 3);
        } else if (op == 1) {
            if (!rotation_ok(x, 3, tol)) return e;
            so3_log(C, x, 3, out, NULL);
        } else if (op == 2) { /* se3._exp_block */
            if (!tangent_ok(x, 6, maxc)) return e;
            double w0 = x[0], w1 = x[1], w2 = x[2], v0 = x[3], v1 = x[4], v2 = x[5];
            double t = sqrt(w0 * w0 + w1 * w1 + w2 * w2);
            double A, B, Cc;
            exp_coefs(C, t, &A, &B, &Cc);
            poly(x, A, B, out, 4);
            double Bw0 = B * w0, Bw1 = B * w1, Bw2 = B * w2;
            double Cd = Cc * (w0 * v0 + w1 * v1 + w2 * v2);
            out[3] = A * v0 + (Bw1 * v2 - Bw2 * v1) + Cd * w0;
            out[7] = A * v1 + (Bw2 * v0 - Bw0 * v2) + Cd * w1;
            out[11] = A * v2 + (Bw0 * v1 - Bw1 * v0) + Cd * w2;
            out[12] = out[13] = out[14] = 0.0;
            out[15] = 1.0;
        } else if (op == 3) { /* se3._log_block */
            if (!pose_ok(x, tol)) return e;
            double w[3];
            double cot_half;
            so3_log(C, x, 4, w, &cot_half);
            double D = coef_D(C, sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]), cot_half);
            se3_log_out(w[0], w[1], w[2], D, x, out);
        } else { /* se3._adjoint: [[R, 0], [hat(t) R, R]] */
            if (!pose_ok(x, tol)) return e;
            double t0 = x[3], t1 = x[7], t2 = x[11];
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 3; c++) {
                    double v = x[4 * r + c];
                    out[6 * r + c] = v;
                    out[6 * r + 3 + c] = 0.0;
                    out[6 * (r + 3) + 3 + c] = v;
                }
            for (int c = 0; c < 3; c++) { /* column c of hat(t) R is t x R[:, c] */
                double v0 = x[c], v1 = x[4 + c], v2 = x[8 + c];
                out[18 + c] = t1 * v2 - t2 * v1;
                out[24 + c] = t2 * v0 - t0 * v2;
                out[30 + c] = t0 * v1 - t1 * v0;
            }
        }
        /* so3.exp/log: finite by construction from certified input (|R_ij| <= 1, |w| <= pi) */
        if (op != 0 && op != 1 && !finite_n(out, os)) return e;
    }
    return -1;
}

/* ---------------------------------------------------------------------------------------------
 * Chunked structure-of-arrays passes (ops 0-3). Per chunk of CH elements: a scalar pass loads and
 * validates the elements into short arrays (L1-resident), a branch-free pass over those arrays
 * evaluates the square roots, divisions and the trigonometry (the compiler vectorizes it: SSE2,
 * and AVX2 where target_clones is available), the few elements outside that pass's range (the
 * series below SMALL_ANGLE, angles beyond FAST_MAX) are redone by the scalar code above, and a
 * last pass writes the output rows once, in order. The numbers are those of the scalar code
 * above except sin/cos/atan2, which come from the fdlibm kernels below instead of libm.
 * ------------------------------------------------------------------------------------------- */
#define CH 256
/* exp: angles up to FAST_MAX use the polynomial sin/cos of the half angle (|h| <= 5 pi / 4 after
   the reduction below); beyond it (tangents are validated up to 1e12) the libm sincos */
#define FAST_MAX 7.8

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) &&      \
    defined(__GLIBC__)
#define VEC_CLONES __attribute__((target_clones("default", "avx2")))
#else
#define VEC_CLONES
#endif
#if defined(__GNUC__) && !defined(__clang__)
/* For the chunk passes below only: sqrt needs no errno path (its arguments are sums of squares)
   and the selects may be evaluated on both sides (no FP traps are enabled): GCC vectorizes them.
   Neither changes a value (no -ffast-math; contraction and reassociation stay as they are). */
#pragma GCC push_options
#pragma GCC optimize("no-math-errno", "no-trapping-math")
#endif

/* in-place square roots of a[0..m) of non-negative numbers: SSE2 packed sqrt (a libm sqrt call
   keeps an errno path that stops the compiler vectorizing the loops that contain it) */
static void sqrt_arr(double *a, int m) {
    int i = 0;
#ifdef __SSE2__
    for (; i + 2 <= m; i += 2) _mm_storeu_pd(a + i, _mm_sqrt_pd(_mm_loadu_pd(a + i)));
#endif
    for (; i < m; i++) a[i] = sqrt(a[i]);
}

/* The polynomial coefficients and interval reductions below are those of fdlibm 5.3, whose
 * notice follows, as its terms require:
 *
 * ====================================================
 * Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
 *
 * Developed at SunSoft, a Sun Microsystems, Inc. business.
 * Permission to use, copy, modify, and distribute this
 * software is freely granted, provided that this notice
 * is preserved.
 * ====================================================
 */

/* fdlibm 5.3 k_sin.c / k_cos.c (FreeBSD msun, musl src/math/__sin.c, __cos.c): sin and cos of
   x + y, |x| <= pi/4, y the tail of the argument; error below 1 ulp. */
static const double S1 = -1.66666666666666324348e-01, S2 = 8.33333333332248946124e-03,
                    S3 = -1.98412698298579493134e-04, S4 = 2.75573137070700676789e-06,
                    S5 = -2.50507602534068634195e-08, S6 = 1.58969099521155010221e-10;
static const double C1 = 4.16666666666666019037e-02, C2 = -1.38888888888741095749e-03,
                    C3 = 2.48015872894767294178e-05, C4 = -2.75573143513906633035e-07,
                    C5 = 2.08757232129817482790e-09, C6 = -1.13596475577881948265e-11;
static const double PIO2_HI = 1.57079632679489655800e+00, PIO2_LO = 6.12323399573676603587e-17;
static const double PIO4 = 0.78539816339744830962, PIO4x3 = 2.35619449019234492885;

/* sin and cos of h in [0, 5 pi / 4]: n = round(h / (pi/2)) in {0, 1, 2}, r + y = h - n pi/2 with
   h - n PIO2_HI exact (Sterbenz) and the PIO2_LO part carried as the tail y (TwoSum) */
INLINE void sincos_poly(double h, double *s, double *c) {
    double n1 = h > PIO4 ? 1.0 : 0.0, n2 = h > PIO4x3 ? 1.0 : 0.0, n = n1 + n2;
    double a = h - n * PIO2_HI, b = -(n * PIO2_LO);
    double r = a + b, bb = r - a, y = (a - (r - bb)) + (b - bb);
    double z = r * r, w = z * z;
    double rs = S2 + z * (S3 + z * S4) + z * w * (S5 + z * S6), v = z * r;
    double sn = r - ((z * (0.5 * y - v * rs) - y) - v * S1);
    double rc = z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6));
    double hz = 0.5 * z, ww = 1.0 - hz;
    double cs = ww + (((1.0 - ww) - hz) + (z * rc - r * y));
    double so = n1 > 0.0 ? cs : sn, co = n1 > 0.0 ? -sn : cs;
    *s = n2 > 0.0 ? -sn : so;
    *c = n2 > 0.0 ? -cs : co;
}

/* fdlibm 5.3 s_atan.c (FreeBSD msun, musl src/math/atan.c) on the ratio y / x, x, y >= 0, with
   its argument reduction written on (y, x) so that one division remains; error below 1 ulp. */
static const double AT[11] = {
    3.33333333333329318027e-01,  -1.99999999998764832476e-01, 1.42857142725034663711e-01,
    -1.11111104054623557880e-01, 9.09088713343650656196e-02,  -7.69187620504482999495e-02,
    6.66107313738753120669e-02,  -5.83357013379057348645e-02, 4.97687799461593236017e-02,
    -3.65315727442169155270e-02, 1.62858201153657823623e-02};
static const double ATANHI[4] = {4.63647609000806093515e-01, 7.85398163397448278999e-01,
                                 9.82793723247329054082e-01, 1.57079632679489655800e+00};
static const double ATANLO[4] = {2.26987774529616870924e-17, 3.06161699786838301793e-17,
                                 1.39033110312309984516e-17, 6.12323399573676603587e-17};
static const double PI_HI = 3.14159265358979311600e+00, PI_LO = 1.22464679914735320717e-16;

/* atan2(y, c) for y >= 0 (theta in [0, pi]): atan(y / |c|) as fdlibm, then pi - it for c < 0 */
INLINE double atan2_poly(double y, double c) {
    double x = fabs(c);
    /* fdlibm's intervals of y/x: [0, 7/16), [7/16, 11/16), [11/16, 19/16), [19/16, 39/16), rest */
    /* fdlibm's intervals of y/x: [0, 7/16), [7/16, 11/16), [11/16, 19/16), [19/16, 39/16), rest;
       the arguments (2y - x)/(2x + y), (y - x)/(y + x), (y - 1.5x)/(x + 1.5y), -x/y are fdlibm's
       forms times x (one select per interval: the compiler vectorizes them) */
    double num = y, den = x, hi = 0.0, lo = 0.0, y16 = 16.0 * y;
    num = y16 >= 7.0 * x ? 2.0 * y - x : num;
    den = y16 >= 7.0 * x ? 2.0 * x + y : den;
    hi = y16 >= 7.0 * x ? ATANHI[0] : hi;
    lo = y16 >= 7.0 * x ? ATANLO[0] : lo;
    num = y16 >= 11.0 * x ? y - x : num;
    den = y16 >= 11.0 * x ? x + y : den;
    hi = y16 >= 11.0 * x ? ATANHI[1] : hi;
    lo = y16 >= 11.0 * x ? ATANLO[1] : lo;
    num = y16 >= 19.0 * x ? y - 1.5 * x : num;
    den = y16 >= 19.0 * x ? x + 1.5 * y : den;
    hi = y16 >= 19.0 * x ? ATANHI[2] : hi;
    lo = y16 >= 19.0 * x ? ATANLO[2] : lo;
    num = y16 >= 39.0 * x ? -x : num;
    den = y16 >= 39.0 * x ? y : den;
    hi = y16 >= 39.0 * x ? ATANHI[3] : hi;
    lo = y16 >= 39.0 * x ? ATANLO[3] : lo;
    double t = num / (den > 0.0 ? den : 1.0); /* y = x = 0 only for non-rotations */
    double z = t * t, w = z * z;
    double s1 = z * (AT[0] + w * (AT[2] + w * (AT[4] + w * (AT[6] + w * (AT[8] + w * AT[10])))));
    double s2 = w * (AT[1] + w * (AT[3] + w * (AT[5] + w * (AT[7] + w * AT[9]))));
    double a = hi - ((t * (s1 + s2) - lo) - t); /* i0 = 0: hi = lo = 0, a = t - t (s1 + s2) */
    /* c < 0: pi - a with pi = PI_HI + PI_LO */
    return c < 0.0 ? PI_HI - (a - PI_LO) : a;
}

/* exp coefficients of a chunk: A, B, C from |w|; returns how many elements
   were left to the scalar code (t < small or t > FAST_MAX) */
VEC_CLONES static int exp_chunk(const double *restrict tt, double *restrict A, double *restrict B,
                                double *restrict Cc, int m, double small) {
    double nspecial = 0.0;
    for (int i = 0; i < m; i++) {
        double t = tt[i];
        double slow = (t >= small ? 0.0 : 1.0) + (t <= FAST_MAX ? 0.0 : 1.0);
        nspecial += slow;
        double ts = slow > 0.0 ? 1.0 : t, sh, ch;
        sincos_poly(0.5 * ts, &sh, &ch);
        double it = 1.0 / ts, st = 2.0 * sh * ch, q = sh * it;
        A[i] = st * it;
        B[i] = 2.0 * (q * q);
        Cc[i] = (ts - st) * (it * it * it);
    }
    return (int)nspecial;
}

static Py_ssize_t run_exp(int se, const Coef *C, const double *x, double *out, Py_ssize_t N,
                          double maxc) {
    const int is = se ? 6 : 3, os = se ? 16 : 9;
    double t2[CH], A[CH], B[CH], Cc[CH];
    for (Py_ssize_t base = 0; base < N; base += CH) {
        const int m = (int)(N - base < CH ? N - base : CH);
        const double *xc = x + base * is;
        double *oc = out + base * os;
        double bad = 0.0;
        for (int i = 0; i < m; i++) {
            const double *w = xc + (Py_ssize_t)i * is;
            double w0 = w[0], w1 = w[1], w2 = w[2];
            t2[i] = w0 * w0 + w1 * w1 + w2 * w2;
            /* |x| <= maxc is false for NaN and infinities */
            int ok = (fabs(w0) <= maxc) & (fabs(w1) <= maxc) & (fabs(w2) <= maxc);
            if (se) ok &= (fabs(w[3]) <= DBL_MAX) & (fabs(w[4]) <= DBL_MAX) & (fabs(w[5]) <= DBL_MAX);
            bad += ok ? 0.0 : 1.0;
        }
        if (bad > 0.0)
            for (int i = 0; i < m; i++)
                if (!tangent_ok(xc + (Py_ssize_t)i * is, is, maxc)) return base + i;
        sqrt_arr(t2, m); /* t2 now holds |w| */
        if (exp_chunk(t2, A, B, Cc, m, C->small))
            for (int i = 0; i < m; i++) {
                double t = t2[i];
                if (!(t >= C->small && t <= FAST_MAX)) exp_coefs(C, t, &A[i], &B[i], &Cc[i]);
            }
        for (int i = 0; i < m; i++) {
            const double *w = xc + (Py_ssize_t)i * is;
            double *o = oc + (Py_ssize_t)i * os;
            if (!se) {
                poly(w, A[i], B[i], o, 3);
                continue;
            }
            double w0 = w[0], w1 = w[1], w2 = w[2], v0 = w[3], v1 = w[4], v2 = w[5];
            double a = A[i], b = B[i];
            poly(w, a, b, o, 4);
            double Bw0 = b * w0, Bw1 = b * w1, Bw2 = b * w2;
            double Cd = Cc[i] * (w0 * v0 + w1 * v1 + w2 * v2);
            o[3] = a * v0 + (Bw1 * v2 - Bw2 * v1) + Cd * w0;
            o[7] = a * v1 + (Bw2 * v0 - Bw0 * v2) + Cd * w1;
            o[11] = a * v2 + (Bw0 * v1 - Bw1 * v0) + Cd * w2;
            o[12] = o[13] = o[14] = 0.0;
            o[15] = 1.0;
        }
        /* so3.exp: finite by construction from certified input (|w| <= MAX_ANGLE) */
        if (se && !finite_n(oc, m * os))
            for (int i = 0; i < m; i++)
                if (!finite_n(oc + (Py_ssize_t)i * os, os)) return base + i;
    }
    return -1;
}

typedef struct {
    double s0[CH], s1[CH], s2[CH], c[CH], d0[CH], d1[CH], d2[CH], s01[CH], s02[CH], s12[CH];
    double y[CH], r[CH], norm[CH], w0[CH], w1[CH], w2[CH], cot[CH];
} LogTmp;

/* so3_log above, branch-free over a chunk (the near-pi axis and the generic formula both
   evaluated, one kept); the series below SMALL_ANGLE evaluated here too (one Horner). Pass 1:
   the squares whose roots sqrt_arr takes; the column u of the axis branch into d0, d1, d2. */
VEC_CLONES static void log_chunk1(LogTmp *restrict L, int m) {
    for (int i = 0; i < m; i++) {
        double s0 = L->s0[i], s1 = L->s1[i], s2 = L->s2[i], c = L->c[i];
        double y2 = s0 * s0 + s1 * s1 + s2 * s2;
        L->y[i] = y2;
        L->r[i] = y2 + c * c;
        double d0 = L->d0[i], d1 = L->d1[i], d2 = L->d2[i];
        double s01 = L->s01[i], s02 = L->s02[i], s12 = L->s12[i];
        /* column 0 if d0 is largest, else column 1 if d1 >= d2, else column 2 */
        double u0 = s02, u1 = s12, u2 = d2;
        u0 = d1 >= d2 ? s01 : u0;
        u1 = d1 >= d2 ? d1 : u1;
        u2 = d1 >= d2 ? s12 : u2;
        double k0 = (d0 >= d1 ? 1.0 : 0.0) * (d0 >= d2 ? 1.0 : 0.0);
        u0 = k0 > 0.0 ? d0 : u0;
        u1 = k0 > 0.0 ? s01 : u1;
        u2 = k0 > 0.0 ? s02 : u2;
        L->d0[i] = u0;
        L->d1[i] = u1;
        L->d2[i] = u2;
        L->norm[i] = u0 * u0 + u1 * u1 + u2 * u2;
    }
}

VEC_CLONES static void log_chunk2(LogTmp *restrict L, int m, const double *restrict sinc_c,
                                  double small) {
    for (int i = 0; i < m; i++) {
        double s0 = L->s0[i], s1 = L->s1[i], s2 = L->s2[i], c = L->c[i];
        double y = L->y[i], r = L->r[i], norm = L->norm[i];
        double u0 = L->d0[i], u1 = L->d1[i], u2 = L->d2[i];
        double theta = atan2_poly(y, c);
        L->cot[i] = (c >= 0.0 ? r + c : y) / (c >= 0.0 ? y : r - c);
        double dot = u0 * s0 + u1 * s1 + u2 * s2;
        double hs = HORNER9(sinc_c, theta * theta);
        /* w = num / den * (u or s): the axis branch (c < -1/2), the series, the closed form;
           the conditions as 0/1 values first (so the SSE2 clone is if-converted too) */
        double sm = theta < small ? 1.0 : 0.0, pib = c < -0.5 ? 1.0 : 0.0;
        double num = sm > 0.0 ? 1.0 : theta * r, den = sm > 0.0 ? hs : y;
        double sth = dot < 0.0 ? -theta : theta;
        num = pib > 0.0 ? sth : num;
        den = pib > 0.0 ? norm : den;
        double q = num / den;
        double v0 = pib > 0.0 ? u0 : s0, v1 = pib > 0.0 ? u1 : s1, v2 = pib > 0.0 ? u2 : s2;
        L->w0[i] = q * v0;
        L->w1[i] = q * v1;
        L->w2[i] = q * v2;
        L->y[i] = L->w0[i] * L->w0[i] + L->w1[i] * L->w1[i] + L->w2[i] * L->w2[i];
    }
}

/* se3: D(|w|) of the chunk into cot's place (coef_D above, the series evaluated here too); y
   holds |w| */
VEC_CLONES static void logD_chunk(LogTmp *restrict L, int m, const double *restrict D_c,
                                  double small) {
    for (int i = 0; i < m; i++) {
        double w0 = L->w0[i], w1 = L->w1[i], w2 = L->w2[i];
        double t2 = w0 * w0 + w1 * w1 + w2 * w2, t = L->y[i], hs = HORNER9(D_c, t2);
        double ts = t < small ? 1.0 : t;
        double closed = 1.0 / (ts * ts) - L->cot[i] / (2.0 * ts);
        L->cot[i] = t < small ? hs : closed;
    }
}

/* log pass 0: the chunk's rotation entries transposed into L (r21 r02 r10 r00 r11 r22 r01 r02 r12
   into s0 s1 s2 d0 d1 d2 s01 s02 s12), rotations of row stride s or poses (se: the bottom row
   and a finite translation certified here); returns how many poses were refused */
INLINE double log_load(const double *restrict xc, LogTmp *restrict L, int m, const int se) {
    const int is = se ? 16 : 9, s = se ? 4 : 3;
    double bad = 0.0;
    for (int i = 0; i < m; i++) {
        const double *R = xc + (Py_ssize_t)i * is;
        L->d0[i] = R[0];
        L->s01[i] = R[1];
        L->s02[i] = R[2];
        L->s2[i] = R[s];
        L->d1[i] = R[s + 1];
        L->s12[i] = R[s + 2];
        L->s1[i] = R[2 * s];
        L->s0[i] = R[2 * s + 1];
        L->d2[i] = R[2 * s + 2];
        if (se) {
            int ok = (R[12] == 0.0) & (R[13] == 0.0) & (R[14] == 0.0) & (R[15] == 1.0) &
                     (fabs(R[3] + R[7] + R[11]) <= DBL_MAX);
            bad += ok ? 0.0 : 1.0;
        }
    }
    return bad;
}
VEC_CLONES static double log_load3(const double *restrict xc, LogTmp *restrict L, int m) {
    return log_load(xc, L, m, 0);
}
VEC_CLONES static double log_load4(const double *restrict xc, LogTmp *restrict L, int m) {
    return log_load(xc, L, m, 1);
}

/* log pass 1: certify the transposed rotations (rotation_ok above) and form in place the
   entries so3_log needs; returns how many were refused */
VEC_CLONES static double log_prep(LogTmp *restrict L, int m, double tol2) {
    double bad = 0.0;
    for (int i = 0; i < m; i++) {
        double r00 = L->d0[i], r01 = L->s01[i], r02 = L->s02[i];
        double r10 = L->s2[i], r11 = L->d1[i], r12 = L->s12[i];
        double r20 = L->s1[i], r21 = L->s0[i], r22 = L->d2[i];
        double e0 = r00 * r00 + r10 * r10 + r20 * r20 - 1.0;
        double e1 = r01 * r01 + r11 * r11 + r21 * r21 - 1.0;
        double e2 = r02 * r02 + r12 * r12 + r22 * r22 - 1.0;
        double e3 = r00 * r01 + r10 * r11 + r20 * r21;
        double e4 = r00 * r02 + r10 * r12 + r20 * r22;
        double e5 = r01 * r02 + r11 * r12 + r21 * r22;
        double det = r00 * (r11 * r22 - r12 * r21) - r01 * (r10 * r22 - r12 * r20) +
                     r02 * (r10 * r21 - r11 * r20);
        double err = e0 * e0 + e1 * e1 + e2 * e2 + 2.0 * (e3 * e3 + e4 * e4 + e5 * e5);
        /* refused: err > tol^2 (or NaN), det <= 0 (or NaN) */
        bad += (err <= tol2 ? 0.0 : 1.0) + (det > 0.0 ? 0.0 : 1.0);
        double c = 0.5 * (r00 + r11 + r22 - 1.0);
        L->s0[i] = 0.5 * (r21 - r12);
        L->s1[i] = 0.5 * (r02 - r20);
        L->s2[i] = 0.5 * (r10 - r01);
        L->c[i] = c;
        L->d0[i] = r00 - c;
        L->d1[i] = r11 - c;
        L->d2[i] = r22 - c;
        L->s01[i] = 0.5 * (r01 + r10);
        L->s02[i] = 0.5 * (r02 + r20);
        L->s12[i] = 0.5 * (r12 + r21);
    }
    return bad;
}

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC pop_options
#endif

static Py_ssize_t run_log(int se, const Coef *C, const double *x, double *out, Py_ssize_t N,
                          double tol) {
    const int is = se ? 16 : 9, os = se ? 6 : 3;
    const double tol2 = tol * tol;
    LogTmp L;
    for (Py_ssize_t base = 0; base < N; base += CH) {
        const int m = (int)(N - base < CH ? N - base : CH);
        const double *xc = x + base * is;
        double *oc = out + base * os;
        double bad = se ? log_load4(xc, &L, m) : log_load3(xc, &L, m);
        bad += log_prep(&L, m, tol2);
        if (bad > 0.0) /* the first element pose_ok / rotation_ok refuses */
            for (int i = 0; i < m; i++) {
                const double *R = xc + (Py_ssize_t)i * is;
                if (!(se ? pose_ok(R, tol) : rotation_ok(R, 3, tol))) return base + i;
            }
        log_chunk1(&L, m);
        sqrt_arr(L.y, m);
        sqrt_arr(L.r, m);
        sqrt_arr(L.norm, m);
        log_chunk2(&L, m, C->c[0], C->small);
        if (!se) {
            for (int i = 0; i < m; i++) {
                double *o = oc + (Py_ssize_t)i * 3;
                o[0] = L.w0[i];
                o[1] = L.w1[i];
                o[2] = L.w2[i];
            }
            continue; /* finite by construction from certified input */
        }
        sqrt_arr(L.y, m);
        logD_chunk(&L, m, C->c[3], C->small);
        for (int i = 0; i < m; i++) { /* se3._log_block */
            const double *X = xc + (Py_ssize_t)i * 16;
            double *o = oc + (Py_ssize_t)i * 6;
            se3_log_out(L.w0[i], L.w1[i], L.w2[i], L.cot[i], X, o);
        }
        if (!finite_n(oc, m * 6))
            for (int i = 0; i < m; i++)
                if (!finite_n(oc + (Py_ssize_t)i * 6, 6)) return base + i;
    }
    return -1;
}

/* one copy of the loop per op (op constant inside: no dispatch per element) */
static Py_ssize_t run(int op, const Coef *C, const double *x, double *out, Py_ssize_t N,
                      double tol, double maxc) {
    switch (op) {
    case 0: return run_exp(0, C, x, out, N, maxc);
    case 1: return run_log(0, C, x, out, N, tol);
    case 2: return run_exp(1, C, x, out, N, maxc);
    case 3: return run_log(1, C, x, out, N, tol);
    default: return run_op(4, C, x, out, N, tol, maxc);
    }
}

static int get_buffer(PyObject *obj, Py_buffer *view, int writable) {
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) != 0) {
        PyErr_Clear();
        return 0;
    }
    if (view->itemsize != 8 || view->format == NULL ||
        !(strcmp(view->format, "d") == 0 || strcmp(view->format, "<d") == 0 ||
          strcmp(view->format, "=d") == 0) ||
        ((uintptr_t)view->buf % sizeof(double)) != 0 || view->ndim < 1) {
        PyBuffer_Release(view);
        return 0;
    }
    return 1;
}

static PyObject *kernel(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 7) {
        PyErr_SetString(PyExc_TypeError,
                        "kernel(op, x, out, coef, small_angle, tol, max_component)");
        return NULL;
    }
    long op = PyLong_AsLong(args[0]);
    if (op == -1 && PyErr_Occurred()) return NULL;
    double small = PyFloat_AsDouble(args[4]), tol = PyFloat_AsDouble(args[5]);
    double maxc = PyFloat_AsDouble(args[6]);
    if (PyErr_Occurred()) return NULL;
    if (op < 0 || op > 4) return PyLong_FromLong(-2);
    static const int in_core[5][3] = {{1, 3, 0}, {2, 3, 3}, {1, 6, 0}, {2, 4, 4}, {2, 4, 4}};
    static const int out_core[5][3] = {{2, 3, 3}, {1, 3, 0}, {2, 4, 4}, {1, 6, 0}, {2, 6, 6}};
    Py_buffer xb, ob, cb;
    if (!get_buffer(args[1], &xb, 0)) return PyLong_FromLong(-2);
    if (!get_buffer(args[2], &ob, 1)) {
        PyBuffer_Release(&xb);
        return PyLong_FromLong(-2);
    }
    if (PyObject_GetBuffer(args[3], &cb, PyBUF_SIMPLE) != 0) {
        PyBuffer_Release(&ob);
        PyBuffer_Release(&xb);
        return NULL;
    }
    Py_ssize_t result = -2;
    int ki = in_core[op][0], ko = out_core[op][0];
    int nb = xb.ndim - ki;
    Py_ssize_t N = 1;
    Coef C;
    if (nb < 0 || ob.ndim != nb + ko) goto done;
    if (cb.len != (Py_ssize_t)(4 * NS * sizeof(double))) goto done;
    for (int i = 0; i < ki; i++)
        if (xb.shape[nb + i] != in_core[op][1 + i]) goto done;
    for (int i = 0; i < ko; i++)
        if (ob.shape[nb + i] != out_core[op][1 + i]) goto done;
    for (int i = 0; i < nb; i++) {
        if (ob.shape[i] != xb.shape[i]) goto done;
        N *= xb.shape[i];
    }
    if (xb.buf == ob.buf && N > 0) goto done;
    memcpy(C.c, cb.buf, sizeof C.c);
    C.small = small;
    {
        const double *x = (const double *)xb.buf;
        double *out = (double *)ob.buf;
        Py_BEGIN_ALLOW_THREADS;
        result = run((int)op, &C, x, out, N, tol, maxc);
        Py_END_ALLOW_THREADS;
    }
done:
    PyBuffer_Release(&cb);
    PyBuffer_Release(&ob);
    PyBuffer_Release(&xb);
    return PyLong_FromSsize_t(result);
}

static PyMethodDef methods[] = {
    {"kernel", (PyCFunction)(void (*)(void))kernel, METH_FASTCALL,
     "kernel(op, x, out, coef, small_angle, tol, max_component) -> int\n\n"
     "Validate and evaluate a batched SO(3)/SE(3) kernel (see _lie_ext.c): -1 done, -2 not\n"
     "handled, k >= 0 the first element not certified."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_lie_ext",
    "Optional compiled SO(3)/SE(3) exp, log and adjoint of liebridge.lie (see _lie_ext.c).", -1,
    methods, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__lie_ext(void) { return PyModule_Create(&module); }
