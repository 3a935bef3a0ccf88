/* Exact IK of 6-hinge arms by Paden-Kahan subproblems: the families, the check of every
   solution, the ranges. Plain C on doubles (no Python, no MuJoCo), built by setup.py
   into the module _subproblem.

   The arm is given in the product-of-exponentials form, in its base frame at the zero
   configuration: unit axes h1..h6, a point p1..p6 on each axis, the end frame (R0, p0).
   A target end pose T fixes G = T T0^-1 = e^(h1 q1) ... e^(h6 q6), where e^(h q) turns
   about the line (p, h): x -> R(h, q) (x - p) + p. Every joint vector with that product
   is found, by subproblems:

     SP1  R(k, t) p = q                          t (one)
     SP2  R(k1, t1) p1 = R(k2, t2) p2            (t1, t2) (two)
     SP3  |R(k, t) p - q| = d                    t (two)
     SP4  h' R(k, t) p = d                       t (two)
     SP6  h' R(k1, t1) a1 + h' R(k2, t2) b1 = d1,
          h' R(k1, t1) a2 + h' R(k2, t2) b2 = d2  (t1, t2) (four: a quartic)

   Families (`family`):
     0  spherical wrist: axes 4, 5, 6 meet at W. G W fixes q1..q3 (the position case
        `pcase`: 0 h2 || h3, SP4 + SP3 + SP1; 1 h1 || h2, SP4 + SP3 + SP1; 2 h1 and h2
        meet at O, SP3 + SP2; 3 h2 and h3 meet at O, SP3 + SP2), then the wrist
        R4 R5 R6 = (R1 R2 R3)' G_R by SP4 + SP1 + SP1: up to 4 x 2 = 8 solutions.
     1  three parallel axes h2 || h3 || h4 (the UR family): q1 and q5 from SP6 (what the
        parallel axes leave along h: a point of axis 6 and the axis h6 itself; `pcase`
        1, axes 5 and 6 meet as on the UR arms: SP4 + SP4 instead), q6 by SP1, the sum
        q2 + q3 + q4 by SP1, then the planar q2, q3 by SP3 + SP1: up to 4 x 2 = 8
        solutions.
   `reverse`: the arm was given reversed (base and end swapped: axes 6..1, negated), so
   G is inverted first and the answers read back in the chain's order; a spherical
   shoulder and h3 || h4 || h5 are then the same two families.

   Every candidate is checked by the product of exponentials and polished by Newton
   steps on the six pose equations (at most three, while the pose error falls); a
   candidate still off by more than ACCEPT is dropped, so an answer is never a spurious
   root. Joint ranges are applied here too (sp_pick): each angle moved by a multiple of
   2 pi into its range (nearest the start where several fit), then the in-range solution
   nearest the start (sum of squares) is chosen.

   This file: the families, the check, the ranges; subproblems.c: SP1-SP6;
   _subproblem.c: the Python binding. Built with -ffp-contract=off (GCC, Clang): the
   same rounding on every machine. */

#include <math.h>
#include <string.h>

#include "subproblems.h"

#define ACCEPT 1e-7    /* largest pose error [m, rad] of an accepted solution */
#define SAME 1e-7      /* two solutions closer than this [rad] per joint are one */
#define POLISH 1e-12   /* a solution off by more [m, rad] gets Newton steps */

/* ------------------------------------------------------------------ the arm's FK */

/* G(q) = e^(h1 q1) ... e^(h6 q6): rotation Rg, translation pg (x -> Rg x + pg); with
   cs, the angles' cosines and sines (cs[2 i], cs[2 i + 1]) instead of cos and sin of q */
static void poe(const ArmGeometry* a, const double* q, const double* cs, double* Rg, double* pg) {
  double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, p[3] = {0, 0, 0};
  for (int i = 0; i < 6; i++) {
    double Ri[9], Rn[9], t[3], c[3];
    if (cs) rot_mat_cs(a->h[i], cs[2 * i], cs[2 * i + 1], Ri);
    else rot_mat(a->h[i], q[i], Ri);
    /* e^(h q) x = Ri x + (p_i - Ri p_i); compose (R, p) o (Ri, ti) */
    mat_vec(Ri, a->p[i], c);
    sub(a->p[i], c, t);
    mat_vec(R, t, c);
    add(p, c, p);
    mat_mul(R, Ri, Rn);
    memcpy(R, Rn, sizeof R);
  }
  memcpy(Rg, R, sizeof R);
  memcpy(pg, p, sizeof p);
}

/* the pose error of q (cs: as for poe) against G (end frame at zero: R0, p0): position
   [m] and the rotation vector [rad] of R_target R(q)', into e[6]; returns the larger norm */
