/* test-cluster.c: the clustering core against SciPy, and on synthetic
 * sonar images.
 *
 * SciPy's results come from tests/data/cluster-fixtures.json, written by
 * tests/cluster_fixtures.py; /cluster/scipy-live reruns that script with
 * /usr/bin/python3 and checks against its fresh output too (skipped when
 * SciPy is missing). */
#include <gio/gio.h>
#include <json-glib/json-glib.h>
#include <math.h>
#include <string.h>
#include <time.h>

#include "sonar-cluster.h"
#include "sonar-kernels.h"
#include "sonar-setup.h"
#include "sonar-rng.h"
#include "sonar-test-util.h"
#include "sonar-error.h"
#include "sonar-workers.h"

/* The synthetic images are not sonar echoes: no spreading loss to undo. */
static void
synthetic_params (SonarClusterParams * p)
{
  sonar_cluster_params_init_default (p);
  p->range_compensation = FALSE;
  p->threshold_db = -20.0;
  p->pfa = 1.0;
  p->sidelobe_db = -200.0;
}

/* The methods of sonar-linkage.h: their nicks are SciPy's method names,
 * the fixtures' keys (a nick SciPy lacks fails the SciPy comparison). */
static guint
n_methods (void)
{
  guint n;

  sonar_linkage_methods (&n);
  return n;
}

static const char *
method_name (SonarLinkage method)
{
  guint n;

  return sonar_linkage_methods (&n)[method].nick;
}

/* SciPy comparison */

static double *
read_matrix (JsonArray * rows, guint n_rows, guint n_cols)
{
  double *m = g_new0 (double, MAX (n_rows * n_cols, 1));

  g_assert_cmpuint (json_array_get_length (rows), ==, n_rows);
  for (guint i = 0; i < n_rows; i++) {
    JsonArray *row = json_array_get_array_element (rows, i);
    g_assert_cmpuint (json_array_get_length (row), ==, n_cols);
    for (guint j = 0; j < n_cols; j++)
      m[i * n_cols + j] = json_array_get_double_element (row, j);
  }
  return m;
}

static int *
read_labels (JsonArray * a, guint n)
{
  int *labels = g_new (int, n);

  g_assert_cmpuint (json_array_get_length (a), ==, n);
  for (guint i = 0; i < n; i++)
    labels[i] = json_array_get_int_element (a, i);
  return labels;
}

/* The same partition, whatever the numbering. */
static gboolean
same_partition (const int *a, const int *b, guint n)
{
  g_autofree int *a_to_b = g_new0 (int, n + 1);
  g_autofree int *b_to_a = g_new0 (int, n + 1);

  for (guint i = 0; i < n; i++) {
    if (a[i] < 1 || a[i] > (int) n || b[i] < 1 || b[i] > (int) n)
      return FALSE;
    if ((a_to_b[a[i]] && a_to_b[a[i]] != b[i])
        || (b_to_a[b[i]] && b_to_a[b[i]] != a[i]))
      return FALSE;
    a_to_b[a[i]] = b[i];
    b_to_a[b[i]] = a[i];
  }
  return TRUE;
}

