/* lm's iteration loop: the one implementation, a CPython extension module built
   against the MuJoCo headers and library of the `mujoco` wheel (setup.py).

   `Kernel(model_bytes)` owns a copy of a model, loaded from the bytes of
   `mujoco.mj_saveModel` (there is no public way to get the `mjModel*` behind a
   `mujoco.MjModel`), and an `mjData` of its own. `Kernel.descend(...)` runs one start of
   lm (solvers/jacobian/lm.py keeps a single solve's restarts in Python);
   `Kernel.solve(...)` runs lm's whole solve of many targets, restarts included, in the
   order lm.py takes them (solve_batch's path: the same answers). One start:

     copy the robot's qpos in, put the start q on the chain's joints, then per iteration
     the forward kinematics of the bodies on the way from the world to the end effector
     only (at the first pass; after it, of those the chain's joints move), computed as
     mj_kinematics computes them (chain_kinematics: the same bits), the task error from
     the end effector's position and its body's quaternion and rotation (the target
     orientation is moved into the body's frame at the first pass), the stall test, the
     chain's Jacobian from the joints' axes and anchors (chain_jacobian), J' W J +
     lambda I (mju_sqrMatTD), -J' W e (mju_mulMatTVec), the linear term in x = q + dq
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
#define SEEDS_MAX 4000     /* library_seeds at its bound, restarts within theirs (OPTION_BOUNDS) */

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

/* A seed library's arrays (solvers/jacobian/seeds.py SeedLibrary): positions (3 L,),
   rotations (9 L,), poses (L n,), what a radian weighs in its ranking (length >= 0),
   and the grid of cubic cells over the positions that orders them: grid (7,) = the
   corner (x, y, z) of cell (0, 0, 0), the cells' side h > 0 and their counts gx, gy, gz
   along x, y, z; cells (gx gy gz + 1,) int64: the poses of cell (ix, iy, iz) are
   cells[c] to cells[c + 1] - 1, c = (iz gy + iy) gx + ix. */
typedef struct {
  const mjtNum *positions, *rotations, *poses, *corner;
  const int64_t* cells;
  Py_ssize_t size;
  mjtNum length, side;
  int dims[3];
} Library;

enum { GRID_MAX = 1024 }; /* cells along one axis at most */

/* The library's arrays into *lib, their views into views from *held on (the caller
   releases them, also on failure); rotations and poses are read only where not NULL
   (n: the poses' joints). Returns -1 with a Python error set. */