static double pose_err(const ArmGeometry* a, const double* q, const double* cs, const double* GR,
                       const double* Gp, double* e) {
  double R[9], p[3], x[3], y[3], D[9];
  poe(a, q, cs, R, p);
  mat_vec(R, a->p0, x);
  add(x, p, x);
  mat_vec(GR, a->p0, y);
  add(y, Gp, y);
  sub(y, x, e);
  /* D = GR R': the rotation left to do; its axis-angle */
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      D[3 * i + j] = GR[3 * i] * R[3 * j] + GR[3 * i + 1] * R[3 * j + 1] + GR[3 * i + 2] * R[3 * j + 2];
  double v[3] = {0.5 * (D[7] - D[5]), 0.5 * (D[2] - D[6]), 0.5 * (D[3] - D[1])};
  double s = norm(v), c = 0.5 * (D[0] + D[4] + D[8] - 1.0), ang = atan2(s, c);
  double f = s > 1e-300 ? ang / s : 1.0;
  for (int i = 0; i < 3; i++) e[3 + i] = f * v[i];
  return fmax(norm(e), norm(e + 3));
}

/* Newton steps on the six pose equations (the error is measured at the end point
   G p0; cs, as for poe, for the first measure); returns the pose error left */
static double polish(const ArmGeometry* a, double* q, const double* cs, const double* GR,
                     const double* Gp) {
  double e[6], err = pose_err(a, q, cs, GR, Gp, e);
  for (int it = 0; it < 3 && err > POLISH; it++) {
    double J[6][7], R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, p[3] = {0, 0, 0}, end[3], Rg[9], pg[3];
    poe(a, q, NULL, Rg, pg);
    mat_vec(Rg, a->p0, end);
    add(end, pg, end);
    for (int i = 0; i < 6; i++) { /* axis i and its point after joints 1..i-1 */
      double w[3], c[3], r[3], v[3], Ri[9], Rn[9], t[3], cc[3];
      mat_vec(R, a->h[i], w);
      mat_vec(R, a->p[i], c);
      add(c, p, c);
      sub(end, c, r);
      cross(w, r, v);
      for (int k = 0; k < 3; k++) J[k][i] = v[k], J[3 + k][i] = w[k];
      rot_mat(a->h[i], q[i], Ri);
      mat_vec(Ri, a->p[i], cc);
      sub(a->p[i], cc, t);
      mat_vec(R, t, cc);
      add(p, cc, p);
      mat_mul(R, Ri, Rn);
      memcpy(R, Rn, sizeof R);
    }
    for (int k = 0; k < 6; k++) J[k][6] = e[k];
    int ok = 1;
    for (int c = 0; c < 6 && ok; c++) { /* Gaussian elimination, partial pivoting */
      int piv = c;
      for (int r = c + 1; r < 6; r++)
        if (fabs(J[r][c]) > fabs(J[piv][c])) piv = r;
      if (fabs(J[piv][c]) < 1e-10) ok = 0;
      for (int k = 0; k < 7 && ok; k++) {
        double tmp = J[c][k];
        J[c][k] = J[piv][k], J[piv][k] = tmp;
      }
      for (int r = c + 1; r < 6 && ok; r++) {
        double f = J[r][c] / J[c][c];
        for (int k = c; k < 7; k++) J[r][k] -= f * J[c][k];
      }
    }
    if (!ok) break;
    double dq[6], qn[6];
    for (int r = 5; r >= 0; r--) {
      double s = J[r][6];
      for (int k = r + 1; k < 6; k++) s -= J[r][k] * dq[k];
      dq[r] = s / J[r][r];
    }
    for (int k = 0; k < 6; k++) qn[k] = q[k] + dq[k];
    double en[6], errn = pose_err(a, qn, NULL, GR, Gp, en);
    if (!(errn < err)) break;
    memcpy(q, qn, sizeof qn);
    memcpy(e, en, sizeof en);
    err = errn;
  }
  return err;
}

/* ------------------------------------------------------------------ the families */