static guint64
leaf_hash (guint64 x)
{
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/* Per row, a hash of the set of points it joins. */
static guint64 *
row_sets (const double *Z, guint n)
{
  guint64 *h = g_new (guint64, n - 1);

  for (guint k = 0; k + 1 < n; k++) {
    h[k] = 0;
    for (int s = 0; s < 2; s++) {
      const int id = (int) Z[4 * k + s];
      h[k] += id < (int) n ? leaf_hash (id) : h[id - n];
    }
  }
  return h;
}

static int
compare_guint64 (gconstpointer a, gconstpointer b)
{
  const guint64 x = *(const guint64 *) a, y = *(const guint64 *) b;
  return x < y ? -1 : x > y;
}

/* Z equals SciPy's: heights within 1e-9 relative, and the same merges:
 * each run of rows of equal height joins the same sets of points (tied rows
 * may come in another order, and then their ids differ). Returns the number
 * of rows whose ids differ. */
static guint
check_linkage (const double *Z, const double *ref, guint n, const char *what)
{
  g_autofree guint64 *sets = row_sets (Z, n);
  g_autofree guint64 *ref_sets = row_sets (ref, n);
  guint differing = 0;

  for (guint k = 0; k + 1 < n; k++) {
    const double h = Z[4 * k + 2], r = ref[4 * k + 2];
    if (!(fabs (h - r) <= 1e-9 * fabs (r) + 1e-15))
      g_error ("%s row %u: height %.17g, SciPy %.17g", what, k, h, r);
    if (Z[4 * k] != ref[4 * k] || Z[4 * k + 1] != ref[4 * k + 1])
      differing++;
  }
  for (guint k = 0; k + 1 < n;) {
    guint end = k + 1;
    while (end + 1 < n && fabs (ref[4 * end + 2] - ref[4 * k + 2]) <=
        1e-12 * fabs (ref[4 * k + 2]))
      end++;
    qsort (sets + k, end - k, sizeof (guint64), compare_guint64);
    qsort (ref_sets + k, end - k, sizeof (guint64), compare_guint64);
    if (memcmp (sets + k, ref_sets + k, (end - k) * sizeof (guint64)) != 0)
      g_error ("%s rows %u-%u: other merges than SciPy's", what, k, end - 1);
    k = end;
  }
  return differing;
}

typedef struct
{
  guint linkages, rows, rows_differing, partitions, skipped;
  double worst_height_error;
} Tally;

static void
check_method (JsonObject * m, const double *points, guint n, guint dims,
    SonarLinkage method, const char *set_name, Tally * tally)
{
  JsonArray *cuts;
  g_autofree double *ref = read_matrix (json_object_get_array_member (m,
          "Z"), n - 1, 4);
  g_autofree double *Z = g_new0 (double, MAX (n - 1, 1) * 4);
  g_autofree int *labels = g_new (int, n);
  g_autofree char *what = g_strdup_printf ("%s/%s", set_name,
      method_name (method));

  sonar_linkage (points, n, dims, method, Z);
  if (n >= 2) {
    tally->rows_differing += check_linkage (Z, ref, n, what);
    for (guint k = 0; k + 1 < n; k++)
      tally->worst_height_error = MAX (tally->worst_height_error,
          fabs (Z[4 * k + 2] - ref[4 * k + 2]) / MAX (ref[4 * k + 2], 1e-300));
  }
  tally->linkages++;
  tally->rows += n - 1;

  cuts = json_object_get_array_member (m, "inconsistent");
  for (guint i = 0; i < json_array_get_length (cuts); i++) {
    JsonObject *cut = json_array_get_object_element (cuts, i);
    const double t = json_object_get_double_member (cut, "t");
    const guint depth = json_object_get_int_member (cut, "depth");
    g_autofree int *expected = read_labels (json_object_get_array_member
        (cut, "labels"), n);
    /* On SciPy's tree (the criterion alone) and on ours (end to end). */
    sonar_fcluster_inconsistent (ref, n, t, depth, labels);
    if (!same_partition (labels, expected, n))
      g_error ("%s: inconsistent t=%g depth=%u differs from SciPy's", what,
          t, depth);
    sonar_fcluster_inconsistent (Z, n, t, depth, labels);
    g_assert_true (same_partition (labels, expected, n));
    tally->partitions += 2;
  }
  cuts = json_object_get_array_member (m, "distance");
  for (guint i = 0; i < json_array_get_length (cuts); i++) {
    JsonObject *cut = json_array_get_object_element (cuts, i);
    const double t = json_object_get_double_member (cut, "t");
    g_autofree int *expected = read_labels (json_object_get_array_member
        (cut, "labels"), n);
    sonar_fcluster_distance (ref, n, t, labels);
    if (!same_partition (labels, expected, n))
      g_error ("%s: distance t=%g differs from SciPy's", what, t);
    sonar_fcluster_distance (Z, n, t, labels);
    g_assert_true (same_partition (labels, expected, n));
    tally->partitions += 2;
  }
}

static void
check_fixtures (const char *path)
{
  g_autoptr (JsonParser) parser = json_parser_new ();
  g_autoptr (GError) error = NULL;
  JsonObject *root;
  JsonArray *sets;
  Tally tally = { 0 };

  g_assert_true (json_parser_load_from_file (parser, path, &error));
  g_assert_no_error (error);
  root = json_node_get_object (json_parser_get_root (parser));
  sets = json_object_get_array_member (root, "sets");
  for (guint s = 0; s < json_array_get_length (sets); s++) {
    JsonObject *set = json_array_get_object_element (sets, s);
    const char *name = json_object_get_string_member (set, "name");
    const guint dims = json_object_get_int_member (set, "dims");
    JsonArray *pts = json_object_get_array_member (set, "points");
    const guint n = json_array_get_length (pts);
    g_autofree double *points = read_matrix (pts, n, dims);
    JsonObject *methods = json_object_get_object_member (set, "methods");
    const gboolean ties = json_object_get_boolean_member (set, "ties");

    for (guint m = 0; m < n_methods (); m++) {
      /* Ward and centroid distances come from the clusters' centroids,
       * SciPy's from Lance-Williams updates: equal to 1e-15, but exact ties
       * may fall the other way and give another, equally valid tree. */
      if (ties && (m == SONAR_LINKAGE_WARD || m == SONAR_LINKAGE_CENTROID)) {
        tally.skipped++;
        continue;
      }
      check_method (json_object_get_object_member (methods,
              method_name (m)), points, n, dims, m, name, &tally);
    }
  }
  g_test_message ("SciPy %s: %u linkages (%u with exact ties skipped), "
      "%u rows, worst relative height error %.1e, %u rows with other ids "
      "(tied heights), %u partitions equal",
      json_object_get_string_member (root, "scipy"), tally.linkages,
      tally.skipped, tally.rows, tally.worst_height_error,
      tally.rows_differing, tally.partitions);
}

static void
test_scipy_fixtures (void)
{
  g_autofree char *path =
      sonar_test_source_path ("tests/data/cluster-fixtures.json");
  check_fixtures (path);
}

static void
test_scipy_live (void)
{
  g_autofree char *script =
      sonar_test_source_path ("tests/cluster_fixtures.py");
  g_autofree char *out = sonar_test_write_temp ("live.json", "");
  const char *argv[] = { "/usr/bin/python3", script, out, NULL };
  g_autoptr (GError) error = NULL;
  int status;

  if (!g_file_test (argv[0], G_FILE_TEST_IS_EXECUTABLE)) {
    g_test_skip ("no /usr/bin/python3");
    return;
  }
  g_assert_true (g_spawn_sync (NULL, (char **) argv, NULL,
          G_SPAWN_STDERR_TO_DEV_NULL, NULL, NULL, NULL, NULL, &status,
          &error));
  if (!g_spawn_check_wait_status (status, &error)
      && g_error_matches (error, G_SPAWN_EXIT_ERROR, 77)) {
    g_test_skip ("no SciPy for /usr/bin/python3");
    return;
  }
  g_assert_no_error (error);
  check_fixtures (out);
}

/* Synthetic images */

typedef struct
{
  double azimuth, range, elevation;     /* degrees, m */
  double amplitude;
  double width;                 /* degrees: Gaussian sigma across */
} Blob;

/* Sigma in range of the main lobe, m: narrow, as the pulse compresses to
 * a few millimetres. */
#define RANGE_SIGMA 0.004
/* Half-length of the cross-talk ridges, m (physics notes: about one pulse
 * length). */
#define RIDGE_HALF_LENGTH 1.0

/* The 2-D fan of the brief: 181 azimuths, 1000 ranges 3 mm apart. */
static void
grid_2d (SonarImageGrid * g)
{
  g->n_azimuth = 181;
  g->azimuth_first = -90.0;
  g->azimuth_step = 1.0;
  g->n_elevation = 1;
  g->elevation_first = 0.0;
  g->elevation_step = 1.0;
  g->n_range = 1000;
  g->range_first = 0.3;
  g->range_step = 0.003;
}

/* Blobs (the maximum where they overlap) plus complex Gaussian noise of
 * @noise per component, as an envelope. With @ridge > 0, each blob also
 * has a cross-talk ridge: at its azimuths (same angular profile), over
 * +-1 m in range, Rayleigh speckle of mean @ridge relative to the blob. */
static float *
render (const SonarImageGrid * g, const Blob * blobs, guint n_blobs,
    double noise, double ridge, guint64 seed)
{
  float *image = g_new (float, sonar_image_grid_size (g));
  double *speckle = g_new (double, (gsize) n_blobs * g->n_range);
  SonarRng rng;

  sonar_rng_init (&rng, seed, 0);
  /* Rayleigh speckle of mean 1, one value per range: at a given range the
   * ridge has the lobe's angular profile. */
  for (gsize k = 0; k < (gsize) n_blobs * g->n_range; k++) {
    const double re = sonar_rng_gaussian (&rng);
    const double im = sonar_rng_gaussian (&rng);
    speckle[k] = sqrt (0.5 * (re * re + im * im)) / sqrt (M_PI / 4.0);
  }
  for (guint e = 0; e < g->n_elevation; e++)
    for (guint a = 0; a < g->n_azimuth; a++)
      for (guint i = 0; i < g->n_range; i++) {
        const double el = g->elevation_first + e * g->elevation_step;
        const double az = g->azimuth_first + a * g->azimuth_step;
        const double r = g->range_first + i * g->range_step;
        const double re = noise * sonar_rng_gaussian (&rng);
        const double im = noise * sonar_rng_gaussian (&rng);
        double v = 0.0;
        for (guint b = 0; b < n_blobs; b++) {
          const double daz = (az - blobs[b].azimuth) / blobs[b].width;
          const double del = (el - blobs[b].elevation) / blobs[b].width;
          const double dr = (r - blobs[b].range) / RANGE_SIGMA;
          const double across = blobs[b].amplitude * exp (-0.5 * (daz * daz +
                  del * del));
          v = MAX (v, across * exp (-0.5 * dr * dr));
          if (fabs (r - blobs[b].range) < RIDGE_HALF_LENGTH)
            v = MAX (v, across * ridge * speckle[b * g->n_range + i]);
        }
        /* The envelope of signal plus complex noise. */
        image[((gsize) e * g->n_azimuth + a) * g->n_range + i] =
            sqrt ((v + re) * (v + re) + im * im);
      }
  g_free (speckle);
  return image;
}

static const Blob three_blobs[] = {
  {0.4, 1.0012, 0.0, 1.0, 2.0},
  {-35.3, 2.0021, 0.0, 0.6, 2.5},
  /* The lobe near 90 degrees: 1 / cos(80 deg) wider. */
  {80.2, 1.4987, 0.0, 0.8, 8.0},
};

static guint
run (const SonarImageGrid * g, const SonarClusterParams * p,
    const float *image, SonarCentroid * out, guint max_out, const char *what)
{
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarClusterer) c = sonar_clusterer_new (g, p, &error);
  guint n;

  g_assert_no_error (error);
  n = sonar_clusterer_process (c, image, out, max_out);
  g_test_message ("%s: %u peaks -> %u centroids", what,
      sonar_clusterer_n_peaks (c), n);
  for (guint k = 0; k < MIN (n, 6); k++)
    g_test_message ("  %.4f m %+6.2f deg %+5.2f deg, peak %.3f, %u peaks",
        out[k].range, out[k].azimuth, out[k].elevation, out[k].peak_value,
        out[k].n_members);
  return n;
}

/* Each blob has exactly one centroid within 1 degree and 1 cm, among the
 * n_blobs strongest. */
