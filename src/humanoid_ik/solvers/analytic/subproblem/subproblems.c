/* The Paden-Kahan subproblems SP1-SP4 and SP6 (the quartic of two conics), on doubles:
   the equations are in families.c's opening comment. Built with
   -ffp-contract=off (GCC, Clang): the same rounding on every machine. */

#include <string.h>

#include "subproblems.h"

/* ------------------------------------------------------------------ subproblems */

/* SP1: t with R(k, t) p closest to q; returns |p_perp| |q_perp| (0: any t) */
double sp1(const double* k, const double* p, const double* q, double* t, double* cs) {
  double pp[3], qp[3], c[3], kp = dot(k, p), kq = dot(k, q);
  for (int i = 0; i < 3; i++) pp[i] = p[i] - kp * k[i], qp[i] = q[i] - kq * k[i];
  cross(pp, qp, c);
  double y = dot(k, c), x = dot(pp, qp);
  *t = atan2(y, x);
  if (cs) { /* cos t, sin t from atan2's own arguments */
    double r = sqrt(x * x + y * y);
    cs[0] = r > 0.0 ? x / r : 1.0, cs[1] = r > 0.0 ? y / r : 0.0;
  }
  return norm(pp) * norm(qp);
}

/* roots of A cos t + B sin t = C: 0 or 2 (a tangent case within SLACK gives 2 equal);
   with cs, their cosines and sines too (cs[2 i], cs[2 i + 1]), from the same numbers
   instead of cos and sin of the roots */
static int trig(double A, double B, double C, double* t, double* cs) {
  double r = hypot(A, B);
  if (r < 1e-300) return 0;
  double x = C / r;
  if (fabs(x) > 1.0 + SLACK) return 0;
  x = x > 1.0 ? 1.0 : (x < -1.0 ? -1.0 : x);
  double base = atan2(B, A), half = acos(x);
  t[0] = base + half, t[1] = base - half;
  if (cs) { /* t = base +- half: cos base = A / r, sin base = B / r, cos half = x */
    double cb = A / r, sb = B / r, sh = sqrt(1.0 - x * x);
    cs[0] = cb * x - sb * sh, cs[1] = sb * x + cb * sh;
    cs[2] = cb * x + sb * sh, cs[3] = sb * x - cb * sh;
  }
  return 2;
}

/* SP3: t with |R(k, t) p - q| = d */
int sp3(const double* k, const double* p, const double* q, double d, double* t, double* cs) {
  double pp[3], qp[3], kpq = dot(k, p) - dot(k, q), c[3];
  double kp = dot(k, p), kq = dot(k, q);
  for (int i = 0; i < 3; i++) pp[i] = p[i] - kp * k[i], qp[i] = q[i] - kq * k[i];
  /* |R pp - qp|^2 = |pp|^2 + |qp|^2 - 2 (cos t pp.qp + sin t k.(pp x qp)) = d^2 - kpq^2 */
  cross(pp, qp, c);
  double A = 2.0 * dot(pp, qp), B = 2.0 * dot(k, c);
  double C = dot(pp, pp) + dot(qp, qp) - d * d + kpq * kpq;
  return trig(A, B, C, t, cs);
}

/* SP4: t with h' R(k, t) p = d */
int sp4(const double* h, const double* k, const double* p, double d, double* t, double* cs) {
  double kx[3], hk = dot(h, k), kp = dot(k, p);
  cross(k, p, kx);
  return trig(dot(h, p) - hk * kp, dot(h, kx), d - hk * kp, t, cs);
}