/* q1..q3 that put the wrist point W at Wd (family 0), up to 4 */
static int position3(const ArmGeometry* a, const double* Wd, double sol[4][3]) {
  const double *h1 = a->h[0], *h2 = a->h[1], *h3 = a->h[2];
  const double *p1 = a->p[0], *p2 = a->p[1], *p3 = a->p[2], *W = a->W, *O = a->O;
  double t[2], u[2], v1[2], v2[2], x[3], y[3], Y[3], V[3], V2[3];
  int n = 0;
  switch (a->pcase) {
    case 0: /* h2 || h3: along h2 only q1 moves Wd */
      sub(Wd, p1, x), sub(W, p1, y);
      for (int i = 0, ni = sp4(h2, h1, x, dot(h2, y), t, NULL); i < ni; i++) {
        turn(h1, p1, t[i], Wd, Y);
        sub(W, p3, x), sub(p2, p3, y), sub(Y, p2, V);
        double d = norm(V);
        for (int j = 0, nj = sp3(h3, x, y, d, u, NULL); j < nj; j++) {
          turn(h3, p3, u[j], W, V);
          sub(V, p2, x), sub(Y, p2, y);
          double q2;
          sp1(h2, x, y, &q2, NULL);
          sol[n][0] = -t[i], sol[n][1] = q2, sol[n][2] = u[j], n++;
        }
      }
      break;
    case 1: /* h1 || h2: along h1 only q3 moves W */
      sub(W, p3, x), sub(Wd, p3, y);
      for (int i = 0, ni = sp4(h1, h3, x, dot(h1, y), t, NULL); i < ni; i++) {
        turn(h3, p3, t[i], W, V);
        sub(V, p2, x), sub(p1, p2, y), sub(Wd, p1, Y);
        for (int j = 0, nj = sp3(h2, x, y, norm(Y), u, NULL); j < nj; j++) {
          turn(h2, p2, u[j], V, V2);
          sub(V2, p1, x);
          double q1;
          sp1(h1, x, Y, &q1, NULL);
          sol[n][0] = q1, sol[n][1] = u[j], sol[n][2] = t[i], n++;
        }
      }
      break;
    case 2: /* h1 and h2 meet at O: |W - O| fixes q3 */
      sub(W, p3, x), sub(O, p3, y), sub(Wd, O, Y);
      for (int i = 0, ni = sp3(h3, x, y, norm(Y), t, NULL); i < ni; i++) {
        turn(h3, p3, t[i], W, V);
        sub(V, O, V2);
        for (int j = 0, nj = sp2(h1, Y, h2, V2, v1, v2); j < nj; j++)
          sol[n][0] = -v1[j], sol[n][1] = v2[j], sol[n][2] = t[i], n++;
      }
      break;
    default: /* h2 and h3 meet at O: |Wd - O| after q1 fixes q1 */
      sub(Wd, p1, x), sub(O, p1, y), sub(W, O, V);
      for (int i = 0, ni = sp3(h1, x, y, norm(V), t, NULL); i < ni; i++) {
        turn(h1, p1, t[i], Wd, Y);
        sub(Y, O, V2);
        for (int j = 0, nj = sp2(h2, V2, h3, V, v1, v2); j < nj; j++)
          sol[n][0] = -t[i], sol[n][1] = -v1[j], sol[n][2] = v2[j], n++;
      }
  }
  return n;
}

/* q4..q6 with R4 R5 R6 = M (axes 4, 5, 6 meet); q4_start where the wrist is straight */
static int wrist3(const ArmGeometry* a, const double* M, double q4_start, double sol[2][3]) {
  const double *h4 = a->h[3], *h5 = a->h[4], *h6 = a->h[5];
  double Mh6[3], Mth4[3], t[2], x[3], y[3];
  mat_vec(M, h6, Mh6);
  mat_tvec(M, h4, Mth4);
  int n = sp4(h4, h5, h6, dot(h4, Mh6), t, NULL);
  for (int i = 0; i < n; i++) {
    double q4, q6;
    rot(h5, t[i], h6, x);
    if (sp1(h4, x, Mh6, &q4, NULL) < 1e-12) { /* h6 turned onto h4: only q4 + q6 counts */
      double R4[9], R5[9], A[9], B[9], nrm[3];
      q4 = q4_start;
      rot_mat(h4, q4, R4), rot_mat(h5, t[i], R5);
      mat_mul(R4, R5, A);
      mat_tmul(A, M, B); /* R6 = (R4 R5)' M */
      normal_to(h6, nrm);
      mat_vec(B, nrm, y);
      sp1(h6, nrm, y, &q6, NULL);
    } else {
      rot(h5, -t[i], h4, y);
      sp1(h6, Mth4, y, &q6, NULL);
    }
    sol[i][0] = q4, sol[i][1] = t[i], sol[i][2] = q6;
  }
  return n;
}