static void
check_blobs (const SonarCentroid * out, guint n, const Blob * blobs,
    guint n_blobs)
{
  g_assert_cmpuint (n, >=, n_blobs);
  for (guint b = 0; b < n_blobs; b++) {
    guint found = 0, where = 0;
    for (guint k = 0; k < n; k++) {
      const SonarVec3 p = sonar_vec3_scale (sonar_vec3_from_direction
          (out[k].azimuth, out[k].elevation), out[k].range);
      if (fabs (out[k].azimuth - blobs[b].azimuth) < 1.0
          && fabs (out[k].elevation - blobs[b].elevation) < 1.0
          && fabs (out[k].range - blobs[b].range) < 0.01) {
        found++;
        where = k;
        g_assert_cmpfloat (sonar_vec3_norm (sonar_vec3_sub (p,
                    out[k].position)), <, 1e-9);
      }
    }
    g_assert_cmpuint (found, ==, 1);
    g_assert_cmpuint (where, <, n_blobs);
  }
}

static void
test_three_blobs (void)
{
  SonarImageGrid g;
  SonarClusterParams p;
  SonarCentroid out[32];
  g_autofree float *image = NULL;
  guint n;

  grid_2d (&g);
  image = render (&g, three_blobs, 3, 0.005, 0.0, 1);
  synthetic_params (&p);
  n = run (&g, &p, image, out, 32, "ward, inconsistency");
  g_assert_cmpuint (n, ==, 3);
  check_blobs (out, n, three_blobs, 3);
  /* Strongest first. */
  for (guint k = 1; k < n; k++)
    g_assert_cmpfloat (out[k].peak_value, <=, out[k - 1].peak_value);

  p.linkage = SONAR_LINKAGE_SINGLE;
  run (&g, &p, image, out, 32, "single, inconsistency");
}

/* Twice the noise: it splits the flat top of the wide lobe at 80 degrees
 * into several peaks, which must stay one cluster; and no noise peak may
 * pass the -20 dB threshold. */
static void
test_three_blobs_noisier (void)
{
  SonarImageGrid g;
  SonarClusterParams p;
  SonarCentroid out[32];
  g_autoptr (SonarClusterer) c = NULL;
  guint split_tops = 0;
  double worst = 0.0;

  grid_2d (&g);
  synthetic_params (&p);
  c = sonar_clusterer_new (&g, &p, NULL);
  for (guint seed = 1; seed <= 20; seed++) {
    g_autofree float *image = render (&g, three_blobs, 3, 0.01, 0.0, seed);
    const guint n = sonar_clusterer_process (c, image, out, 32);
    g_assert_cmpuint (n, ==, 3);
    for (guint k = 0; k < n; k++) {
      const Blob *b = &three_blobs[fabs (out[k].azimuth - 80.2) < 5.0 ? 2 :
          fabs (out[k].azimuth) < 5.0 ? 0 : 1];
      worst = MAX (worst, fabs (out[k].azimuth - b->azimuth));
      g_assert_cmpfloat (fabs (out[k].range - b->range), <, 0.01);
      if (b == &three_blobs[2] && out[k].n_members > 1)
        split_tops++;
    }
  }
  g_test_message ("20 images: 3 centroids each; the 80 degree lobe had "
      "several peaks in %u; worst azimuth error %.2f deg", split_tops, worst);
  g_assert_cmpuint (split_tops, >, 0);
}

/* The ghosts of physics-notes.md: a cross-talk ridge 20 dB down through
 * each reflector. The ridges' peaks may form clusters of their own, but no
 * reflector may absorb them: each keeps its own centroid, within 1 degree
 * and 1 cm, and the ridge clusters are weaker than every reflector. */
static void
test_ridges (void)
{
  const double level = 0.1;
  SonarImageGrid g;
  SonarClusterParams p;
  SonarCentroid out[256];
  g_autofree float *image = NULL;
  guint n;

  grid_2d (&g);
  image = render (&g, three_blobs, 3, 0.004, level, 2);
  synthetic_params (&p);
  for (SonarLinkage m = 0; m < n_methods (); m++) {
    g_autofree char *what = g_strdup_printf ("ridges: %s, inconsistency",
        method_name (m));
    p.linkage = m;
    n = run (&g, &p, image, out, G_N_ELEMENTS (out), what);
    check_blobs (out, n, three_blobs, 3);
  }
}

static void
test_3d (void)
{
  const Blob blobs[] = {
    {10.3, 1.2013, -5.2, 1.0, 3.0},
    {-20.4, 0.9021, 12.3, 0.7, 3.0},
  };
  SonarImageGrid g = { 61, -30.0, 1.0, 41, -20.0, 1.0, 400, 0.5, 0.003 };
  SonarClusterParams p;
  SonarCentroid out[8];
  g_autofree float *image = render (&g, blobs, 2, 0.004, 0.1, 3);
  guint n;

  synthetic_params (&p);
  n = run (&g, &p, image, out, 8, "3-D");
  check_blobs (out, n, blobs, 2);
}

/* Lobes of a squared distance q from their peak: the Gaussian's log is
 * a quadratic, the other's is not (flatter at its top, steeper below). */
static double
gaussian_lobe (double q)
{
  return exp (-0.5 * q);
}

static double
rational_lobe (double q)
{
  return 1.0 / (1.0 + 0.5 * q + 0.5 * q * q);
}

/* A beam tilted in azimuth and elevation (the eRTIS array's are: its
 * layout has no symmetry) at @az0, @el0 and range 1.0903 m, on a 3-D
 * grid of 2-degree steps; its peak's centroid. */
static SonarCentroid
tilted_peak (SonarClusterer * c, const SonarImageGrid * g, float *image,
    double (*lobe) (double), double az0, double el0)
{
  const double width_a = 3.0, width_e = 4.0, tilt = 0.6, r0 = 1.0903;
  SonarCentroid out[8];

  for (guint e = 0; e < g->n_elevation; e++)
    for (guint a = 0; a < g->n_azimuth; a++)
      for (guint k = 0; k < g->n_range; k++) {
        const double x = (g->azimuth_first + a * g->azimuth_step - az0) /
            width_a;
        const double y = (g->elevation_first + e * g->elevation_step -
            el0) / width_e;
        const double dr = (g->range_first + k * g->range_step - r0) /
            RANGE_SIGMA;
        image[((gsize) e * g->n_azimuth + a) * g->n_range + k] =
            (float) (1e-4 + lobe (x * x + y * y + 2.0 * tilt * x * y) *
            exp (-0.5 * dr * dr));
      }
  g_assert_cmpuint (sonar_clusterer_process (c, image, out,
          G_N_ELEMENTS (out)), >=, 1);
  g_assert_cmpfloat (fabs (out[0].range - r0), <, 1e-4);
  g_test_message ("peak %+.3f %+.3f deg: centroid %+.4f %+.4f deg", az0,
      el0, out[0].azimuth, out[0].elevation);
  return out[0];
}

/* A tilted Gaussian beam with its peak at sub-step offsets either side of
 * the half step between two rows (where the peak pixel moves from one
 * row to the other) and of two columns: the centroid is the peak's
 * direction within 0.01 degrees. Parabolas along the peak's row and
 * column alone read a direction that follows the row and column (the
 * first case: 0.27 degrees off in azimuth, 0.48 in elevation). */