/* SP2: (t1, t2) with R(k1, t1) p1 = R(k2, t2) p2, k1 not parallel to k2 */
int sp2(const double* k1, const double* p1, const double* k2, const double* p2,
               double* t1, double* t2) {
  double k12 = dot(k1, k2), den = 1.0 - k12 * k12, n[3];
  if (den < 1e-24) return 0;
  double a1 = dot(k1, p1), a2 = dot(k2, p2);
  double al = (a1 - k12 * a2) / den, be = (a2 - k12 * a1) / den;
  double r2 = 0.5 * (dot(p1, p1) + dot(p2, p2));
  cross(k1, k2, n);
  double g2 = (r2 - al * al - be * be - 2.0 * al * be * k12) / den;
  if (g2 < -SLACK * (r2 + 1e-300)) return 0;
  double g = g2 > 0.0 ? sqrt(g2) : 0.0;
  for (int s = 0; s < 2; s++) {
    double c[3], gs = s ? -g : g;
    for (int i = 0; i < 3; i++) c[i] = al * k1[i] + be * k2[i] + gs * n[i];
    sp1(k1, p1, c, &t1[s], NULL);
    sp1(k2, p2, c, &t2[s], NULL);
  }
  return 2;
}

/* the coefficients of h' R(k, t) p = c0 + cc cos t + cs sin t */
void trig_terms(const double* h, const double* k, const double* p, double* c) {
  double kx[3], hk = dot(h, k), kp = dot(k, p);
  cross(k, p, kx);
  c[0] = hk * kp, c[1] = dot(h, p) - hk * kp, c[2] = dot(h, kx);
}

/* ------------------------------------------------------------------ polynomials */

static double peval(const double* c, int deg, double x) { /* c[0] + c[1] x + ... */
  double v = c[deg];
  for (int i = deg - 1; i >= 0; i--) v = v * x + c[i];
  return v;
}

/* the real roots of the polynomial c (degree <= 4) in [lo, hi], by its critical points
   (the derivative's roots, recursively) and a safeguarded Newton search between them;
   a critical point where the polynomial nearly vanishes is a (double) root */
static int real_roots(const double* c, int deg, double lo, double hi, double* roots) {
  double scale = 0.0;
  for (int i = 0; i <= deg; i++) scale = fmax(scale, fabs(c[i]));
  while (deg > 0 && fabs(c[deg]) <= 1e-14 * scale) deg--;
  if (deg <= 0 || scale == 0.0) return 0;
  double d[4], crit[6], pts[8];
  for (int i = 1; i <= deg; i++) d[i - 1] = i * c[i];
  int nc = real_roots(d, deg - 1, lo, hi, crit), np = 0, n = 0;
  pts[np++] = lo;
  for (int i = 0; i < nc; i++) pts[np++] = crit[i];
  pts[np++] = hi;
  double tol = 1e-12 * scale;
  for (int i = 0; i + 1 < np; i++) {
    double a = pts[i], b = pts[i + 1], fa = peval(c, deg, a), fb = peval(c, deg, b);
    if (i > 0 && fabs(fa) <= tol) {
      if (n == 0 || fabs(roots[n - 1] - a) > 1e-12) roots[n++] = a;
      continue;
    }
    if (fa * fb > 0.0 || b <= a) continue;
    if (fb == 0.0) continue; /* b is the next interval's start */
    double x = 0.5 * (a + b);
    for (int it = 0; it < 60; it++) {
      double f = peval(c, deg, x), fd = peval(d, deg - 1, x);
      if (f == 0.0) break;
      if ((f < 0.0) == (fa < 0.0)) a = x; else b = x;
      double xn = fd != 0.0 ? x - f / fd : 0.5 * (a + b);
      if (!(xn > a && xn < b)) xn = 0.5 * (a + b);
      double step = fabs(xn - x);
      x = xn;
      if (step <= 1e-14 * (1.0 + fabs(x)) || b - a <= 1e-15 * (1.0 + fabs(x))) break;
    }
    if (n == 0 || fabs(roots[n - 1] - x) > 1e-12) roots[n++] = x;
  }
  return n;
}

static void pmul(const double* a, int da, const double* b, int db, double* out) {
  for (int i = 0; i <= da + db; i++) out[i] = 0.0;
  for (int i = 0; i <= da; i++)
    for (int j = 0; j <= db; j++) out[i + j] += a[i] * b[j];
}