static int family_wrist(const ArmGeometry* a, const double* GR, const double* Gp, const double* q0,
                        double out[MAXSOL][6]) {
  double Wd[3], pos[4][3], wr[2][3];
  mat_vec(GR, a->W, Wd);
  add(Wd, Gp, Wd);
  int np = position3(a, Wd, pos), n = 0;
  for (int i = 0; i < np; i++) {
    double R1[9], R2[9], R3[9], A[9], B[9], M[9];
    rot_mat(a->h[0], pos[i][0], R1), rot_mat(a->h[1], pos[i][1], R2), rot_mat(a->h[2], pos[i][2], R3);
    mat_mul(R1, R2, A), mat_mul(A, R3, B);
    mat_tmul(B, GR, M);
    int nw = wrist3(a, M, q0[3], wr);
    for (int j = 0; j < nw && n < MAXSOL; j++, n++) {
      memcpy(out[n], pos[i], 3 * sizeof(double));
      memcpy(out[n] + 3, wr[j], 3 * sizeof(double));
    }
  }
  return n;
}

/* the pairs (t1, t2) = (-q1, q5) of family 1 (three parallel axes, along h), up to 4,
   and their cosines and sines (c1 = cos t1, s1 = sin t1, c5, s5).
   Along h what the parallel axes leave: h' R(h1, -q1) (G p6 - p1) - h' R(h5, q5) (p6 - p5)
   = h' (p5 - p1) and h' R(h1, -q1) (G_R h6) - h' R(h5, q5) h6 = 0; SP6 solves the two at
   once. Where axes 5 and 6 meet at O (pcase 1, the UR arms), p5 = p6 = O makes the first
   an SP4 in q1 alone and the second, for each q1, an SP4 in q5. */
static int parallel_pairs(const ArmGeometry* a, const double* GR, const double* Gp, double* t1,
                          double* t2, double* c1, double* s1, double* c5, double* s5) {
  const double *h = a->h[1], *h1 = a->h[0], *h5 = a->h[4], *h6 = a->h[5];
  const double *p1 = a->p[0], *p5 = a->p[4], *p6 = a->p[5];
  double Gp6[3], a1[3], b1[3], a2[3], b2[3], c[3], A[2][4], b[2];
  if (a->pcase == 1) {
    double u[2], v[2], r[3], cu[4], cv[4];
    int n = 0;
    mat_vec(GR, a->O, Gp6);
    add(Gp6, Gp, Gp6);
    sub(Gp6, p1, a1), sub(a->O, p1, c), mat_vec(GR, h6, a2);
    for (int i = 0, ni = sp4(h, h1, a1, dot(h, c), u, cu); i < ni; i++) {
      rot_cs(h1, cu[2 * i], cu[2 * i + 1], a2, r);
      for (int j = 0, nj = sp4(h, h5, h6, dot(h, r), v, cv); j < nj; j++, n++) {
        t1[n] = u[i], t2[n] = v[j];
        c1[n] = cu[2 * i], s1[n] = cu[2 * i + 1], c5[n] = cv[2 * j], s5[n] = cv[2 * j + 1];
      }
    }
    return n;
  }
  mat_vec(GR, p6, Gp6);
  add(Gp6, Gp, Gp6);
  sub(Gp6, p1, a1), sub(p5, p6, b1), mat_vec(GR, h6, a2);
  for (int i = 0; i < 3; i++) b2[i] = -h6[i];
  sub(p5, p1, c);
  b[0] = dot(h, c), b[1] = 0.0;
  const double* rows[2][2] = {{a1, b1}, {a2, b2}};
  for (int r = 0; r < 2; r++) {
    double ta[3], tb[3];
    trig_terms(h, h1, rows[r][0], ta);
    trig_terms(h, h5, rows[r][1], tb);
    A[r][0] = ta[1], A[r][1] = ta[2], A[r][2] = tb[1], A[r][3] = tb[2];
    b[r] -= ta[0] + tb[0];
  }
  int n = sp6(A, b, t1, t2);
  for (int i = 0; i < n; i++) c1[i] = cos(t1[i]), s1[i] = sin(t1[i]), c5[i] = cos(t2[i]), s5[i] = sin(t2[i]);
  return n;
}