static int get_library(PyObject* positions, PyObject* rotations, PyObject* grid,
                       PyObject* cells, PyObject* poses, int n, PyObject* length,
                       Py_buffer* views, int* held, Library* lib) {
  Py_ssize_t len = 0;
  memset(lib, 0, sizeof(*lib));
  if (get_array(positions, &views[*held], 'd', -1, 0, "positions", &len) < 0) return -1;
  lib->positions = views[(*held)++].buf;
  if (len % 3) {
    PyErr_Format(PyExc_ValueError, "positions must have 3 values per pose, got %zd", len);
    return -1;
  }
  lib->size = len / 3;
  if (get_array(grid, &views[*held], 'd', 7, 0, "grid", NULL) < 0) return -1;
  const mjtNum* g = views[(*held)++].buf;
  lib->corner = g, lib->side = g[3];
  Py_ssize_t count = 1;
  for (int a = 0; a < 3; a++) {
    mjtNum v = g[4 + a];
    if (!(v >= 1 && v <= GRID_MAX && v == (int)v)) {
      PyErr_Format(PyExc_ValueError, "grid's cell counts must be whole numbers in [1, %d]",
                   GRID_MAX);
      return -1;
    }
    lib->dims[a] = (int)v, count *= (Py_ssize_t)v;
  }
  if (!(lib->side > 0.0 && isfinite(lib->side) && isfinite(g[0]) && isfinite(g[1]) &&
        isfinite(g[2]))) {
    PyErr_SetString(PyExc_ValueError, "grid's corner and side must be finite, the side > 0");
    return -1;
  }
  if (get_array(cells, &views[*held], 'i', count + 1, 0, "cells", NULL) < 0) return -1;
  lib->cells = views[(*held)++].buf;
  if (lib->cells[0] != 0 || lib->cells[count] != lib->size) {
    PyErr_Format(PyExc_ValueError, "cells must run from 0 to the %zd poses", lib->size);
    return -1;
  }
  if (rotations) {
    if (get_array(rotations, &views[*held], 'd', 9 * lib->size, 0, "rotations", NULL) < 0) {
      return -1;
    }
    lib->rotations = views[(*held)++].buf;
  }
  if (poses) {
    if (get_array(poses, &views[*held], 'd', lib->size * n, 0, "poses", NULL) < 0) return -1;
    lib->poses = views[(*held)++].buf;
  }
  lib->length = PyFloat_AsDouble(length);
  if (lib->length == -1.0 && PyErr_Occurred()) return -1;
  if (!(lib->length >= 0.0)) {
    PyErr_Format(PyExc_ValueError, "length must be >= 0, got %g", (double)lib->length);
    return -1;
  }
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

/* The bodies from the world's child down to the end effector's body, parents first (in
   mj_kinematics's order), into path (nbody ints); their count is returned and *moving
   set to the index in path of the topmost body with a chain joint: the bodies from there
   on are the ones the chain's joints move. Returns 0 when a chain joint is not above the
   end effector (then every pass runs mj_kinematics). */
static int chain_bodies(const mjModel* m, const Problem* p, int* path, int* moving) {
  int count = 0, top = -1;
  for (int b = p->body; b > 0; b = m->body_parentid[b]) path[count++] = b; /* end first */
  for (int i = 0; i < p->n; i++) {
    int body = m->jnt_bodyid[m->dof_jntid[p->dof[i]]], k = 0;
    while (k < count && path[k] != body) k++;
    if (k == count) return 0;
    if (k > top) top = k;
  }
  for (int i = 0, j = count - 1; i < j; i++, j--) {
    int b = path[i];
    path[i] = path[j], path[j] = b;
  }
  *moving = count - 1 - top;
  return count;
}

/* mj_kinematics's frames (xpos, xquat, xmat, and each joint's xanchor and xaxis) of the
   `count` bodies of `path`, each from its parent's frame, its qpos (or its mocap pose),
   with the same operations in the same order as mj_kinematics (its first part): the
   same bits. Nothing else is computed: the kernel's own data serves this loop only.
   Without `axes` the joints' xaxis is not computed (a measure needs no Jacobian). */
static void chain_kinematics(const mjModel* m, mjData* d, const int* path, int count, int axes) {
  for (int k = 0; k < count; k++) {
    int i = path[k], pid = m->body_parentid[i];
    int adr = m->body_jntadr[i], num = m->body_jntnum[i];
    mjtNum xpos[3], xquat[4];
    if (num == 1 && m->jnt_type[adr] == mjJNT_FREE) {
      int qadr = m->jnt_qposadr[adr];
      mju_copy3(xpos, d->qpos + qadr);
      mju_copy4(xquat, d->qpos + qadr + 3);
      mju_normalize4(xquat);
      mju_copy3(d->xanchor + 3 * adr, xpos);
      mju_copy3(d->xaxis + 3 * adr, m->jnt_axis + 3 * adr);
      num = 0;
    } else {
      const mjtNum *bodypos = m->body_pos + 3 * i, *bodyquat = m->body_quat + 4 * i;
      mjtNum mocap[4];
      if (m->body_mocapid[i] >= 0) {
        bodypos = d->mocap_pos + 3 * m->body_mocapid[i];
        mju_copy4(mocap, d->mocap_quat + 4 * m->body_mocapid[i]);
        mju_normalize4(mocap);
        bodyquat = mocap;
      }
      if (pid) {
        mju_mulMatVec3(xpos, d->xmat + 9 * pid, bodypos);
        mju_addTo3(xpos, d->xpos + 3 * pid);
        mju_mulQuat(xquat, d->xquat + 4 * pid, bodyquat);
      } else {
        mju_copy3(xpos, bodypos);
        mju_copy4(xquat, bodyquat);
      }
    }
    for (int j = adr; j < adr + num; j++) {
      int qadr = m->jnt_qposadr[j];
      mjtNum xanchor[3], xaxis[3];
      if (axes) mju_rotVecQuat(xaxis, m->jnt_axis + 3 * j, xquat);
      mju_rotVecQuat(xanchor, m->jnt_pos + 3 * j, xquat);
      mju_addTo3(xanchor, xpos);
      if (m->jnt_type[j] == mjJNT_SLIDE) {
        mju_addToScl3(xpos, xaxis, d->qpos[qadr] - m->qpos0[qadr]);
      } else { /* hinge or ball (a free joint is a body's only joint) */
        mjtNum qloc[4], vec[3];
        if (m->jnt_type[j] == mjJNT_BALL) {
          mju_copy4(qloc, d->qpos + qadr);
          mju_normalize4(qloc);
        } else {
          mju_axisAngle2Quat(qloc, m->jnt_axis + 3 * j, d->qpos[qadr] - m->qpos0[qadr]);
        }
        mju_mulQuat(xquat, xquat, qloc);
        mju_rotVecQuat(vec, m->jnt_pos + 3 * j, xquat);
        mju_sub3(xpos, xanchor, vec);
      }
      mju_copy3(d->xanchor + 3 * j, xanchor);
      if (axes) mju_copy3(d->xaxis + 3 * j, xaxis);
    }
    mju_normalize4(xquat);
    mju_copy4(d->xquat + 4 * i, xquat);
    mju_copy3(d->xpos + 3 * i, xpos);
    mju_quat2Mat(d->xmat + 9 * i, xquat);
  }
}

/* A site end effector's frame after chain_kinematics, as mj_kinematics places it
   (mj_local2Global, from its body's inertial frame where the site sits on it): its
   position, and its rotation too when `rotation` (the first pass of a pose target). */
static void site_frame(const mjModel* m, mjData* d, const Problem* p, int rotation) {
  int id = p->ee_id, b = p->body, same = m->site_sameframe[id];
  if (same == mjSAMEFRAME_INERTIA || same == mjSAMEFRAME_INERTIAROT) {
    mj_local2Global(d, d->xipos + 3 * b, d->ximat + 9 * b, m->body_ipos + 3 * b,
                    m->body_iquat + 4 * b, b, m->body_sameframe[b]);
  }
  mj_local2Global(d, d->site_xpos + 3 * id, rotation ? d->site_xmat + 9 * id : NULL,
                  m->site_pos + 3 * id, rotation ? m->site_quat + 4 * id : NULL, b, same);
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

/* target_body = quat * s^-1 * b: the body orientation that puts the site on the
   target, from the first pass's site and body frames (the site's placement on its body
   as MuJoCo computes it); the target's own orientation for a body end effector */
static void body_target(const mjModel* m, const mjData* d, const Problem* p, mjtNum* target_body) {
  if (p->site) {
    mjtNum site[4], rel[4], tmp[4];
    mju_mat2Quat(site, d->site_xmat + 9 * p->ee_id);
    mju_negQuat(rel, site);
    mju_mulQuat(tmp, p->target_quat, rel);
    mju_mulQuat(target_body, tmp, d->xquat + 4 * p->body);
  } else {
    memcpy(target_body, p->target_quat, sizeof(mjtNum) * 4);
  }
}

/* The task error at the end effector's point xpos and its body's frame: -e into e (the
   position rows, then for a pose the rotation rows scaled by wr: -w, log(t^-1 b) in the
   body's frame, to the world by the body's rotation), its two norms into *ep, *er */
static void task_error(const Problem* p, const mjtNum* xpos, const mjtNum* body_quat,
                       const mjtNum* body_mat, const mjtNum* target_body, mjtNum* e, mjtNum* ep,
                       mjtNum* er) {
  mju_sub3(e, xpos, p->target_pos); /* -e: g = J' W (-e) needs no negation */
  *ep = mju_norm3(e);
  if (p->rows == 6) {
    mjtNum q_err[3];
    mju_subQuat(q_err, body_quat, target_body);
    mju_mulMatVec3(e + 3, body_mat, q_err);
    *er = mju_norm3(e + 3);
    mju_scl3(e + 3, e + 3, p->wr);
  }
}

/* Iterate from q (n,), which ends at the converged pose or this start's best pose (the
   lowest e' W e); the cost and the errors are those of that pose. The stall rule is the
   one of solvers/iterate.py (Stall): no 1 % drop over the last `window` iterations. */
static Outcome descend(const mjModel* m, mjData* d, const Problem* p, mjtNum* q) {
  const int n = p->n, rows = p->rows, pose = rows == 6;
  Outcome out = {0, 0, INFINITY, NAN, NAN};
  mjtNum e[6] = {0}, target_body[4], w[6] = {1, 1, 1, p->wr, p->wr, p->wr};
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
  int* path = mj_stackAllocInt(d, (size_t)m->nbody);
  int moving = 0;
  const int count = chain_bodies(m, p, path, &moving);

  memcpy(x, q, sizeof(mjtNum) * n);
  memcpy(best_q, q, sizeof(mjtNum) * n);
  for (int k = 0; k < p->history; k++) history[k] = INFINITY;
  for (it = 0; it <= p->max_iterations; it++) {
    put_joints(p, d, x);
    if (!count) {
      mj_kinematics(m, d);
    } else { /* the whole path at the first pass, then the part the chain moves */
      chain_kinematics(m, d, path + (it ? moving : 0), count - (it ? moving : 0), 1);
      if (p->site) site_frame(m, d, p, it == 0 && pose);
    }
    if (it == 0 && pose) body_target(m, d, p, target_body);
    task_error(p, xpos, body_quat, body_mat, target_body, e, &ep, &er);
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

/* pose i's cost enters the k best found so far: below the last, or equal and earlier */
static int enters(mjtNum c, Py_ssize_t i, const mjtNum* best, const int64_t* out,
                  Py_ssize_t at) {
  return c < best[at] || (c == best[at] && i < out[at]);
}

/* Pose i into the k best so far (best/out, have of them) when its cost enters. */
static void offer(const Library* lib, const mjtNum* tp, const mjtNum* tr, Py_ssize_t i,
                  Py_ssize_t k, Py_ssize_t* have, mjtNum* best, int64_t* out) {
  const mjtNum* x = lib->positions + 3 * i;
  mjtNum dx = x[0] - tp[0], dy = x[1] - tp[1], dz = x[2] - tp[2];
  mjtNum sq = dx * dx + dy * dy + dz * dz;
  /* the margin keeps rounding from dropping a pose that would enter */
  if (*have == k && sq > best[k - 1] * best[k - 1] * (1.0 + 1e-9)) return;
  mjtNum c = sqrt(sq);
  if (tr) {
    const mjtNum* r = lib->rotations + 9 * i;
    mjtNum dot = 0.0;
    for (int j = 0; j < 9; j++) dot += r[j] * tr[j];
    c += lib->length * (1.0 - (dot - 1.0) * 0.5);
  }
  if (*have == k && !enters(c, i, best, out, k - 1)) return;
  Py_ssize_t at = *have < k ? (*have)++ : k - 1;
  while (at > 0 && enters(c, i, best, out, at - 1)) {
    best[at] = best[at - 1], out[at] = out[at - 1];
    at--;
  }
  best[at] = c, out[at] = i;
}

/* The k poses nearest a target by the seed library's cost (seed_nearest's doc), their
   indices into out (k,), their costs into best (k,); returns how many (min(k, size)).
   The cells are visited in rings outward from the target's cell (the nearest cell when
   the target lies outside the grid): ring r's cells lie at least (r - 1) side from the
   target, so the rings stop when that exceeds the k-th cost found, and a cell whose box
   lies farther than it is skipped (a pose's cost is at least its distance). */
static Py_ssize_t rank_nearest(const Library* lib, const mjtNum* tp, const mjtNum* tr,
                               Py_ssize_t k, mjtNum* best, int64_t* out) {
  Py_ssize_t have = 0;
  if (k > lib->size) k = lib->size;
  if (k <= 0) return 0;
  const mjtNum h = lib->side, *lo = lib->corner;
  const int *g = lib->dims;
  int at[3], rings = 0;
  for (int a = 0; a < 3; a++) {
    mjtNum f = floor((tp[a] - lo[a]) / h);
    at[a] = f < 0 ? 0 : f >= g[a] ? g[a] - 1 : (int)f;
    if (g[a] > rings) rings = g[a];
  }
  for (int r = 0; r < rings; r++) {
    if (have == k && (r - 1) * h - 1e-12 > best[k - 1] * (1.0 + 1e-9)) break;
    for (int z = at[2] - r; z <= at[2] + r; z++) {
      if (z < 0 || z >= g[2]) continue;
      for (int y = at[1] - r; y <= at[1] + r; y++) {
        if (y < 0 || y >= g[1]) continue;
        int shell = z == at[2] - r || z == at[2] + r || y == at[1] - r || y == at[1] + r;
        int step = shell || r == 0 ? 1 : 2 * r; /* inside the ring: its two x ends only */
        for (int x = at[0] - r; x <= at[0] + r; x += step) {
          if (x < 0 || x >= g[0]) continue;
          if (have == k) { /* the cell's box farther than the k-th cost: skipped */
            const int cell[3] = {x, y, z};
            mjtNum sq = 0.0;
            for (int a = 0; a < 3; a++) {
              mjtNum low = lo[a] + cell[a] * h, high = low + h;
              mjtNum gap = tp[a] < low ? low - tp[a] : tp[a] > high ? tp[a] - high : 0.0;
              gap = gap > 1e-12 ? gap - 1e-12 : 0.0;
              sq += gap * gap;
            }
            if (sq > best[k - 1] * best[k - 1] * (1.0 + 1e-9)) continue;
          }
          Py_ssize_t c = ((Py_ssize_t)z * g[1] + y) * g[0] + x;
          Py_ssize_t first = lib->cells[c], last = lib->cells[c + 1];
          if (first < 0) first = 0; /* a malformed grid ranks wrongly, never reads outside */
          if (last > lib->size) last = lib->size;
          for (Py_ssize_t i = first; i < last; i++) offer(lib, tp, tr, i, k, &have, best, out);
        }
      }
    }
  }
  return have;
}

/* ------------------------------------------------------------------ restarts */

/* The starts after a first start that did not converge, in the order of
   solvers/jacobian/seeds.py restart_poses: the library's poses nearest the target
   (ranked once, when the first is needed) at the even restarts while they last, random
   poses otherwise; the best pose over all by solvers/iterate.py pose_cost (the first on
   a tie), from the caller's best. */
typedef struct {
  Library lib; /* lib.positions NULL: no library */
  const mjtNum *target_rot, *randoms;
  mjtNum best_cost;
  Py_ssize_t seeds;
  int restarts;
} Restarts;

static mjtNum pose_cost(mjtNum ep, mjtNum er) { return er != 0.0 ? ep + 0.1 * er : ep; }

static Outcome restart(const mjModel* m, mjData* d, const Problem* p, const Restarts* r,
                       mjtNum* q) {
  const int n = p->n;
  Outcome out = {0, 0, r->best_cost, NAN, NAN};
  mj_markStack(d);
  mjtNum* x = mj_stackAllocNum(d, n);
  mjtNum* near_cost = mj_stackAllocNum(d, r->seeds ? r->seeds : 1);
  int64_t* near = (int64_t*)mj_stackAllocNum(d, r->seeds ? r->seeds : 1);
  Py_ssize_t found = -1, used = 0, drawn = 0;
  for (int k = 0; k < r->restarts; k++) {
    const mjtNum* start = NULL;
    if (k % 2 == 0 && r->lib.positions && used < r->seeds) {
      if (found < 0) {
        found = rank_nearest(&r->lib, p->target_pos, p->target_quat ? r->target_rot : NULL,
                             r->seeds, near_cost, near);
      }
      if (used < found) start = r->lib.poses + (size_t)n * near[used++];
    }
    if (!start) start = r->randoms + (size_t)n * drawn++;
    memcpy(x, start, sizeof(mjtNum) * n);
    Outcome one = descend(m, d, p, x);
    out.iterations += one.iterations;
    if (one.converged) {
      memcpy(q, x, sizeof(mjtNum) * n);
      out.converged = 1, out.cost = one.cost, out.ep = one.ep, out.er = one.er;
      break;
    }
    mjtNum c = pose_cost(one.ep, one.er);
    if (c < out.cost) {
      memcpy(q, x, sizeof(mjtNum) * n);
      out.cost = c, out.ep = one.ep, out.er = one.er;
    }
  }
  mj_freeStack(d);
  return out;
}

/* lm's whole solve of one target from q0 into q: the first start, then the restarts */
static Outcome solve_one(const mjModel* m, mjData* d, const Problem* p, Restarts* r,
                         const mjtNum* q0, mjtNum* q) {
  memcpy(q, q0, sizeof(mjtNum) * p->n);
  Outcome out = descend(m, d, p, q);
  if (out.converged || !r->restarts) return out;
  r->best_cost = pose_cost(out.ep, out.er); /* er is 0 for a position target */
  if (!(r->best_cost < INFINITY)) { /* a start that overflowed: the best pose is q0 */
    memcpy(q, q0, sizeof(mjtNum) * p->n);
    r->best_cost = INFINITY;
  }
  Outcome more = restart(m, d, p, r, q);
  more.iterations += out.iterations;
  return more;
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
  /* room on the stack for the largest call: (6 + 6) nv + 2 nv^2 + 12 nv + HISTORY_MAX
     + 2 SEEDS_MAX + 2 numbers (a solve's restarts) and nbody ints */
  mjtSize nv = m->nv;
  m->narena +=
      (mjtSize)sizeof(mjtNum) * (24 * nv + 2 * nv * nv + HISTORY_MAX + 2 * SEEDS_MAX + 2) +
      (mjtSize)sizeof(int) * m->nbody + 64 + STACK_SLACK;
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

/* The arguments descend and solve share (descend's doc; for solve, `count` non-NULL:
   positions (3 N,) and quats (4 N,) in place of one target, N into *count) into *out,
   the buffers' views in views (8 slots, *held_out of them held: the caller releases
   them, also on failure), the robot's qpos in *qpos, q in *q; `extra` bytes of MuJoCo
   stack asked for beside one start's. Returns -1 with a Python error set. */
static int parse_problem(Kernel* self, PyObject* const* args, Problem* out, Py_buffer* views,
                         int* held_out, const mjtNum** qpos, mjtNum** q, size_t extra,
                         Py_ssize_t* count) {
  *held_out = 0;
  if (!self->m) {
    PyErr_SetString(PyExc_RuntimeError, "Kernel is not initialised");
    return -1;
  }
  if (self->busy) {
    PyErr_SetString(PyExc_RuntimeError,
                    "this lm kernel is in use by another thread; a kernel serves one "
                    "thread at a time (give each thread its own robot state)");
    return -1;
  }
  const mjModel* m = self->m;
  const mjData* d = self->d;
  Problem p;
  memset(&p, 0, sizeof(p));
  int held = 0;
  Py_ssize_t n = 0;

  p.site = PyObject_IsTrue(args[3]);
  if (p.site < 0) return -1;
  if (get_array(args[10], &views[held], 'd', -1, 1, "q", &n) < 0) return -1;
  *q = views[held].buf;
  *held_out = ++held;
  if (n < 1 || n > m->nv) {
    PyErr_Format(PyExc_ValueError, "q must have 1 to nv = %lld values, got %zd",
                 (long long)m->nv, n);
    return -1;
  }
  if (get_array(args[0], &views[held], 'd', (Py_ssize_t)m->nq, 0, "qpos", NULL) < 0) return -1;
  *qpos = views[held].buf;
  *held_out = ++held;
  if (get_array(args[1], &views[held], 'i', n, 0, "qpos_adr", NULL) < 0) return -1;
  p.qadr = views[held].buf;
  *held_out = ++held;
  if (get_array(args[2], &views[held], 'i', n, 0, "dof_adr", NULL) < 0) return -1;
  p.dof = views[held].buf;
  *held_out = ++held;
  if (get_array(args[5], &views[held], 'd', n, 0, "lower", NULL) < 0) return -1;
  p.lower = views[held].buf;
  *held_out = ++held;
  if (get_array(args[6], &views[held], 'd', n, 0, "upper", NULL) < 0) return -1;
  p.upper = views[held].buf;
  *held_out = ++held;
  if (!count) { /* one target: its position (3,) and its orientation (4,) or None */
    if (get_array(args[7], &views[held], 'd', 3, 0, "target_pos", NULL) < 0) return -1;
    p.target_pos = views[held].buf;
    *held_out = ++held;
    if (args[8] != Py_None) {
      if (get_array(args[8], &views[held], 'd', 4, 0, "target_quat", NULL) < 0) return -1;
      p.target_quat = views[held].buf;
      *held_out = ++held;
    }
  } else { /* targets: positions (3 N,) and orientations (4 N,), NaN rows for none */
    Py_ssize_t len = 0;
    if (get_array(args[7], &views[held], 'd', -1, 0, "positions", &len) < 0) return -1;
    p.target_pos = views[held].buf;
    *held_out = ++held;
    if (len % 3) {
      PyErr_Format(PyExc_ValueError, "positions must have 3 values per target, got %zd", len);
      return -1;
    }
    *count = len / 3;
    if (get_array(args[8], &views[held], 'd', 4 * *count, 0, "quats", NULL) < 0) return -1;
    p.target_quat = views[held].buf;
    *held_out = ++held;
  }
  for (Py_ssize_t i = 0; i < n; i++) {
    if (p.qadr[i] < 0 || p.qadr[i] >= m->nq || p.dof[i] < 0 || p.dof[i] >= m->nv) {
      PyErr_Format(PyExc_ValueError, "joint %zd: qpos address %lld or dof address %lld "
                   "is outside the model", i, (long long)p.qadr[i], (long long)p.dof[i]);
      return -1;
    }
    int type = m->jnt_type[m->dof_jntid[p.dof[i]]];
    if (type != mjJNT_HINGE && type != mjJNT_SLIDE) { /* chain_jacobian's joints */
      PyErr_Format(PyExc_ValueError, "joint %zd: dof address %lld is not a hinge's or a slide's",
                   i, (long long)p.dof[i]);
      return -1;
    }
  }
  long ids = p.site ? (long)m->nsite : (long)m->nbody;
  if (as_int(args[4], "ee_id", p.site ? 0 : 1, ids - 1, &p.ee_id) < 0) return -1;
  p.body = p.site ? m->site_bodyid[p.ee_id] : p.ee_id;

  PyObject* opts = args[9];
  if (!PyTuple_Check(opts) || PyTuple_GET_SIZE(opts) != 7) {
    PyErr_SetString(PyExc_TypeError, "options must be a tuple of 7 values");
    return -1;
  }
  mjtNum f[5];
  for (int k = 0; k < 5; k++) {
    f[k] = PyFloat_AsDouble(PyTuple_GET_ITEM(opts, k));
    if (f[k] == -1.0 && PyErr_Occurred()) return -1;
  }
  p.tol = f[0], p.rot_tol = f[1], p.wr = f[2], p.damp_e = 0.5 * f[3], p.damp_0 = f[4];
  if (as_int(PyTuple_GET_ITEM(opts, 5), "max_iterations", 0, HISTORY_MAX - 1,
             &p.max_iterations) < 0 ||
      as_int(PyTuple_GET_ITEM(opts, 6), "stall_window", 1, INT32_MAX, &p.window) < 0) {
    return -1;
  }
  /* the stall test reads slot it % window only once it >= window, so a window longer
     than the iterations needs max_iterations + 1 slots */
  p.history = p.window < p.max_iterations + 1 ? p.window : p.max_iterations + 1;
  p.n = (int)n;
  p.nv = (int)m->nv;
  p.rows = p.target_quat ? 6 : 3;

  size_t need = sizeof(mjtNum) * ((size_t)12 * p.nv + 2 * (size_t)p.n * p.n + 11 * (size_t)p.n +
                                  (size_t)p.history) + sizeof(int) * (size_t)m->nbody + 64 + extra;
  size_t free_bytes = (size_t)d->narena - d->parena - d->pstack;
  if (need + STACK_SLACK > free_bytes) {
    PyErr_Format(PyExc_MemoryError, "lm kernel: %zu bytes of MuJoCo stack needed, %zu free",
                 need + STACK_SLACK, free_bytes);
    return -1;
  }

  *out = p;
  return 0;
}

static PyObject* Kernel_descend(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 11) {
    PyErr_Format(PyExc_TypeError, "descend() takes 11 arguments, got %zd", nargs);
    return NULL;
  }
  Problem p;
  Py_buffer views[8];
  int held = 0;
  const mjtNum* qpos;
  mjtNum* q;
  PyObject* result = NULL;
  if (parse_problem(self, args, &p, views, &held, &qpos, &q, 0, NULL) < 0) goto done;
  const mjModel* m = self->m;
  mjData* d = self->d;
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

/* library_seeds (args[13]) and restarts (args[15]) of solve and restart, each in
   [0, SEEDS_MAX]; returns -1 with a Python error set */
static int restart_counts(PyObject* const* args, long* seeds, long* restarts) {
  *seeds = PyLong_AsLong(args[13]), *restarts = PyLong_AsLong(args[15]);
  if ((*seeds == -1 || *restarts == -1) && PyErr_Occurred()) return -1;
  if (*seeds < 0 || *seeds > SEEDS_MAX || *restarts < 0 || *restarts > SEEDS_MAX) {
    PyErr_Format(PyExc_ValueError, "library_seeds and restarts must be in [0, %d], got %ld "
                 "and %ld", SEEDS_MAX, *seeds, *restarts);
    return -1;
  }
  return 0;
}

/* the restarts' random poses (args[14], restarts n,) and library (args[12], None or
   the 6-tuple of get_library) of solve and restart into *r, their views into views from
   *held on; returns -1 with a Python error set */
static int restart_arrays(PyObject* const* args, int n, long seeds, long restarts, Restarts* r,
                          Py_buffer* views, int* held) {
  r->restarts = (int)restarts;
  if (get_array(args[14], &views[*held], 'd', (Py_ssize_t)restarts * n, 0, "randoms", NULL) <
      0) {
    return -1;
  }
  r->randoms = views[(*held)++].buf;
  PyObject* lib = args[12];
  if (lib == Py_None || seeds == 0) return 0;
  if (!PyTuple_Check(lib) || PyTuple_GET_SIZE(lib) != 6) {
    PyErr_SetString(PyExc_TypeError, "library must be None or (positions, rotations, "
                                     "grid, cells, poses, length)");
    return -1;
  }
  if (get_library(PyTuple_GET_ITEM(lib, 0), PyTuple_GET_ITEM(lib, 1), PyTuple_GET_ITEM(lib, 2),
                  PyTuple_GET_ITEM(lib, 3), PyTuple_GET_ITEM(lib, 4), n,
                  PyTuple_GET_ITEM(lib, 5), views, held, &r->lib) < 0) {
    return -1;
  }
  r->seeds = seeds < r->lib.size ? seeds : r->lib.size;
  return 0;
}

PyDoc_STRVAR(solve_doc,
"solve(qpos, qpos_adr, dof_adr, site, ee_id, lower, upper, positions, quats, options,\n"
"      q0, rotations, library, library_seeds, randoms, restarts, out_q, out_info) -> None\n"
"\n"
"lm's whole solve of each of N targets from q0, as LM._solve does it one target at a\n"
"time (the same answers bit for bit): descend from q0, then, when that start did not\n"
"converge, the restarts in the order of seeds.restart_poses (the library's\n"
"library_seeds poses nearest the target, ranked as seed_nearest ranks them, at the\n"
"even restarts while they last, else the rows of randoms (restarts n,) in turn), the\n"
"best pose over the starts by iterate.pose_cost. The first 11 arguments as for\n"
"descend, with positions (3 N,) and quats (4 N,) (a NaN row: a position target) for\n"
"the target and q0 (n,) for q (not changed); rotations (9 N,): each pose target's\n"
"rotation matrix (for the ranking); library: None or (positions (3 L,), rotations\n"
"(9 L,), grid (7,), cells, poses (L n,), length) as seed_nearest takes its first four.\n"
"Writes each answer into out_q (N n,) and\n"
"(converged, iterations, position error, orientation error) into out_info (4 N,); a\n"
"target no start solved gets its best pose and that pose's errors as the kernel\n"
"measured them. The loop runs without the GIL.");

static PyObject* Kernel_solve(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 18) {
    PyErr_Format(PyExc_TypeError, "solve() takes 18 arguments, got %zd", nargs);
    return NULL;
  }
  Problem p;
  Restarts r;
  memset(&r, 0, sizeof(r));
  Py_buffer views[20];
  int held = 0;
  const mjtNum* qpos;
  mjtNum* q0;
  PyObject* result = NULL;
  Py_ssize_t count = 0;
  long seeds, restarts;
  if (restart_counts(args, &seeds, &restarts) < 0) return NULL;
  size_t nv = self->m ? (size_t)self->m->nv : 0;
  size_t extra = sizeof(mjtNum) * (nv + 2 * (size_t)(seeds ? seeds : 1) + 2) + 64;
  if (parse_problem(self, args, &p, views, &held, &qpos, &q0, extra, &count) < 0) goto done;
  const mjtNum *positions = p.target_pos, *quats = p.target_quat;
  if (get_array(args[11], &views[held], 'd', 9 * count, 0, "rotations", NULL) < 0) goto done;
  const mjtNum* rotations = views[held++].buf;
  if (get_array(args[16], &views[held], 'd', count * p.n, 1, "out_q", NULL) < 0) goto done;
  mjtNum* out_q = views[held++].buf;
  if (get_array(args[17], &views[held], 'd', 4 * count, 1, "out_info", NULL) < 0) goto done;
  mjtNum* info = views[held++].buf;
  if (restart_arrays(args, p.n, seeds, restarts, &r, views, &held) < 0) goto done;
  const mjModel* m = self->m;
  mjData* d = self->d;
  const int n = p.n;
  self->busy = 1;
  Py_BEGIN_ALLOW_THREADS
  memcpy(d->qpos, qpos, sizeof(mjtNum) * (size_t)m->nq);
  for (Py_ssize_t i = 0; i < count; i++) {
    p.target_pos = positions + 3 * i;
    p.target_quat = isnan(quats[4 * i]) ? NULL : quats + 4 * i;
    p.rows = p.target_quat ? 6 : 3;
    r.target_rot = rotations + 9 * i;
    Outcome out = solve_one(m, d, &p, &r, q0, out_q + (size_t)n * i);
    mjtNum* row = info + 4 * i;
    row[0] = out.converged, row[1] = out.iterations, row[2] = out.ep, row[3] = out.er;
  }
  Py_END_ALLOW_THREADS
  self->busy = 0;
  result = Py_NewRef(Py_None);

done:
  for (int k = 0; k < held; k++) PyBuffer_Release(&views[k]);
  return result;
}

PyDoc_STRVAR(restart_doc,
"restart(qpos, qpos_adr, dof_adr, site, ee_id, lower, upper, target_pos, target_quat,\n"
"        options, q, target_rot, library, library_seeds, randoms, restarts, best_cost)\n"
"    -> (converged, iterations, cost, position error, orientation error)\n"
"\n"
"lm's restarts of one target after its first start did not converge, as solve runs\n"
"them (the same starts in the same order: the library's library_seeds poses nearest\n"
"the target at the even restarts while they last, else the rows of randoms in turn):\n"
"the first 11 arguments as for descend, q (n,) the first start's best pose (written:\n"
"the converged pose, else the best over all starts, the first on a tie) and best_cost\n"
"its iterate.pose_cost (inf: none); target_rot (9,) or None as target_quat;\n"
"library None or (positions, rotations, grid, cells, poses, length). iterations counts\n"
"the restarts' only. The loop runs without the GIL.");

static PyObject* Kernel_restart(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 17) {
    PyErr_Format(PyExc_TypeError, "restart() takes 17 arguments, got %zd", nargs);
    return NULL;
  }
  Problem p;
  Restarts r;
  memset(&r, 0, sizeof(r));
  Py_buffer views[16];
  int held = 0;
  const mjtNum* qpos;
  mjtNum* q;
  PyObject* result = NULL;
  long seeds, restarts;
  if (restart_counts(args, &seeds, &restarts) < 0) return NULL;
  r.best_cost = PyFloat_AsDouble(args[16]);
  if (r.best_cost == -1.0 && PyErr_Occurred()) return NULL;
  size_t extra = sizeof(mjtNum) * (2 * (size_t)(seeds ? seeds : 1) + 2) + 64;
  if (parse_problem(self, args, &p, views, &held, &qpos, &q, extra, NULL) < 0) goto done;
  if (p.target_quat) {
    if (get_array(args[11], &views[held], 'd', 9, 0, "target_rot", NULL) < 0) goto done;
    r.target_rot = views[held++].buf;
  }
  if (restart_arrays(args, p.n, seeds, restarts, &r, views, &held) < 0) goto done;
  const mjModel* m = self->m;
  mjData* d = self->d;
  Outcome out;
  self->busy = 1;
  Py_BEGIN_ALLOW_THREADS
  memcpy(d->qpos, qpos, sizeof(mjtNum) * (size_t)m->nq);
  out = restart(m, d, &p, &r, q);
  Py_END_ALLOW_THREADS
  self->busy = 0;
  result = Py_BuildValue("(Oiddd)", out.converged ? Py_True : Py_False, out.iterations,
                         (double)out.cost, (double)out.ep, (double)out.er);
done:
  for (int k = 0; k < held; k++) PyBuffer_Release(&views[k]);
  return result;
}

/* descend's measure (max_iterations 0) of each of `count` joint vectors qs (count n)
   toward its target (positions, quats: NaN for a position target), without descend's
   buffers: the path's bodies are found once, and from the second target on only the
   part the chain moves is computed again (the other joints stay where the first put
   them), without the joints' axes. The same bits as descend's first pass. Into info
   (4 count): converged, iterations (0), position error, orientation error. */
static void measure_all(const mjModel* m, mjData* d, Problem* p, const mjtNum* positions,
                        const mjtNum* quats, const mjtNum* qs, Py_ssize_t count, mjtNum* info) {
  const mjtNum* xpos = p->site ? d->site_xpos + 3 * p->ee_id : d->xpos + 3 * p->ee_id;
  const mjtNum *body_quat = d->xquat + 4 * p->body, *body_mat = d->xmat + 9 * p->body;
  mj_markStack(d);
  int* path = mj_stackAllocInt(d, (size_t)m->nbody);
  int moving = 0;
  const int bodies = chain_bodies(m, p, path, &moving);
  for (Py_ssize_t i = 0; i < count; i++) {
    mjtNum e[6], target_body[4], ep, er = 0.0;
    p->target_pos = positions + 3 * i;
    p->target_quat = isnan(quats[4 * i]) ? NULL : quats + 4 * i;
    p->rows = p->target_quat ? 6 : 3;
    put_joints(p, d, qs + (size_t)p->n * i);
    if (!bodies) {
      mj_kinematics(m, d);
    } else {
      chain_kinematics(m, d, path + (i ? moving : 0), bodies - (i ? moving : 0), 0);
      if (p->site) site_frame(m, d, p, p->rows == 6);
    }
    if (p->rows == 6) body_target(m, d, p, target_body);
    task_error(p, xpos, body_quat, body_mat, target_body, e, &ep, &er);
    mjtNum* row = info + 4 * i;
    row[0] = ep < p->tol && er < p->rot_tol, row[1] = 0, row[2] = ep;
    row[3] = er; /* 0 for a position target, as descend gives it */
  }
  mj_freeStack(d);
}

PyDoc_STRVAR(measure_doc,
"measure(qpos, qpos_adr, dof_adr, site, ee_id, lower, upper, positions, quats, options,\n"
"        scratch, qs, out_info) -> None\n"
"\n"
"the kernel's measure of each row of qs (N n,) toward its target (the first 11 arguments\n"
"as for solve, scratch (n,) a writable array standing for q): the errors of MuJoCo's FK\n"
"of it (the kernel's chain kinematics), the first pass of descend to the last bit,\n"
"without iterating (options' max_iterations is not read), and whether they are within\n"
"options' tolerances; (converged, iterations 0, position error, orientation error) into\n"
"out_info (4 N,). The loop runs without the GIL.");

static PyObject* Kernel_measure(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 13) {
    PyErr_Format(PyExc_TypeError, "measure() takes 13 arguments, got %zd", nargs);
    return NULL;
  }
  Problem p;
  Py_buffer views[12];
  int held = 0;
  const mjtNum* qpos;
  mjtNum* scratch;
  PyObject* result = NULL;
  Py_ssize_t count = 0;
  if (parse_problem(self, args, &p, views, &held, &qpos, &scratch, 0, &count) < 0) goto done;
  const mjtNum *positions = p.target_pos, *quats = p.target_quat;
  if (get_array(args[11], &views[held], 'd', count * p.n, 1, "qs", NULL) < 0) goto done;
  mjtNum* qs = views[held++].buf;
  if (get_array(args[12], &views[held], 'd', 4 * count, 1, "out_info", NULL) < 0) goto done;
  mjtNum* info = views[held++].buf;
  const mjModel* m = self->m;
  mjData* d = self->d;
  self->busy = 1;
  Py_BEGIN_ALLOW_THREADS
  memcpy(d->qpos, qpos, sizeof(mjtNum) * (size_t)m->nq);
  measure_all(m, d, &p, positions, quats, qs, count, info);
  Py_END_ALLOW_THREADS
  self->busy = 0;
  result = Py_NewRef(Py_None);
done:
  for (int k = 0; k < held; k++) PyBuffer_Release(&views[k]);
  return result;
}

PyDoc_STRVAR(set_mocap_doc,
"set_mocap(mocap_pos, mocap_quat) -> None\n"
"\n"
"The mocap bodies' poses of the kernel's data: mocap_pos (3 nmocap,) and mocap_quat\n"
"(4 nmocap,) float64, as the robot state's data holds them (a chain below a mocap body\n"
"moves with it; descend and solve copy qpos only).");

static PyObject* Kernel_set_mocap(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 2) {
    PyErr_Format(PyExc_TypeError, "set_mocap() takes 2 arguments, got %zd", nargs);
    return NULL;
  }
  if (!self->m) {
    PyErr_SetString(PyExc_RuntimeError, "Kernel is not initialised");
    return NULL;
  }
  if (self->busy) {
    PyErr_SetString(PyExc_RuntimeError, "this lm kernel is in use by another thread");
    return NULL;
  }
  Py_buffer views[2];
  int held = 0;
  PyObject* result = NULL;
  Py_ssize_t k = self->m->nmocap;
  if (get_array(args[0], &views[held], 'd', 3 * k, 0, "mocap_pos", NULL) < 0) goto done;
  held++;
  if (get_array(args[1], &views[held], 'd', 4 * k, 0, "mocap_quat", NULL) < 0) goto done;
  held++;
  memcpy(self->d->mocap_pos, views[0].buf, sizeof(mjtNum) * 3 * (size_t)k);
  memcpy(self->d->mocap_quat, views[1].buf, sizeof(mjtNum) * 4 * (size_t)k);
  result = Py_NewRef(Py_None);
done:
  for (int j = 0; j < held; j++) PyBuffer_Release(&views[j]);
  return result;
}

static PyObject* Kernel_get_nq(Kernel* self, void* closure) {
  return PyLong_FromLongLong(self->m ? (long long)self->m->nq : 0);
}

static PyObject* Kernel_get_nv(Kernel* self, void* closure) {
  return PyLong_FromLongLong(self->m ? (long long)self->m->nv : 0);
}

/* ------------------------------------------------------------------ seed ranking */

PyDoc_STRVAR(seed_nearest_doc,
"seed_nearest(positions, rotations, grid, cells, target_pos, target_rot, length, out)\n"
"    -> int\n"
"\n"
"The seed library's poses nearest a target (solvers/jacobian/seeds.py): their indices\n"
"into out (k,) int64, writable, nearest first, by the cost |positions[i] - target_pos|\n"
"+ length (1 - cos), cos = (trace(target_rot' R_i) - 1) / 2 from the flattened\n"
"rotations (9 per pose) for a pose target (target_rot (9,)), the distance alone when\n"
"target_rot is None; equal costs in index order. Returns how many were written\n"
"(min(k, size)). positions (3 size,) ordered by the cells of grid (7,): the corner of\n"
"cell (0, 0, 0), the cells' side and their counts along x, y, z; cells (count + 1,)\n"
"int64, the first pose of each cell and the end (poses outside their cell give a\n"
"wrong ranking, never a bad access); rotations (9 size,) float64, length >= 0. The\n"
"cells are visited in rings outward from the target's, until the ring's distance alone\n"
"exceeds the k-th cost found (cost >= distance); a cell farther than that cost is\n"
"skipped. The same ranking as a full sort, in a fixed order: the same on every\n"
"machine.");

static PyObject* seed_nearest(PyObject* module, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 8) {
    PyErr_Format(PyExc_TypeError, "seed_nearest() takes 8 arguments, got %zd", nargs);
    return NULL;
  }
  Py_buffer views[7];
  int held = 0;
  PyObject* result = NULL;
  Py_ssize_t k = 0;
  Library lib;
  int pose = args[5] != Py_None;
  if (get_library(args[0], pose ? args[1] : NULL, args[2], args[3], NULL, 0, args[6], views,
                  &held, &lib) < 0) {
    goto done;
  }
  if (get_array(args[4], &views[held], 'd', 3, 0, "target_pos", NULL) < 0) goto done;
  const mjtNum* tp = views[held++].buf;
  const mjtNum* tr = NULL;
  if (pose) {
    if (get_array(args[5], &views[held], 'd', 9, 0, "target_rot", NULL) < 0) goto done;
    tr = views[held++].buf;
  }
  if (get_array(args[7], &views[held], 'i', -1, 1, "out", &k) < 0) goto done;
  int64_t* out = views[held++].buf;
  if (k > lib.size) k = lib.size;
  mjtNum* best = PyMem_Malloc(sizeof(mjtNum) * (size_t)(k ? k : 1));
  if (!best) {
    PyErr_NoMemory();
    goto done;
  }
  Py_ssize_t have = 0;
  Py_BEGIN_ALLOW_THREADS
  have = rank_nearest(&lib, tp, tr, k, best, out);
  Py_END_ALLOW_THREADS
  PyMem_Free(best);
  result = PyLong_FromSsize_t(have);
done:
  for (int j = 0; j < held; j++) PyBuffer_Release(&views[j]);
  return result;
}

static PyMethodDef module_methods[] = {
    {"seed_nearest", (PyCFunction)(void (*)(void))seed_nearest, METH_FASTCALL,
     seed_nearest_doc},
    {NULL, NULL, 0, NULL},
};

static PyMethodDef Kernel_methods[] = {
    {"descend", (PyCFunction)(void (*)(void))Kernel_descend, METH_FASTCALL, descend_doc},
    {"solve", (PyCFunction)(void (*)(void))Kernel_solve, METH_FASTCALL, solve_doc},
    {"set_mocap", (PyCFunction)(void (*)(void))Kernel_set_mocap, METH_FASTCALL, set_mocap_doc},
    {"measure", (PyCFunction)(void (*)(void))Kernel_measure, METH_FASTCALL, measure_doc},
    {"restart", (PyCFunction)(void (*)(void))Kernel_restart, METH_FASTCALL, restart_doc},
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
    .m_methods = module_methods,
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
