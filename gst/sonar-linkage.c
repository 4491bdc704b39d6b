/* sonar-linkage.c: see sonar-linkage.h.
 *
 * The linkage reproduces SciPy 1.10 (scipy/cluster/_hierarchy.pyx) step by
 * step, its tie-breaking included: Prim's minimum spanning tree for single
 * linkage, the nearest-neighbour chain for Ward, complete and average
 * (reducible distances), Muellner's generic algorithm for the centroid
 * method (not reducible). All take O(n^2) time.
 *
 * Where the distances come from: single linkage computes them from the
 * points; Ward and centroid from the clusters' centroids, which is what
 * their Lance-Williams updates amount to for Euclidean distances; only
 * complete and average keep an n x n matrix. Updating a matrix after a
 * merge writes one of its columns, a cache miss per entry, so the centroid
 * form is several times faster at 2000 points, in O(n) memory. It rounds
 * differently from SciPy's updates (1e-14 relative), which can only matter
 * between exactly tied distances.
 */
#include "sonar-linkage.h"

#include <math.h>
#include <string.h>

/* Scratch for the clustering of up to @capacity points of @dims
 * coordinates. Clusters live in point slots: a merge keeps the higher
 * slot, as SciPy does. */
struct _SonarLinkageWork
{
  guint capacity, dims;
  SonarLinkage method;
  const double *points;         /* the caller's, n x dims */
  double *dist;                 /* n x n, complete and average only */
  double *centre;               /* per slot: its cluster's centroid, dims */
  int *size;                    /* per slot: points in its cluster, 0: none */
  int *live;                    /* the slots in use, ascending */
  guint n_live;
  int *chain;                   /* nearest-neighbour chain */
  int *ids;                     /* per slot: linkage id of its cluster */
  int *neighbor;                /* per slot: nearest higher slot (a guess) */
  double *min_dist;             /* per slot: a lower bound of that distance */
  int *heap_key, *heap_pos;     /* key at heap position, position of key */
  double *heap_value;           /* at heap position */
  double *Z;                    /* (capacity - 1) x 4, in merge order */
  double *Z_sorted;
  guint *order, *order_tmp;     /* rows, for the stable sort */
  int *parent;                  /* union-find over 2 capacity - 1 ids */
  double *coefficient;          /* per row */
  int *n_links;                 /* per row: links in its coefficient */
  guint8 *refused;              /* per row: it or a row below must not merge */
  int *stack;                   /* 2 capacity + 2 */
};

typedef SonarLinkageWork Work;

static gboolean
uses_matrix (SonarLinkage method)
{
  return method == SONAR_LINKAGE_COMPLETE || method == SONAR_LINKAGE_AVERAGE;
}

static Work *
work_new (guint capacity, guint dims, SonarLinkage method)
{
  Work *w = g_new0 (Work, 1);
  const gsize rows = MAX (capacity, 2) - 1;

  w->capacity = capacity;
  w->dims = dims;
  w->method = method;
  if (uses_matrix (method))
    w->dist = g_new (double, (gsize) capacity * capacity);
  w->centre = g_new (double, (gsize) capacity * dims);
  w->size = g_new (int, capacity);
  w->live = g_new (int, capacity);
  w->chain = g_new (int, capacity);
  w->ids = g_new (int, capacity);
  w->neighbor = g_new (int, capacity);
  w->min_dist = g_new (double, capacity);
  w->heap_key = g_new (int, capacity);
  w->heap_pos = g_new (int, capacity);
  w->heap_value = g_new (double, capacity);
  w->Z = g_new (double, rows * 4);
  w->Z_sorted = g_new (double, rows * 4);
  w->order = g_new (guint, rows);
  w->order_tmp = g_new (guint, rows);
  w->parent = g_new (int, 2 * (gsize) capacity);
  w->coefficient = g_new (double, rows);
  w->n_links = g_new (int, rows);
  w->refused = g_new (guint8, rows);
  w->stack = g_new (int, 2 * (gsize) capacity + 2);
  return w;
}

static void
work_free (Work * w)
{
  if (!w)
    return;
  g_free (w->dist);
  g_free (w->centre);
  g_free (w->size);
  g_free (w->live);
  g_free (w->chain);
  g_free (w->ids);
  g_free (w->neighbor);
  g_free (w->min_dist);
  g_free (w->heap_key);
  g_free (w->heap_pos);
  g_free (w->heap_value);
  g_free (w->Z);
  g_free (w->Z_sorted);
  g_free (w->order);
  g_free (w->order_tmp);
  g_free (w->parent);
  g_free (w->coefficient);
  g_free (w->n_links);
  g_free (w->refused);
  g_free (w->stack);
  g_free (w);
}

