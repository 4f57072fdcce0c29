/* The tracking forward kinematics of hex_control/kinematics/stewart.py, in C: the Newton
 * steps TrackingForwardKinematics.solve takes once a control period in the plant, a fifth
 * of the lock-step plant's CPU in numpy (issue 39 item 2: a cheaper lock-step period).
 *
 * The algorithm of stewart._lengths_and_jacobian and TrackingForwardKinematics.solve: the
 * pose q = (x, y, z, roll, pitch, yaw) with R = R_z(yaw) R_y(pitch) R_x(roll); strut i runs
 * from base joint b_i to q[:3] + R p_i (p_i the platform joint relative to the tool point),
 * its length L_i = |s_i| and its Jacobian row (u_i, (dR/droll p_i).u_i, (dR/dpitch p_i).u_i,
 * (dR/dyaw p_i).u_i) with u_i = s_i / L_i; a Newton step solves J dq = target - L by Gaussian
 * elimination with partial pivoting (numpy's solve is LAPACK's LU with partial pivoting:
 * the same steps, other roundings, so the two agree to about 1e-12 mm, not to the bit).
 * Arrays come as float64 buffers (contiguous). Units: mm, rad.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#define STRUTS 6

/* L (6) and dL/dq (6 x 6, row-major, a row per strut) at pose q */
static void lengths_and_jacobian(const double *joints, const double *base, const double *q, double *lengths,
                                 double *jacobian) {
    double cr = cos(q[3]), sr = sin(q[3]), cp = cos(q[4]), sp = sin(q[4]), cy = cos(q[5]), sy = sin(q[5]);
    /* R, dR/droll, dR/dpitch, dR/dyaw, each 3 x 3 row-major (stewart._lengths_and_jacobian's terms) */
    const double terms[4][9] = {
        {cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,
         sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,
         -sp, cp * sr, cp * cr},
        {0.0, cy * sp * cr + sy * sr, -cy * sp * sr + sy * cr,
         0.0, sy * sp * cr - cy * sr, -sy * sp * sr - cy * cr,
         0.0, cp * cr, -cp * sr},
        {-cy * sp, cy * cp * sr, cy * cp * cr,
         -sy * sp, sy * cp * sr, sy * cp * cr,
         -cp, -sp * sr, -sp * cr},
        {-sy * cp, -sy * sp * sr - cy * cr, -sy * sp * cr + cy * sr,
         cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,
         0.0, 0.0, 0.0}};
    for (int i = 0; i < STRUTS; i++) {
        const double *p = joints + 3 * i;
        double s[3], rotated[4][3];
        for (int m = 0; m < 4; m++)
            for (int r = 0; r < 3; r++)
                rotated[m][r] = terms[m][3 * r] * p[0] + terms[m][3 * r + 1] * p[1] + terms[m][3 * r + 2] * p[2];
        for (int r = 0; r < 3; r++) s[r] = q[r] + rotated[0][r] - base[3 * i + r];
        double length = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
        double *row = jacobian + STRUTS * i;
        for (int r = 0; r < 3; r++) row[r] = s[r] / length;
        for (int m = 1; m < 4; m++)
            row[2 + m] = rotated[m][0] * row[0] + rotated[m][1] * row[1] + rotated[m][2] * row[2];
        lengths[i] = length;
    }
}

/* x = A^-1 b by Gaussian elimination with partial pivoting; 0 if A is singular */
static int solve6(const double *matrix, const double *rhs, double *x) {
    double a[STRUTS][STRUTS + 1];
    for (int i = 0; i < STRUTS; i++) {
        memcpy(a[i], matrix + STRUTS * i, STRUTS * sizeof(double));
        a[i][STRUTS] = rhs[i];
    }
    for (int k = 0; k < STRUTS; k++) {
        int pivot = k;
        for (int i = k + 1; i < STRUTS; i++)
            if (fabs(a[i][k]) > fabs(a[pivot][k])) pivot = i;
        if (a[pivot][k] == 0.0 || !isfinite(a[pivot][k])) return 0;
        if (pivot != k)
            for (int j = k; j <= STRUTS; j++) {
                double t = a[k][j];
                a[k][j] = a[pivot][j];
                a[pivot][j] = t;
            }
        for (int i = k + 1; i < STRUTS; i++) {
            double factor = a[i][k] / a[k][k];
            for (int j = k; j <= STRUTS; j++) a[i][j] -= factor * a[k][j];
        }
    }
    for (int i = STRUTS - 1; i >= 0; i--) {
        double sum = a[i][STRUTS];
        for (int j = i + 1; j < STRUTS; j++) sum -= a[i][j] * x[j];
        x[i] = sum / a[i][i];
    }
    return 1;
}