static void
test_tilted_peak (void)
{
  const SonarImageGrid g = { 21, -20.0, 2.0, 21, -20.0, 2.0, 60, 1.0, 0.003 };
  const double offsets[] = { 0.3, 0.45, 0.5, 0.55, 0.7 };
  g_autofree float *image = g_new (float, sonar_image_grid_size (&g));
  g_autoptr (SonarClusterer) c = NULL;
  SonarClusterParams p;

  synthetic_params (&p);
  c = sonar_clusterer_new (&g, &p, NULL);
  for (guint i = 0; i < G_N_ELEMENTS (offsets); i++)
    for (guint j = 0; j < G_N_ELEMENTS (offsets); j++) {
      const double az0 = 2.0 * (1.0 + offsets[i]);
      const double el0 = -2.0 * (1.0 + offsets[j]);
      const SonarCentroid o = tilted_peak (c, &g, image, gaussian_lobe,
          az0, el0);
      g_assert_cmpfloat (fabs (o.azimuth - az0), <, 0.01);
      g_assert_cmpfloat (fabs (o.elevation - el0), <, 0.01);
    }
}

/* A tilted beam whose log is not a quadratic, as a real one's: the fit
 * around either pixel of the half step errs its own way, and the
 * direction must not jump as the peak crosses it (0.04 degrees apart
 * either side of the half step between two rows, then two columns: the
 * centroids within 0.1 degrees of each other, within 0.4 of the truth);
 * and near the grid's edge, where the neighbour's fit cannot be had. */
static void
test_tilted_peak_continuity (void)
{
  const SonarImageGrid g = { 21, -20.0, 2.0, 21, -20.0, 2.0, 60, 1.0, 0.003 };
  g_autofree float *image = g_new (float, sonar_image_grid_size (&g));
  g_autoptr (SonarClusterer) c = NULL;
  SonarClusterParams p;

  synthetic_params (&p);
  c = sonar_clusterer_new (&g, &p, NULL);
  for (guint axis = 0; axis < 2; axis++) {
    SonarCentroid o[2];
    double truth[2][2];
    for (guint side = 0; side < 2; side++) {
      const double across = 2.0 * (0.49 + 0.02 * side), along = 2.0 * 0.3;
      truth[side][0] = axis == 0 ? 2.0 + across : 2.0 + along;
      truth[side][1] = axis == 0 ? -2.0 - along : -2.0 - across;
      o[side] = tilted_peak (c, &g, image, rational_lobe, truth[side][0],
          truth[side][1]);
      g_assert_cmpfloat (fabs (o[side].azimuth - truth[side][0]), <, 0.4);
      g_assert_cmpfloat (fabs (o[side].elevation - truth[side][1]), <, 0.4);
    }
    g_assert_cmpfloat (fabs (o[1].azimuth - o[0].azimuth), <, 0.1);
    g_assert_cmpfloat (fabs (o[1].elevation - o[0].elevation), <, 0.1);
  }
  /* 0.6 steps from the first column: its peak pixel the second. */
  {
    const double az0 = -20.0 + 2.0 * 0.6, el0 = 1.0;
    const SonarCentroid o = tilted_peak (c, &g, image, rational_lobe, az0,
        el0);
    g_assert_cmpfloat (fabs (o.azimuth - az0), <, 0.5);
    g_assert_cmpfloat (fabs (o.elevation - el0), <, 0.5);
  }
}

/* The image of a still point at @az0, @el0 through the built-in array's
 * MIMO beam, as the delay-and-sum imager forms it in the far field:
 * every emitter-microphone pair's delay difference tau, each pair's
 * output the band's autocorrelation (20-80 kHz: a sinc envelope at the
 * 50 kHz centre), the envelope of their sum. */
static double
ertis_beam (const SonarGeometry * geo, double az0, double el0, double az,
    double el)
{
  const SonarVec3 du = sonar_vec3_sub (sonar_vec3_from_direction (az, el),
      sonar_vec3_from_direction (az0, el0));
  double re = 0.0, im = 0.0;

  for (guint n = 0; n < geo->n_emitters; n++)
    for (guint j = 0; j < geo->n_microphones; j++) {
      const double tau = sonar_vec3_dot (sonar_vec3_add (geo->emitters[n],
              geo->microphones[j]), du) / 343.0;
      const double x = M_PI * 60e3 * tau;
      const double envelope = fabs (x) < 1e-12 ? 1.0 : sin (x) / x;
      re += envelope * cos (2.0 * M_PI * 50e3 * tau);
      im += envelope * sin (2.0 * M_PI * 50e3 * tau);
    }
  return hypot (re, im) / (geo->n_emitters * geo->n_microphones);
}

/* The eRTIS beam's peak swept across a grid cell (2-degree steps) in
 * steps of 0.05 degrees, along azimuth and along elevation, at four
 * directions (three of tools/uncertainty-3d.py's points): the direction
 * moves with it, by at most 0.09 degrees a step (0.05 for an unbiased
 * estimate), and stays within 0.06 degrees of the truth (0.058 and
 * 0.038 when written). The log beam is not a quadratic and is tilted:
 * the fits around the pixels either side of a half step err their own
 * ways, and taking one of them made the direction jump as the peak
 * crossed it (0.106 degrees in a step, 0.075 off the truth; through the
 * chain up to 0.2 in a step of 0.1, tools/uncertainty-3d.py). */
static void
test_ertis_beam_sweep (void)
{
  const double starts[][2] = { {1.1, 0.3}, {22.1, -17.7}, {-9.4, 31.1},
    {37.7, 4.7}
  };
  SonarGeometry geo;
  SonarClusterParams p;
  double largest_move = 0.0, largest_error = 0.0;

  sonar_geometry_init_default (&geo);
  synthetic_params (&p);
  for (guint s = 0; s < G_N_ELEMENTS (starts); s++) {
    /* 15 x 15 directions about the start. */
    const SonarImageGrid g = { 15, 2.0 * round (starts[s][0] / 2.0) - 14.0,
      2.0, 15, 2.0 * round (starts[s][1] / 2.0) - 14.0, 2.0, 40, 1.0, 0.003
    };
    g_autofree float *image = g_new (float, sonar_image_grid_size (&g));
    g_autoptr (SonarClusterer) c = sonar_clusterer_new (&g, &p, NULL);
    for (guint axis = 0; axis < 2; axis++) {
      SonarCentroid last = { 0 };
      for (guint k = 0; k <= 40; k++) {
        const double az0 = starts[s][0] + (axis == 0 ? 0.05 * k : 0.0);
        const double el0 = starts[s][1] + (axis == 1 ? 0.05 * k : 0.0);
        const double r0 = 1.0607;
        SonarCentroid out[8];
        for (guint e = 0; e < g.n_elevation; e++)
          for (guint a = 0; a < g.n_azimuth; a++) {
            const double beam = ertis_beam (&geo, az0, el0,
                g.azimuth_first + a * g.azimuth_step,
                g.elevation_first + e * g.elevation_step);
            for (guint i = 0; i < g.n_range; i++) {
              const double dr = (g.range_first + i * g.range_step - r0) /
                  RANGE_SIGMA;
              image[((gsize) e * g.n_azimuth + a) * g.n_range + i] =
                  (float) (1e-4 + beam * exp (-0.5 * dr * dr));
            }
          }
        g_assert_cmpuint (sonar_clusterer_process (c, image, out,
                G_N_ELEMENTS (out)), >=, 1);
        largest_error = MAX (largest_error, MAX (fabs (out[0].azimuth -
                    az0), fabs (out[0].elevation - el0)));
        if (k > 0)
          largest_move = MAX (largest_move, MAX (fabs (out[0].azimuth -
                      last.azimuth), fabs (out[0].elevation -
                      last.elevation)));
        last = out[0];
      }
    }
  }
  g_test_message ("largest move between steps %.3f deg, largest error "
      "%.3f deg", largest_move, largest_error);
  g_assert_cmpfloat (largest_move, <, 0.09);
  g_assert_cmpfloat (largest_error, <, 0.06);
  sonar_geometry_clear (&geo);
}

/* The passes shared between workers (compensation, noise floors, peaks)
 * give the same peaks and centroids bit for bit with 1 to 7 threads, on
 * a 3-D image with ridges and a few non-finite pixels (7 threads for 13
 * blocks of floors): at the defaults (range compensation, the CFAR
 * floors), and with the floors off and max-peaks 50, so that the noise's
 * peaks fill every worker's heap and the merge keeps the strongest. */
