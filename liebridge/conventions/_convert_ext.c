/*
 * Optional compiled kernel of liebridge's conversions: validate and convert in one pass.
 *
 * For every element of a batch it evaluates the first-order tangent map M(X) of a pair of
 * conventions exactly as liebridge/conventions/tangent_maps.py describes it: 3x3 block by block,
 * each block a combination of the primitives I, R, R^T, hat(t) R and -R^T hat(t) with constant
 * coefficients (a "grid"; pair_map_coefficients() gives it as an array (blocks, blocks, 5)), and
 *
 *   mode 0 (tangent_map):         out = M
 *   mode 1 (convert_covariance):  out = M A M^T
 *   mode 2 (convert_information): out = M^T A M   (M is then the map dst -> src, i.e. M^-1)
 *   mode 3 (a Jacobian's columns, at_input):  out = A M   (A: (m, n) per element)
 *   mode 4 (a Jacobian's rows, at_output):    out = M A   (A: (n, m) per element)
 *
 * Validation is a *certificate* that can only accept valid input, the one liebridge/_validate.py
 * runs first: a pose has the bottom row exactly (0, 0, 0, 1), a finite translation,
 * ||R^T R - I||_F <= tol (which bounds max|R^T R - I|, the documented check) and det R > 0; a
 * covariance (modes 1, 2) is exactly symmetric and its Cholesky factorisation has positive,
 * finite pivots; a Jacobian (modes 3, 4) is finite; the output is finite. The first element where
 * any of this does not hold stops the pass and its flat index is returned: the caller then runs
 * the numpy path, whose exact checks accept the input (e.g. a singular PSD covariance) or raise
 * the error naming the argument, the batch index and the size of the violation.
 *
 * A plan is a tuple (grid_pose, grid_pose_2, grid_rot, grid_rot_2, tol): C-contiguous float64
 * coefficient arrays (or None: not covered; a second grid is a second factor, M = M1(X) M2(X)).
 * X, A and out are buffers with shapes (C-contiguous, aligned float64: numpy arrays) with equal
 * batch shapes; anything else (another dtype, a strided view, broadcasting) returns -2 and the
 * caller uses numpy. Return: -1 done, -2 not handled here, k >= 0 the first element (flat index)
 * not certified. Nothing is allocated; the GIL is released during the pass.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#define MAXN 6

#if defined(__GNUC__) || defined(__clang__)
#define INLINE static inline __attribute__((always_inline))
#elif defined(_MSC_VER)
#define INLINE static __forceinline
#else
#define INLINE static inline
#endif
#define NPRIM 5 /* I, R, R^T, hat(t) R, -R^T hat(t): tangent_maps.PRIMITIVES */

/* a tangent map as a grid of 3x3 blocks, block (i, j) = sum_p c[i][j][p] P_p(X) */
typedef struct {
    double c[2][2][NPRIM];
    int nb;     /* 2 for a pose, 1 for a rotation */
    int need_t; /* whether hat(t) R appears */
} Grid;

/* M (n x n, n = 3 nb) of the grid at X (a pose, k = 4, or a rotation, k = 3) */
INLINE void eval_grid(const Grid *G, const double *X, int k, int nb, double *M) {
    const int n = 3 * nb;
    double P[NPRIM][9];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            P[1][3 * r + c] = X[k * r + c];
            P[2][3 * c + r] = X[k * r + c];
        }
    if (k == 4 && G->need_t) { /* column c of hat(t) R is t x R[:, c]; -R^T hat(t) its transpose */
        double t0 = X[3], t1 = X[7], t2 = X[11];
        for (int c = 0; c < 3; c++) {
            double v0 = X[c], v1 = X[4 + c], v2 = X[8 + c];
            double w0 = t1 * v2 - t2 * v1, w1 = t2 * v0 - t0 * v2, w2 = t0 * v1 - t1 * v0;
            P[3][c] = w0;
            P[3][3 + c] = w1;
            P[3][6 + c] = w2;
            P[4][3 * c] = w0;
            P[4][3 * c + 1] = w1;
            P[4][3 * c + 2] = w2;
        }
    }
    for (int bi = 0; bi < nb; bi++)
        for (int bj = 0; bj < nb; bj++) {
            double blk[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
            int np = (k == 4 && G->need_t) ? NPRIM : 3;
            blk[0] = blk[4] = blk[8] = G->c[bi][bj][0];
            for (int p = 1; p < np; p++) {
                double w = G->c[bi][bj][p];
                if (w != 0.0) /* the same branch for every element: predicted */
                    for (int q = 0; q < 9; q++) blk[q] += w * P[p][q];
            }
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 3; c++) M[(3 * bi + r) * n + 3 * bj + c] = blk[3 * r + c];
        }
}