/* |a - b|^2, summed in SciPy's pdist order so that single peaks' distances
 * agree to the last bit. */
static inline double
squared_distance (const double *a, const double *b, guint dims)
{
  double s = 0.0;

  /* The sensor frame, unrolled. */
  if (dims == 3) {
    const double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return d0 * d0 + d1 * d1 + d2 * d2;
  }
  for (guint k = 0; k < dims; k++) {
    const double d = a[k] - b[k];
    s += d * d;
  }
  return s;
}

static inline double
point_distance (const Work * w, int a, int b)
{
  return sqrt (squared_distance (w->points + (gsize) a * w->dims,
          w->points + (gsize) b * w->dims, w->dims));
}

/* Distance between the clusters in slots a and b. Ward's is
 * sqrt (2 na nb / (na + nb)) |ca - cb|: sqrt (2 x the increase of the sum
 * of squared errors, eq. 14), the distance itself for two points. */
static inline double
cluster_distance (const Work * w, guint n, SonarLinkage method, int a, int b)
{
  double s;

  if (uses_matrix (method))
    return w->dist[(gsize) a * n + b];
  s = squared_distance (w->centre + (gsize) a * w->dims,
      w->centre + (gsize) b * w->dims, w->dims);
  if (method == SONAR_LINKAGE_WARD) {
    const double na = w->size[a], nb = w->size[b];
    s *= 2.0 * na * nb / (na + nb);
  }
  return sqrt (s);
}

/* Ward and centroid distances are at least the centroids' distance, so a
 * cluster whose squared centroid distance exceeds this bound cannot be
 * nearer than @d: most are dismissed without the division and the square
 * root (the margin dwarfs the rounding errors). */
static inline double
q_bound (double d)
{
  return d * d * (1.0 + 1e-9);
}

/* The slot nearest to slot x among the live slots from live[from] on
 * (other than x), if strictly nearer than *dist, else @best: the first of
 * equals wins, as in SciPy's scans. */
static int
nearest (Work * w, guint n, SonarLinkage method, int x, guint from,
    int best, double *dist)
{
  const int *live = w->live;
  const guint dims = w->dims;
  const double *cx = w->centre + (gsize) x * dims;
  const double x0 = cx[0], x1 = dims > 1 ? cx[1] : 0.0;
  const double x2 = dims > 2 ? cx[2] : 0.0;
  double bound = q_bound (*dist);

  if (uses_matrix (method)) {
    const double *row = w->dist + (gsize) x * n;
    for (guint j = from; j < w->n_live; j++) {
      const int i = live[j];
      if (i != x && row[i] < *dist) {
        *dist = row[i];
        best = i;
      }
    }
    return best;
  }
  for (guint j = from; j < w->n_live; j++) {
    const int i = live[j];
    const double *ci = w->centre + (gsize) i * dims;
    double d;
    /* The sensor frame unrolled, with x's centroid in registers: the hot
     * loop of the clustering. */
    if (dims == 3) {
      const double d0 = ci[0] - x0, d1 = ci[1] - x1, d2 = ci[2] - x2;
      if (d0 * d0 + d1 * d1 + d2 * d2 > bound)
        continue;
    } else if (squared_distance (ci, cx, dims) > bound) {
      continue;
    }
    if (i == x)
      continue;
    d = cluster_distance (w, n, method, x, i);
    if (d < *dist) {
      *dist = d;
      best = i;
      bound = q_bound (d);
    }
  }
  return best;
}

/* Lance-Williams update of the matrix methods, in SciPy's operation order:
 * distance from cluster i to the union of x and y. */
static inline double
merged_distance (SonarLinkage method, double d_xi, double d_yi, int nx,
    int ny)
{
  return method == SONAR_LINKAGE_COMPLETE ? MAX (d_xi, d_yi) :
      (nx * d_xi + ny * d_yi) / (nx + ny);
}