static void
test_threads (void)
{
  const Blob blobs[] = {
    {10.3, 1.2013, -5.2, 1.0, 3.0},
    {-20.4, 0.9021, 12.3, 0.7, 3.0},
    {3.1, 1.5007, 7.9, 0.05, 3.0},
  };
  SonarImageGrid g = { 61, -30.0, 1.0, 41, -20.0, 1.0, 400, 0.5, 0.003 };
  const guint threads[] = { 1, 2, 3, 7 };
  g_autofree float *image = render (&g, blobs, 3, 0.004, 0.1, 5);

  image[1234] = NAN;
  image[20 * g.n_range + 399] = INFINITY;
  for (guint crowded = 0; crowded < 2; crowded++) {
    SonarCentroid first[64], out[64];
    guint n_first = 0, peaks_first = 0;

    for (guint t = 0; t < G_N_ELEMENTS (threads); t++) {
      SonarClusterParams p;
      g_autoptr (GError) error = NULL;
      g_autoptr (SonarClusterer) c = NULL;
      guint n;

      sonar_cluster_params_init_default (&p);
      if (crowded) {
        p.pfa = 1.0;
        p.sidelobe_db = -200.0;
        p.threshold_db = -60.0;
        p.max_peaks = 50;
      }
      p.threads = threads[t];
      c = sonar_clusterer_new (&g, &p, &error);
      g_assert_no_error (error);
      n = sonar_clusterer_process (c, image, t == 0 ? first : out, 64);
      g_test_message ("%s, %u threads: %u centroids, %u peaks found",
          crowded ? "floors off" : "defaults", threads[t], n,
          sonar_clusterer_n_peaks (c));
      if (t == 0) {
        n_first = n;
        peaks_first = sonar_clusterer_n_peaks (c);
        if (crowded)
          g_assert_cmpuint (peaks_first, >, 20 * p.max_peaks);
        else
          check_blobs (first, n, blobs, 3);
        continue;
      }
      g_assert_cmpuint (n, ==, n_first);
      g_assert_cmpuint (sonar_clusterer_n_peaks (c), ==, peaks_first);
      g_assert_cmpmem (out, sizeof out[0] * n, first, sizeof first[0] * n);
    }
  }
}

static void
test_degenerate (void)
{
  SonarImageGrid g;
  SonarClusterParams p;
  SonarCentroid out[4];
  g_autoptr (SonarClusterer) c = NULL;
  const gsize size = 181 * 1000;
  g_autofree float *image = g_new0 (float, size);

  grid_2d (&g);
  synthetic_params (&p);
  c = sonar_clusterer_new (&g, &p, NULL);

  /* Empty, negative, non-finite. */
  g_assert_cmpuint (sonar_clusterer_process (c, image, out, 4), ==, 0);
  for (gsize i = 0; i < size; i++)
    image[i] = -1.0f;
  g_assert_cmpuint (sonar_clusterer_process (c, image, out, 4), ==, 0);
  for (gsize i = 0; i < size; i++)
    image[i] = i % 2 ? NAN : INFINITY;
  g_assert_cmpuint (sonar_clusterer_process (c, image, out, 4), ==, 0);

  /* One pixel, among NaN and infinite ones that must not count. */
  memset (image, 0, size * sizeof (float));
  image[90 * 1000 + 500] = 1.0f;
  image[90 * 1000 + 501] = NAN;
  image[91 * 1000 + 500] = INFINITY;
  image[10 * 1000 + 10] = -INFINITY;
  g_assert_cmpuint (sonar_clusterer_process (c, image, out, 4), ==, 1);
  g_assert_cmpuint (out[0].n_members, ==, 1);
  g_assert_cmpuint (out[0].peak_azimuth_index, ==, 90);
  g_assert_cmpuint (out[0].peak_range_index, ==, 500);
  g_assert_cmpfloat_with_epsilon (out[0].range, 1.8, 1e-9);
  g_assert_cmpfloat_with_epsilon (out[0].azimuth, 0.0, 1e-9);
  g_assert_cmpfloat_with_epsilon (out[0].energy, 1.0, 1e-12);

  /* A plateau of two equal pixels: one peak, the first. */
  image[90 * 1000 + 501] = 1.0f;
  g_assert_cmpuint (sonar_clusterer_process (c, image, out, 4), ==, 1);
  g_assert_cmpuint (sonar_clusterer_n_peaks (c), ==, 1);
  g_assert_cmpuint (out[0].peak_range_index, ==, 500);

  /* No room for centroids. */
  g_assert_cmpuint (sonar_clusterer_process (c, image, NULL, 0), ==, 0);
}

/* The peaks of @raw by their definition (sonar-cluster.h, steps 1 and
 * 2), every test on every pixel: how many, and in @strongest the pixel
 * of the strongest (ties: the first). */
static guint
reference_peaks (const SonarImageGrid * g, const SonarClusterParams * p,
    const float *raw, gsize * strongest)
{
  const gsize n_dirs = (gsize) g->n_azimuth * g->n_elevation;
  const guint R = g->n_range;
  const gsize stride = (n_dirs + 1023) / 1024;
  const double k_eff = sonar_cluster_effective_hypotheses (p->hypotheses);
  const double gain = sonar_cluster_floor_gain (p->pfa, k_eff);
  const float censor = (float) sonar_cluster_floor_gain
      (SONAR_CLUSTER_CENSOR_SHARE, k_eff);
  const float column_gain = (float) (SONAR_CLUSTER_COLUMN_MARGIN * gain);
  const guint bins = sonar_cluster_column_bins (g);
  const guint n_blocks = (R + bins - 1) / bins;
  const float ratio = (float) pow (10.0, p->sidelobe_db / 20.0);
  const int w = (int) ceil (SONAR_CLUSTER_SIDELOBE_RANGE /
      MAX (g->range_step, 1e-9));
  const gsize size = n_dirs * R, most = MAX (n_dirs, bins);
  g_autofree float *v = g_new (float, size);
  g_autofree float *r = g_new (float, R);
  g_autofree float *row_max = g_new0 (float, R);
  g_autofree float *floors = g_new0 (float, R);
  g_autofree float *sidelobe = g_new (float, R);
  g_autofree float *values = g_new (float, most);
  g_autofree float *scratch = g_new (float, 2 * most);
  g_autofree float *column_q = g_new (float, n_dirs * n_blocks);
  float max = 0.0f, threshold, best = -INFINITY;
  guint count = 0;

  for (guint i = 0; i < R; i++)
    r[i] = (float) (g->range_first + i * g->range_step);
  for (gsize d = 0; d < n_dirs; d++)
    for (guint i = 0; i < R; i++) {
      const float x = raw[d * R + i];
      const float y = p->range_compensation ? x * r[i] * r[i] : x;
      v[d * R + i] = y;
      if (isfinite (y) && y > row_max[i])
        row_max[i] = y;
    }
  for (guint i = 0; i < R; i++)
    max = MAX (max, row_max[i]);
  if (!(max > 0.0f))
    return 0;
  threshold = MAX (max * pow (10.0, p->threshold_db / 20.0),
      p->absolute_threshold);
  for (guint i = 0; gain > 0.0 && i < R; i++) {
    gsize n = 0;
    for (gsize d = 0; d < n_dirs; d += stride)
      if (isfinite (v[d * R + i]))
        values[n++] = v[d * R + i];
    floors[i] = (float) gain * sonar_cluster_censored_quartile (values, n,
        censor, NAN, scratch);
  }
  for (guint i = 0; i < R; i++) {
    float top = 0.0f;
    for (int j = MAX ((int) i - w, 0); j <= MIN ((int) i + w, (int) R - 1);
        j++)
      top = MAX (top, row_max[j]);
    sidelobe[i] = top * ratio;
  }
  for (gsize d = 0; d < n_dirs; d++)
    for (guint b = 0; b < n_blocks; b++) {
      gsize n = 0;
      for (guint i = b * bins; i < MIN ((b + 1) * bins, R); i++)
        if (isfinite (raw[d * R + i]))
          values[n++] = raw[d * R + i];
      column_q[d * n_blocks + b] = n > 0 ? sonar_select_kth (values, n,
          n / 4) : 0.0f;
    }
  for (gsize d = 0; d < n_dirs; d++)
    for (guint i = 0; i < R; i++) {
      const gsize px = d * R + i;
      const guint a = d % g->n_azimuth, e = d / g->n_azimuth, b = i / bins;
      const float y = v[px];
      float q = column_q[d * n_blocks + b];
      gboolean peak = TRUE;
      if (b > 0)
        q = MAX (q, column_q[d * n_blocks + b - 1]);
      if (b + 1 < n_blocks)
        q = MAX (q, column_q[d * n_blocks + b + 1]);
      if (!(y >= threshold && y >= floors[i] && y >= sidelobe[i]
              && isfinite (y) && y >= column_gain * q *
              (p->range_compensation ? r[i] * r[i] : 1.0f)))
        continue;
      for (int de = -1; de <= 1; de++)
        for (int da = -1; da <= 1; da++)
          for (int di = -1; di <= 1; di++) {
            gsize nb;
            if ((int) e + de < 0 || (int) e + de >= (int) g->n_elevation
                || (int) a + da < 0 || (int) a + da >= (int) g->n_azimuth
                || (int) i + di < 0 || (int) i + di >= (int) R
                || (de == 0 && da == 0 && di == 0))
              continue;
            nb = (((gsize) (e + de) * g->n_azimuth + a + da) * R) + i + di;
            if (isfinite (v[nb]) && (v[nb] > y || (v[nb] == y && nb < px)))
              peak = FALSE;
          }
      if (!peak)
        continue;
      count++;
      if (y > best) {
        best = y;
        *strongest = px;
      }
    }
  return count;
}

