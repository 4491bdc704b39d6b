/* sonar-linkage.h: agglomerative hierarchical clustering exactly as
 * SciPy's scipy.cluster.hierarchy (linkage, inconsistent, fcluster), tie
 * for tie, so that it can be checked against SciPy on shared fixtures
 * (tests/test-cluster.c). sonar-cluster.h clusters an image's peaks with
 * it.
 */
#ifndef SONAR_LINKAGE_H
#define SONAR_LINKAGE_H

#include <glib.h>

G_BEGIN_DECLS

/* SciPy's scipy.cluster.hierarchy.linkage methods of the same names. */
typedef enum
{
  SONAR_LINKAGE_WARD,
  SONAR_LINKAGE_SINGLE,
  SONAR_LINKAGE_COMPLETE,
  SONAR_LINKAGE_AVERAGE,
  SONAR_LINKAGE_CENTROID,       /* UPGMC */
} SonarLinkage;

typedef struct
{
  SonarLinkage linkage;
  const char *nick;             /* SciPy's method name: "ward" */
  const char *description;      /* one line, for gst-inspect and tools */
} SonarLinkageInfo;

/* Every method, in the enum's order: *n_methods of them. wardcluster's
 * property, sonar-bench and the tests take their names from here. */
const SonarLinkageInfo *sonar_linkage_methods (guint * n_methods);

/* The nicks joined by @separator, for messages. g_free it. */
char *sonar_linkage_nicks (const char *separator);

/* Linkage matrix Z ((n - 1) x 4, row-major) of @n points of @dims
 * coordinates (row-major), Euclidean metric, exactly as SciPy's
 * linkage (points, method): row k merges clusters Z[k][0] < Z[k][1] (ids
 * below n are points, n + j the cluster of row j) at height Z[k][2] into a
 * cluster of Z[k][3] points. Rows are sorted by height except for the
 * centroid method, whose heights need not increase. n >= 1. */
void sonar_linkage (const double *points, guint n, guint dims,
    SonarLinkage linkage, double *Z);

/* Flat cluster labels 1..k of the n points of @Z, as SciPy's
 * fcluster (Z, threshold, criterion='inconsistent', depth=depth) and
 * fcluster (Z, threshold, criterion='distance'), up to the numbering. The
 * inconsistency coefficient is SciPy's inconsistent (Z, depth)[:, 3]:
 * (height - mean) / std over the link and its sub-links down to depth - 1
 * levels below (sample std; 0 when the std is 0). n >= 1. */
void sonar_fcluster_inconsistent (const double *Z, guint n,
    double threshold, guint depth, int *labels);
void sonar_fcluster_distance (const double *Z, guint n, double threshold,
    int *labels);

/* The same on memory allocated once, for callers that must not allocate
 * per call: up to @capacity points of @dims coordinates, @linkage's
 * method. */
typedef struct _SonarLinkageWork SonarLinkageWork;

SonarLinkageWork *sonar_linkage_work_new (guint capacity, guint dims,
    SonarLinkage linkage);
void sonar_linkage_work_free (SonarLinkageWork * work);

/* sonar_linkage () of @n <= capacity @points: returns Z, held by @work
 * until its next call (n >= 2). */
const double *sonar_linkage_work_run (SonarLinkageWork * work,
    const double *points, guint n);

/* SciPy's inconsistent (Z, depth) of @Z's n - 1 rows: per row, the
 * coefficient (column 3) and the links it was taken over (column 2), in
 * arrays held by @work. */
void sonar_linkage_work_inconsistency (SonarLinkageWork * work,
    const double *Z, guint n, guint depth, const double **coefficient,
    const int **n_links);

/* Per row of Z: whether it must not merge. The caller sets the n - 1
 * flags of a stop criterion, then asks for the flat clusters. */
guint8 *sonar_linkage_work_refused (SonarLinkageWork * work);

/* Flat cluster labels 1..k of Z's n points: the largest subtrees none of
 * whose rows is refused (fcluster's numbering). */
void sonar_linkage_work_flat_clusters (SonarLinkageWork * work,
    const double *Z, guint n, int *labels);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarLinkageWork, sonar_linkage_work_free)

G_END_DECLS

#endif