INLINE int block_zero(const Grid *G, int i, int j) {
    for (int p = 0; p < NPRIM; p++)
        if (G->c[i][j][p] != 0.0) return 0;
    return 1;
}

/* certificate of R (row stride s): ||R^T R - I||_F <= tol and det R > 0 (see _validate.py) */
INLINE int rotation_ok(const double *R, int s, double tol) {
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

INLINE int element_ok(const double *X, int k, double tol) {
    if (k == 3) return rotation_ok(X, 3, tol);
    if (X[12] != 0.0 || X[13] != 0.0 || X[14] != 0.0 || X[15] != 1.0) return 0;
    if (!isfinite(X[3] + X[7] + X[11])) return 0;
    return rotation_ok(X, 4, tol);
}

/* exactly symmetric, and the Cholesky factorisation A = L D L^T (the square-root-free form of
   L L^T: the same pivots) has positive, finite pivots */
INLINE int psd_ok(const double *A, int n) {
    double L[MAXN * MAXN], d[MAXN], id[MAXN];
    int sym = 1;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < i; j++) sym &= A[i * n + j] == A[j * n + i]; /* NaN fails too */
    if (!sym) return 0;
    for (int j = 0; j < n; j++) {
        double dj = A[j * n + j];
        for (int p = 0; p < j; p++) dj -= L[j * n + p] * L[j * n + p] * d[p];
        if (!(dj > 0.0) || !isfinite(dj)) return 0;
        d[j] = dj;
        id[j] = 1.0 / dj;
        for (int i = j + 1; i < n; i++) {
            double s = A[i * n + j];
            for (int p = 0; p < j; p++) s -= L[i * n + p] * L[j * n + p] * d[p];
            L[i * n + j] = s * id[j];
        }
    }
    return 1;
}

/* no Inf or NaN in a[0 .. len): x - x is 0 for finite x, NaN otherwise (four independent sums) */
INLINE int finite_n(const double *a, int len) {
    double s[4] = {0.0, 0.0, 0.0, 0.0};
    int i = 0;
    for (; i + 4 <= len; i += 4)
        for (int j = 0; j < 4; j++) s[j] += a[i + j] - a[i + j];
    for (; i < len; i++) s[0] += a[i] - a[i];
    return (s[0] + s[1]) + (s[2] + s[3]) == 0.0;
}

/* C = A B with A (m, q), B (q, r): rows of C as sums of rows of B (vectorizes; unrolled) */
INLINE void matmul(const double *A, const double *B, double *C, int m, int q, int r) {
    for (int i = 0; i < m; i++) {
        double c[64];
#pragma GCC unroll 8
        for (int j = 0; j < r; j++) c[j] = A[i * q] * B[j];
#pragma GCC unroll 8
        for (int p = 1; p < q; p++) {
            double a = A[i * q + p];
#pragma GCC unroll 8
            for (int j = 0; j < r; j++) c[j] += a * B[p * r + j];
        }
#pragma GCC unroll 8
        for (int j = 0; j < r; j++) C[i * r + j] = c[j];
    }
}

/* out = L A L^T for symmetric A (n = 3 nb), skipping the 3x3 blocks of L that are zero for every
   element (nz[i][j]: block (i, j) of L may be nonzero); exactly symmetric (upper blocks,
   mirrored). Lt is L^T. */
