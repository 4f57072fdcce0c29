/* The contact search and the truncation of hex_control/grinding/contact.py, in C: the two
 * calls a pass simulation makes five times a step, two thirds of its time in plain Python
 * (issue 39 item 1: in lock-step the clock stands while the pass planner simulates).
 *
 * Each function is the plain-float algorithm of contact._patch_of_few / contact._clip_few
 * (with contact._below and contact._interp_sorted) in the same operations and order, for
 * any number of points: on a few points the results are the Python kernel's to the last
 * bit, on many its numpy path's to rounding (numpy sums pairwise). Built by setup.py with
 * -ffp-contract=off (no fused multiply-add, which would round differently) and sin, cos and
 * tan not built in (GCC would merge sin and cos into sincos, not math.sin's); contact.py
 * falls back to the Python kernel when this module is missing, and test_contact.py holds
 * the two together. Arrays come as float64 buffers (contiguous); outputs as bytes of
 * float64. Units: mm, rad.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* numpy.searchsorted on increasing x: the first index with x[i] >= v (left) or > v (right) */
static Py_ssize_t search_left(const double *x, Py_ssize_t n, double v) {
    Py_ssize_t lo = 0, hi = n;
    while (lo < hi) {
        Py_ssize_t mid = lo + (hi - lo) / 2;
        if (x[mid] < v) lo = mid + 1; else hi = mid;
    }
    return lo;
}

static Py_ssize_t search_right(const double *x, Py_ssize_t n, double v) {
    Py_ssize_t lo = 0, hi = n;
    while (lo < hi) {
        Py_ssize_t mid = lo + (hi - lo) / 2;
        if (x[mid] <= v) lo = mid + 1; else hi = mid;
    }
    return lo;
}

/* Python's min(a, b) and max(a, b): the first unless the second is strictly beyond it */
static double py_min(double a, double b) { return b < a ? b : a; }
static double py_max(double a, double b) { return b > a ? b : a; }

/* contact._height: the polyline at `at` given i = searchsorted(x, at), clamped at the ends */
static double height(const double *x, const double *z, Py_ssize_t n, Py_ssize_t i, double at) {
    if (i <= 0) return z[0];
    if (i >= n) return z[n - 1];
    double x0 = x[i - 1], x1 = x[i];
    return z[i - 1] + (z[i] - z[i - 1]) * (at - x0) / (x1 - x0);
}

/* contact._interp_sorted: np.interp at increasing points `at`, in one walk */
static void interp_sorted(const double *at, Py_ssize_t m, const double *xs, const double *zs, Py_ssize_t n,
                          double *out) {
    Py_ssize_t j = 0;
    for (Py_ssize_t k = 0; k < m; k++) {
        double x = at[k];
        while (j < n - 1 && xs[j + 1] <= x) j++;
        if (x < xs[0]) out[k] = zs[0];
        else if (j >= n - 1) out[k] = zs[n - 1];
        else out[k] = (zs[j + 1] - zs[j]) / (xs[j + 1] - xs[j]) * (x - xs[j]) + zs[j];
    }
}

static int float_buffers(Py_buffer *views, int count) {
    for (int k = 0; k < count; k++) {
        if (views[k].len % (Py_ssize_t)sizeof(double) != 0 || views[k].len == 0
            || (uintptr_t)views[k].buf % sizeof(double) != 0) {
            PyErr_SetString(PyExc_ValueError, "need non-empty, aligned float64 arrays");
            return 0;
        }
        if (views[k].len > PY_SSIZE_T_MAX / 64) { /* the work arrays' sizes stay far from overflow */
            PyErr_SetString(PyExc_ValueError, "arrays too long");
            return 0;
        }
    }
    return 1;
}

static void release(Py_buffer *views, int count) {
    for (int k = 0; k < count; k++) PyBuffer_Release(&views[k]);
}

/* contact_patch(x, z, centre_x, centre_z, angle, radius, touch, top)
 *   -> (length mm, centroid mm, runs, the tip inside); runs 0 is no contact */
