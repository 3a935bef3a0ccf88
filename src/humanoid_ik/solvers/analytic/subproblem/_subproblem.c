/* The subproblem solver's Python binding: a CPython extension module on Python's headers
   only (no MuJoCo), built by setup.py from this file and subproblems.c (the arithmetic:
   the subproblems, the families, the ranges; see its opening comment).

   Arm(...) holds an arm's numbers (ArmGeometry), nothing a call changes: any thread may
   call it, and solve() runs without the GIL. solve() finds every solution, applies the
   ranges and writes the pick into the caller's array; solutions() returns every
   solution. The answer's errors are measured by lm's kernel (_lm_kernel.c), from
   MuJoCo's FK of it. Every buffer is checked (C-contiguous float64, its length) before
   it is read. */

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <string.h>

#include "subproblems.h"

typedef struct {
  PyObject_HEAD
  LockedArm g; /* g.locked: -1 for a 6-hinge arm (g.arm alone) */
  Py_ssize_t n; /* the chain's joints: 6, or 7 with one locked */
} Arm;

static int get_array(PyObject* obj, Py_buffer* view, Py_ssize_t n, int writable, const char* name) {
  int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
  if (PyObject_GetBuffer(obj, view, flags) < 0) {
    PyErr_Format(PyExc_TypeError, "%s must be a C-contiguous%s float64 array", name,
                 writable ? " writable" : "");
    return -1;
  }
  const char* f = view->format ? view->format : "B";
  if (*f == '<' || *f == '=' || *f == '@') f++;
  if (view->itemsize != 8 || f[0] != 'd' || f[1] != '\0' || view->len / 8 != n) {
    PyErr_Format(PyExc_ValueError, "%s must be %zd float64 values", name, n);
    PyBuffer_Release(view);
    return -1;
  }
  return 0;
}

static int Arm_init(Arm* self, PyObject* args, PyObject* kwds) {
  int family, pcase, reverse, locked = -1;
  PyObject *ax, *pt, *R0, *p0, *W, *O, *lh = Py_None, *lp = Py_None;
  static char* kw[] = {"family", "position_case", "reverse", "axes", "points", "end_rotation",
                       "end_position", "wrist", "meet", "locked", "locked_axis",
                       "locked_point", NULL};
  if (!PyArg_ParseTupleAndKeywords(args, kwds, "iipOOOOOO|iOO", kw, &family, &pcase, &reverse,
                                   &ax, &pt, &R0, &p0, &W, &O, &locked, &lh, &lp))
    return -1;
  if (family < 0 || family > 1 || pcase < 0 || pcase > 3) {
    PyErr_Format(PyExc_ValueError, "family must be 0 or 1 and position_case 0..3, got %d, %d",
                 family, pcase);
    return -1;
  }
  if (locked != -1 && locked != 0 && locked != 6) {
    PyErr_Format(PyExc_ValueError, "locked must be -1 (none), 0 or 6, got %d", locked);
    return -1;
  }
  int count = locked < 0 ? 6 : 8;
  PyObject* objs[8] = {ax, pt, R0, p0, W, O, lh, lp};
  const char* names[8] = {"axes", "points", "end_rotation", "end_position", "wrist", "meet",
                          "locked_axis", "locked_point"};
  Py_ssize_t sizes[8] = {18, 18, 9, 3, 3, 3, 3, 3};
  ArmGeometry* g = &self->g.arm;
  double* dest[8] = {&g->h[0][0], &g->p[0][0], g->R0, g->p0, g->W, g->O, self->g.h, self->g.p};
  for (int i = 0; i < count; i++) {
    Py_buffer v;
    if (get_array(objs[i], &v, sizes[i], 0, names[i]) < 0) return -1;
    memcpy(dest[i], v.buf, sizes[i] * sizeof(double));
    PyBuffer_Release(&v);
  }
  g->family = family, g->pcase = pcase, g->reverse = reverse;
  self->g.locked = locked;
  self->n = locked < 0 ? 6 : 7;
  return 0;
}

/* shared argument reading: pos, quat, base, q0 */
static int read_common(PyObject* const* args, Py_buffer* v, double* GR, double* Gp, Arm* self) {
  const char* names[4] = {"position", "quaternion", "base", "start"};
  Py_ssize_t sizes[4] = {3, 4, 12, self->n};
  for (int i = 0; i < 4; i++)
    if (get_array(args[i], &v[i], sizes[i], 0, names[i]) < 0) {
      for (int j = 0; j < i; j++) PyBuffer_Release(&v[j]);
      return -1;
    }
  sp_target(&self->g.arm, v[0].buf, v[1].buf, v[2].buf, GR, Gp);
  return 0;
}