static void
work_start (Work * w, guint n, SonarLinkage method)
{
  const guint dims = w->dims;

  w->n_live = n;
  for (guint i = 0; i < n; i++) {
    w->size[i] = 1;
    w->live[i] = i;
    w->ids[i] = i;
  }
  memcpy (w->centre, w->points, sizeof (double) * n * dims);
  if (uses_matrix (method))
    for (guint i = 0; i < n; i++)
      for (guint j = 0; j < n; j++)
        w->dist[(gsize) i * n + j] = point_distance (w, i, j);
}

/* Merges slot x into slot y (the union stays in y). */
static void
work_merge (Work * w, guint n, SonarLinkage method, int x, int y)
{
  const int nx = w->size[x], ny = w->size[y];
  guint j = 0;

  while (w->live[j] != x)
    j++;
  memmove (w->live + j, w->live + j + 1, sizeof (int) * (--w->n_live - j));
  w->size[x] = 0;
  w->size[y] = nx + ny;
  if (uses_matrix (method)) {
    const double *row_x = w->dist + (gsize) x * n;
    double *row_y = w->dist + (gsize) y * n;
    for (j = 0; j < w->n_live; j++) {
      const int i = w->live[j];
      if (i != y)
        row_y[i] = w->dist[(gsize) i * n + y] = merged_distance (method,
            row_x[i], row_y[i], nx, ny);
    }
  } else {
    double *cx = w->centre + (gsize) x * w->dims;
    double *cy = w->centre + (gsize) y * w->dims;
    for (guint k = 0; k < w->dims; k++)
      cy[k] = (nx * cx[k] + ny * cy[k]) / (nx + ny);
  }
}

static inline void
set_row (double *Z, guint k, int a, int b, double height, int count)
{
  Z[4 * k] = a;
  Z[4 * k + 1] = b;
  Z[4 * k + 2] = height;
  Z[4 * k + 3] = count;
}

/* Rows of merges between point slots (w->Z), sorted stably by height into
 * @Z with cluster ids n + row and sizes, as SciPy's label (). */
static void
sort_and_label (Work * w, guint n, double *Z)
{
  const guint rows = n - 1;
  guint *order = w->order, *tmp = w->order_tmp;
  int *parent = w->parent;

  /* Bottom-up merge sort: stable, like numpy's mergesort. */
  for (guint k = 0; k < rows; k++)
    order[k] = k;
  for (guint width = 1; width < rows; width *= 2) {
    for (guint lo = 0; lo < rows; lo += 2 * width) {
      const guint mid = MIN (lo + width, rows), hi = MIN (lo + 2 * width,
          rows);
      guint a = lo, b = mid, o = lo;
      while (a < mid && b < hi)
        tmp[o++] = w->Z[4 * order[b] + 2] < w->Z[4 * order[a] + 2] ?
            order[b++] : order[a++];
      while (a < mid)
        tmp[o++] = order[a++];
      while (b < hi)
        tmp[o++] = order[b++];
    }
    {
      guint *t = order;
      order = tmp;
      tmp = t;
    }
  }

  for (guint i = 0; i < 2 * n - 1; i++)
    parent[i] = i;
  for (guint k = 0; k < rows; k++) {
    const double *row = w->Z + 4 * order[k];
    int roots[2];
    for (int s = 0; s < 2; s++) {
      int x = (int) row[s], r = x;
      while (parent[r] != r)
        r = parent[r];
      while (parent[x] != r) {
        const int next = parent[x];
        parent[x] = r;
        x = next;
      }
      roots[s] = r;
    }
    {
      const int a = MIN (roots[0], roots[1]), b = MAX (roots[0], roots[1]);
      const int na = a < (int) n ? 1 : (int) Z[4 * (a - n) + 3];
      const int nb = b < (int) n ? 1 : (int) Z[4 * (b - n) + 3];
      set_row (Z, k, a, b, row[2], na + nb);
      parent[a] = parent[b] = n + k;
    }
  }
}

/* Prim's algorithm, distances straight from the points. */
static void
linkage_single (Work * w, guint n, double *Z)
{
  double *best = w->min_dist;   /* distance of each point to the tree */
  int *merged = w->size;
  int x = 0, y = 0;

  for (guint i = 0; i < n; i++) {
    best[i] = INFINITY;
    merged[i] = 0;
  }
  for (guint k = 0; k + 1 < n; k++) {
    double current = INFINITY;
    merged[x] = 1;
    for (guint i = 0; i < n; i++) {
      double d;
      if (merged[i])
        continue;
      d = point_distance (w, x, i);
      if (best[i] > d)
        best[i] = d;
      if (best[i] < current) {
        y = i;
        current = best[i];
      }
    }
    set_row (w->Z, k, x, y, current, 0);
    x = y;
  }
  sort_and_label (w, n, Z);
}

