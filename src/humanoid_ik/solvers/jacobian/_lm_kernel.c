/* lm's iteration loop: the one implementation, a CPython extension module built
   against the MuJoCo headers and library of the `mujoco` wheel (setup.py).

   `Kernel(model_bytes)` owns a copy of a model, loaded from the bytes of
   `mujoco.mj_saveModel` (there is no public way to get the `mjModel*` behind a
   `mujoco.MjModel`), and an `mjData` of its own. `Kernel.descend(...)` runs one start of
   lm (solvers/jacobian/lm.py keeps the restarts in Python):

     copy the robot's qpos in, put the start q on the chain's joints, then per iteration
     mj_kinematics, the task error from the end effector's position and its body's
     quaternion and rotation (the target orientation is moved into the body's frame at
     the first pass), the stall test, the chain's Jacobian from the joints' axes and anchors
     (chain_jacobian), J' W J + lambda I
     (mju_sqrMatTD), -J' W e (mju_mulMatTVec), the linear term in x = q + dq
     (mju_mulMatVec) and mju_boxQP between the joint ranges, warm-started at q.

   The per-call buffers come from the kernel's own mjData stack (mj_markStack /
   mj_stackAllocNum / mj_freeStack): the object holds no solve's values between calls.
   The loop runs without the GIL. A kernel serves one thread at a time (lm keeps it in
   the robot state's workspace, and the robot state is claimed for a solve); a second
   concurrent call is refused with RuntimeError rather than corrupting the first.

   Every index and size is checked before MuJoCo sees it, and the stack space before it
   is allocated: MuJoCo's own error handler ends the process, so no MuJoCo error may be
   reachable from here. Built with -ffp-contract=off (GCC, Clang) so no multiply-add is
   fused: the same answers on every machine with the same MuJoCo. */

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stdint.h>
#include <string.h>

#include <mujoco/mujoco.h>

#define HISTORY_MAX 100001 /* max_iterations + 1 at its bound (OPTION_BOUNDS) */
#define STACK_SLACK 65536  /* bytes kept free for the stack frame records and MuJoCo */

typedef struct {
  PyObject_HEAD
  mjModel* m;
  mjData* d;
  int busy; /* a call is running (set and cleared with the GIL held) */
} Kernel;

/* ------------------------------------------------------------------ buffers */

/* A C-contiguous buffer of `n` 8-byte items of kind 'd' (float64) or 'i' (int64);
   n < 0 takes any length (stored in *len). */
static int get_array(PyObject* obj, Py_buffer* view, char kind, Py_ssize_t n, int writable,
                     const char* name, Py_ssize_t* len) {
  int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
  if (PyObject_GetBuffer(obj, view, flags) < 0) {
    PyErr_Format(PyExc_TypeError, "%s must be a C-contiguous%s %s array", name,
                 writable ? " writable" : "", kind == 'd' ? "float64" : "int64");
    return -1;
  }
  const char* f = view->format ? view->format : "B";
  if (*f == '<' || *f == '=' || *f == '@') f++;
  int ok = view->itemsize == 8 && f[1] == '\0' &&
           (kind == 'd' ? f[0] == 'd' : (f[0] == 'q' || f[0] == 'l'));
  Py_ssize_t count = view->len / 8;
  if (!ok || view->ndim > 1) {
    PyErr_Format(PyExc_TypeError, "%s must be a one-dimensional %s array", name,
                 kind == 'd' ? "float64" : "int64");
    PyBuffer_Release(view);
    return -1;
  }
  if (n >= 0 && count != n) {
    PyErr_Format(PyExc_ValueError, "%s must have %zd values, got %zd", name, n, count);
    PyBuffer_Release(view);
    return -1;
  }
  if (len) *len = count;
  return 0;
}

/* ------------------------------------------------------------------ the loop */

typedef struct {
  int n, rows, nv, ee_id, body, site, max_iterations, window, history;
  const int64_t *qadr, *dof;
  const mjtNum *lower, *upper, *target_pos, *target_quat;
  mjtNum tol, rot_tol, wr, damp_e, damp_0;
} Problem;

typedef struct {
  int converged, iterations;
  mjtNum cost, ep, er;
} Outcome;

static void put_joints(const Problem* p, mjData* d, const mjtNum* x) {
  for (int i = 0; i < p->n; i++) d->qpos[p->qadr[i]] = x[i];
}