/* SP6 on the linear form A x = b, x = (cos t1, sin t1, cos t2, sin t2), A 2x4:
   x = xp + N y over the null space N of A (4x2, orthonormal), and |x_12| = |x_34| = 1
   are two conics in y = (u, v); their resultant in v is a quartic in u (|y| <= sqrt 2).
   Each root is polished by Newton steps on the two equations themselves. */
int sp6(const double A[2][4], const double b[2], double* t1, double* t2) {
  double M[2][2] = {{0, 0}, {0, 0}};
  for (int i = 0; i < 2; i++)
    for (int j = 0; j < 2; j++)
      for (int k = 0; k < 4; k++) M[i][j] += A[i][k] * A[j][k];
  double det = M[0][0] * M[1][1] - M[0][1] * M[1][0];
  double sc = M[0][0] + M[1][1];
  if (!(fabs(det) > 1e-20 * sc * sc)) return 0;
  double Mi[2][2] = {{M[1][1] / det, -M[0][1] / det}, {-M[1][0] / det, M[0][0] / det}};
  double w[2] = {Mi[0][0] * b[0] + Mi[0][1] * b[1], Mi[1][0] * b[0] + Mi[1][1] * b[1]};
  double xp[4], P[4][4];
  for (int k = 0; k < 4; k++) xp[k] = A[0][k] * w[0] + A[1][k] * w[1];
  double xx = dot(xp, xp) + xp[3] * xp[3];
  if (xx > 2.0 * (1.0 + SLACK)) return 0;
  for (int i = 0; i < 4; i++)
    for (int j = 0; j < 4; j++) {
      double s = 0.0;
      for (int r = 0; r < 2; r++)
        for (int q = 0; q < 2; q++) s += A[r][i] * Mi[r][q] * A[q][j];
      P[i][j] = (i == j) - s;
    }
  /* two orthonormal null-space vectors: the projector's longest columns */
  double N[2][4];
  int best = 0;
  double bn = -1.0;
  for (int j = 0; j < 4; j++) {
    double s = 0.0;
    for (int i = 0; i < 4; i++) s += P[i][j] * P[i][j];
    if (s > bn) bn = s, best = j;
  }
  for (int i = 0; i < 4; i++) N[0][i] = P[i][best] / sqrt(bn);
  bn = -1.0;
  double cand[4];
  for (int j = 0; j < 4; j++) {
    double pr = 0.0, s = 0.0, v[4];
    for (int i = 0; i < 4; i++) pr += N[0][i] * P[i][j];
    for (int i = 0; i < 4; i++) v[i] = P[i][j] - pr * N[0][i], s += v[i] * v[i];
    if (s > bn) {
      bn = s;
      for (int i = 0; i < 4; i++) cand[i] = v[i];
    }
  }
  for (int i = 0; i < 4; i++) N[1][i] = cand[i] / sqrt(bn);
  { /* a fixed turn of the basis: no conic axis along u or v by construction */
    double c = cos(0.5), s = sin(0.5);
    for (int i = 0; i < 4; i++) {
      double a0 = N[0][i], a1 = N[1][i];
      N[0][i] = c * a0 + s * a1, N[1][i] = -s * a0 + c * a1;
    }
  }
  /* conic i: Au u^2 + Buv u v + Cv v^2 + Du u + Ev v + F */
  double Q[2][6];
  for (int i = 0; i < 2; i++) {
    const double *n0 = N[0] + 2 * i, *n1 = N[1] + 2 * i, *x0 = xp + 2 * i;
    Q[i][0] = n0[0] * n0[0] + n0[1] * n0[1];
    Q[i][1] = 2.0 * (n0[0] * n1[0] + n0[1] * n1[1]);
    Q[i][2] = n1[0] * n1[0] + n1[1] * n1[1];
    Q[i][3] = 2.0 * (n0[0] * x0[0] + n0[1] * x0[1]);
    Q[i][4] = 2.0 * (n1[0] * x0[0] + n1[1] * x0[1]);
    Q[i][5] = x0[0] * x0[0] + x0[1] * x0[1] - 1.0;
  }
  /* as quadratics in v: a (const), b(u) = Buv u + Ev, c(u) = Au u^2 + Du u + F */
  double a1 = Q[0][2], a2 = Q[1][2];
  double b1[2] = {Q[0][4], Q[0][1]}, b2[2] = {Q[1][4], Q[1][1]};
  double c1[3] = {Q[0][5], Q[0][3], Q[0][0]}, c2[3] = {Q[1][5], Q[1][3], Q[1][0]};
  /* R(u) = (a1 c2 - a2 c1)^2 - (a1 b2 - a2 b1)(b1 c2 - b2 c1) */
  double e[3], f[2], g[4], t[4], R[5], sq[5], pr[5];
  for (int i = 0; i < 3; i++) e[i] = a1 * c2[i] - a2 * c1[i];
  for (int i = 0; i < 2; i++) f[i] = a1 * b2[i] - a2 * b1[i];
  pmul(b1, 1, c2, 2, g);
  pmul(b2, 1, c1, 2, t);
  for (int i = 0; i < 4; i++) g[i] -= t[i];
  pmul(e, 2, e, 2, sq);
  pmul(f, 1, g, 3, pr);
  for (int i = 0; i < 5; i++) R[i] = sq[i] - pr[i];
  double lim = sqrt(2.0) * (1.0 + 1e-6), us[4];
  int nu = real_roots(R, 4, -lim, lim, us), n = 0;
  for (int r = 0; r < nu; r++) {
    double u = us[r], vs[2];
    int k = fabs(a1) >= fabs(a2) ? 0 : 1, nv = 0;
    double qa = Q[k][2], qb = Q[k][1] * u + Q[k][4], qc = Q[k][0] * u * u + Q[k][3] * u + Q[k][5];
    if (fabs(qa) > 1e-12) {
      double disc = qb * qb - 4.0 * qa * qc;
      if (disc < -1e-9) continue;
      disc = disc > 0.0 ? sqrt(disc) : 0.0;
      vs[nv++] = (-qb + disc) / (2.0 * qa), vs[nv++] = (-qb - disc) / (2.0 * qa);
    } else if (fabs(qb) > 1e-12) {
      vs[nv++] = -qc / qb;
    }
    for (int s = 0; s < nv && n < 4; s++) {
      double v = vs[s], x[4], th[2];
      const double* o = Q[1 - k];
      double other = o[0] * u * u + o[1] * u * v + o[2] * v * v + o[3] * u + o[4] * v + o[5];
      if (fabs(other) > 1e-6) continue;
      for (int i = 0; i < 4; i++) x[i] = xp[i] + N[0][i] * u + N[1][i] * v;
      th[0] = atan2(x[1], x[0]), th[1] = atan2(x[3], x[2]);
      for (int it = 0; it < 4; it++) { /* Newton on A x(th) = b */
        double c0 = cos(th[0]), s0 = sin(th[0]), cc = cos(th[1]), ss = sin(th[1]);
        double r0 = A[0][0] * c0 + A[0][1] * s0 + A[0][2] * cc + A[0][3] * ss - b[0];
        double r1 = A[1][0] * c0 + A[1][1] * s0 + A[1][2] * cc + A[1][3] * ss - b[1];
        double J00 = -A[0][0] * s0 + A[0][1] * c0, J01 = -A[0][2] * ss + A[0][3] * cc;
        double J10 = -A[1][0] * s0 + A[1][1] * c0, J11 = -A[1][2] * ss + A[1][3] * cc;
        double dj = J00 * J11 - J01 * J10;
        if (fabs(r0) + fabs(r1) < 1e-15 || fabs(dj) < 1e-14) break;
        th[0] -= (J11 * r0 - J01 * r1) / dj;
        th[1] -= (-J10 * r0 + J00 * r1) / dj;
      }
      t1[n] = th[0], t2[n] = th[1], n++;
    }
  }
  return n;
}