static int family_parallel(const ArmGeometry* a, const double* GR, const double* Gp, const double* q0,
                           double out[MAXSOL][6], double cs[MAXSOL][12]) {
  const double *h = a->h[1], *h1 = a->h[0], *h5 = a->h[4], *h6 = a->h[5];
  const double *p1 = a->p[0], *p2 = a->p[1], *p3 = a->p[2], *p4 = a->p[3], *p5 = a->p[4], *p6 = a->p[5];
  double s3 = dot(a->h[2], h) > 0.0 ? 1.0 : -1.0, s4 = dot(a->h[3], h) > 0.0 ? 1.0 : -1.0;
  double t1[4], t2[4], c1[4], s1[4], c5[4], s5[4];
  int n6 = parallel_pairs(a, GR, Gp, t1, t2, c1, s1, c5, s5), n = 0;
  double R1[9], M[9], Mth[3], nrm[3], pp[3], qq[3];
  normal_to(h, nrm);
  sub(p4, p3, pp), sub(p2, p3, qq);
  for (int i = 0; i < n6; i++) {
    double q1 = -t1[i], q5 = t2[i], q6, R5[9], R6[9], x[3], y[3], z[3], th, Kp4[3], d[3], u[2];
    double c6[2], cu[4], cth[2];
    if (i == 0 || t1[i] != t1[i - 1]) { /* the pairs of one q1 share its rotation */
      rot_mat_cs(h1, c1[i], -s1[i], R1); /* R(h1, q1), q1 = -t1 */
      mat_tmul(R1, GR, M);               /* R234 R5 R6 */
      mat_tvec(M, h, Mth);
    }
    rot_mat_cs(h5, c5[i], s5[i], R5);
    mat_tvec(R5, h, y);
    if (sp1(h6, Mth, y, &q6, c6) < 1e-12) q6 = q0[5], c6[0] = cos(q6), c6[1] = sin(q6);
    rot_mat_cs(h6, c6[0], c6[1], R6);
    /* R234 = M R6' R5': its angle about h, from where it turns nrm */
    mat_tvec(R5, nrm, x);
    mat_tvec(R6, x, z);
    mat_vec(M, z, y);
    sp1(h, nrm, y, &th, cth);
    /* K p4 = e^(-h1 q1) G (e^(h5 q5) e^(h6 q6))^-1 p4, and K = e^(h2 q2) e^(h3 q3) e^(h4 q4);
       e^(-h q) x = R(h, q)' (x - p) + p */
    sub(p4, p5, z), mat_tvec(R5, z, x), add(x, p5, x);
    sub(x, p6, z), mat_tvec(R6, z, x), add(x, p6, x);
    mat_vec(GR, x, z), add(z, Gp, z);
    sub(z, p1, x), mat_tvec(R1, x, Kp4), add(Kp4, p1, Kp4);
    sub(Kp4, p2, d);
    for (int j = 0, nj = sp3(a->h[2], pp, qq, norm(d), u, cu); j < nj && n < MAXSOL; j++) {
      double V[3], q2, c2[2], c3 = cu[2 * j], sn3 = s3 * cu[2 * j + 1];
      rot_cs(a->h[2], cu[2 * j], cu[2 * j + 1], pp, V); /* e^(h3 q3) p4 - p3 */
      add(V, p3, V);
      sub(V, p2, x);
      sp1(h, x, d, &q2, c2);
      out[n][0] = q1, out[n][1] = q2, out[n][2] = u[j];
      out[n][3] = s4 * (th - q2 - s3 * u[j]), out[n][4] = q5, out[n][5] = q6;
      /* the cosines and sines: q4 = s4 (th - q2 - s3 q3) by the angle differences */
      double ca = cth[0] * c2[0] + cth[1] * c2[1], sa = cth[1] * c2[0] - cth[0] * c2[1];
      double c4 = ca * c3 + sa * sn3, sn4 = sa * c3 - ca * sn3;
      double row[12] = {c1[i], -s1[i], c2[0], c2[1], c3, cu[2 * j + 1], c4, s4 * sn4, c5[i], s5[i], c6[0], c6[1]};
      memcpy(cs[n], row, sizeof row);
      n++;
    }
  }
  return n;
}

/* the raw solutions of G (in the solved order, unchecked) into raw, and G and q0 in
   the solved order (G inverted on a reversed arm) into GR, Gp, q0; returns how many,
   and *have (cs filled: their cosines and sines, as poe takes them) for family 1 */
static int raw_solutions(const ArmGeometry* a, const double* GR_in, const double* Gp_in,
                         const double* q0_in, double* GR, double* Gp, double* q0,
                         double raw[MAXSOL][6], double cs[MAXSOL][12], int* have) {
  if (a->reverse) { /* G^-1 on the reversed arm */
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++) GR[3 * i + j] = GR_in[3 * j + i];
    mat_vec(GR, Gp_in, Gp);
    for (int i = 0; i < 3; i++) Gp[i] = -Gp[i];
    for (int i = 0; i < 6; i++) q0[i] = q0_in[5 - i];
  } else {
    memcpy(GR, GR_in, 9 * sizeof(double)), memcpy(Gp, Gp_in, 3 * sizeof(double));
    memcpy(q0, q0_in, 6 * sizeof(double));
  }
  *have = a->family == 1;
  return a->family == 0 ? family_wrist(a, GR, Gp, q0, raw) : family_parallel(a, GR, Gp, q0, raw, cs);
}

/* a raw solution in the chain's order, each angle in (-pi, pi] */
static void chain_order(const ArmGeometry* a, const double* raw, double* q) {
  for (int k = 0; k < 6; k++) q[k] = wrap(raw[a->reverse ? 5 - k : k]);
}