/* The chain's Jacobian J (rows, n) at the end effector's point from the joint frames
   mj_kinematics computed: a hinge's column is axis x (point - anchor) (and the axis for
   the rotation rows), a slide's its axis (and zero). The chain's joints are hinges and
   slides (chains refuse the others), so this is mj_jacSite's (mj_jacBody's) columns of
   the chain's dofs, without mj_comPos and the columns of every other dof. */
static void chain_jacobian(const mjModel* m, const mjData* d, const Problem* p,
                           const mjtNum* point, mjtNum* J) {
  const int n = p->n, pose = p->rows == 6;
  for (int i = 0; i < n; i++) {
    int j = m->dof_jntid[p->dof[i]];
    const mjtNum* axis = d->xaxis + 3 * j;
    mjtNum col[3];
    if (m->jnt_type[j] == mjJNT_HINGE) {
      mjtNum r[3];
      mju_sub3(r, point, d->xanchor + 3 * j);
      mju_cross(col, axis, r);
    } else {
      mju_copy3(col, axis);
    }
    for (int k = 0; k < 3; k++) J[k * n + i] = col[k];
    if (pose) {
      int hinge = m->jnt_type[j] == mjJNT_HINGE;
      for (int k = 0; k < 3; k++) J[(3 + k) * n + i] = hinge ? axis[k] : 0.0;
    }
  }
}

/* Iterate from q (n,), which ends at the converged pose or this start's best pose (the
   lowest e' W e); the cost and the errors are those of that pose. The stall rule is the
   one of solvers/iterate.py (Stall): no 1 % drop over the last `window` iterations. */
static Outcome descend(const mjModel* m, mjData* d, const Problem* p, mjtNum* q) {
  const int n = p->n, rows = p->rows, pose = rows == 6;
  Outcome out = {0, 0, INFINITY, NAN, NAN};
  mjtNum e[6] = {0}, q_err[3], target_body[4], w[6] = {1, 1, 1, p->wr, p->wr, p->wr};
  mjtNum *e_p = e, *e_r = e + 3;
  mjtNum best = INFINITY, best_ep = NAN, best_er = NAN, ep = 0.0, er = 0.0, cost = 0.0;
  const mjtNum* xpos = p->site ? d->site_xpos + 3 * p->ee_id : d->xpos + 3 * p->ee_id;
  const mjtNum* body_quat = d->xquat + 4 * p->body;
  const mjtNum* body_mat = d->xmat + 9 * p->body;
  int it;

  mj_markStack(d);
  mjtNum* J = mj_stackAllocNum(d, (size_t)rows * n);
  mjtNum* H = mj_stackAllocNum(d, (size_t)n * n);
  mjtNum* R = mj_stackAllocNum(d, (size_t)n * (n + 7));
  mjtNum* g = mj_stackAllocNum(d, n);
  mjtNum* Hx = mj_stackAllocNum(d, n);
  mjtNum* x = mj_stackAllocNum(d, n);
  mjtNum* best_q = mj_stackAllocNum(d, n);
  mjtNum* history = mj_stackAllocNum(d, p->history);

  memcpy(x, q, sizeof(mjtNum) * n);
  memcpy(best_q, q, sizeof(mjtNum) * n);
  for (int k = 0; k < p->history; k++) history[k] = INFINITY;
  for (it = 0; it <= p->max_iterations; it++) {
    put_joints(p, d, x);
    mj_kinematics(m, d);
    if (it == 0 && pose) {
      /* target_body = quat * s^-1 * b: the body orientation that puts the site on the
         target, from this pass's site and body frames (the site's placement on its
         body as MuJoCo computes it) */
      if (p->site) {
        mjtNum site[4], rel[4], tmp[4];
        mju_mat2Quat(site, d->site_xmat + 9 * p->ee_id);
        mju_negQuat(rel, site);
        mju_mulQuat(tmp, p->target_quat, rel);
        mju_mulQuat(target_body, tmp, body_quat);
      } else {
        memcpy(target_body, p->target_quat, sizeof(mjtNum) * 4);
      }
    }
    mju_sub3(e_p, xpos, p->target_pos); /* -e: g = J' W (-e) needs no negation */
    ep = mju_norm3(e_p);
    if (pose) {
      /* -w: log(t^-1 b) in the body's frame, to the world by the body's rotation */
      mju_subQuat(q_err, body_quat, target_body);
      mju_mulMatVec3(e_r, body_mat, q_err);
      er = mju_norm3(e_r);
      mju_scl3(e_r, e_r, p->wr);
    }
    cost = ep * ep + p->wr * er * er;
    if (cost < best) {
      best = cost, best_ep = ep, best_er = er;
      memcpy(best_q, x, sizeof(mjtNum) * n);
    }
    if (ep < p->tol && er < p->rot_tol) {
      memcpy(q, x, sizeof(mjtNum) * n);
      out.converged = 1, out.iterations = it, out.cost = cost, out.ep = ep, out.er = er;
      mj_freeStack(d);
      return out;
    }
    int slot = it % p->window; /* < history: see the caller */
    if (it == p->max_iterations || (it >= p->window && cost > 0.99 * history[slot])) break;
    history[slot] = cost;
    chain_jacobian(m, d, p, xpos, J);
    mju_sqrMatTD(H, J, w, rows, n); /* H = J' W J */
    mjtNum lambda = p->damp_e * cost + p->damp_0;
    for (int i = 0; i < n; i++) H[i * (n + 1)] += lambda; /* + lambda I */
    mju_mulMatTVec(g, J, e, rows, n);                     /* g = -J' W e */
    mju_mulMatVec(Hx, H, x, n, n);
    mju_addToScl(g, Hx, -1.0, n); /* in x = q + dq: the linear term g - H q */
    if (mju_boxQP(x, R, NULL, H, g, n, p->lower, p->upper) < 0) {
      break; /* not positive definite (an overflow): this start ends like a stall */
    }
  }
  memcpy(q, best_q, sizeof(mjtNum) * n);
  out.iterations = it, out.cost = best, out.ep = best_ep, out.er = best_er;
  mj_freeStack(d);
  return out;
}