/* The peak search's shortcuts (the noise floors' brackets, a per-range
 * level tested for chunks of pixels at once) find exactly the peaks of
 * the definition: 2-D and 3-D images of blobs, ridges and noise, with
 * non-finite pixels and a plateau, every threshold on and off. */
static void
test_peak_search (void)
{
  const Blob blobs[] = {
    {10.3, 1.2013, -5.2, 1.0, 3.0},
    {-20.4, 0.9021, 12.3, 0.7, 3.0},
    {3.1, 1.5007, 7.9, 0.05, 3.0},
  };
  const SonarImageGrid grids[] = {
    {91, -45.0, 1.0, 1, 0.0, 1.0, 600, 0.5, 0.003},
    {61, -30.0, 1.0, 41, -20.0, 1.0, 200, 0.8, 0.003},
  };
  const double pfas[] = { 1e-10, 1e-3, 1.0 };

  for (guint k = 0; k < G_N_ELEMENTS (grids); k++) {
    const SonarImageGrid *g = &grids[k];
    g_autofree float *image = render (g, blobs, 3, 0.004, 0.1, 7 + k);

    image[1234] = NAN;
    image[20 * g->n_range + 99] = INFINITY;
    /* A plateau: one peak, the first pixel. */
    for (guint i = 300; i < 303; i++)
      image[40 * g->n_range + i % g->n_range] = 0.5f;
    /* Another across the search's chunks of 16 range bins, one across
     * two directions, and infinite pixels beside a chunk's first and in
     * a neighbouring direction, which beat nothing. */
    image[50 * g->n_range + 127] = image[50 * g->n_range + 128] = 0.5f;
    image[70 * g->n_range + 150] = image[71 * g->n_range + 150] = 0.5f;
    image[60 * g->n_range + 143] = INFINITY;
    image[60 * g->n_range + 144] = 0.4f;
    image[80 * g->n_range + 150] = INFINITY;
    image[81 * g->n_range + 151] = 0.4f;
    for (guint variant = 0; variant < 24; variant++) {
      SonarClusterParams p;
      g_autoptr (SonarClusterer) c = NULL;
      SonarCentroid out[1];
      gsize strongest = 0;
      guint want, n;

      sonar_cluster_params_init_default (&p);
      p.range_compensation = variant % 2;
      p.pfa = pfas[variant / 2 % 3];
      p.sidelobe_db = variant / 6 % 2 ? -40.0 : -16.0;
      p.threshold_db = variant / 12 ? -30.0 : -200.0;
      p.hypotheses = 1 + variant % 5 * 10;
      p.max_peaks = 4096;
      c = sonar_clusterer_new (g, &p, NULL);
      n = sonar_clusterer_process (c, image, out, 1);
      want = reference_peaks (g, &p, image, &strongest);
      g_test_message ("grid %u, variant %u: %u peaks", k, variant, want);
      g_assert_cmpuint (sonar_clusterer_n_peaks (c), ==, want);
      g_assert_cmpuint (n, ==, want > 0);
      if (want > 0) {
        g_assert_cmpuint (out[0].peak_range_index, ==, strongest % g->n_range);
        g_assert_cmpuint (out[0].peak_azimuth_index, ==, strongest /
            g->n_range % g->n_azimuth);
        g_assert_cmpuint (out[0].peak_elevation_index, ==, strongest /
            g->n_range / g->n_azimuth);
      }
    }
  }
}

static void
test_max_centroids (void)
{
  SonarImageGrid g;
  SonarClusterParams p;
  SonarCentroid out[2];
  g_autofree float *image = NULL;

  grid_2d (&g);
  image = render (&g, three_blobs, 3, 0.004, 0.1, 4);
  synthetic_params (&p);
  g_assert_cmpuint (run (&g, &p, image, out, 2, "two wanted"), ==, 2);
  g_assert_cmpfloat (fabs (out[0].azimuth - 0.4), <, 1.0);
  g_assert_cmpfloat (fabs (out[1].azimuth - 80.2), <, 1.0);

  /* Fewer peaks than found: the strongest are kept, the blobs survive. */
  p.max_peaks = 5;
  g_assert_cmpuint (run (&g, &p, image, out, 2, "5 peaks kept"), ==, 2);
  g_assert_cmpfloat (fabs (out[0].azimuth - 0.4), <, 1.0);
}

/* Spoils one parameter (case @i) of valid ones; FALSE past the last. */
static gboolean
spoil (guint i, SonarImageGrid * g, SonarClusterParams * p)
{
  switch (i) {
    case 0:
      p->threshold_db = 3.0;
      break;
    case 1:
      p->threshold_db = NAN;
      break;
    case 2:
      p->absolute_threshold = -1.0;
      break;
    case 3:
      p->linkage = 17;
      break;
    case 4:
      p->stop = 9;
      break;
    case 5:
      p->inconsistency = INFINITY;
      break;
    case 6:
      p->depth = 0;
      break;
    case 7:
      p->distance = -0.1;
      break;
    case 8:
      p->max_peaks = 0;
      break;
    case 9:
      p->max_peaks = 100000;
      break;
    case 10:
      g->n_range = 0;
      break;
    case 11:
      g->range_step = NAN;
      break;
    case 12:
      p->pfa = 0.0;
      break;
    case 13:
      p->pfa = 1.5;
      break;
    case 14:
      p->hypotheses = 0;
      break;
    case 15:
      p->sidelobe_db = 1.0;
      break;
    case 16:
      p->threads = SONAR_MAX_WORKERS + 1;
      break;
    default:
      return FALSE;
  }
  return TRUE;
}