INLINE void congruence(const double *L, const double *Lt, const int nz[2][2], const double *A,
                       double *out, int nb) {
    const int n = 3 * nb;
    double T[MAXN * MAXN];
    for (int i = 0; i < n * n; i++) T[i] = 0.0;
    for (int bi = 0; bi < nb; bi++) /* T = L A, block row by block row */
        for (int bp = 0; bp < nb; bp++) {
            if (!nz[bi][bp]) continue;
            for (int r = 0; r < 3; r++) {
                double *Tr = T + (3 * bi + r) * n;
                for (int q = 0; q < 3; q++) {
                    double l = L[(3 * bi + r) * n + 3 * bp + q];
                    const double *Ar = A + (3 * bp + q) * n;
#pragma GCC unroll 8
                    for (int j = 0; j < n; j++) Tr[j] += l * Ar[j];
                }
            }
        }
    for (int bi = 0; bi < nb; bi++) /* out = T L^T, blocks bi <= bj */
        for (int bj = bi; bj < nb; bj++) {
            double o[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
            for (int bp = 0; bp < nb; bp++) {
                if (!nz[bj][bp]) continue;
                for (int r = 0; r < 3; r++)
                    for (int q = 0; q < 3; q++) {
                        double t = T[(3 * bi + r) * n + 3 * bp + q];
                        const double *Lq = Lt + (3 * bp + q) * n + 3 * bj;
                        for (int c = 0; c < 3; c++) o[3 * r + c] += t * Lq[c];
                    }
            }
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 3; c++) {
                    out[(3 * bi + r) * n + 3 * bj + c] = o[3 * r + c];
                    out[(3 * bj + c) * n + 3 * bi + r] = o[3 * r + c];
                }
        }
    if (nb == 2) /* the diagonal blocks' lower triangles: from their upper ones */
        for (int b = 0; b < 2; b++)
            for (int r = 1; r < 3; r++)
                for (int c = 0; c < r; c++)
                    out[(3 * b + r) * n + 3 * b + c] = out[(3 * b + c) * n + 3 * b + r];
    else
        for (int r = 1; r < 3; r++)
            for (int c = 0; c < r; c++) out[r * n + c] = out[c * n + r];
}

INLINE void transpose(const double *M, double *Mt, int n) {
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) Mt[i * n + j] = M[j * n + i];
}

/* the pass over N elements; k, n, mode constant in each call below (inlined, unrolled) */
INLINE Py_ssize_t run(int mode, int k, int n, const Grid *T1, const Grid *T2, double tol,
                      const double *X, const double *A, double *out, Py_ssize_t N, int ar,
                      int ac) {
    Py_ssize_t xs = (Py_ssize_t)k * k, as = (Py_ssize_t)ar * ac;
    double M[MAXN * MAXN], Mt[MAXN * MAXN], M1[MAXN * MAXN], M2[MAXN * MAXN];
    const int nb = n / 3;
    int nz[2][2], nzt[2][2]; /* blocks of M (of M^T) that may be nonzero */
    for (int i = 0; i < nb; i++)
        for (int j = 0; j < nb; j++) {
            int z = 1;
            if (T2) {
                for (int p = 0; p < nb; p++) z &= block_zero(T1, i, p) || block_zero(T2, p, j);
            } else {
                z = block_zero(T1, i, j);
            }
            nz[i][j] = !z;
            nzt[j][i] = !z;
        }
    for (Py_ssize_t e = 0; e < N; e++, X += xs, out += as) {
        if (!element_ok(X, k, tol)) return e;
        if (T2) {
            eval_grid(T1, X, k, nb, M1);
            eval_grid(T2, X, k, nb, M2);
            matmul(M1, M2, M, n, n, n);
        } else {
            eval_grid(T1, X, k, nb, M);
        }
        if (mode == 0) {
            for (int i = 0; i < n * n; i++) out[i] = M[i];
        } else if (mode <= 2) {
            if (!psd_ok(A, n)) return e;
            transpose(M, Mt, n);
            if (mode == 1)
                congruence(M, Mt, nz, A, out, nb);
            else
                congruence(Mt, M, nzt, A, out, nb);
        } else {
            if (!finite_n(A, (int)as)) return e;
            if (mode == 3)
                matmul(A, M, out, ar, n, n);
            else
                matmul(M, A, out, n, n, ac);
        }
        if (!finite_n(out, (int)as)) return e;
        if (A) A += as;
    }
    return -1;
}