static PyObject *contact_patch(PyObject *self, PyObject *args) {
    Py_buffer v[2];
    double centre_x, centre_z, angle, radius, touch, top;
    if (!PyArg_ParseTuple(args, "y*y*dddddd", &v[0], &v[1], &centre_x, &centre_z, &angle, &radius, &touch, &top))
        return NULL;
    if (!float_buffers(v, 2) || v[0].len != v[1].len) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "x and z differ in length");
        release(v, 2);
        return NULL;
    }
    const double *x = v[0].buf, *z = v[1].buf;
    Py_ssize_t n = v[0].len / (Py_ssize_t)sizeof(double);
    double length = 0.0, moment = 0.0;
    long runs = 0;
    int tip_inside = 0;
    double tip_z = centre_z - radius * sin(angle);
    if (!(tip_z - touch > top)) {
        double tip_x = centre_x - radius * cos(angle), tan_ = tan(angle);
        double reach = tan_ > 0 ? (top + touch - tip_z) / tan_ * (1 + 1e-9) + 1e-9 : INFINITY;
        double end_x = py_min(centre_x, tip_x + reach);
        Py_ssize_t lo = search_right(x, n, tip_x), hi = search_left(x, n, end_x);
        Py_ssize_t points = hi > lo ? hi - lo : 0; /* the points under the face's reach, then its end */
        double x0 = tip_x;
        double d0 = height(x, z, n, lo, tip_x) - (centre_z - (centre_x - x0) * tan_) + touch;
        tip_inside = d0 > 0;
        runs = tip_inside ? 1 : 0;
        for (Py_ssize_t k = 0; k <= points; k++) {
            double x1, z1;
            if (k < points) { x1 = x[lo + k]; z1 = z[lo + k]; }
            else { x1 = end_x; z1 = height(x, z, n, hi, end_x); }
            double d1 = z1 - (centre_z - (centre_x - x1) * tan_) + touch;
            if (d0 > 0 || d1 > 0) {
                double start = d0 > 0 ? x0 : x0 + (x1 - x0) * d0 / (d0 - d1);
                double end = d1 > 0 ? x1 : x0 + (x1 - x0) * d0 / (d0 - d1);
                length += end - start;
                moment += (end - start) * (centre_x - (start + end) / 2);
                if (d1 > 0 && 0 >= d0) runs++;
            }
            x0 = x1;
            d0 = d1;
        }
        if (runs > 0) {
            double secant = 1.0 / cos(angle);
            length *= secant;
            if (length > 0) moment = moment * secant * secant / length;
            else runs = 0;
        }
    }
    release(v, 2);
    if (runs == 0) return Py_BuildValue("ddlO", 0.0, 0.0, 0L, Py_False);
    return Py_BuildValue("ddlO", length, moment, runs, tip_inside ? Py_True : Py_False);
}

/* Python's list.sort of the crossings merged into the points, nearly sorted already: a stable
 * insertion sort (equal values, -0.0 and +0.0, keep their order as in Python; NaN stops a walk) */
static void sort_stable(double *values, Py_ssize_t m) {
    for (Py_ssize_t k = 1; k < m; k++) {
        double value = values[k];
        Py_ssize_t j = k;
        while (j > 0 && values[j - 1] > value) {
            values[j] = values[j - 1];
            j--;
        }
        values[j] = value;
    }
}

/* clip_region(x, z, cutter_x, cutter_z, top, keep_mm) -> None or (lo, hi, new x, new z) with
 * the new points (bytes of float64) replacing x[lo:hi]; the cutter's x increasing, the
 * contour's heights at most `top`. keep_mm: how far under the contour a cutter point at a
 * vertex of the cutter still touches it (TOUCH_MM * 1e-2). */