/* Nearest-neighbour chain: valid for reducible distances (Ward, complete,
 * average), where merging two reciprocal nearest neighbours never brings
 * another cluster closer. */
static void
linkage_nn_chain (Work * w, guint n, SonarLinkage method, double *Z)
{
  int *chain = w->chain;
  guint length = 0;

  work_start (w, n, method);
  for (guint k = 0; k + 1 < n; k++) {
    int x, y = 0;
    double current;

    if (length == 0)
      chain[length++] = w->live[0];
    for (;;) {
      x = chain[length - 1];
      /* Preferring the previous link on ties keeps the chain from
       * cycling. */
      if (length > 1) {
        y = chain[length - 2];
        current = cluster_distance (w, n, method, x, y);
      } else {
        current = INFINITY;
      }
      y = nearest (w, n, method, x, 0, y, &current);
      if (length > 1 && y == chain[length - 2])
        break;
      chain[length++] = y;
    }
    length -= 2;
    set_row (w->Z, k, MIN (x, y), MAX (x, y), current,
        w->size[x] + w->size[y]);
    work_merge (w, n, method, MIN (x, y), MAX (x, y));
  }
  sort_and_label (w, n, Z);
}

/* The min-heap of the generic algorithm: keys are slots. */
static inline void
heap_swap (Work * w, int i, int j)
{
  const double v = w->heap_value[i];
  const int ki = w->heap_key[i], kj = w->heap_key[j];

  w->heap_value[i] = w->heap_value[j];
  w->heap_value[j] = v;
  w->heap_key[i] = kj;
  w->heap_key[j] = ki;
  w->heap_pos[ki] = j;
  w->heap_pos[kj] = i;
}

static void
heap_sift_down (Work * w, int size, int i)
{
  int child = 2 * i + 1;

  while (child < size) {
    if (child + 1 < size && w->heap_value[child + 1] < w->heap_value[child])
      child++;
    if (!(w->heap_value[i] > w->heap_value[child]))
      break;
    heap_swap (w, i, child);
    i = child;
    child = 2 * i + 1;
  }
}

static void
heap_change (Work * w, int size, int key, double value)
{
  int i = w->heap_pos[key];
  const double old = w->heap_value[i];

  w->heap_value[i] = value;
  if (value < old) {
    while (i > 0 && w->heap_value[(i - 1) / 2] > w->heap_value[i]) {
      heap_swap (w, i, (i - 1) / 2);
      i = (i - 1) / 2;
    }
  } else {
    heap_sift_down (w, size, i);
  }
}