static void
test_bad_params (void)
{
  for (guint i = 0;; i++) {
    SonarImageGrid g;
    SonarClusterParams p;
    g_autoptr (GError) error = NULL;
    grid_2d (&g);
    synthetic_params (&p);
    if (!spoil (i, &g, &p))
      break;
    g_assert_null (sonar_clusterer_new (&g, &p, &error));
    g_assert_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS);
    g_test_message ("%s", error->message);
  }
}

/* Thresholds retuned between calls act as if the clusterer had been made
 * with them; what would need a new allocation is refused, by name, and
 * leaves the clusterer as it was. */
static void
test_retune (void)
{
  SonarImageGrid g;
  SonarClusterParams p, strict;
  SonarCentroid out[32], fresh[32];
  g_autofree float *image = NULL;
  g_autoptr (SonarClusterer) c = NULL;
  g_autoptr (GError) error = NULL;
  guint n;

  grid_2d (&g);
  image = render (&g, three_blobs, 3, 0.005, 0.0, 1);
  synthetic_params (&p);
  c = sonar_clusterer_new (&g, &p, NULL);
  g_assert_cmpuint (sonar_clusterer_process (c, image, out, 32), ==, 3);

  /* 1 dB below the strongest: the first blob alone. */
  strict = p;
  strict.threshold_db = -1.0;
  g_assert_true (sonar_clusterer_retune (c, &strict, &error));
  g_assert_no_error (error);
  n = sonar_clusterer_process (c, image, out, 32);
  g_assert_cmpuint (n, ==, 1);
  g_assert_cmpuint (run (&g, &strict, image, fresh, 32, "made strict"), ==,
      n);
  g_assert_cmpmem (&out[0], sizeof out[0], &fresh[0], sizeof fresh[0]);

  strict.max_peaks = p.max_peaks + 1;
  g_assert_false (sonar_clusterer_retune (c, &strict, &error));
  g_assert_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS);
  g_assert_cmpstr (error->message, ==, "cluster: hypotheses, linkage, "
      "max-peaks, range-compensation and threads are set when the clusterer "
      "is made, not between pings");
  g_clear_error (&error);
  strict = p;
  strict.pfa = 2.0;
  g_assert_false (sonar_clusterer_retune (c, &strict, &error));
  g_assert_cmpstr (error->message, ==, "cluster: pfa must be in [1e-15, 1]");
  /* Refused: the last accepted thresholds hold. */
  g_assert_cmpuint (sonar_clusterer_process (c, image, out, 32), ==, 1);
}

/* Thread CPU time, ms: what the work costs, whatever else the machine
 * runs. */