static PyObject *clip_region(PyObject *self, PyObject *args) {
    Py_buffer v[4];
    double top, keep_mm;
    if (!PyArg_ParseTuple(args, "y*y*y*y*dd", &v[0], &v[1], &v[2], &v[3], &top, &keep_mm)) return NULL;
    if (!float_buffers(v, 4) || v[0].len != v[1].len || v[2].len != v[3].len) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "x and z differ in length");
        release(v, 4);
        return NULL;
    }
    const double *x = v[0].buf, *z = v[1].buf, *cutter_x = v[2].buf, *cutter_z = v[3].buf;
    Py_ssize_t n = v[0].len / (Py_ssize_t)sizeof(double), c = v[2].len / (Py_ssize_t)sizeof(double);
    PyObject *result = NULL;
    double *memory = NULL, cut_buffer[2 * 8], *trimmed = cut_buffer; /* a few cutter points on the stack */
    double lowest = cutter_z[0];
    for (Py_ssize_t k = 1; k < c; k++) lowest = cutter_z[k] < lowest ? cutter_z[k] : lowest;
    if (lowest >= top) goto nothing;
    /* contact._below: the cutter trimmed to where it can be below top (the rising face's
     * 80 mm to the few that can cut) */
    Py_ssize_t i = 0, j = c - 1;
    while (i < c && !(cutter_z[i] < top)) i++;
    if (i == c) goto nothing; /* a cutter of NaN heights: nothing below the top */
    while (!(cutter_z[j] < top)) j--;
    int trim = !(i == 0 && j == c - 1);
    Py_ssize_t m_cut = j - i + 1 + (i > 0) + (j < c - 1);
    double level = top + 1e-9 * (1.0 + fabs(top));
    const double *cx = cutter_x, *cz = cutter_z;
    if (trim) {
        if (m_cut > 8 && !(trimmed = PyMem_Malloc(2 * (size_t)m_cut * sizeof(double)))) {
            trimmed = cut_buffer;
            PyErr_NoMemory();
            goto done;
        }
        double *tx = trimmed, *tz = trimmed + m_cut;
        Py_ssize_t at = 0;
        if (i > 0) {
            double f = (level - cutter_z[i]) / (cutter_z[i - 1] - cutter_z[i]);
            tx[0] = cutter_x[i] + f * (cutter_x[i - 1] - cutter_x[i]);
            tz[0] = level;
            at = 1;
        }
        memcpy(tx + at, cutter_x + i, (size_t)(j - i + 1) * sizeof(double));
        memcpy(tz + at, cutter_z + i, (size_t)(j - i + 1) * sizeof(double));
        if (j < c - 1) {
            double f = (level - cutter_z[j]) / (cutter_z[j + 1] - cutter_z[j]);
            tx[m_cut - 1] = cutter_x[j] + f * (cutter_x[j + 1] - cutter_x[j]);
            tz[m_cut - 1] = level;
        }
        cx = tx;
        cz = tz;
        c = m_cut;
    }
    double first = py_max(cx[0], x[0]), last = py_min(cx[c - 1], x[n - 1]);
    if (!(first < last)) goto nothing; /* nothing to cut, or a NaN end */
    Py_ssize_t lo = search_left(x, n, first), hi = search_right(x, n, last);
    if (hi < lo) goto nothing; /* a contour whose x does not increase: no window to cut */
    Py_ssize_t start = lo - 1 > 0 ? lo - 1 : 0, stop = hi + 1 < n ? hi + 1 : n;
    const double *xs = x + start, *zs = z + start;
    Py_ssize_t near = stop - start, window = hi - lo;
    /* work arrays: contour at the cutter (c), cutter at the window (window), candidates and
     * added (c + 2 each), merged (window + c + 2), depth (same), new (2 (window + c + 2)),
     * original and cutter at new (same each), out x and z (same each) */
    Py_ssize_t merged_cap = window + c + 2, new_cap = 2 * merged_cap;
    memory = PyMem_Malloc((size_t)(c + window + 2 * (c + 2) + 2 * merged_cap + 5 * new_cap) * sizeof(double));
    if (!memory) { PyErr_NoMemory(); goto done; }
    double *contour_at_cutter = memory, *cutter_at_window = contour_at_cutter + c;
    double *candidates = cutter_at_window + window, *added = candidates + c + 2;
    double *merged = added + c + 2, *depth = merged + merged_cap, *fresh = depth + merged_cap;
    double *original = fresh + new_cap, *cutter_at = original + new_cap, *out_x = cutter_at + new_cap;
    double *out_z = out_x + new_cap;
    interp_sorted(cx, c, xs, zs, near, contour_at_cutter);
    int cuts = 0;
    for (Py_ssize_t k = 0; k < c && !cuts; k++)
        cuts = first <= cx[k] && cx[k] <= last && cz[k] < contour_at_cutter[k];
    if (!cuts) {
        interp_sorted(x + lo, window, cx, cz, c, cutter_at_window);
        for (Py_ssize_t k = 0; k < window && !cuts; k++) cuts = z[lo + k] > cutter_at_window[k];
    }
    if (!cuts) goto nothing;
    /* the span's ends and the cutter's vertices inside it, where not contour points: kept
     * while looking for crossings, dropped after where nothing is cut (a bisect insertion) */
    Py_ssize_t count = 0;
    candidates[count++] = first;
    for (Py_ssize_t k = 0; k < c; k++)
        if (first < cx[k] && cx[k] < last) candidates[count++] = cx[k];
    candidates[count++] = last;
    memcpy(merged, x + lo, (size_t)window * sizeof(double));
    Py_ssize_t size = window, n_added = 0;
    for (Py_ssize_t k = 0; k < count; k++) {
        double value = candidates[k];
        Py_ssize_t at = search_left(merged, size, value);
        if (at == size || merged[at] != value) {
            memmove(merged + at + 1, merged + at, (size_t)(size - at) * sizeof(double));
            merged[at] = value;
            size++;
            added[n_added++] = value;
        }
    }
    interp_sorted(merged, size, xs, zs, near, depth);
    interp_sorted(merged, size, cx, cz, c, original); /* scratch: the cutter at the merged points */
    for (Py_ssize_t k = 0; k < size; k++) depth[k] = depth[k] - original[k];
    Py_ssize_t m = 0;
    int crossed = 0;
    fresh[m++] = merged[0];
    for (Py_ssize_t k = 0; k < size - 1; k++) {
        double a = depth[k], b = depth[k + 1];
        if ((a > 0 && 0 > b) || (a < 0 && 0 < b)) {
            fresh[m++] = merged[k] + a / (a - b) * (merged[k + 1] - merged[k]);
            crossed = 1;
        }
        fresh[m++] = merged[k + 1];
    }
    if (crossed) { /* a crossing at a vertex (within 1e-9 mm) is the vertex */
        sort_stable(fresh, m);
        Py_ssize_t kept = 1;
        for (Py_ssize_t k = 1; k < m; k++)
            if (fresh[k] - fresh[k - 1] > 1e-9) out_x[kept++] = fresh[k];
        out_x[0] = fresh[0];
        memcpy(fresh, out_x, (size_t)kept * sizeof(double));
        m = kept;
    }
    interp_sorted(fresh, m, xs, zs, near, original);
    interp_sorted(fresh, m, cx, cz, c, cutter_at);
    Py_ssize_t kept = 0;
    for (Py_ssize_t k = 0; k < m; k++) {
        int keep = cutter_at[k] <= original[k] + keep_mm;
        if (!keep) {
            keep = 1;
            for (Py_ssize_t a = 0; a < n_added; a++)
                if (added[a] == fresh[k]) { keep = 0; break; }
        }
        if (keep) {
            out_x[kept] = fresh[k];
            out_z[kept] = py_min(original[k], cutter_at[k]);
            kept++;
        }
    }
    result = Py_BuildValue("nny#y#", lo, hi, (const char *)out_x, kept * (Py_ssize_t)sizeof(double),
                           (const char *)out_z, kept * (Py_ssize_t)sizeof(double));
    goto done;
nothing:
    result = Py_None;
    Py_INCREF(result);
done:
    if (trimmed != cut_buffer) PyMem_Free(trimmed);
    PyMem_Free(memory);
    release(v, 4);
    return result;
}

static PyMethodDef methods[] = {
    {"contact_patch", contact_patch, METH_VARARGS,
     "contact_patch(x, z, centre_x, centre_z, angle, radius, touch, top) -> (length, centroid, runs, tip inside)"},
    {"clip_region", clip_region, METH_VARARGS,
     "clip_region(x, z, cutter_x, cutter_z, top, keep_mm) -> None or (lo, hi, new x bytes, new z bytes)"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_contact_c",
                                    "The contact kernel of hex_control.grinding.contact, in C.", -1, methods};

PyMODINIT_FUNC PyInit__contact_c(void) { return PyModule_Create(&module); }
