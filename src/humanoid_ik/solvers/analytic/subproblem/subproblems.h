/* The subproblem solver's arithmetic, shared by its three C files: the subproblems
   (subproblems.c), the families, the ranges and the check (families.c), and the Python
   binding (_subproblem.c). Plain C on doubles, no Python, no MuJoCo. */

#ifndef HUMANOID_IK_SUBPROBLEMS_H
#define HUMANOID_IK_SUBPROBLEMS_H

#include <math.h>

#define MAXSOL 16 /* the most solutions one target has here (8 per family, room to spare) */
#define TWO_PI 6.283185307179586476925286766559
#define SLACK 1e-9 /* relative slack that keeps a tangent case's root */

/* A 6-hinge arm in its base frame at the zero configuration, in the family's order. */
typedef struct {
  int family, pcase, reverse;
  double h[6][3], p[6][3]; /* the axes and points the subproblems use (reversed if so) */
  double R0[9], p0[3];     /* the end frame at zero, in the base frame (the chain's) */
  double W[3], O[3];       /* the wrist point; the meeting point of the position case */
} ArmGeometry;

/* A 7-hinge arm whose joint `locked` (0: the first, 6: the last) is searched over: the
   6-hinge arm of the other joints (`arm`, its end frame the 7-hinge arm's at zero) and
   the locked joint's axis and point, in the base frame at zero. */
typedef struct {
  ArmGeometry arm;
  int locked;
  double h[3], p[3];
} LockedArm;

#define SEARCH_COARSE 0.25 /* [rad] between two values of the locked joint searched first */
#define SEARCH_HALVINGS 2  /* bisections towards the start after a coarse step finds one */
#define SEARCH_STEP 0.002  /* [rad] between two values searched when the coarse steps miss */

/* G = T T0^-1 in the base frame from a world target (position 3, wxyz quaternion 4)
   and the base's world pose (position 3, row-major rotation 9) */
void sp_target(const ArmGeometry* a, const double* pos, const double* quat, const double* base,
               double* GR, double* Gp);

/* every solution of G, in the chain's order, each angle in (-pi, pi]; q0 the start
   (settles a straight wrist); returns how many */
int sp_solve_all(const ArmGeometry* a, const double* GR, const double* Gp, const double* q0,
                 double out[MAXSOL][6]);

/* the solutions of G with the ranges applied and only the pick checked (see
   families.c); the pick into out; returns how many fit the ranges, *found how many
   solutions there were */
int sp_solve_pick(const ArmGeometry* a, const double* GR, const double* Gp, const double* q0,
                  const double* lower, const double* upper, double tol, double* out, int* found);

/* every solution (7 angles) of G7 with the locked joint at t (the others in (-pi, pi]) */
int sp_locked_solutions(const LockedArm* a, const double* GR, const double* Gp, const double* q0,
                        double t, double out[MAXSOL][7]);

/* the search over the locked joint (see families.c): the pick into out (7); returns how
   many solutions fit the ranges at the value taken, *found the most solutions at one
   value, *tried how many values were tried */
int sp_search(const LockedArm* a, const double* GR, const double* Gp, const double* q0,
              const double* lower, const double* upper, double tol, double* out, int* found,
              int* tried);

/* the subproblems (subproblems.c): sp1 returns how well its angle is defined (0: any),
   the others how many solutions they wrote */
double sp1(const double* k, const double* p, const double* q, double* t, double* cs);
int sp2(const double* k1, const double* p1, const double* k2, const double* p2, double* t1,
        double* t2);
int sp3(const double* k, const double* p, const double* q, double d, double* t, double* cs);
int sp4(const double* h, const double* k, const double* p, double d, double* t, double* cs);
int sp6(const double A[2][4], const double b[2], double* t1, double* t2);
void trig_terms(const double* h, const double* k, const double* p, double* c);

/* ------------------------------------------------------------------ vectors */

static inline double dot(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static inline void cross(const double* a, const double* b, double* c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}
static inline void sub(const double* a, const double* b, double* c) {
  c[0] = a[0] - b[0], c[1] = a[1] - b[1], c[2] = a[2] - b[2];
}
static inline void add(const double* a, const double* b, double* c) {
  c[0] = a[0] + b[0], c[1] = a[1] + b[1], c[2] = a[2] + b[2];
}
static inline double norm(const double* a) { return sqrt(dot(a, a)); }

/* R(k, t) v (Rodrigues), k a unit vector, from c = cos t and s = sin t */
static inline void rot_cs(const double* k, double c, double s, const double* v, double* out) {
  double kv = dot(k, v), kx[3];
  cross(k, v, kx);
  for (int i = 0; i < 3; i++) out[i] = c * v[i] + s * kx[i] + (1.0 - c) * kv * k[i];
}
static inline void rot(const double* k, double t, const double* v, double* out) {
  rot_cs(k, cos(t), sin(t), v, out);
}
/* R(k, t) as a row-major matrix, from c = cos t and s = sin t */
static inline void rot_mat_cs(const double* k, double c, double s, double* R) {
  double v = 1.0 - c;
  R[0] = c + k[0] * k[0] * v, R[1] = k[0] * k[1] * v - k[2] * s, R[2] = k[0] * k[2] * v + k[1] * s;
  R[3] = k[1] * k[0] * v + k[2] * s, R[4] = c + k[1] * k[1] * v, R[5] = k[1] * k[2] * v - k[0] * s;
  R[6] = k[2] * k[0] * v - k[1] * s, R[7] = k[2] * k[1] * v + k[0] * s, R[8] = c + k[2] * k[2] * v;
}
static inline void rot_mat(const double* k, double t, double* R) { rot_mat_cs(k, cos(t), sin(t), R); }
static inline void mat_mul(const double* A, const double* B, double* C) { /* C = A B */
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}
static inline void mat_tmul(const double* A, const double* B, double* C) { /* C = A' B */
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      C[3 * i + j] = A[i] * B[j] + A[3 + i] * B[3 + j] + A[6 + i] * B[6 + j];
}
static inline void mat_vec(const double* A, const double* v, double* out) {
  for (int i = 0; i < 3; i++) out[i] = A[3 * i] * v[0] + A[3 * i + 1] * v[1] + A[3 * i + 2] * v[2];
}
static inline void mat_tvec(const double* A, const double* v, double* out) {
  for (int i = 0; i < 3; i++) out[i] = A[i] * v[0] + A[3 + i] * v[1] + A[6 + i] * v[2];
}

/* e^(h q) applied to x: R(h, q) (x - p) + p */
static inline void turn(const double* h, const double* p, double q, const double* x, double* out) {
  double d[3];
  sub(x, p, d);
  rot(h, q, d, out);
  add(out, p, out);
}

/* a in (-pi, pi]; a few turns at most, so subtraction beats remainder() */
static inline double wrap(double a) {
  if (fabs(a) > 8.0 * TWO_PI) a = remainder(a, TWO_PI);
  while (a > M_PI) a -= TWO_PI;
  while (a <= -M_PI) a += TWO_PI;
  return a;
}

/* a unit vector normal to unit k */
static inline void normal_to(const double* k, double* n) {
  double e[3] = {0.0, 0.0, 0.0}, c[3];
  int i = fabs(k[0]) < fabs(k[1]) ? (fabs(k[0]) < fabs(k[2]) ? 0 : 2) : (fabs(k[1]) < fabs(k[2]) ? 1 : 2);
  e[i] = 1.0;
  cross(k, e, c);
  double r = norm(c);
  for (int j = 0; j < 3; j++) n[j] = c[j] / r;
}

#endif