/* q is none of the n solutions in sol (no two angles within SAME, both in (-pi, pi]) */
static int distinct(double sol[MAXSOL][6], int n, const double* q) {
  for (int j = 0; j < n; j++) {
    int same = 1;
    for (int k = 0; k < 6 && same; k++) {
      double d = fabs(q[k] - sol[j][k]);
      same = d <= SAME || TWO_PI - d <= SAME;
    }
    if (same) return 0;
  }
  return 1;
}

/* every solution of G (in the chain's order, each angle in (-pi, pi]), each checked and
   polished; q0 the start */
int sp_solve_all(const ArmGeometry* a, const double* GR_in, const double* Gp_in,
                 const double* q0_in, double out[MAXSOL][6]) {
  double GR[9], Gp[3], q0[6], raw[MAXSOL][6], cs[MAXSOL][12], q[6];
  int have, nr = raw_solutions(a, GR_in, Gp_in, q0_in, GR, Gp, q0, raw, cs, &have), n = 0;
  for (int i = 0; i < nr; i++) {
    if (polish(a, raw[i], have ? cs[i] : NULL, GR, Gp) > ACCEPT) continue;
    chain_order(a, raw[i], q);
    if (distinct(out, n, q)) memcpy(out[n++], q, sizeof q);
  }
  return n;
}

/* ------------------------------------------------------------------ targets, ranges */

/* the rotation of a wxyz quaternion (normalised here), row-major */
static void quat_mat(const double* q, double* R) {
  double w = q[0], x = q[1], y = q[2], z = q[3], s = 1.0 / (w * w + x * x + y * y + z * z);
  R[0] = 1 - 2 * s * (y * y + z * z), R[1] = 2 * s * (x * y - w * z), R[2] = 2 * s * (x * z + w * y);
  R[3] = 2 * s * (x * y + w * z), R[4] = 1 - 2 * s * (x * x + z * z), R[5] = 2 * s * (y * z - w * x);
  R[6] = 2 * s * (x * z - w * y), R[7] = 2 * s * (y * z + w * x), R[8] = 1 - 2 * s * (x * x + y * y);
}

/* target (position 3, quaternion wxyz 4) and base (position 3, row-major rotation 9,
   world) into G in the base frame */
void sp_target(const ArmGeometry* a, const double* pos, const double* quat, const double* base,
               double* GR, double* Gp) {
  double Rt[9], Rd[9], pd[3], d[3], c[3];
  quat_mat(quat, Rt);
  mat_tmul(base + 3, Rt, Rd); /* Rb' Rt */
  sub(pos, base, d);
  mat_tvec(base + 3, d, pd);
  for (int i = 0; i < 3; i++) /* GR = Rd R0' */
    for (int j = 0; j < 3; j++)
      GR[3 * i + j] = Rd[3 * i] * a->R0[3 * j] + Rd[3 * i + 1] * a->R0[3 * j + 1] + Rd[3 * i + 2] * a->R0[3 * j + 2];
  mat_vec(GR, a->p0, c);
  sub(pd, c, Gp);
}

/* angle q moved by a multiple of 2 pi into [lo, hi] (slack tol), nearest the start s;
   returns 0 where no shift fits */
static int shift(double q, double s, double lo, double hi, double tol, double* out) {
  if (fabs(s - q) < M_PI && q >= lo - tol && q <= hi + tol) { /* no shift: the common case */
    *out = q < lo ? lo : (q > hi ? hi : q);
    return 1;
  }
  double k = round((s - q) / TWO_PI);
  if (isfinite(lo)) k = fmax(k, ceil((lo - tol - q) / TWO_PI));
  if (isfinite(hi)) k = fmin(k, floor((hi + tol - q) / TWO_PI));
  double x = q + k * TWO_PI;
  if ((isfinite(lo) && x < lo - tol) || (isfinite(hi) && x > hi + tol)) return 0;
  *out = x < lo ? lo : (x > hi ? hi : x);
  return 1;
}

/* a solution with the ranges applied: its angles shifted (shift) or, out of range, the
   shift nearest the range clipped into it; its distance to the start (sum of squares),
   how far it leaves the ranges, whether it fits them */
typedef struct {
  double x[6], d, miss;
  int ok;
} Placed;