/* ------------------------------------------------------------------ the type */

static void Kernel_dealloc(Kernel* self) {
  if (self->d) mj_deleteData(self->d);
  if (self->m) mj_deleteModel(self->m);
  Py_TYPE(self)->tp_free((PyObject*)self);
}

static int Kernel_init(Kernel* self, PyObject* args, PyObject* kwds) {
  static char* keywords[] = {"model", NULL};
  Py_buffer buf;
  if (!PyArg_ParseTupleAndKeywords(args, kwds, "y*:Kernel", keywords, &buf)) return -1;
  if (self->m) {
    PyBuffer_Release(&buf);
    PyErr_SetString(PyExc_RuntimeError, "Kernel is already initialised");
    return -1;
  }
  mjModel* m = mj_loadModelBuffer(buf.buf, (mjtSize)buf.len);
  PyBuffer_Release(&buf);
  if (!m) {
    PyErr_SetString(PyExc_ValueError,
                    "Kernel: the bytes are not a model saved by mujoco.mj_saveModel");
    return -1;
  }
  /* room on the stack for the largest call: (6 + 6) nv + 2 nv^2 + 11 nv + HISTORY_MAX */
  mjtSize nv = m->nv;
  m->narena += (mjtSize)sizeof(mjtNum) * (23 * nv + 2 * nv * nv + HISTORY_MAX) + STACK_SLACK;
  mjData* d = mj_makeData(m);
  if (!d) {
    mj_deleteModel(m);
    PyErr_NoMemory();
    return -1;
  }
  self->m = m;
  self->d = d;
  return 0;
}

static int as_int(PyObject* obj, const char* name, long lo, long hi, int* out) {
  long v = PyLong_AsLong(obj);
  if (v == -1 && PyErr_Occurred()) return -1;
  if (v < lo || v > hi) {
    PyErr_Format(PyExc_ValueError, "%s must be in [%ld, %ld], got %ld", name, lo, hi, v);
    return -1;
  }
  *out = (int)v;
  return 0;
}

PyDoc_STRVAR(descend_doc,
"descend(qpos, qpos_adr, dof_adr, site, ee_id, lower, upper, target_pos, target_quat,\n"
"        options, q) -> (converged, iterations, cost, position_error, orientation_error)\n"
"\n"
"One start of lm. qpos (nq,) float64: the robot's scratch joints (the joints off the\n"
"chain stay there); qpos_adr, dof_adr (n,) int64: the chain's addresses; site: True\n"
"for a site end effector, False for a body; ee_id: its id; lower, upper (n,) float64:\n"
"the joint ranges (+-inf for none); target_pos (3,); target_quat: None for a position\n"
"target, else the wxyz orientation (4,) of the site (body) frame; options: (tol,\n"
"rot_tol, weight^2, error_damping, min_damping, max_iterations, stall_window); q (n,)\n"
"float64, writable: the start, overwritten with the converged pose or this start's\n"
"best pose. cost is e' W e of that pose, and the errors are that pose's (the\n"
"orientation error 0 for a position target).");