/* Position of the first live slot above @x. */
static guint
live_above (const Work * w, int x)
{
  guint lo = 0, hi = w->n_live;

  while (lo < hi) {
    const guint mid = (lo + hi) / 2;
    if (w->live[mid] <= x)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

/* Nearest live slot above @x, or -1. */
static int
nearest_above (Work * w, guint n, SonarLinkage method, int x, double *dist)
{
  *dist = INFINITY;
  return nearest (w, n, method, x, live_above (w, x), -1, dist);
}

/* Muellner's generic algorithm: a heap of lower bounds of each slot's
 * distance to its nearest higher slot, refreshed lazily. Rows stay in merge
 * order: centroid heights can decrease. */
static void
linkage_generic (Work * w, guint n, SonarLinkage method, double *Z)
{
  int *ids = w->ids, *neighbor = w->neighbor;
  int heap_size = n - 1;

  work_start (w, n, method);
  for (int x = 0; x < heap_size; x++) {
    neighbor[x] = nearest_above (w, n, method, x, &w->min_dist[x]);
    w->heap_key[x] = w->heap_pos[x] = x;
    w->heap_value[x] = w->min_dist[x];
  }
  for (int i = heap_size / 2 - 1; i >= 0; i--)
    heap_sift_down (w, heap_size, i);

  for (guint k = 0; k + 1 < n; k++) {
    int x = 0, y = 0;
    double dist = 0.0;

    for (guint i = 0; i < n - k; i++) {
      x = w->heap_key[0];
      dist = w->heap_value[0];
      y = neighbor[x];
      if (y >= 0 && dist == cluster_distance (w, n, method, x, y))
        break;
      y = nearest_above (w, n, method, x, &dist);
      neighbor[x] = y;
      w->min_dist[x] = dist;
      heap_change (w, heap_size, x, dist);
    }
    heap_swap (w, 0, --heap_size);
    heap_sift_down (w, heap_size, 0);

    set_row (Z, k, MIN (ids[x], ids[y]), MAX (ids[x], ids[y]), dist,
        w->size[x] + w->size[y]);
    work_merge (w, n, method, x, y);
    ids[y] = n + k;

    for (guint j = 0; j < w->n_live && w->live[j] < x; j++)
      if (neighbor[w->live[j]] == x)
        neighbor[w->live[j]] = y;
    for (guint j = 0; j < w->n_live && w->live[j] < y; j++) {
      const int z = w->live[j];
      double d;
      if (squared_distance (w->centre + (gsize) z * w->dims, w->centre +
              (gsize) y * w->dims, w->dims) > q_bound (w->min_dist[z]))
        continue;
      d = cluster_distance (w, n, method, z, y);
      if (d < w->min_dist[z]) {
        neighbor[z] = y;
        w->min_dist[z] = d;
        heap_change (w, heap_size, z, d);
      }
    }
    if (y < (int) n - 1) {
      const int z = nearest_above (w, n, method, y, &dist);
      if (z >= 0) {
        neighbor[y] = z;
        w->min_dist[y] = dist;
        heap_change (w, heap_size, y, dist);
      }
    }
  }
}

/* Linkage of the n points at w->points. */
static void
work_linkage (Work * w, guint n, SonarLinkage method, double *Z)
{
  if (n < 2)
    return;
  switch (method) {
    case SONAR_LINKAGE_SINGLE:
      linkage_single (w, n, Z);
      break;
    case SONAR_LINKAGE_WARD:
    case SONAR_LINKAGE_COMPLETE:
    case SONAR_LINKAGE_AVERAGE:
      linkage_nn_chain (w, n, method, Z);
      break;
    case SONAR_LINKAGE_CENTROID:
      linkage_generic (w, n, method, Z);
      break;
  }
}

static void
work_inconsistency (Work * w, const double *Z, guint n, guint depth,
    double *coefficient)
{
  /* stack[2 k]: row at level k; stack[2 k + 1]: children already pushed.
   * Heights are summed in SciPy's order (post-order, left first) because
   * equal heights make the variance a difference of nearly equal sums. */
  int *stack = w->stack;

  for (guint i = 0; i + 1 < n; i++) {
    double sum = 0.0, sum_sq = 0.0, var;
    int count = 0, k = 0;

    stack[0] = i;
    stack[1] = 0;
    while (k >= 0) {
      const double *row = Z + 4 * stack[2 * k];
      gboolean descended = FALSE;
      if (k + 1 < (int) depth) {
        while (stack[2 * k + 1] < 2 && !descended) {
          const int child = (int) row[stack[2 * k + 1]++];
          if (child >= (int) n) {
            k++;
            stack[2 * k] = child - n;
            stack[2 * k + 1] = 0;
            descended = TRUE;
          }
        }
      }
      if (descended)
        continue;
      sum += row[2];
      sum_sq += row[2] * row[2];
      count++;
      k--;
    }
    var = count < 2 ? (sum_sq - sum * sum) / count :
        (sum_sq - sum * sum / count) / (count - 1);
    coefficient[i] = var > 0.0 ? (Z[4 * i + 2] - sum / count) / sqrt (var) :
        0.0;
    w->n_links[i] = count;
  }
}

/* Flat clusters: the largest subtrees none of whose rows is refused
 * (w->refused). Rows must follow their children, as in every linkage
 * matrix. */
static void
work_flat_clusters (Work * w, const double *Z, guint n, int *labels)
{
  guint8 *refused = w->refused;
  int *stack = w->stack;        /* pairs: node id, label of its cluster */
  int top = 0, n_clusters = 0;

  if (n < 2) {
    if (n == 1)
      labels[0] = 1;
    return;
  }
  for (guint i = 0; i + 1 < n; i++)
    for (int s = 0; s < 2; s++) {
      const int child = (int) Z[4 * i + s];
      if (child >= (int) n)
        refused[i] |= refused[child - n];
    }

  stack[0] = 2 * n - 2;
  stack[1] = 0;
  top = 1;
  while (top > 0) {
    const int id = stack[2 * (top - 1)];
    int label = stack[2 * (top - 1) + 1];
    top--;
    if (id < (int) n) {
      labels[id] = label ? label : ++n_clusters;
      continue;
    }
    if (!label && !refused[id - n])
      label = ++n_clusters;
    /* Right pushed first: the left subtree is numbered first. */
    for (int s = 1; s >= 0; s--) {
      stack[2 * top] = (int) Z[4 * (id - n) + s];
      stack[2 * top + 1] = label;
      top++;
    }
  }
}

void
sonar_linkage (const double *points, guint n, guint dims,
    SonarLinkage linkage, double *Z)
{
  Work *w;

  g_return_if_fail (n == 0 || points);
  g_return_if_fail (dims >= 1);
  for (gsize i = 0; i < (gsize) n * dims; i++)
    g_return_if_fail (isfinite (points[i]));
  if (n < 2)
    return;
  w = work_new (n, dims, linkage);
  w->points = points;
  work_linkage (w, n, linkage, Z);
  work_free (w);
}

void
sonar_fcluster_inconsistent (const double *Z, guint n, double threshold,
    guint depth, int *labels)
{
  Work *w = work_new (MAX (n, 2), 0, SONAR_LINKAGE_WARD);

  if (n >= 2)
    work_inconsistency (w, Z, n, MAX (depth, 1), w->coefficient);
  for (guint i = 0; i + 1 < n; i++)
    w->refused[i] = w->coefficient[i] > threshold;
  work_flat_clusters (w, Z, n, labels);
  work_free (w);
}

void
sonar_fcluster_distance (const double *Z, guint n, double threshold,
    int *labels)
{
  Work *w = work_new (MAX (n, 2), 0, SONAR_LINKAGE_WARD);

  for (guint i = 0; i + 1 < n; i++)
    w->refused[i] = Z[4 * i + 2] > threshold;
  work_flat_clusters (w, Z, n, labels);
  work_free (w);
}

static const SonarLinkageInfo methods[] = {
  {SONAR_LINKAGE_WARD, "ward", "Ward's minimum variance"},
  {SONAR_LINKAGE_SINGLE, "single", "Single link (nearest neighbour, SLINK)"},
  {SONAR_LINKAGE_COMPLETE, "complete", "Complete link (farthest neighbour)"},
  {SONAR_LINKAGE_AVERAGE, "average", "Average link (UPGMA)"},
  {SONAR_LINKAGE_CENTROID, "centroid", "Centroid link (UPGMC)"},
};

G_STATIC_ASSERT (G_N_ELEMENTS (methods) == SONAR_LINKAGE_CENTROID + 1);

const SonarLinkageInfo *
sonar_linkage_methods (guint * n_methods)
{
  *n_methods = G_N_ELEMENTS (methods);
  return methods;
}

char *
sonar_linkage_nicks (const char *separator)
{
  GString *nicks = g_string_new (NULL);

  for (guint i = 0; i < G_N_ELEMENTS (methods); i++)
    g_string_append_printf (nicks, "%s%s", i ? separator : "",
        methods[i].nick);
  return g_string_free (nicks, FALSE);
}

SonarLinkageWork *
sonar_linkage_work_new (guint capacity, guint dims, SonarLinkage linkage)
{
  g_return_val_if_fail (dims >= 1, NULL);
  return work_new (MAX (capacity, 2), dims, linkage);
}

void
sonar_linkage_work_free (SonarLinkageWork * w)
{
  work_free (w);
}

const double *
sonar_linkage_work_run (SonarLinkageWork * w, const double *points, guint n)
{
  g_return_val_if_fail (n <= w->capacity, NULL);
  w->points = points;
  work_linkage (w, n, w->method, w->Z_sorted);
  return w->Z_sorted;
}

void
sonar_linkage_work_inconsistency (SonarLinkageWork * w, const double *Z,
    guint n, guint depth, const double **coefficient, const int **n_links)
{
  g_return_if_fail (n <= w->capacity);
  if (n >= 2)
    work_inconsistency (w, Z, n, MAX (depth, 1), w->coefficient);
  *coefficient = w->coefficient;
  *n_links = w->n_links;
}

guint8 *
sonar_linkage_work_refused (SonarLinkageWork * w)
{
  return w->refused;
}

void
sonar_linkage_work_flat_clusters (SonarLinkageWork * w, const double *Z,
    guint n, int *labels)
{
  g_return_if_fail (n <= w->capacity);
  work_flat_clusters (w, Z, n, labels);
}