PyDoc_STRVAR(solutions_doc,
"solutions(position, quaternion, base, start) -> list of 6-tuples\n"
"\n"
"Every joint vector that puts the end frame at the target (world position, wxyz\n"
"quaternion; base: the chain's base position and row-major rotation in the world),\n"
"each angle in (-pi, pi], ranges not applied. ``start`` settles a straight wrist and,\n"
"on a 7-hinge arm, holds the locked joint (its value is kept as given).");

static PyObject* Arm_solutions(Arm* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 4) {
    PyErr_SetString(PyExc_TypeError, "solutions takes 4 arguments");
    return NULL;
  }
  Py_buffer v[4];
  double GR[9], Gp[3], sol[MAXSOL][7];
  if (read_common(args, v, GR, Gp, self) < 0) return NULL;
  const double* start = v[3].buf;
  int n;
  if (self->g.locked < 0) {
    double s6[MAXSOL][6];
    n = sp_solve_all(&self->g.arm, GR, Gp, start, s6);
    for (int i = 0; i < n; i++) memcpy(sol[i], s6[i], sizeof s6[i]);
  } else {
    n = sp_locked_solutions(&self->g, GR, Gp, start, start[self->g.locked], sol);
  }
  for (int i = 0; i < 4; i++) PyBuffer_Release(&v[i]);
  PyObject* out = PyList_New(n);
  if (!out) return NULL;
  for (int i = 0; i < n; i++) {
    PyObject* t = PyTuple_New(self->n);
    for (Py_ssize_t k = 0; t && k < self->n; k++) {
      PyObject* x = PyFloat_FromDouble(sol[i][k]);
      if (!x) Py_CLEAR(t);
      else PyTuple_SET_ITEM(t, k, x);
    }
    if (!t) {
      Py_DECREF(out);
      return NULL;
    }
    PyList_SET_ITEM(out, i, t);
  }
  return out;
}

/* One target: solve's work (the pick into out, its counts into info: found, inside,
   tried) */
static void solve_target(const Arm* self, const double* GR, const double* Gp, const double* q0,
                         const double* lo, const double* hi, double tol, double* out,
                         double* info) {
  int n, inside, tried = 1;
  if (self->g.locked < 0) {
    inside = sp_solve_pick(&self->g.arm, GR, Gp, q0, lo, hi, tol, out, &n);
  } else {
    inside = sp_search(&self->g, GR, Gp, q0, lo, hi, tol, out, &n, &tried);
  }
  info[0] = n, info[1] = inside, info[2] = tried;
}

PyDoc_STRVAR(solve_doc,
"solve(position, quaternion, base, start, lower, upper, tol, out) -> (found, inside, tried)\n"
"\n"
"Every solution, each angle shifted by multiples of 2 pi into its range (slack ``tol``\n"
"[rad]) nearest the start; the in-range one nearest ``start`` (sum of squares) is\n"
"written into ``out``. ``found``: solutions before the ranges, ``inside``: those in\n"
"range. With none inside, ``out`` holds the solution whose angles (shifted nearest\n"
"the ranges) leave them least, clipped into them; with none at all, ``start``.\n"
"On a 7-hinge arm the locked joint is searched (sp_search in families.c): the first\n"
"value with a solution in range, from the start's outwards; ``found`` is then the most\n"
"solutions at one value, ``tried`` how many values were tried (1 on a 6-hinge arm).");

static PyObject* Arm_solve(Arm* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 8) {
    PyErr_SetString(PyExc_TypeError, "solve takes 8 arguments");
    return NULL;
  }
  Py_buffer v[4], lo, hi, out;
  double GR[9], Gp[3];
  double tol = PyFloat_AsDouble(args[6]);
  if (tol == -1.0 && PyErr_Occurred()) return NULL;
  if (read_common(args, v, GR, Gp, self) < 0) return NULL;
  if (get_array(args[4], &lo, self->n, 0, "lower") < 0) goto fail4;
  if (get_array(args[5], &hi, self->n, 0, "upper") < 0) goto fail5;
  if (get_array(args[7], &out, self->n, 1, "out") < 0) goto fail6;
  double info[3];
  Py_BEGIN_ALLOW_THREADS /* the buffers are held; the arm is only read */
  solve_target(self, GR, Gp, v[3].buf, lo.buf, hi.buf, tol, out.buf, info);
  Py_END_ALLOW_THREADS
  int n = (int)info[0], inside = (int)info[1], tried = (int)info[2];
  PyBuffer_Release(&out);
  PyBuffer_Release(&hi);
  PyBuffer_Release(&lo);
  for (int i = 0; i < 4; i++) PyBuffer_Release(&v[i]);
  return Py_BuildValue("(iii)", n, inside, tried);
fail6:
  PyBuffer_Release(&hi);
fail5:
  PyBuffer_Release(&lo);
fail4:
  for (int i = 0; i < 4; i++) PyBuffer_Release(&v[i]);
  return NULL;
}