static void place(const double* sol, const double* q0, const double* L, const double* U,
                  double tol, Placed* p) {
  p->d = 0.0, p->miss = 0.0, p->ok = 1;
  for (int k = 0; k < 6; k++) {
    if (!shift(sol[k], q0[k], L[k], U[k], tol, &p->x[k])) {
      double c = isfinite(L[k]) && isfinite(U[k]) ? 0.5 * (L[k] + U[k]) : q0[k];
      double y = sol[k] + round((c - sol[k]) / TWO_PI) * TWO_PI;
      p->miss += y < L[k] ? L[k] - y : y - U[k];
      p->x[k] = y < L[k] ? L[k] : (y > U[k] ? U[k] : y);
      p->ok = 0;
    }
    p->d += (p->x[k] - q0[k]) * (p->x[k] - q0[k]);
  }
}

/* The pick of n placed solutions: the in-range one nearest the start; with none inside,
   the one that leaves the ranges least (clipped into them); -1 with none at all. Into
   *inside how many fit the ranges. */
static int choose(const Placed* p, int n, int* inside) {
  int best = -1, near = -1;
  *inside = 0;
  for (int i = 0; i < n; i++) {
    if (p[i].ok) {
      ++*inside;
      if (best < 0 || p[i].d < p[best].d) best = i;
    } else if (!*inside && (near < 0 || p[i].miss < p[near].miss)) {
      near = i;
    }
  }
  return *inside ? best : near;
}

/* The solutions of G unchecked and distinct (in the chain's order), each angle moved by
   multiples of 2 pi into its range nearest the start (shift), and the in-range one
   nearest q0 (sum of squares) picked; with none inside, the one whose angles (shifted
   nearest the ranges) leave them least, clipped into them; with none at all, q0. Only
   the pick is checked and polished: a pick off by more than ACCEPT is dropped and the
   next one picked, so an answer is never a spurious root (one pose error a target
   instead of one a solution). The pick into out; returns how many solutions fit the
   ranges, *found how many there were (those never picked unchecked). */
int sp_solve_pick(const ArmGeometry* a, const double* GR_in, const double* Gp_in,
                  const double* q0_in, const double* L, const double* U, double tol, double* out,
                  int* found) {
  double GR[9], Gp[3], q0[6], raw[MAXSOL][6], cs[MAXSOL][12], sol[MAXSOL][6];
  Placed placed[MAXSOL];
  int from[MAXSOL], checked[MAXSOL], n = 0, inside = 0, have;
  int nr = raw_solutions(a, GR_in, Gp_in, q0_in, GR, Gp, q0, raw, cs, &have);
  for (int i = 0; i < nr; i++) {
    chain_order(a, raw[i], sol[n]);
    if (!distinct(sol, n, sol[n])) continue;
    place(sol[n], q0_in, L, U, tol, &placed[n]);
    from[n] = i, checked[n] = 0, n++;
  }
  for (;;) {
    int k = choose(placed, n, &inside);
    if (k < 0 || checked[k]) {
      memcpy(out, k < 0 ? q0_in : placed[k].x, 6 * sizeof(double));
      *found = n;
      return inside;
    }
    if (polish(a, raw[from[k]], have ? cs[from[k]] : NULL, GR, Gp) > ACCEPT) { /* spurious */
      n--;
      memmove(placed + k, placed + k + 1, (n - k) * sizeof placed[0]);
      memmove(from + k, from + k + 1, (n - k) * sizeof from[0]);
      memmove(checked + k, checked + k + 1, (n - k) * sizeof checked[0]);
      continue;
    }
    double q[6];
    chain_order(a, raw[from[k]], q);
    place(q, q0_in, L, U, tol, &placed[k]);
    checked[k] = 1;
  }
}

/* ------------------------------------------------------------------ a 7th joint, locked */

/* G of the 6-hinge arm left when the 7-hinge arm's joint `locked` (0: the first, 6: the
   last) is held at t: G7 = e^(h1 q1) ... e^(h7 q7) loses e^(h t) on its side */
static void unlock(const double* h, const double* p, int locked, double t, const double* GR,
                   const double* Gp, double* GR6, double* Gp6) {
  double Rm[9], c[3], u[3]; /* e^(-h t): x -> Rm x + u, u = p - Rm p */
  rot_mat(h, -t, Rm);
  mat_vec(Rm, p, c);
  sub(p, c, u);
  if (locked == 0) { /* e^(-h t) G7 */
    mat_mul(Rm, GR, GR6);
    mat_vec(Rm, Gp, c);
    add(c, u, Gp6);
  } else { /* G7 e^(-h t) */
    mat_mul(GR, Rm, GR6);
    mat_vec(GR, u, c);
    add(c, Gp, Gp6);
  }
}

/* the 6 angles of the unlocked joints (k the locked one) out of 7, or back */
static void drop(const double* q7, int k, double* q6) {
  for (int i = 0, j = 0; i < 7; i++)
    if (i != k) q6[j++] = q7[i];
}
static void insert(const double* q6, int k, double t, double* q7) {
  for (int i = 0, j = 0; i < 7; i++) q7[i] = i == k ? t : q6[j++];
}

