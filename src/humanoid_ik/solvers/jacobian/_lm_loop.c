/* One start of `lm` (solvers/jacobian/lm.py, `LM._descend`): the iteration loop in C.

   The loop is the Python one of lm.py statement by statement, calling the same MuJoCo
   functions in the same order (their addresses come from MuJoCo's own library through
   ctypes, see solvers/jacobian/lm_loop.py), so both give the same joints and iteration
   counts bit for bit (tests/test_lm.py::test_compiled_loop_matches_the_python_loop).
   Built with -ffp-contract=off so that no multiply-add is fused where Python rounds
   twice. It needs no MuJoCo or Python header: the model and data are opaque pointers,
   and the fields read (qpos, the end effector's position, its body's quaternion and
   rotation) are passed as pointers into MjData's arrays. */

#include <math.h>
#include <string.h>

typedef double num;

typedef struct {
  void (*kinematics)(const void* m, void* d);
  void (*com_pos)(const void* m, void* d);
  void (*jac)(const void* m, const void* d, num* jacp, num* jacr, int id);
  void (*sub3)(num res[3], const num a[3], const num b[3]);
  num (*norm3)(const num v[3]);
  void (*scl3)(num res[3], const num v[3], num s);
  void (*sub_quat)(num res[3], const num qa[4], const num qb[4]);
  void (*mul_mat_vec3)(num res[3], const num mat[9], const num v[3]);
  void (*sqr_mat_td)(num* res, const num* mat, const num* diag, int nr, int nc);
  void (*add_to_scl)(num* res, const num* v, num s, int n);
  void (*mul_mat_t_vec)(num* res, const num* mat, const num* v, int nr, int nc);
  void (*mul_mat_vec)(num* res, const num* mat, const num* v, int nr, int nc);
  int (*box_qp)(num* res, num* R, int* index, const num* H, const num* g, int n,
                const num* lower, const num* upper);
} lm_api;

typedef struct {
  const void* m;
  void* d;
  int n, rows, nv, ee_id, max_iterations, window;
  const long long* qadr; /* (n,) the chain's qpos addresses */
  const long long* dof;  /* (n,) its dof addresses */
  num* qpos;             /* MjData.qpos */
  const num* xpos;       /* the end effector's position (site_xpos or xpos row) */
  const num* body_quat;  /* its body's xquat and xmat rows */
  const num* body_mat;
  const num* target_pos;  /* (3,) */
  const num* target_body; /* (4,) the body orientation that puts the site on target */
  num* jac;               /* (6, nv): jacp then jacr */
  num *J, *w, *H, *eye, *g, *Hx, *R, *e, *q_err, *x, *best_q, *history;
  const num *lower, *upper;
  num tol, rot_tol, wr, damp_e, damp_0;
} lm_problem;

static void put_joints(const lm_problem* p, const num* x) {
  for (int i = 0; i < p->n; i++) p->qpos[p->qadr[i]] = x[i];
}

/* Iterate from q (n,), which ends at the converged pose or this start's best pose.
   out = (iterations, cost, position error, orientation error); returns 1 when
   converged, else 0 (the errors are then NaN, as in the Python loop). */
int lm_descend(const lm_api* f, const lm_problem* p, num* q, num* out) {
  const int n = p->n, rows = p->rows, pose = rows == 6;
  num *x = p->x, *e_p = p->e, *e_r = p->e + 3;
  num best = INFINITY, ep = 0.0, er = 0.0, cost = 0.0;
  int it;
  memcpy(x, q, sizeof(num) * n);
  memcpy(p->best_q, q, sizeof(num) * n);
  for (int k = 0; k < p->window; k++) p->history[k] = INFINITY;
  for (it = 0; it <= p->max_iterations; it++) {
    put_joints(p, x);
    f->kinematics(p->m, p->d);
    f->sub3(e_p, p->xpos, p->target_pos); /* -e: g = J' W (-e) needs no negation */
    ep = f->norm3(e_p);
    if (pose) {
      f->sub_quat(p->q_err, p->body_quat, p->target_body);
      f->mul_mat_vec3(e_r, p->body_mat, p->q_err);
      er = f->norm3(e_r);
      f->scl3(e_r, e_r, p->wr);
    }
    cost = ep * ep + p->wr * er * er;
    if (cost < best) {
      best = cost;
      memcpy(p->best_q, x, sizeof(num) * n);
    }
    if (ep < p->tol && er < p->rot_tol) {
      memcpy(q, x, sizeof(num) * n);
      out[0] = it, out[1] = cost, out[2] = ep, out[3] = er;
      return 1;
    }
    int slot = it % p->window;
    if (it == p->max_iterations || (it >= p->window && cost > 0.99 * p->history[slot])) break;
    p->history[slot] = cost;
    f->com_pos(p->m, p->d);
    f->jac(p->m, p->d, p->jac, p->jac + 3 * p->nv, p->ee_id);
    for (int r = 0; r < rows; r++)
      for (int i = 0; i < n; i++) p->J[r * n + i] = p->jac[r * p->nv + p->dof[i]];
    f->sqr_mat_td(p->H, p->J, p->w, rows, n);                   /* H = J' W J */
    f->add_to_scl(p->H, p->eye, p->damp_e * cost + p->damp_0, n * n); /* + lambda I */
    f->mul_mat_t_vec(p->g, p->J, p->e, rows, n); /* g = -J' W e */
    f->mul_mat_vec(p->Hx, p->H, x, n, n);
    f->add_to_scl(p->g, p->Hx, -1.0, n); /* in x = q + dq: linear term g - H q */
    if (f->box_qp(x, p->R, 0, p->H, p->g, n, p->lower, p->upper) < 0) break;
  }
  put_joints(p, x);
  memcpy(q, p->best_q, sizeof(num) * n);
  out[0] = it, out[1] = best, out[2] = NAN, out[3] = NAN;
  return 0;
}