PyDoc_STRVAR(solve_many_doc,
"solve_many(positions, quaternions, base, start, lower, upper, tol, out, info) -> None\n"
"\n"
"solve for each of N targets from the same start: positions (3 N,), quaternions (4 N,),\n"
"the picks into out (N n,) and (found, inside, tried) into info (3 N,); each the answer\n"
"solve gives that target, bit for bit. Runs without the GIL.");

static PyObject* Arm_solve_many(Arm* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 9) {
    PyErr_SetString(PyExc_TypeError, "solve_many takes 9 arguments");
    return NULL;
  }
  double tol = PyFloat_AsDouble(args[6]);
  if (tol == -1.0 && PyErr_Occurred()) return NULL;
  Py_buffer v[8];
  int held = 0;
  PyObject* result = NULL;
  Py_buffer probe;
  if (PyObject_GetBuffer(args[0], &probe, PyBUF_C_CONTIGUOUS) < 0) return NULL;
  Py_ssize_t count = probe.len / (3 * (Py_ssize_t)sizeof(double));
  PyBuffer_Release(&probe);
  const char* names[8] = {"positions", "quaternions", "base", "start", "lower", "upper", "out",
                          "info"};
  Py_ssize_t sizes[8] = {3 * count, 4 * count, 12, self->n, self->n, self->n, count * self->n,
                         3 * count};
  int slots[8] = {0, 1, 2, 3, 4, 5, 7, 8};
  for (int i = 0; i < 8; i++, held++) {
    if (get_array(args[slots[i]], &v[i], sizes[i], i >= 6, names[i]) < 0) goto done;
  }
  const double *pos = v[0].buf, *quat = v[1].buf, *base = v[2].buf, *q0 = v[3].buf;
  const double *lo = v[4].buf, *hi = v[5].buf;
  double *out = v[6].buf, *info = v[7].buf;
  Py_BEGIN_ALLOW_THREADS /* the buffers are held; the arm is only read */
  for (Py_ssize_t i = 0; i < count; i++) {
    double GR[9], Gp[3];
    sp_target(&self->g.arm, pos + 3 * i, quat + 4 * i, base, GR, Gp);
    solve_target(self, GR, Gp, q0, lo, hi, tol, out + self->n * i, info + 3 * i);
  }
  Py_END_ALLOW_THREADS
  result = Py_NewRef(Py_None);
done:
  for (int i = 0; i < held; i++) PyBuffer_Release(&v[i]);
  return result;
}

static PyMethodDef module_methods[] = {
    {NULL, NULL, 0, NULL},
};

static PyMethodDef Arm_methods[] = {
    {"solutions", (PyCFunction)(void (*)(void))Arm_solutions, METH_FASTCALL, solutions_doc},
    {"solve", (PyCFunction)(void (*)(void))Arm_solve, METH_FASTCALL, solve_doc},
    {"solve_many", (PyCFunction)(void (*)(void))Arm_solve_many, METH_FASTCALL, solve_many_doc},
    {NULL, NULL, 0, NULL},
};

PyDoc_STRVAR(Arm_doc,
"Arm(family, position_case, reverse, axes, points, end_rotation, end_position, wrist, meet,\n"
"    locked=-1, locked_axis=None, locked_point=None)\n"
"\n"
"A 6-hinge arm in its base frame at zero (float64 arrays: axes and points 18 values,\n"
"end_rotation 9 row-major, end_position, wrist, meet 3 each), in the family's order\n"
"(reversed when ``reverse``). With ``locked`` 0 or 6, a 7-hinge arm: the chain's first\n"
"or last joint (axis and point: 3 values each) searched over, the six others this\n"
"6-hinge arm, the end frame the 7-hinge arm's. Holds numbers only: any thread may call it.");

static PyTypeObject ArmType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "humanoid_ik.solvers.analytic.subproblem._subproblem.Arm",
    .tp_basicsize = sizeof(Arm),
    .tp_itemsize = 0,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = Arm_doc,
    .tp_methods = Arm_methods,
    .tp_init = (initproc)Arm_init,
    .tp_new = PyType_GenericNew,
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT,
    .m_name = "humanoid_ik.solvers.analytic.subproblem._subproblem",
    .m_doc = "Exact IK of 6-hinge arms by Paden-Kahan subproblems, in C.",
    .m_size = -1,
    .m_methods = module_methods,
};

PyMODINIT_FUNC PyInit__subproblem(void) {
  if (PyType_Ready(&ArmType) < 0) return NULL;
  PyObject* mod = PyModule_Create(&module);
  if (!mod) return NULL;
  Py_INCREF(&ArmType);
  if (PyModule_AddObject(mod, "Arm", (PyObject*)&ArmType) < 0) {
    Py_DECREF(&ArmType);
    Py_DECREF(mod);
    return NULL;
  }
  if (PyModule_AddIntConstant(mod, "MAX_SOLUTIONS", MAXSOL) < 0) {
    Py_DECREF(mod);
    return NULL;
  }
  return mod;
}
