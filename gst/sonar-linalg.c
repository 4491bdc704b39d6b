/* sonar-linalg.c: small dense matrices (sonar-linalg.h). */
#include "sonar-linalg.h"

#include <math.h>
#include <string.h>

void
sonar_linalg_multiply (const double *a, const double *b, double *c, guint n,
    guint m, guint k)
{
  for (guint i = 0; i < n; i++)
    for (guint j = 0; j < k; j++) {
      double sum = 0.0;
      for (guint l = 0; l < m; l++)
        sum += a[i * m + l] * b[l * k + j];
      c[i * k + j] = sum;
    }
}

void
sonar_linalg_multiply_transposed (const double *a, const double *b,
    double *c, guint n, guint m, guint k)
{
  for (guint i = 0; i < n; i++)
    for (guint j = 0; j < k; j++) {
      double sum = 0.0;
      for (guint l = 0; l < m; l++)
        sum += a[i * m + l] * b[j * m + l];
      c[i * k + j] = sum;
    }
}

gboolean
sonar_linalg_invert_spd (double *a, guint n, double *log_det)
{
  double l[SONAR_LINALG_MAX * SONAR_LINALG_MAX] = { 0 };
  double inv_l[SONAR_LINALG_MAX * SONAR_LINALG_MAX] = { 0 };
  double ld = 0.0;

  g_return_val_if_fail (n <= SONAR_LINALG_MAX, FALSE);
  /* a = L L^T */
  for (guint i = 0; i < n; i++)
    for (guint j = 0; j <= i; j++) {
      double sum = a[i * n + j];
      for (guint k = 0; k < j; k++)
        sum -= l[i * n + k] * l[j * n + k];
      if (i == j) {
        if (!(sum > 0.0) || !isfinite (sum))
          return FALSE;
        l[i * n + i] = sqrt (sum);
        ld += log (sum);
      } else {
        l[i * n + j] = sum / l[j * n + j];
      }
    }
  /* L^-1, lower triangular */
  for (guint j = 0; j < n; j++) {
    inv_l[j * n + j] = 1.0 / l[j * n + j];
    for (guint i = j + 1; i < n; i++) {
      double sum = 0.0;
      for (guint k = j; k < i; k++)
        sum -= l[i * n + k] * inv_l[k * n + j];
      inv_l[i * n + j] = sum / l[i * n + i];
    }
  }
  /* a^-1 = L^-T L^-1 */
  for (guint i = 0; i < n; i++)
    for (guint j = 0; j <= i; j++) {
      double sum = 0.0;
      for (guint k = i; k < n; k++)
        sum += inv_l[k * n + i] * inv_l[k * n + j];
      a[i * n + j] = a[j * n + i] = sum;
    }
  if (log_det)
    *log_det = ld;
  return TRUE;
}

gboolean
sonar_linalg_cholesky (double *a, guint n)
{
  for (guint j = 0; j < n; j++) {
    double d = a[(gsize) j * n + j];
    for (guint k = 0; k < j; k++)
      d -= a[(gsize) j * n + k] * a[(gsize) j * n + k];
    if (!(d > 0.0) || !isfinite (d))
      return FALSE;
    d = sqrt (d);
    a[(gsize) j * n + j] = d;
    for (guint i = j + 1; i < n; i++) {
      double sum = a[(gsize) i * n + j];
      for (guint k = 0; k < j; k++)
        sum -= a[(gsize) i * n + k] * a[(gsize) j * n + k];
      a[(gsize) i * n + j] = sum / d;
    }
  }
  return TRUE;
}

void
sonar_linalg_cholesky_solve (const double *l, guint n, double *b)
{
  /* L y = b, then L^T x = y */
  for (guint i = 0; i < n; i++) {
    double sum = b[i];
    for (guint k = 0; k < i; k++)
      sum -= l[(gsize) i * n + k] * b[k];
    b[i] = sum / l[(gsize) i * n + i];
  }
  for (guint i = n; i-- > 0;) {
    double sum = b[i];
    for (guint k = i + 1; k < n; k++)
      sum -= l[(gsize) k * n + i] * b[k];
    b[i] = sum / l[(gsize) i * n + i];
  }
}

void
sonar_linalg_eigen_symmetric3 (const double a_in[3][3], double values[3],
    double vectors[3][3])
{
  double a[3][3], v[3][3] = { {1, 0, 0}, {0, 1, 0}, {0, 0, 1} };
  guint order[3] = { 0, 1, 2 };

  memcpy (a, a_in, sizeof a);
  for (guint sweep = 0; sweep < 50; sweep++) {
    const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2]
        + a[1][2] * a[1][2];
    const double scale = a[0][0] * a[0][0] + a[1][1] * a[1][1]
        + a[2][2] * a[2][2];
    if (off <= 1e-30 * scale || off == 0.0)
      break;
    for (guint p = 0; p < 2; p++)
      for (guint q = p + 1; q < 3; q++) {
        double theta, t, c, s;
        if (a[p][q] == 0.0)
          continue;
        theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        t = (theta >= 0 ? 1.0 : -1.0) / (fabs (theta) + sqrt (theta * theta
                + 1.0));
        c = 1.0 / sqrt (t * t + 1.0);
        s = t * c;
        for (guint k = 0; k < 3; k++) {
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (guint k = 0; k < 3; k++) {
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (guint k = 0; k < 3; k++) {
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
  }
  /* Sort decreasing; eigenvector i is column order[i] of v. */
  for (guint i = 0; i < 3; i++)
    for (guint j = i + 1; j < 3; j++)
      if (a[order[j]][order[j]] > a[order[i]][order[i]]) {
        const guint t = order[i];
        order[i] = order[j];
        order[j] = t;
      }
  for (guint i = 0; i < 3; i++) {
    values[i] = a[order[i]][order[i]];
    for (guint k = 0; k < 3; k++)
      vectors[i][k] = v[k][order[i]];
  }
}

gboolean
sonar_linalg_quadratic_peak (double gx, double gy, double hxx, double hxy,
    double hyy, double *x, double *y)
{
  const double det = hxx * hyy - hxy * hxy;

  if (!(hxx < 0.0 && det > 0.0))
    return FALSE;
  *x = (hxy * gy - hyy * gx) / det;
  *y = (hxy * gx - hxx * gy) / det;
  return TRUE;
}