static PyObject* Kernel_descend(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 11) {
    PyErr_Format(PyExc_TypeError, "descend() takes 11 arguments, got %zd", nargs);
    return NULL;
  }
  if (!self->m) {
    PyErr_SetString(PyExc_RuntimeError, "Kernel is not initialised");
    return NULL;
  }
  if (self->busy) {
    PyErr_SetString(PyExc_RuntimeError,
                    "this lm kernel is in use by another thread; a kernel serves one "
                    "thread at a time (give each thread its own robot state)");
    return NULL;
  }
  const mjModel* m = self->m;
  mjData* d = self->d;
  Problem p;
  memset(&p, 0, sizeof(p));
  Py_buffer views[8];
  int held = 0;
  PyObject* result = NULL;
  Py_ssize_t n = 0;

  p.site = PyObject_IsTrue(args[3]);
  if (p.site < 0) goto done;
  if (get_array(args[10], &views[held], 'd', -1, 1, "q", &n) < 0) goto done;
  held++;
  if (n < 1 || n > m->nv) {
    PyErr_Format(PyExc_ValueError, "q must have 1 to nv = %lld values, got %zd",
                 (long long)m->nv, n);
    goto done;
  }
  mjtNum* q = views[0].buf;
  if (get_array(args[0], &views[held], 'd', (Py_ssize_t)m->nq, 0, "qpos", NULL) < 0) goto done;
  const mjtNum* qpos = views[held++].buf;
  if (get_array(args[1], &views[held], 'i', n, 0, "qpos_adr", NULL) < 0) goto done;
  p.qadr = views[held++].buf;
  if (get_array(args[2], &views[held], 'i', n, 0, "dof_adr", NULL) < 0) goto done;
  p.dof = views[held++].buf;
  if (get_array(args[5], &views[held], 'd', n, 0, "lower", NULL) < 0) goto done;
  p.lower = views[held++].buf;
  if (get_array(args[6], &views[held], 'd', n, 0, "upper", NULL) < 0) goto done;
  p.upper = views[held++].buf;
  if (get_array(args[7], &views[held], 'd', 3, 0, "target_pos", NULL) < 0) goto done;
  p.target_pos = views[held++].buf;
  if (args[8] != Py_None) {
    if (get_array(args[8], &views[held], 'd', 4, 0, "target_quat", NULL) < 0) goto done;
    p.target_quat = views[held++].buf;
  }
  for (Py_ssize_t i = 0; i < n; i++) {
    if (p.qadr[i] < 0 || p.qadr[i] >= m->nq || p.dof[i] < 0 || p.dof[i] >= m->nv) {
      PyErr_Format(PyExc_ValueError, "joint %zd: qpos address %lld or dof address %lld "
                   "is outside the model", i, (long long)p.qadr[i], (long long)p.dof[i]);
      goto done;
    }
    int type = m->jnt_type[m->dof_jntid[p.dof[i]]];
    if (type != mjJNT_HINGE && type != mjJNT_SLIDE) { /* chain_jacobian's joints */
      PyErr_Format(PyExc_ValueError, "joint %zd: dof address %lld is not a hinge's or a slide's",
                   i, (long long)p.dof[i]);
      goto done;
    }
  }
  long count = p.site ? (long)m->nsite : (long)m->nbody;
  if (as_int(args[4], "ee_id", p.site ? 0 : 1, count - 1, &p.ee_id) < 0) goto done;
  p.body = p.site ? m->site_bodyid[p.ee_id] : p.ee_id;

  PyObject* opts = args[9];
  if (!PyTuple_Check(opts) || PyTuple_GET_SIZE(opts) != 7) {
    PyErr_SetString(PyExc_TypeError, "options must be a tuple of 7 values");
    goto done;
  }
  mjtNum f[5];
  for (int k = 0; k < 5; k++) {
    f[k] = PyFloat_AsDouble(PyTuple_GET_ITEM(opts, k));
    if (f[k] == -1.0 && PyErr_Occurred()) goto done;
  }
  p.tol = f[0], p.rot_tol = f[1], p.wr = f[2], p.damp_e = 0.5 * f[3], p.damp_0 = f[4];
  if (as_int(PyTuple_GET_ITEM(opts, 5), "max_iterations", 0, HISTORY_MAX - 1,
             &p.max_iterations) < 0 ||
      as_int(PyTuple_GET_ITEM(opts, 6), "stall_window", 1, INT32_MAX, &p.window) < 0) {
    goto done;
  }
  /* the stall test reads slot it % window only once it >= window, so a window longer
     than the iterations needs max_iterations + 1 slots */
  p.history = p.window < p.max_iterations + 1 ? p.window : p.max_iterations + 1;
  p.n = (int)n;
  p.nv = (int)m->nv;
  p.rows = p.target_quat ? 6 : 3;

  size_t need = sizeof(mjtNum) * ((size_t)12 * p.nv + 2 * (size_t)p.n * p.n + 11 * (size_t)p.n +
                                  (size_t)p.history);
  size_t free_bytes = (size_t)d->narena - d->parena - d->pstack;
  if (need + STACK_SLACK > free_bytes) {
    PyErr_Format(PyExc_MemoryError, "lm kernel: %zu bytes of MuJoCo stack needed, %zu free",
                 need + STACK_SLACK, free_bytes);
    goto done;
  }

  Outcome out;
  self->busy = 1;
  Py_BEGIN_ALLOW_THREADS
  memcpy(d->qpos, qpos, sizeof(mjtNum) * (size_t)m->nq);
  out = descend(m, d, &p, q);
  Py_END_ALLOW_THREADS
  self->busy = 0;
  result = Py_BuildValue("(Oiddd)", out.converged ? Py_True : Py_False, out.iterations,
                         (double)out.cost, (double)out.ep, (double)out.er);