static Py_ssize_t run_pose_cov(const Grid *T1, const Grid *T2, double tol, const double *X,
                               const double *A, double *out, Py_ssize_t N) {
    return run(1, 4, 6, T1, T2, tol, X, A, out, N, 6, 6);
}
static Py_ssize_t run_pose_info(const Grid *T1, const Grid *T2, double tol, const double *X,
                                const double *A, double *out, Py_ssize_t N) {
    return run(2, 4, 6, T1, T2, tol, X, A, out, N, 6, 6);
}
static Py_ssize_t run_pose_map(const Grid *T1, const Grid *T2, double tol, const double *X,
                               double *out, Py_ssize_t N) {
    return run(0, 4, 6, T1, T2, tol, X, NULL, out, N, 6, 6);
}

static Py_ssize_t dispatch(int mode, int k, const Grid *T1, const Grid *T2, double tol,
                           const double *X, const double *A, double *out, Py_ssize_t N, int ar,
                           int ac) {
    if (k == 4 && mode == 1) return run_pose_cov(T1, T2, tol, X, A, out, N);
    if (k == 4 && mode == 2) return run_pose_info(T1, T2, tol, X, A, out, N);
    if (k == 4 && mode == 0) return run_pose_map(T1, T2, tol, X, out, N);
    if (k == 4 && mode == 3) return run(3, 4, 6, T1, T2, tol, X, A, out, N, ar, 6);
    if (k == 4 && mode == 4) return run(4, 4, 6, T1, T2, tol, X, A, out, N, 6, ac);
    if (mode == 0) return run(0, 3, 3, T1, T2, tol, X, NULL, out, N, 3, 3);
    if (mode == 1) return run(1, 3, 3, T1, T2, tol, X, A, out, N, 3, 3);
    if (mode == 2) return run(2, 3, 3, T1, T2, tol, X, A, out, N, 3, 3);
    if (mode == 3) return run(3, 3, 3, T1, T2, tol, X, A, out, N, ar, 3);
    return run(4, 3, 3, T1, T2, tol, X, A, out, N, 3, ac);
}

/* a C-contiguous, aligned float64 buffer with shape, or 0 (the caller returns -2) */
static int get_buffer(PyObject *obj, Py_buffer *view, int writable) {
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) != 0) {
        PyErr_Clear();
        return 0;
    }
    if (view->itemsize != 8 || view->format == NULL ||
        !(strcmp(view->format, "d") == 0 || strcmp(view->format, "<d") == 0 ||
          strcmp(view->format, "=d") == 0) ||
        ((uintptr_t)view->buf % sizeof(double)) != 0 || view->ndim < 2) {
        PyBuffer_Release(view);
        return 0;
    }
    return 1;
}

/* a coefficient grid (nb, nb, NPRIM) float64 into G; 0 if it is not one */
static int read_grid(PyObject *obj, Grid *G, int nb, int k) {
    Py_buffer v;
    if (PyObject_GetBuffer(obj, &v, PyBUF_SIMPLE) != 0) {
        PyErr_Clear();
        return 0;
    }
    int ok = v.len == (Py_ssize_t)(nb * nb * NPRIM * sizeof(double)) &&
             ((uintptr_t)v.buf % sizeof(double)) == 0;
    G->nb = nb;
    G->need_t = 0;
    if (ok) {
        const double *c = (const double *)v.buf;
        for (int i = 0; i < nb; i++)
            for (int j = 0; j < nb; j++)
                for (int p = 0; p < NPRIM; p++) {
                    double w = c[(i * nb + j) * NPRIM + p];
                    if (!isfinite(w)) ok = 0;
                    G->c[i][j][p] = w;
                    if (p >= 3 && w != 0.0) G->need_t = 1;
                }
        if (k == 3 && G->need_t) ok = 0; /* a rotation has no translation */
    }
    PyBuffer_Release(&v);
    return ok;
}