static double
cpu_ms (void)
{
  struct timespec t;
  clock_gettime (CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

static void
test_speed (void)
{
  SonarImageGrid g;
  SonarClusterParams p;
  SonarCentroid out[64];
  g_autofree float *image = NULL;
  g_autofree double *points = g_new (double, 2000 * 3);
  g_autofree double *Z = g_new (double, 1999 * 4);
  SonarRng rng;

  /* Noise alone, no threshold to speak of: ~20000 local maxima, the 2000
   * strongest clustered. */
  grid_2d (&g);
  image = render (&g, NULL, 0, 1.0, 0.0, 5);
  synthetic_params (&p);
  p.threshold_db = -200.0;
  for (guint m = 0; m < n_methods (); m++) {
    g_autoptr (SonarClusterer) c = NULL;
    double best = INFINITY;
    guint n = 0;
    p.linkage = m;
    c = sonar_clusterer_new (&g, &p, NULL);
    for (int rep = 0; rep < 3; rep++) {
      const double t0 = cpu_ms ();
      n = sonar_clusterer_process (c, image, out, 64);
      best = MIN (best, cpu_ms () - t0);
    }
    g_test_message ("%s: image of %u peaks, the 2000 strongest clustered "
        "into %u+ centroids: %.1f ms CPU", method_name (m),
        sonar_clusterer_n_peaks (c), n, best);
    g_assert_cmpuint (sonar_clusterer_n_peaks (c), >, 2000);
  }

  sonar_rng_init (&rng, 6, 0);
  for (guint i = 0; i < 2000 * 3; i++)
    points[i] = sonar_rng_uniform (&rng);
  for (guint m = 0; m < n_methods (); m++) {
    const double t0 = cpu_ms ();
    sonar_linkage (points, 2000, 3, m, Z);
    g_test_message ("sonar_linkage %s, 2000 random points: %.1f ms CPU",
        method_name (m), cpu_ms () - t0);
  }
}

/* The noise-floor factor against the statistics it is derived from: the
 * maximum of K independent Rayleigh envelopes, its quartile and its
 * 1 - pfa point computed by bisection on the distribution function
 * F(x) = (1 - exp (-x^2 / 2))^K, and the values the issue quotes (about
 * 17 dB for one envelope and 7 dB for 47 at pfa 1e-6); pfa 1 is off. */
static double
max_rayleigh_quantile (double k, double p)
{
  double lo = 0.0, hi = 20.0;

  for (int i = 0; i < 200; i++) {
    const double mid = 0.5 * (lo + hi);
    if (pow (-expm1 (-0.5 * mid * mid), k) < p)
      lo = mid;
    else
      hi = mid;
  }
  return 0.5 * (lo + hi);
}

static void
test_floor_gain (void)
{
  const double pfas[] = { 1e-2, 1e-4, 1e-6 };
  const double ks[] = { 1.0, 8.0, 41.0 };

  for (guint i = 0; i < G_N_ELEMENTS (pfas); i++)
    for (guint j = 0; j < G_N_ELEMENTS (ks); j++) {
      const double want = max_rayleigh_quantile (ks[j], 1.0 - pfas[i]) /
          max_rayleigh_quantile (ks[j], 0.25);
      g_assert_cmpfloat (fabs (sonar_cluster_floor_gain (pfas[i], ks[j]) /
              want - 1.0), <, 1e-6);
    }
  g_assert_cmpfloat (fabs (20.0 * log10 (sonar_cluster_floor_gain (1e-6,
                  1.0)) - 16.8), <, 0.1);
  g_assert_cmpfloat (fabs (20.0 * log10 (sonar_cluster_floor_gain (1e-6,
                  47.0)) - 7.0), <, 0.1);
  g_assert_cmpfloat (sonar_cluster_floor_gain (1.0, 47.0), ==, 0.0);
  /* K_eff: one hypothesis is one envelope; more are fewer independent. */
  g_assert_cmpfloat (sonar_cluster_effective_hypotheses (1), ==, 1.0);
  g_assert_cmpfloat (sonar_cluster_effective_hypotheses (47), <, 47.0);
  g_assert_cmpfloat (sonar_cluster_effective_hypotheses (47), >, 30.0);
}

static int
compare_floats (gconstpointer a, gconstpointer b)
{
  const float x = *(const float *) a, y = *(const float *) b;
  return (x > y) - (x < y);
}

/* The censored quartile by its definition, on sorted values. */
static float
censored_quartile_reference (const float *values, gsize n, float gain)
{
  g_autofree float *sorted = g_memdup2 (values, sizeof (float) * n);
  gsize kept = n, rank = n / 4;
  float q;

  if (n == 0)
    return 0.0f;
  qsort (sorted, n, sizeof (float), compare_floats);
  q = sorted[rank];
  for (int round = 0; round < 8; round++) {
    const float level = gain * q;
    gsize end = 0;
    if (!(level > q))
      break;
    while (end < kept && sorted[end] < level)
      end++;
    if (end == kept || end < 4)
      break;
    kept = end;
    rank = MIN (kept - 1, (gsize) (0.25 * kept / (1.0 -
                SONAR_CLUSTER_CENSOR_SHARE)));
    q = sorted[rank];
  }
  return q;
}

/* sonar_cluster_censored_quartile () of the @n @values against the
 * definition, bit for bit, whatever the guess (none, right, a little or
 * far off, zero, negative, infinite). */
static void
check_censored_quartile (const float *values, gsize n, float gain, int row,
    int kind)
{
  const float offsets[] = { NAN, 1.0f, 1.02f, 0.97f, 1.1f, 0.8f, 1.5f,
    0.3f, 0.0f, -1.0f, INFINITY
  };
  const float want = censored_quartile_reference (values, n, gain);
  float copy[1100], scratch[2 * 1100];

  for (guint g = 0; g < G_N_ELEMENTS (offsets); g++) {
    float got;
    memcpy (copy, values, sizeof (float) * n);
    /* NaN in the scratch: a selection that read past what it wrote
     * would find no value of the row's (the last row's ties hid one). */
    for (gsize k = 0; k < 2 * n; k++)
      scratch[k] = NAN;
    got = sonar_cluster_censored_quartile (copy, n, gain, want *
        offsets[g], scratch);
    if (memcmp (&got, &want, sizeof (float)) != 0)
      g_error ("row %d (n %" G_GSIZE_FORMAT ", kind %d), guess x %g: "
          "%.9g, want %.9g", row, n, kind, offsets[g], got, want);
  }
}

/* wardcluster's noise floor selects among the values within a bracket
 * about a guess, or counted below levels about it: the same value as the
 * definition on rows of noise, of noise with a crowd, of ties, with
 * zeros, with a plateau, and with infinite values up to most of the
 * row. */
static void
test_censored_quartile (void)
{
  float values[1100];
  SonarRng rng;

  sonar_rng_init (&rng, 13, 0);
  for (int row = 0; row < 20000; row++) {
    const gsize n = row % 5 == 0 ? (gsize) (sonar_rng_uniform (&rng) * 1025)
        : 181;
    const int kind = row % 5;
    const float gain = 1.0f + 3.0f * (float) sonar_rng_uniform (&rng);

    for (gsize i = 0; i < n; i++) {
      const double a = sonar_rng_gaussian (&rng), b =
          sonar_rng_gaussian (&rng);
      float v = (float) hypot (a, b);
      if (kind == 1 && sonar_rng_uniform (&rng) < 0.1)
        v *= 30.0f;             /* a crowd crossing the row */
      else if (kind == 2)
        v = floorf (3.0f * v);  /* ties */
      else if (kind == 3 && sonar_rng_uniform (&rng) < 0.3)
        v = 0.0f;
      else if (kind == 4)       /* a plateau under the rest: the censored
                                 * rounds' quartiles fall within it */
        v = sonar_rng_uniform (&rng) < 0.4 ? 1.0f : 1.0f + v;
      values[i] = v;
    }
    check_censored_quartile (values, n, gain, row, kind);
  }
  for (int row = 0; row < 200; row++) {
    for (gsize i = 0; i < 181; i++)
      values[i] = sonar_rng_uniform (&rng) < row / 200.0 ? INFINITY :
          (float) hypot (sonar_rng_gaussian (&rng), sonar_rng_gaussian (&rng));
    check_censored_quartile (values, 181, 2.0f, row, 5);
  }
}

/* The noise floors' 16 columns at once (sonar_cluster_censored_quartiles
 * ()): bit for bit the definition's, on the rows of
 * test_censored_quartile () laid out as the image lays out range bins
 * (lane j of direction r at r * stride + j), each block's lanes of one
 * kind, whatever the guess; nearly all found by the passes (the rest
 * are the caller's). A value not finite refuses the block. */
static void
test_censored_quartiles (void)
{
  const float offsets[] = { 1.0f, 1.02f, 0.97f, 1.1f, 0.8f, 1.5f, 0.3f,
    0.0f, -1.0f, 30.0f
  };
  const gsize stride = SONAR_RANK_LANES + 3;
  g_autofree float *x = g_new (float, 1100 * stride);
  float column[1100], q[SONAR_RANK_LANES];
  guint8 ok[SONAR_RANK_LANES];
  SonarRng rng;
  guint lanes = 0, found = 0;

  sonar_rng_init (&rng, 17, 0);
  for (int block = 0; block < 1500; block++) {
    const gsize n = block % 5 == 0 ? 1 + (gsize) (sonar_rng_uniform (&rng) *
        1024) : 181;
    const int kind = block % 5;
    const float gain = 1.0f + 3.0f * (float) sonar_rng_uniform (&rng);
    float want[SONAR_RANK_LANES];

    for (guint j = 0; j < SONAR_RANK_LANES; j++) {
      for (gsize i = 0; i < n; i++) {
        const double a = sonar_rng_gaussian (&rng), b =
            sonar_rng_gaussian (&rng);
        float v = (float) hypot (a, b);
        if (kind == 1 && sonar_rng_uniform (&rng) < 0.1)
          v *= 30.0f;
        else if (kind == 2)
          v = floorf (3.0f * v);
        else if (kind == 3 && sonar_rng_uniform (&rng) < 0.3)
          v = 0.0f;
        else if (kind == 4)
          v = sonar_rng_uniform (&rng) < 0.4 ? 1.0f : 1.0f + v;
        x[i * stride + j] = column[i] = v;
      }
      want[j] = censored_quartile_reference (column, n, gain);
    }
    for (guint g = 0; g < G_N_ELEMENTS (offsets); g++) {
      g_assert_true (sonar_cluster_censored_quartiles (x, stride, n, gain,
              want[0] * offsets[g], q, ok));
      for (guint j = 0; j < SONAR_RANK_LANES; j++) {
        lanes++;
        if (!ok[j])
          continue;
        found++;
        if (memcmp (&q[j], &want[j], sizeof (float)) != 0)
          g_error ("block %d (n %" G_GSIZE_FORMAT ", kind %d), lane %u, "
              "guess x %g: %.9g, want %.9g", block, n, kind, j, offsets[g],
              q[j], want[j]);
      }
    }
  }
  g_test_message ("%u of %u lanes found by the passes", found, lanes);
  g_assert_cmpuint (found, >=, lanes - lanes / 100);
  x[5 * stride + 3] = NAN;
  g_assert_false (sonar_cluster_censored_quartiles (x, stride, 181, 2.0f,
          1.0f, q, ok));
  x[5 * stride + 3] = INFINITY;
  g_assert_false (sonar_cluster_censored_quartiles (x, stride, 181, 2.0f,
          1.0f, q, ok));
  x[5 * stride + 3] = 1.0f;
  g_assert_false (sonar_cluster_censored_quartiles (x, stride, 181, 2.0f,
          NAN, q, ok));
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/cluster/scipy-fixtures", test_scipy_fixtures);
  g_test_add_func ("/cluster/scipy-live", test_scipy_live);
  g_test_add_func ("/cluster/three-blobs", test_three_blobs);
  g_test_add_func ("/cluster/three-blobs-noisier", test_three_blobs_noisier);
  g_test_add_func ("/cluster/ridges", test_ridges);
  g_test_add_func ("/cluster/3d", test_3d);
  g_test_add_func ("/cluster/tilted-peak", test_tilted_peak);
  g_test_add_func ("/cluster/tilted-peak-continuity",
      test_tilted_peak_continuity);
  g_test_add_func ("/cluster/ertis-beam-sweep", test_ertis_beam_sweep);
  g_test_add_func ("/cluster/threads", test_threads);
  g_test_add_func ("/cluster/degenerate", test_degenerate);
  g_test_add_func ("/cluster/peak-search", test_peak_search);
  g_test_add_func ("/cluster/max-centroids", test_max_centroids);
  g_test_add_func ("/cluster/bad-params", test_bad_params);
  g_test_add_func ("/cluster/retune", test_retune);
  g_test_add_func ("/cluster/floor-gain", test_floor_gain);
  g_test_add_func ("/cluster/censored-quartile", test_censored_quartile);
  g_test_add_func ("/cluster/censored-quartiles", test_censored_quartiles);
  g_test_add_func ("/cluster/speed", test_speed);
  return g_test_run ();
}