static int converged(const double *target, const double *lengths, double tolerance) {
    for (int i = 0; i < STRUTS; i++)
        if (!(fabs(target[i] - lengths[i]) < tolerance)) return 0; /* NaN: not converged */
    return 1;
}

static int float_buffer(Py_buffer *view, Py_ssize_t count, const char *name) {
    if (view->len != count * (Py_ssize_t)sizeof(double) || (uintptr_t)view->buf % sizeof(double) != 0) {
        PyErr_Format(PyExc_ValueError, "%s: need an aligned float64 array of %zd values", name, count);
        return 0;
    }
    return 1;
}

/* track(joints, base, pose, lengths, jacobian, target, tolerance, max_iterations) -> bool
 *   joints, base: (6, 3) platform joints from the tool point and base joints (mm); pose (6),
 *   lengths (6), jacobian (36): the last solution and its lengths and Jacobian, written over
 *   with the new ones when the steps reach ``tolerance`` (True), left as they were if not */
static PyObject *track(PyObject *self, PyObject *args) {
    Py_buffer v[6];
    double tolerance;
    int max_iterations;
    if (!PyArg_ParseTuple(args, "y*y*w*w*w*y*di", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &tolerance,
                          &max_iterations))
        return NULL;
    static const char *names[6] = {"joints", "base", "pose", "lengths", "jacobian", "target"};
    static const Py_ssize_t sizes[6] = {18, 18, STRUTS, STRUTS, STRUTS * STRUTS, STRUTS};
    int ok = 1;
    for (int k = 0; k < 6 && ok; k++) ok = float_buffer(&v[k], sizes[k], names[k]);
    PyObject *result = NULL;
    if (ok) {
        const double *joints = v[0].buf, *base = v[1].buf, *target = v[5].buf;
        double q[STRUTS], lengths[STRUTS], jacobian[STRUTS * STRUTS], error[STRUTS], step[STRUTS];
        memcpy(q, v[2].buf, sizeof q);
        memcpy(lengths, v[3].buf, sizeof lengths);
        memcpy(jacobian, v[4].buf, sizeof jacobian);
        int reached = 0;
        for (int iteration = 0; iteration <= max_iterations; iteration++) {
            if (converged(target, lengths, tolerance)) {
                reached = 1;
                break;
            }
            if (iteration == max_iterations) break;
            for (int i = 0; i < STRUTS; i++) error[i] = target[i] - lengths[i];
            if (!solve6(jacobian, error, step)) break;
            int finite = 1;
            for (int i = 0; i < STRUTS; i++) {
                q[i] += step[i];
                finite &= isfinite(q[i]);
            }
            if (!finite) break;
            lengths_and_jacobian(joints, base, q, lengths, jacobian);
        }
        if (reached) {
            memcpy(v[2].buf, q, sizeof q);
            memcpy(v[3].buf, lengths, sizeof lengths);
            memcpy(v[4].buf, jacobian, sizeof jacobian);
        }
        result = PyBool_FromLong(reached);
    }
    for (int k = 0; k < 6; k++) PyBuffer_Release(&v[k]);
    return result;
}

static PyMethodDef methods[] = {
    {"track", track, METH_VARARGS,
     "track(joints, base, pose, lengths, jacobian, target, tolerance, max_iterations) -> reached"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_stewart_c",
                                    "The tracking forward kinematics of hex_control.kinematics.stewart, in C.", -1,
                                    methods};

PyMODINIT_FUNC PyInit__stewart_c(void) { return PyModule_Create(&module); }