static PyObject *transform(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 5) {
        PyErr_SetString(PyExc_TypeError, "transform(mode, plan, X, A, out)");
        return NULL;
    }
    long mode = PyLong_AsLong(args[0]);
    if (mode == -1 && PyErr_Occurred()) return NULL;
    PyObject *plan = args[1];
    if (!PyTuple_Check(plan) || PyTuple_GET_SIZE(plan) != 5) {
        PyErr_SetString(PyExc_TypeError, "plan: expected a tuple of 5");
        return NULL;
    }
    double tol = PyFloat_AsDouble(PyTuple_GET_ITEM(plan, 4));
    if (tol == -1.0 && PyErr_Occurred()) return NULL;

    Py_buffer xb, ab, ob;
    int has_a = args[3] != Py_None;
    if (!get_buffer(args[2], &xb, 0)) return PyLong_FromLong(-2);
    if (has_a && !get_buffer(args[3], &ab, 0)) {
        PyBuffer_Release(&xb);
        return PyLong_FromLong(-2);
    }
    if (!get_buffer(args[4], &ob, 1)) {
        if (has_a) PyBuffer_Release(&ab);
        PyBuffer_Release(&xb);
        return PyLong_FromLong(-2);
    }
    Py_ssize_t result = -2;
    Grid T1, T2;
    int xd = xb.ndim, nb = xd - 2;
    int k = (int)xb.shape[xd - 1];
    int n = k == 4 ? 6 : 3;
    int ar = n, ac = n; /* A's (rows, columns) per element */
    Py_ssize_t N = 1;
    if (mode < 0 || mode > 4 || xb.shape[xd - 2] != k || (k != 3 && k != 4)) goto done;
    for (int i = 0; i < nb; i++) N *= xb.shape[i];
    if (has_a) {
        if (ab.ndim != xd) goto done;
        for (int i = 0; i < nb; i++)
            if (ab.shape[i] != xb.shape[i]) goto done;
        ar = (int)ab.shape[xd - 2];
        ac = (int)ab.shape[xd - 1];
        if ((mode == 1 || mode == 2) && (ar != n || ac != n)) goto done;
        if ((mode == 3 && ac != n) || (mode == 4 && ar != n)) goto done;
        if (ab.shape[xd - 2] > 64 || ab.shape[xd - 1] > 64) goto done;
        if (ab.buf == ob.buf && N > 0) goto done; /* never write into the input */
    } else if (mode != 0) {
        goto done;
    }
    if (ob.ndim != xd) goto done;
    for (int i = 0; i < nb; i++)
        if (ob.shape[i] != xb.shape[i]) goto done;
    if (ob.shape[xd - 2] != ar || ob.shape[xd - 1] != ac) goto done;
    {
        PyObject *p1 = PyTuple_GET_ITEM(plan, k == 4 ? 0 : 2);
        PyObject *p2 = PyTuple_GET_ITEM(plan, k == 4 ? 1 : 3);
        if (p1 == Py_None || !read_grid(p1, &T1, n / 3, k)) goto done;
        if (p2 != Py_None && !read_grid(p2, &T2, n / 3, k)) goto done;
        const double *X = (const double *)xb.buf;
        const double *A = has_a ? (const double *)ab.buf : NULL;
        double *out = (double *)ob.buf;
        Py_BEGIN_ALLOW_THREADS;
        result = dispatch((int)mode, k, &T1, p2 == Py_None ? NULL : &T2, tol, X, A, out, N, ar,
                          ac);
        Py_END_ALLOW_THREADS;
    }
done:
    PyBuffer_Release(&ob);
    if (has_a) PyBuffer_Release(&ab);
    PyBuffer_Release(&xb);
    return PyLong_FromSsize_t(result);
}

static PyMethodDef methods[] = {
    {"transform", (PyCFunction)(void (*)(void))transform, METH_FASTCALL,
     "transform(mode, plan, X, A, out) -> int\n\n"
     "Validate and convert a batch (see _convert_ext.c): -1 done, -2 not handled, k >= 0 the\n"
     "first element whose input (or output) was not certified."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_convert_ext",
    "Optional compiled validate-and-convert pass of liebridge.conventions (see convert.py).", -1,
    methods, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__convert_ext(void) { return PyModule_Create(&module); }
