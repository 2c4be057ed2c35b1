/*
 * Optional compiled batched SO(3)/SE(3) kernels of liebridge.lie: exp, log and the adjoint in one
 * validate-and-compute pass over the batch.
 *
 * The formulas are those of liebridge/lie/so3.py (_poly_into, _log) and se3.py (_exp_block,
 * _log_block, _adjoint), entry by entry, with the coefficient functions of series.py: the closed
 * forms above SMALL_ANGLE and the same Maclaurin series (their coefficients are passed in) below.
 * tests/test_lie_compiled.py compares every output with the numpy kernels.
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
 * bottom row exactly (0, 0, 0, 1) and a finite translation; the output is finite. The first
 * element that is not certified stops the pass and its flat index is returned: the caller then
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
#include <math.h>
#include <stdint.h>
#include <string.h>

#define NS 9 /* terms of each series */
#if defined(__GNUC__) || defined(__clang__)
#define INLINE static inline __attribute__((always_inline))
#elif defined(_MSC_VER)
#define INLINE static __forceinline
#else
#define INLINE static inline
#endif

typedef struct {
    double c[4][NS];
    double small;
} Coef;

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
            double w0 = w[0], w1 = w[1], w2 = w[2];
            double t0 = x[3], t1 = x[7], t2 = x[11];
            double D = coef_D(C, sqrt(w0 * w0 + w1 * w1 + w2 * w2), cot_half);
            double c0 = w1 * t2 - w2 * t1, c1 = w2 * t0 - w0 * t2, c2 = w0 * t1 - w1 * t0;
            out[0] = w0;
            out[1] = w1;
            out[2] = w2;
            out[3] = t0 - 0.5 * c0 + D * (w1 * c2 - w2 * c1);
            out[4] = t1 - 0.5 * c1 + D * (w2 * c0 - w0 * c2);
            out[5] = t2 - 0.5 * c2 + D * (w0 * c1 - w1 * c0);
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

/* one copy of the loop per op (op constant inside: no dispatch per element) */
static Py_ssize_t run(int op, const Coef *C, const double *x, double *out, Py_ssize_t N,
                      double tol, double maxc) {
    switch (op) {
    case 0: return run_op(0, C, x, out, N, tol, maxc);
    case 1: return run_op(1, C, x, out, N, tol, maxc);
    case 2: return run_op(2, C, x, out, N, tol, maxc);
    case 3: return run_op(3, C, x, out, N, tol, maxc);
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