int sp_locked_solutions(const LockedArm* a, const double* GR, const double* Gp, const double* q0,
                        double t, double out[MAXSOL][7]) {
  double GR6[9], Gp6[3], s6[6], sol[MAXSOL][6];
  int k = a->locked;
  unlock(a->h, a->p, k, t, GR, Gp, GR6, Gp6);
  drop(q0, k, s6);
  int n = sp_solve_all(&a->arm, GR6, Gp6, s6, sol);
  for (int i = 0; i < n; i++) insert(sol[i], k, t, out[i]);
  return n;
}

/* The locked joint at t: the other six by the 6-hinge families and their ranges
   (sp_pick), the pick into out (7); returns how many fit the ranges, *n how many
   solutions there were. */
static int locked_at(const LockedArm* a, const double* GR, const double* Gp, const double* q0,
                     const double* L, const double* U, double tol, double t, double* out, int* n) {
  double GR6[9], Gp6[3], s6[6], l6[6], u6[6], got[6];
  int k = a->locked;
  unlock(a->h, a->p, k, t, GR, Gp, GR6, Gp6);
  drop(q0, k, s6), drop(L, k, l6), drop(U, k, u6);
  int inside = sp_solve_pick(&a->arm, GR6, Gp6, s6, l6, u6, tol, got, n);
  insert(got, k, t, out);
  return inside;
}

/* The search over the locked joint: its start value first (clipped into its range), then
   steps of SEARCH_COARSE outwards, both ways in turn, to the ends of its range (half a
   turn each way when unlimited); at the first step with a solution in range, the value
   nearest the start that has one is found by bisection between it and the step before
   (SEARCH_HALVINGS times), and the answer is the in-range solution nearest the start
   there. A window narrower than the coarse step is looked for again in steps of
   SEARCH_STEP when the coarse steps found none. *tried: the values tried; *found: the
   most solutions at one of them. With none inside anywhere, out holds the start value's
   out-of-range pick where it has solutions, else the first tried value's that has, else
   q0. */
static int scan(const LockedArm* a, const double* GR, const double* Gp, const double* q0,
                const double* L, const double* U, double tol, double t0, double below,
                double above, double step, double* out, int* found, int* tried, double* miss,
                int* have_miss) {
  int n;
  for (int j = 0;; j++) {
    double d = j * step;
    if (d > below && d > above) return 0;
    for (int side = 0; side < (j ? 2 : 1); side++) {
      if ((side == 0 && d > above) || (side == 1 && d > below)) continue;
      double sign = side == 0 ? 1.0 : -1.0, t = t0 + sign * d, x[7];
      int inside = locked_at(a, GR, Gp, q0, L, U, tol, t, x, &n);
      ++*tried;
      if (n > *found) *found = n;
      if (!inside) {
        if (n && !*have_miss) memcpy(miss, x, sizeof x), *have_miss = 1;
        continue;
      }
      memcpy(out, x, sizeof x);
      if (j == 0) return inside;
      double in = d, gap = d - step; /* in range at in, not at gap */
      for (int h = 0; h < SEARCH_HALVINGS; h++) {
        double mid = 0.5 * (in + gap), y[7];
        int k = locked_at(a, GR, Gp, q0, L, U, tol, t0 + sign * mid, y, &n);
        ++*tried;
        if (n > *found) *found = n;
        if (k) in = mid, inside = k, memcpy(out, y, sizeof y);
        else gap = mid;
      }
      return inside;
    }
  }
}

int sp_search(const LockedArm* a, const double* GR, const double* Gp, const double* q0,
              const double* L, const double* U, double tol, double* out, int* found, int* tried) {
  int k = a->locked, have_miss = 0;
  double lo = L[k], hi = U[k], t0 = q0[k], miss[7];
  if (isfinite(lo) && t0 < lo) t0 = lo;
  if (isfinite(hi) && t0 > hi) t0 = hi;
  double below = isfinite(lo) ? t0 - lo : M_PI, above = isfinite(hi) ? hi - t0 : M_PI;
  *found = 0, *tried = 0;
  memcpy(out, q0, 7 * sizeof(double));
  for (int pass = 0; pass < 2; pass++) {
    double step = pass ? SEARCH_STEP : SEARCH_COARSE;
    int inside = scan(a, GR, Gp, q0, L, U, tol, t0, below, above, step, out, found, tried, miss,
                      &have_miss);
    if (inside) return inside;
  }
  memcpy(out, have_miss ? miss : q0, 7 * sizeof(double));
  return 0;
}