done:
  for (int k = 0; k < held; k++) PyBuffer_Release(&views[k]);
  return result;
}

static PyObject* Kernel_get_nq(Kernel* self, void* closure) {
  return PyLong_FromLongLong(self->m ? (long long)self->m->nq : 0);
}

static PyObject* Kernel_get_nv(Kernel* self, void* closure) {
  return PyLong_FromLongLong(self->m ? (long long)self->m->nv : 0);
}

static PyMethodDef Kernel_methods[] = {
    {"descend", (PyCFunction)(void (*)(void))Kernel_descend, METH_FASTCALL, descend_doc},
    {NULL, NULL, 0, NULL},
};

static PyGetSetDef Kernel_getset[] = {
    {"nq", (getter)Kernel_get_nq, NULL, "qpos size of the kernel's model", NULL},
    {"nv", (getter)Kernel_get_nv, NULL, "dof count of the kernel's model", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

PyDoc_STRVAR(Kernel_doc,
"Kernel(model)\n"
"\n"
"lm's iteration loop on a copy of a model: ``model`` is the bytes that\n"
"``mujoco.mj_saveModel`` writes. The kernel owns that model and an MjData of its\n"
"own; ``descend`` runs one start. One thread at a time.");

static PyTypeObject KernelType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "humanoid_ik.solvers.jacobian._lm_kernel.Kernel",
    .tp_basicsize = sizeof(Kernel),
    .tp_itemsize = 0,
    .tp_dealloc = (destructor)Kernel_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = Kernel_doc,
    .tp_methods = Kernel_methods,
    .tp_getset = Kernel_getset,
    .tp_init = (initproc)Kernel_init,
    .tp_new = PyType_GenericNew,
};

/* ------------------------------------------------------------------ the module */

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT,
    .m_name = "humanoid_ik.solvers.jacobian._lm_kernel",
    .m_doc = "lm's iteration loop in C, on MuJoCo's own headers and library.",
    .m_size = -1,
};

PyMODINIT_FUNC PyInit__lm_kernel(void) {
  if (mj_version() != mjVERSION_HEADER) {
    PyErr_Format(PyExc_ImportError,
                 "humanoid_ik's lm kernel was built against MuJoCo %d.%d.%d but MuJoCo %s "
                 "is loaded: reinstall humanoid_ik with this MuJoCo",
                 mjVERSION_HEADER / 1000000, mjVERSION_HEADER / 1000 % 1000,
                 mjVERSION_HEADER % 1000, mj_versionString());
    return NULL;
  }
  if (PyType_Ready(&KernelType) < 0) return NULL;
  PyObject* mod = PyModule_Create(&module);
  if (!mod) return NULL;
  Py_INCREF(&KernelType);
  if (PyModule_AddObject(mod, "Kernel", (PyObject*)&KernelType) < 0) {
    Py_DECREF(&KernelType);
    Py_DECREF(mod);
    return NULL;
  }
  if (PyModule_AddIntConstant(mod, "MUJOCO_VERSION", mjVERSION_HEADER) < 0) {
    Py_DECREF(mod);
    return NULL;
  }
  return mod;
}
