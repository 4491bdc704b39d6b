/* sonar-cluster.c: see sonar-cluster.h. The linkage itself is
 * sonar-linkage.c's. */
#include "sonar-cluster.h"
#include "sonar-error.h"
#include "sonar-kernels.h"
#include "sonar-linalg.h"
#include "sonar-workers.h"

#include <gio/gio.h>
#include <math.h>
#include <string.h>

/* Range bins per gather of noise_floors (). */
#define FLOOR_BLOCK 32
/* Directions, at most, in the noise floor's quartile. */
#define FLOOR_DIRECTIONS 1024

#define MAX_PEAKS 4096

/* Pixels the passes over the image handle in one loop of a constant
 * count, which the compiler turns into vector code (at -O2 it vectorises
 * no loop that needs a scalar remainder). */
#define CHUNK 16

/* Range along one direction over which its noise floor is taken, m: a
 * tenth of a pulse (4000 samples at 450 kHz, 1.5 m of range), over which
 * a cross-talk ridge's level changes little, and 56 range bins at the
 * default 2.7 mm step. At least COLUMN_MIN_BINS bins. */
#define COLUMN_SPAN 0.15
#define COLUMN_MIN_BINS 16

/* The image the peak search and the fits read: @values, times the square
 * of their range (@range[i] for range bin i) as they are read when
 * @range is not NULL: the range-compensated image without a copy. */
typedef struct
{
  const float *values;
  const float *range;
  guint n_range;
} Pixels;

/* Pixel @p of @im, in range bin @i. The compensation multiplies as
 * compensate_pixels () does, (v r) r: the same floats. */
static inline float
pixel_in_bin (const Pixels * im, gsize p, guint i)
{
  const float v = im->values[p];

  return im->range ? v * im->range[i] * im->range[i] : v;
}

static inline float
pixel (const Pixels * im, gsize p)
{
  return pixel_in_bin (im, p, im->range ? p % im->n_range : 0);
}

/* The strongest peaks found: a min-heap (weakest on top) of at most
 * max_peaks while scanning. Which are kept depends on the peaks alone
 * (values, ties broken by pixel), not on the order they come in: the
 * workers' heaps merged give the heap of one scan. */
typedef struct
{
  float *value;
  gsize *pixel;
  guint n;                      /* kept */
  guint n_found;                /* offered */
} PeakHeap;

/* One worker's scratch for the passes shared out (the compensation,
 * noise_floors (), find_peaks ()): each writes only its own. */
typedef struct
{
  float *columns;               /* one range bin's values over the
                                 * directions (column_censored_quartile ()) */
  float *bracketed;             /* censored_quartile ()'s: 2 per direction,
                                 * at least column_bins */
  float *row_max;               /* per range bin: its directions' strongest */
  float *column_values;         /* one column block's values */
  PeakHeap peaks;               /* its directions' peaks */
} WorkerScratch;

struct _SonarClusterer
{
  SonarImageGrid grid;
  SonarClusterParams params;
  SonarWorkers *workers;
  WorkerScratch scratch[SONAR_MAX_WORKERS];
  SonarLinkageWork *linkage;    /* the clustering of the peaks */
  /* Peaks kept: the workers' heaps merged, then sorted strongest first. */
  PeakHeap peaks;
  float threshold;              /* the call's relative and absolute one */
  double *points;               /* 3 per peak: sensor frame, m */
  double *peak_range;           /* m */
  SonarVec3 *peak_direction;    /* unit */
  int *labels;
  int *slot;                    /* per label: output index, or -1 */
  /* With range_compensation, the image times r^2 over the directions the
   * noise floors take (floor_rows), row after row. The peak search reads
   * it when it holds every direction (a 2-D image), else the image,
   * compensating as it goes: a whole copy of a 3-D image was 58 MB held
   * and written every ping, for a ninth of it read back by the floors
   * (7-10 % of the clustering's CPU time). */
  float *compensated;
  /* The noise floors' rows: every floor_stride-th direction, n_floor_rows
   * of them, floor_pitch floats apart from floor_rows on (the copy's or
   * the image's). */
  gsize floor_stride, n_floor_rows, floor_pitch;
  const float *floor_rows;
  Pixels pixels;                /* the call's image, for the peak search */
  /* Per range bin: a level below which an uncompensated pixel of
   * pixels.values fails passing (the same as passing when pixels.range is
   * NULL); the chunks' first test. */
  float *passing_raw;
  float *range;                 /* per range bin: r, m (the float the
                                 * compensation has always multiplied by) */
  float *floor;                 /* per range bin: threshold over the noise floor */
  float *row_max;               /* per range bin: strongest over the directions */
  float *sidelobe;              /* per range bin: the sidelobe threshold */
  /* Per range bin: the highest of the call's threshold, the floor and the
   * sidelobe threshold, which a pixel must reach to be a peak (the
   * search's one test of nearly every pixel). */
  float *passing;
  /* Per direction and block of column_bins range bins: the lower
   * quartile of the block along the direction, of the image before range
   * compensation (its noise is flat over range); NaN until a pixel there
   * needs it (column_floor ()). */
  guint column_bins, n_column_blocks;
  float *column_quartile;
  float column_gain;
  const float *raw;             /* the call's image before compensation */
};

guint
sonar_cluster_column_bins (const SonarImageGrid * g)
{
  const guint bins = MAX (COLUMN_MIN_BINS, (guint) lround (COLUMN_SPAN /
          MAX (g->range_step, 1e-9)));

  return MIN (bins, MAX (g->n_range, 1));
}

void
sonar_cluster_params_init_default (SonarClusterParams * p)
{
  p->range_compensation = TRUE;
  p->threshold_db = -200.0;
  p->sidelobe_db = -16.0;
  p->pfa = 1e-10;
  p->hypotheses = 1;
  p->absolute_threshold = 0.0;
  p->linkage = SONAR_LINKAGE_WARD;
  p->stop = SONAR_STOP_INCONSISTENCY;
  p->inconsistency = 1.0;
  p->depth = 3;
  p->distance = 0.1;
  p->max_peaks = 2000;
  p->threads = 0;
}

static gboolean
validate (const SonarImageGrid * g, const SonarClusterParams * p,
    GError ** error)
{
  const char *problem = NULL;

  if (g->n_azimuth < 1 || g->n_elevation < 1 || g->n_range < 1)
    problem = "grid: n-azimuth, n-elevation and n-range must be >= 1";
  else if (!(isfinite (g->azimuth_first) && isfinite (g->azimuth_step)
          && isfinite (g->elevation_first) && isfinite (g->elevation_step)
          && isfinite (g->range_first) && isfinite (g->range_step)))
    problem = "grid: first values and steps must be finite";
  else if (!(p->threshold_db <= 0.0 && p->threshold_db >= -200.0))
    problem = "threshold-db must be in [-200, 0] dB";
  else if (!(p->sidelobe_db <= 0.0 && p->sidelobe_db >= -200.0))
    problem = "sidelobe-db must be in [-200, 0] dB";
  else if (!(p->pfa >= 1e-15 && p->pfa <= 1.0))
    problem = "pfa must be in [1e-15, 1]";
  else if (p->hypotheses < 1)
    problem = "hypotheses must be >= 1";
  else if (!(p->absolute_threshold >= 0.0 && isfinite (p->absolute_threshold)))
    problem = "absolute-threshold must be finite and >= 0";
  else if ((guint) p->stop > SONAR_STOP_DISTANCE)
    problem = "stop must be inconsistency or distance";
  else if (!isfinite (p->inconsistency))
    problem = "inconsistency must be finite";
  else if (p->depth < 1 || p->depth > 64)
    problem = "depth must be 1 to 64";
  else if (!(p->distance >= 0.0 && isfinite (p->distance)))
    problem = "distance must be finite and >= 0 m";
  else if (p->max_peaks < 1 || p->max_peaks > MAX_PEAKS)
    problem = "max-peaks must be 1 to 4096";
  else if (p->threads > SONAR_MAX_WORKERS)
    problem = "threads must be 0 to " G_STRINGIFY (SONAR_MAX_WORKERS);
  if (problem) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "cluster: %s", problem);
    return FALSE;
  }
  if ((guint) p->linkage > SONAR_LINKAGE_CENTROID) {
    g_autofree char *nicks = sonar_linkage_nicks (", ");
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "cluster: linkage is %d; it must be one of %s", (int) p->linkage,
        nicks);
    return FALSE;
  }
  return TRUE;
}

SonarClusterer *
sonar_clusterer_new (const SonarImageGrid * grid,
    const SonarClusterParams * params, GError ** error)
{
  SonarClusterer *c;
  const guint m = params ? params->max_peaks : 0;

  g_return_val_if_fail (grid && params, NULL);
  if (!validate (grid, params, error))
    return NULL;
  c = g_new0 (SonarClusterer, 1);
  c->grid = *grid;
  c->params = *params;
  c->linkage = sonar_linkage_work_new (m, 3, params->linkage);
  c->peaks.value = g_new (float, m);
  c->peaks.pixel = g_new (gsize, m);
  c->points = g_new (double, 3 * (gsize) m);
  c->peak_range = g_new (double, m);
  c->peak_direction = g_new (SonarVec3, m);
  c->labels = g_new (int, m);
  c->slot = g_new (int, m + 1);
  c->floor_stride = ((gsize) grid->n_azimuth * grid->n_elevation +
      FLOOR_DIRECTIONS - 1) / FLOOR_DIRECTIONS;
  c->n_floor_rows = ((gsize) grid->n_azimuth * grid->n_elevation +
      c->floor_stride - 1) / c->floor_stride;
  if (params->range_compensation)
    c->compensated = g_new (float, c->n_floor_rows * grid->n_range);
  c->passing_raw = g_new (float, grid->n_range);
  c->floor = g_new (float, grid->n_range);
  c->range = g_new (float, grid->n_range);
  for (guint i = 0; i < grid->n_range; i++)
    c->range[i] = (float) (grid->range_first + i * grid->range_step);
  c->row_max = g_new (float, grid->n_range);
  c->sidelobe = g_new (float, grid->n_range);
  c->passing = g_new (float, grid->n_range);
  c->column_bins = sonar_cluster_column_bins (grid);
  c->n_column_blocks = (grid->n_range + c->column_bins - 1) / c->column_bins;
  c->column_quartile = g_new (float, (gsize) grid->n_azimuth *
      grid->n_elevation * c->n_column_blocks);
  c->workers = sonar_workers_new (params->threads, error);
  if (!c->workers) {
    sonar_clusterer_free (c);
    return NULL;
  }
  for (guint w = 0; w < sonar_workers_count (c->workers); w++) {
    const gsize n_dirs = (gsize) grid->n_azimuth * grid->n_elevation;
    WorkerScratch *ws = &c->scratch[w];
    ws->columns = g_new (float, n_dirs);
    ws->bracketed = g_new (float, MAX (2 * n_dirs, c->column_bins));
    ws->row_max = g_new (float, grid->n_range);
    ws->column_values = g_new (float, c->column_bins);
    ws->peaks.value = g_new (float, m);
    ws->peaks.pixel = g_new (gsize, m);
  }
  return c;
}

gboolean
sonar_clusterer_retune (SonarClusterer * c, const SonarClusterParams * p,
    GError ** error)
{
  SonarClusterParams tuned = c->params;

  g_return_val_if_fail (c && p, FALSE);
  if (p->hypotheses != c->params.hypotheses
      || p->linkage != c->params.linkage
      || p->max_peaks != c->params.max_peaks
      || p->threads != c->params.threads
      || !p->range_compensation != !c->params.range_compensation) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "cluster: "
        "hypotheses, linkage, max-peaks, range-compensation and threads are "
        "set when the clusterer is made, not between pings");
    return FALSE;
  }
  tuned.threshold_db = p->threshold_db;
  tuned.absolute_threshold = p->absolute_threshold;
  tuned.sidelobe_db = p->sidelobe_db;
  tuned.pfa = p->pfa;
  tuned.stop = p->stop;
  tuned.inconsistency = p->inconsistency;
  tuned.depth = p->depth;
  tuned.distance = p->distance;
  if (!validate (&c->grid, &tuned, error))
    return FALSE;
  c->params = tuned;
  return TRUE;
}

void
sonar_clusterer_free (SonarClusterer * c)
{
  if (!c)
    return;
  sonar_workers_free (c->workers);
  for (guint w = 0; w < SONAR_MAX_WORKERS; w++) {
    WorkerScratch *ws = &c->scratch[w];
    g_free (ws->columns);
    g_free (ws->bracketed);
    g_free (ws->row_max);
    g_free (ws->column_values);
    g_free (ws->peaks.value);
    g_free (ws->peaks.pixel);
  }
  sonar_linkage_work_free (c->linkage);
  g_free (c->peaks.value);
  g_free (c->peaks.pixel);
  g_free (c->points);
  g_free (c->peak_range);
  g_free (c->peak_direction);
  g_free (c->labels);
  g_free (c->slot);
  g_free (c->compensated);
  g_free (c->floor);
  g_free (c->range);
  g_free (c->row_max);
  g_free (c->sidelobe);
  g_free (c->passing);
  g_free (c->passing_raw);
  g_free (c->column_quartile);
  g_free (c);
}

guint
sonar_clusterer_n_peaks (const SonarClusterer * c)
{
  return c->peaks.n_found;
}

/* Peak a is weaker than b: lower value, or equal and later in the image. */
static inline gboolean
weaker (const PeakHeap * h, guint a, guint b)
{
  return h->value[a] < h->value[b] ||
      (h->value[a] == h->value[b] && h->pixel[a] > h->pixel[b]);
}

static inline void
peak_swap (PeakHeap * h, guint a, guint b)
{
  const float v = h->value[a];
  const gsize p = h->pixel[a];

  h->value[a] = h->value[b];
  h->pixel[a] = h->pixel[b];
  h->value[b] = v;
  h->pixel[b] = p;
}

static void
peak_sift_down (PeakHeap * h, guint size, guint i)
{
  guint child = 2 * i + 1;

  while (child < size) {
    if (child + 1 < size && weaker (h, child + 1, child))
      child++;
    if (!weaker (h, child, i))
      break;
    peak_swap (h, i, child);
    i = child;
    child = 2 * i + 1;
  }
}

/* Keeps the @capacity strongest peaks in the min-heap @h. */
static void
keep_peak (PeakHeap * h, guint capacity, float value, gsize pixel)
{
  h->n_found++;
  if (h->n < capacity) {
    guint i = h->n++;
    h->value[i] = value;
    h->pixel[i] = pixel;
    while (i > 0 && weaker (h, i, (i - 1) / 2)) {
      peak_swap (h, i, (i - 1) / 2);
      i = (i - 1) / 2;
    }
  } else if (value > h->value[0] || (value == h->value[0]
          && pixel < h->pixel[0])) {
    h->value[0] = value;
    h->pixel[0] = pixel;
    peak_sift_down (h, capacity, 0);
  }
}

float
sonar_select_kth (float *v, gsize n, gsize k)
{
  gsize lo = 0, hi = n - 1;

  while (lo < hi) {
    const float pivot = v[lo + (hi - lo) / 2];
    gsize i = lo, j = hi;
    while (i <= j) {
      while (v[i] < pivot)
        i++;
      while (v[j] > pivot)
        j--;
      if (i <= j) {
        const float t = v[i];
        v[i] = v[j];
        v[j] = t;
        i++;
        if (j == 0)
          break;
        j--;
      }
    }
    if (k <= j)
      hi = j;
    else if (k >= i)
      lo = i;
    else
      break;
  }
  return v[k];
}

/* Censoring rounds of censored_quartile (), at most. */
#define CENSOR_ROUNDS 8
/* Share of noise's values censored_quartile () sets aside. */
#define CENSOR_SHARE SONAR_CLUSTER_CENSOR_SHARE

/* The brackets around a guess of censored_quartile (), relative
 * half-widths: a range bin's quartile over
 * about 180 directions is a sample of the level the bins around it
 * share, about 10 % off it (neighbouring bins are nearly independent at
 * the band's range resolution; measured on a Fig. 10 image, against the
 * running mean of the floors). The narrow bracket holds that level in
 * two bins of three, the wide one nearly always. */
#define BRACKET_NARROW 0.1f
#define BRACKET_WIDE 0.3f

/* Values, at most, that select_small () ranks by counting. */
#define SMALL_SELECT 12

/* Element @k of the @n <= SMALL_SELECT @values in ascending order: the
 * value with at most k values below it and more than k not above it,
 * found by counting both for each value in turn. n^2 comparisons without
 * branches, against Hoare's selection with a misprediction every other
 * comparison: faster for a dozen values (measured on Fig. 9/10 images). */
static float
select_small (const float *values, gsize n, gsize k)
{
  for (gsize i = 0; i < n; i++) {
    const float x = values[i];
    guint below = 0, not_above = 0;
    for (gsize j = 0; j < n; j++) {
      below += values[j] < x;
      not_above += values[j] <= x;
    }
    if (below <= k && k < not_above)
      return x;
  }
  return values[k];             /* not reached: some value has rank k */
}

/* Element @k of the @m values of @set (which it may reorder) in
 * ascending order. */
static float
select_set (float *set, gsize m, gsize k)
{
  return m <= SMALL_SELECT ? select_small (set, m, k) :
      sonar_select_kth (set, m, k);
}

/* The values of @from (@n) within [@lo, @hi] copied to @to (which may be
 * @from: the copy moves them down), without branches; returns how many,
 * and in @below how many lay below @lo. */
static gsize
keep_within (const float *from, gsize n, float lo, float hi, float *to,
    gsize * below)
{
  gsize inside = 0, under = 0;

  for (gsize i = 0; i < n; i++) {
    const float x = from[i];
    under += x < lo;
    to[inside] = x;
    inside += (x >= lo) & (x <= hi);
  }
  *below = under;
  return inside;
}

/* Element @k of the @m values of @set (which it reorders), all within
 * [@lo, @hi], in ascending order: the bracket halved at its middle and
 * the half that holds it kept, until SMALL_SELECT values are left (or
 * ties leave nothing to split). */
static float
select_within (float *set, gsize m, gsize k, float lo, float hi)
{
  while (m > SMALL_SELECT) {
    const float mid = 0.5f * (lo + hi);
    gsize under = 0, kept = 0;

    if (!(mid > lo && mid < hi))
      break;
    for (gsize i = 0; i < m; i++)
      under += set[i] < mid;
    if (k < under) {
      for (gsize i = 0; i < m; i++) {
        const float x = set[i];
        set[kept] = x;
        kept += x < mid;
      }
      hi = mid;
    } else {
      for (gsize i = 0; i < m; i++) {
        const float x = set[i];
        set[kept] = x;
        kept += x >= mid;
      }
      k -= under;
      lo = mid;
    }
    m = kept;
  }
  return select_set (set, m, k);
}

/* Share of a lane's values per unit of relative value about its
 * quartile, before one is measured: a Fig. 10 image's (a Rayleigh
 * amplitude's is 0.43; the image's maximum over hypotheses is steeper). */
#define LANE_DENSITY 0.9

/* Where a lane of sonar_cluster_censored_quartiles () stands. */
enum
{
  LANE_SEARCH,                  /* for the element of rank target */
  LANE_COUNT,                   /* for how many lie below level */
  LANE_DONE,
};

typedef struct
{
  int stage;
  gboolean first;               /* searching for the first quartile */
  guint target, rank, kept, round;
  /* The search's bracket: the element of rank target lies in [lo, hi];
   * c_lo values lie below lo, c_hi at or below hi (about: interpolation
   * reads them); each end known or not; one-sided steps taken. */
  float lo, hi;
  guint c_lo, c_hi;
  gboolean has_lo, has_hi;
  guint steps;
  double density;               /* see LANE_DENSITY; measured once known */
  float q;
  /* The elements of ranks known_first to known_first + 3 (G_MAXUINT:
   * none), read by the last pass that found a quartile (lane_found ()):
   * a censoring round's next quartile, most often a rank or two from the
   * last, is often among them. Order statistics of all the lane's
   * values, and those kept are the lowest: they hold for every round. */
  guint known_first;
  float known[4];
} Lane;

/* The next level a searching lane @l of @n values counts below: between
 * its bracket's ends, where the ranks interpolate (strictly above lo, at
 * most hi, so that each pass narrows it); with one end known, a step
 * from it to where the lane's density puts the target, and after three
 * such steps the infinite end (every value on one side). */
static float
lane_level (const Lane * l, guint n)
{
  const double t = l->target + 0.5;

  if (l->has_lo && l->has_hi) {
    float m = l->lo + (l->hi - l->lo) * (float) ((t - l->c_lo) /
        ((double) l->c_hi - l->c_lo));
    if (!(m > l->lo && m <= l->hi))
      m = l->lo + 0.5f * (l->hi - l->lo);
    if (!(m > l->lo && m <= l->hi))
      m = l->hi;
    return m;
  }
  if (l->has_hi)
    return l->steps >= 3 || !(l->hi > 0.0f) ? -INFINITY :
        l->hi * (float) (1.0 - MIN (0.5, (l->c_hi - t) / n / l->density *
            (1.0 + 0.5 * l->steps)));
  return l->steps >= 3 || !(l->lo > 0.0f) ? INFINITY :
      l->lo * (float) (1.0 + MIN (1.0, (t - l->c_lo) / n / l->density *
          (1.0 + 0.5 * l->steps)));
}

/* How many of the @n @values lie below @level: vector code over chunks
 * of CHUNK. */
static gsize
count_below (const float *values, gsize n, float level)
{
  gsize count = 0, i = 0;

  for (; i + CHUNK <= n; i += CHUNK) {
    guint chunk = 0;
    for (guint j = 0; j < CHUNK; j++)
      chunk += values[i + j] < level;
    count += chunk;
  }
  for (; i < n; i++)
    count += values[i] < level;
  return count;
}

/* Counts, at most, select_counted () makes before it selects, and the
 * values it leaves: a count costs about what select_small () does over
 * six. */
#define COUNTED_PASSES 6
#define COUNTED_LEFT 6

/* Element @k of the @n @values (none NaN) in ascending order, as
 * sonar_select_kth () (the same value; @values are not reordered,
 * @scratch holds @n floats): counts of the values below levels about
 * @guess (NaN: none; then a sample's quartile) close a bracket on it, as
 * a lane's search in sonar_cluster_censored_quartiles () does, until it
 * holds COUNTED_LEFT values or fewer, which are selected among.
 * Why: a bracket of fixed width about a guess missed a column block's
 * quartile two times in three (its guess, the neighbouring block's, is a
 * sample of 56 values too, a tenth off) and Hoare's selection, with a
 * misprediction every other comparison, was then its fallback: together
 * a quarter of the clustering's time. A count is a pass of vector
 * compares. */
static float
select_counted (const float *values, gsize n, gsize k, float guess,
    float *scratch)
{
  Lane l = { .target = k, .density = LANE_DENSITY };
  /* The element lies in [lo, hi) ([lo, hi] for an infinite hi): c_lo
   * values lie below lo, c_hi below hi. */
  float lo = -INFINITY, hi = INFINITY, level = guess;
  gsize c_lo = 0, c_hi = n, below;

  if (n <= SMALL_SELECT)
    return select_small (values, n, k);
  if (!isfinite (level)) {
    float sample[8];
    for (guint s = 0; s < 8; s++)
      sample[s] = values[s * n / 8];
    level = select_small (sample, 8, 2);
  }
  for (guint pass = 0; pass < COUNTED_PASSES && c_hi - c_lo > COUNTED_LEFT;
      pass++) {
    gsize count;
    if (!(level > lo && level < hi))
      break;
    count = count_below (values, n, level);
    if (count <= k) {
      lo = l.lo = level;
      c_lo = l.c_lo = count;
      l.has_lo = TRUE;
    } else {
      hi = l.hi = level;
      c_hi = l.c_hi = count;
      l.has_hi = TRUE;
    }
    if (!(l.has_lo && l.has_hi))
      l.steps++;
    level = lane_level (&l, n);
  }
  /* [lo, hi) is [lo, the float below hi]. */
  if (hi < INFINITY)
    hi = nextafterf (hi, -INFINITY);
  keep_within (values, n, lo, hi, scratch, &below);
  return select_within (scratch, c_hi - c_lo, k - c_lo, lo, hi);
}

/* censored_quartile ()'s result in *@result, when the bracket [@lo, @hi]
 * (0 <= @lo, @gain > 1) holds every order statistic it takes; FALSE
 * otherwise. One pass without branches keeps the values within the
 * bracket and counts those below it; each round's count of the values
 * kept is a pass of vector compares (no compaction: those kept are those
 * below the lowest level so far), and its selection is among the values
 * within the bracket: a few dozen, down to those on the side of the last
 * quartile that holds the next. Before, each round compacted the values
 * and selected among them again (clustering's largest part). @scratch
 * holds 2 @n floats; @values are left as they are. */
static gboolean
censored_in_bracket (const float *values, gsize n, float gain, float lo,
    float hi, float *scratch, float *result)
{
  float *inside = scratch, *work = scratch + n;
  gsize below, n_inside, kept = n, rank = n / 4;
  float q;

  n_inside = keep_within (values, n, lo, hi, inside, &below);
  if (!(rank >= below && rank - below < n_inside))
    return FALSE;
  memcpy (work, inside, sizeof (float) * n_inside);
  q = select_within (work, n_inside, rank - below, lo, hi);
  for (int round = 0; round < CENSOR_ROUNDS; round++) {
    const float level = gain * q;
    gsize end, next, m = 0;

    if (!(level > q))
      break;
    /* Those kept are those below the lowest level so far. */
    end = count_below (values, n, level);
    if (end >= kept || end < 4)
      break;
    kept = end;
    next = MIN (kept - 1, (gsize) (0.25 * kept / (1.0 - CENSOR_SHARE)));
    /* The next quartile lies on the side of q (below the level, as do
     * all the values below @lo) that its rank says. */
    if (next < rank) {
      if (next < below)
        return FALSE;
      for (gsize k = 0; k < n_inside; k++) {
        const float x = inside[k];
        work[m] = x;
        m += x <= q;
      }
      q = select_within (work, m, next - below, lo, q);
    } else if (next > rank) {
      for (gsize k = 0; k < n_inside; k++) {
        const float x = inside[k];
        work[m] = x;
        m += x < level;
      }
      if (next - below >= m)
        return FALSE;
      q = select_within (work, m, next - below, lo, hi);
    }
    rank = next;
  }
  *result = q;
  return TRUE;
}

/* The lower quartile of the @n @values, those above @gain times it set
 * aside: the quartile of them all, then again of those below that level,
 * until no more are set aside. @gain is the factor noise exceeds with
 * probability CENSOR_SHARE: in noise alone that share is set aside and
 * the quartile, taken at rank 1/4 / (1 - CENSOR_SHARE) of the rest, is
 * unchanged; a row crossed by many objects (a crowd: tens of them at one
 * range, each filling a few directions with its main lobe and skirts)
 * loses them, and its floor falls back to what lies between them.
 * A function of the values alone, whatever their order (the same value
 * as the Hoare selections it replaced, over 400,000 random rows of ties,
 * zeros and crowds): @guess (near the expected quartile; NaN for none)
 * only speeds it up: in one pass when a bracket about it holds every
 * quartile taken (censored_in_bracket ()), else by counts about the
 * last quartile (select_counted ()). Reorders
 * @values; @scratch holds 2 @n floats. */
static float
censored_quartile (float *values, gsize n, float gain, float guess,
    float *scratch)
{
  gsize kept = n, rank;
  float q;

  if (n == 0)
    return 0.0f;
  if (guess > 0.0f && isfinite (guess) && gain > 1.0f && isfinite (gain)
      && (censored_in_bracket (values, n, gain,
              guess * (1.0f - BRACKET_NARROW),
              guess * (1.0f + BRACKET_NARROW), scratch, &q)
          || censored_in_bracket (values, n, gain,
              guess * (1.0f - BRACKET_WIDE), guess * (1.0f + BRACKET_WIDE),
              scratch, &q)))
    return q;
  rank = n / 4;
  q = sonar_select_kth (values, n, rank);
  for (int round = 0; round < CENSOR_ROUNDS; round++) {
    const float level = gain * q;
    gsize end = 0, next;

    if (!(level > q))
      break;
    /* Those below the level kept, compacted without branches. */
    for (gsize k = 0; k < kept; k++) {
      const float v = values[k];
      values[end] = v;
      end += v < level;
    }
    if (end == kept || end < 4)
      break;
    kept = end;
    next = MIN (kept - 1, (gsize) (0.25 * kept / (1.0 - CENSOR_SHARE)));
    /* Only values above q were set aside: the element at the old rank is
     * still q, and the new one near it. */
    if (next != rank)
      q = select_counted (values, kept, next, q, scratch);
    rank = next;
  }
  return q;
}

/* Passes over a block's rows that sonar_cluster_censored_quartiles ()
 * makes at most before it leaves the lanes still searching to
 * censored_quartile (). */
#define LANE_PASSES 48
/* The top of censored_quartile ()'s rounds for lane @l, its quartile q
 * known: done, or counting below the next level. */
static void
lane_round (Lane * l, float gain, float *level)
{
  const float next_level = gain * l->q;

  if (l->round >= CENSOR_ROUNDS || !(next_level > l->q)) {
    l->stage = LANE_DONE;
    return;
  }
  l->stage = LANE_COUNT;
  *level = next_level;
}

/* Whether a pass that counted @count of lane @l's values below its level
 * found its target: the elements of ranks count - 2 to count + 1 are the
 * two values either side of the level (sonar_kernel_rank_pass ()), kept
 * as the lane's known ones when found. */
static gboolean
lane_found (Lane * l, guint count, const float *under, const float *over)
{
  const guint t = l->target;

  if (t + 1 == count)
    l->q = under[0];
  else if (t + 2 == count)
    l->q = under[SONAR_RANK_LANES];
  else if (t == count)
    l->q = over[0];
  else if (t == count + 1)
    l->q = over[SONAR_RANK_LANES];
  else
    return FALSE;
  if (count >= 2 && count + 1 < l->kept) {
    l->known_first = count - 2;
    l->known[0] = under[SONAR_RANK_LANES];
    l->known[1] = under[0];
    l->known[2] = over[0];
    l->known[3] = over[SONAR_RANK_LANES];
  }
  return TRUE;
}

/* Lane @l's bracket after a pass that counted @count below its level,
 * none of the four ranks about it the target: the end on the target's
 * side moves to the nearest value read. TRUE when the bracket closed on
 * one value (the target's). */
static gboolean
lane_narrow (Lane * l, guint count, const float *under, const float *over)
{
  if (count > l->target + 2) {
    l->hi = under[SONAR_RANK_LANES];
    l->c_hi = count - 1;
    l->has_hi = TRUE;
  } else {
    l->lo = over[SONAR_RANK_LANES];
    l->c_lo = count + 1;
    l->has_lo = TRUE;
  }
  if (l->has_lo && l->has_hi && l->lo == l->hi) {
    l->q = l->lo;
    return TRUE;
  }
  return FALSE;
}

/* sonar_cluster_censored_quartile () of SONAR_RANK_LANES columns at once
 * (sonar-cluster.h): the same quartiles, being order statistics, found by
 * passes of sonar_kernel_rank_pass () over the rows instead of copies of
 * the columns and selections among them. Each pass counts, in every
 * lane, the values below a level of the lane's own and reads the two
 * values either side of it, the elements of four ranks; the levels close
 * in on the target rank, from a guess, by Newton steps on the lane's
 * density and interpolation between the ranks read (three or four passes
 * a quartile; one more a censoring round, whose next quartile is most
 * often within two ranks of the last), over values that stay in the
 * cache. */
gboolean
sonar_cluster_censored_quartiles (const float *x, gsize stride, guint n,
    float gain, float guess, float *q, guint8 * ok)
{
  const guint L = SONAR_RANK_LANES;
  Lane lanes[SONAR_RANK_LANES];
  float level[SONAR_RANK_LANES], under[2 * SONAR_RANK_LANES],
      over[2 * SONAR_RANK_LANES];
  guint32 below[SONAR_RANK_LANES], finite[SONAR_RANK_LANES];
  guint pass;

  if (!isfinite (guess) || n == 0)
    return FALSE;
  for (guint j = 0; j < L; j++) {
    Lane *l = &lanes[j];
    memset (l, 0, sizeof *l);
    l->stage = LANE_SEARCH;
    l->first = TRUE;
    l->target = n / 4;
    l->kept = n;
    l->density = LANE_DENSITY;
    l->known_first = G_MAXUINT;
    level[j] = guess;
  }
  for (pass = 0; pass < LANE_PASSES; pass++) {
    gboolean searching = FALSE;

    sonar_kernel_rank_pass (x, stride, n, level, below, under, over,
        pass == 0 ? finite : NULL);
    for (guint j = 0; j < L && pass == 0; j++)
      if (finite[j] != n)
        return FALSE;
    for (guint j = 0; j < L; j++) {
      Lane *l = &lanes[j];
      const guint count = below[j];

      if (l->stage == LANE_SEARCH) {
        float *const ul = under + j, *const ol = over + j;
        if (lane_found (l, count, ul, ol) || lane_narrow (l, count, ul,
                ol)) {
          /* The density the bracket measured, for the next search. */
          if (l->has_lo && l->has_hi && l->lo > 0.0f && l->hi > l->lo)
            l->density = CLAMP (((double) l->c_hi - l->c_lo) / n /
                ((l->hi - l->lo) / l->lo), 0.05, 20.0);
          if (!l->first)
            l->round++;
          l->first = FALSE;
          l->rank = l->target;
          lane_round (l, gain, &level[j]);
        } else {
          level[j] = lane_level (l, n);
          if (!(l->has_lo && l->has_hi))
            l->steps++;
        }
      } else if (l->stage == LANE_COUNT) {
        guint next;
        /* censored_quartile ()'s round: those kept are those below the
         * lowest level so far. */
        if (count >= l->kept || count < 4) {
          l->stage = LANE_DONE;
          continue;
        }
        l->kept = count;
        next = MIN (l->kept - 1, (guint) (0.25 * l->kept /
                (1.0 - CENSOR_SHARE)));
        if (next == l->rank) {
          /* The same quartile, so the same level and count: done. */
          l->stage = LANE_DONE;
          continue;
        }
        if (next >= l->known_first && next - l->known_first < 4) {
          /* Read already: the round's quartile, and its count next. */
          l->q = l->known[next - l->known_first];
          l->round++;
          l->rank = l->target = next;
          lane_round (l, gain, &level[j]);
          searching |= l->stage != LANE_DONE;
          continue;
        }
        /* The next quartile lies on q's side that its rank says: a
         * Newton step from q, whose rank is known. */
        l->stage = LANE_SEARCH;
        l->target = next;
        l->steps = 0;
        l->has_lo = next > l->rank;
        l->has_hi = next < l->rank;
        l->lo = l->hi = l->q;
        l->c_lo = l->rank;
        l->c_hi = l->rank + 1;
        level[j] = lane_level (l, n);
        l->steps++;
      }
      searching |= l->stage != LANE_DONE;
    }
    if (!searching)
      break;
  }
  for (guint j = 0; j < L; j++) {
    q[j] = lanes[j].q;
    ok[j] = lanes[j].stage == LANE_DONE;
  }
  return TRUE;
}

float
sonar_cluster_censored_quartile (float *values, gsize n, float gain,
    float guess, float *scratch)
{
  return censored_quartile (values, n, gain, guess, scratch);
}

double
sonar_cluster_effective_hypotheses (guint hypotheses)
{
  return 1.0 + (MAX (hypotheses, 1) - 1.0) * SONAR_CLUSTER_HYPOTHESIS_SHARE;
}

double
sonar_cluster_floor_gain (double pfa, double k)
{
  /* 1 - 4^(-1/K) and 1 - (1 - pfa)^(1/K), without cancellation. */
  const double below_quartile = -expm1 (log (0.25) / k);
  const double below_threshold = -expm1 (log1p (-pfa) / k);

  if (pfa >= 1.0)
    return 0.0;
  return sqrt (log (below_threshold) / log (below_quartile));
}

/* censored_quartile () of range bin @i's column (its finite values over
 * the floors' rows), gathered into worker @w's columns. */
static float
column_censored_quartile (SonarClusterer * c, guint w, guint i, float censor,
    float guess)
{
  float *column = c->scratch[w].columns;
  gsize n = 0;

  for (gsize r = 0; r < c->n_floor_rows; r++) {
    const float v = c->floor_rows[r * c->floor_pitch + i];
    if (isfinite (v))
      column[n++] = v;
  }
  return censored_quartile (column, n, censor, guess,
      c->scratch[w].bracketed);
}

/* Per range bin: the floor gain times the lower quartile over the
 * directions.
 * Not the median: a reflector near +-90 degrees smears over most of the
 * fan and would lift it. SONAR_RANK_LANES range bins at a time, by passes
 * over their directions' runs of bins (sonar_cluster_censored_quartiles
 * ()): reading one bin's column at a time reads a cache line per value
 * (300 ms for a 3-D image of 14 million pixels), and copying the columns
 * out cost as much as the selections. A 3-D image's quartile is taken
 * over every k-th direction, at most FLOOR_DIRECTIONS of them: from a
 * thousand samples a quartile is steady to a few per cent. */
/* Range bin @i's floor on its own (column_censored_quartile ()), and
 * the running @guess: the mean of the last bins' quartiles (the level
 * they share; one bin's own is a sample of it, off by a few per cent:
 * neighbouring bins are nearly independent at the band's range
 * resolution). */
static void
floor_alone (SonarClusterer * c, guint w, guint i, float censor, float gain,
    float *guess)
{
  const float q = column_censored_quartile (c, w, i, censor, *guess);

  *guess = isfinite (*guess) ? *guess + 0.125f * (q - *guess) : q;
  c->floor[i] = gain * q;
}

/* Worker @w's share of the noise floors: a contiguous run of the range
 * bins (whole blocks of FLOOR_BLOCK), SONAR_RANK_LANES at a time, the
 * last lanes ending with the run (overlapping the ones before, whose
 * floors they take again: one at a time, the 26 bins a Fig. 10 image
 * leaves cost as much as all the lanes of a share). One at a time too:
 * the run's first bin (for a guess), a run shorter than the lanes, lanes
 * with a value not finite, and those the passes leave. The floors do
 * not depend on the share (an order statistic is exact whatever the
 * guess that speeds it up). */
static void
noise_floors_share (gpointer data, guint w, guint n_workers)
{
  SonarClusterer *c = data;
  const SonarImageGrid *g = &c->grid;
  const guint L = SONAR_RANK_LANES;
  const guint n_blocks = (g->n_range + FLOOR_BLOCK - 1) / FLOOR_BLOCK;
  const guint start = MIN (n_blocks * w / n_workers * FLOOR_BLOCK,
      g->n_range);
  const guint stop = MIN (n_blocks * (w + 1) / n_workers * FLOOR_BLOCK,
      g->n_range);
  const float gain = (float) sonar_cluster_floor_gain (c->params.pfa,
      sonar_cluster_effective_hypotheses (c->params.hypotheses));
  const float censor = (float) sonar_cluster_floor_gain (CENSOR_SHARE,
      sonar_cluster_effective_hypotheses (c->params.hypotheses));
  float guess = NAN;

  for (guint i = start; i < stop;) {
    const guint first = stop - start >= L ? MIN (i, stop - L) : i;
    float q[SONAR_RANK_LANES];
    guint8 ok[SONAR_RANK_LANES];

    if (stop - start < L || !(isfinite (guess) && guess > 0.0f)) {
      floor_alone (c, w, i++, censor, gain, &guess);
      continue;
    }
    if (!sonar_cluster_censored_quartiles (c->floor_rows + first,
            c->floor_pitch, c->n_floor_rows, censor, guess, q, ok)) {
      for (; i < first + L; i++)
        floor_alone (c, w, i, censor, gain, &guess);
      continue;
    }
    for (; i < first + L; i++) {
      if (!ok[i - first])
        q[i - first] = column_censored_quartile (c, w, i, censor, guess);
      guess = guess + 0.125f * (q[i - first] - guess);
      c->floor[i] = gain * q[i - first];
    }
  }
}

/* Per range bin, the CFAR threshold over its directions' noise floor
 * (over c->floor_rows). */
static void
noise_floors (SonarClusterer * c)
{
  if (!(sonar_cluster_floor_gain (c->params.pfa,
              sonar_cluster_effective_hypotheses (c->params.hypotheses)) >
          0.0)) {
    memset (c->floor, 0, sizeof (float) * c->grid.n_range);
    return;
  }
  sonar_workers_run (c->workers, noise_floors_share, c);
}

/* The lower quartile of block @b of direction @d's column, computed
 * once per call; a neighbouring block's, when known, the guess of
 * select_counted () (a ridge's level changes little from block to
 * block). */
static float
column_quartile (SonarClusterer * c, WorkerScratch * ws, gsize d, guint b)
{
  float *q = &c->column_quartile[d * c->n_column_blocks + b];

  if (isnan (*q)) {
    const float guess = b > 0 && !isnan (q[-1]) ? q[-1] :
        b + 1 < c->n_column_blocks ? q[1] : NAN;
    const guint n_range = c->grid.n_range;
    const float *column = c->raw + d * n_range;
    const guint i1 = MIN ((b + 1) * c->column_bins, n_range);
    gsize count = 0;
    for (guint i = b * c->column_bins; i < i1; i++)
      if (isfinite (column[i]))
        ws->column_values[count++] = column[i];
    *q = count > 0 ? select_counted (ws->column_values, count, count / 4,
        guess, ws->bracketed) : 0.0f;
  }
  return *q;
}

/* The floor along direction @d at range bin @i: the floor gain times the
 * largest lower quartile of the block of column_bins range bins holding
 * it and of its two neighbours, on the image before range compensation
 * (whose noise is flat over range). The range bin's floor over the
 * directions misses what fills one direction over a long range: a strong
 * echo's cross-talk ridge, noise-like, about 20 dB below it and 1.5 m
 * long at its direction. Along the direction the ridge is the floor, and
 * its peaks pass about as rarely as noise's. An object fills 1-3 bins of
 * a block: the quartile ignores it, and a second object within the
 * block. The neighbours count because where a ridge ends within a block
 * its quartile is the lower part's, and the rest of the ridge would pass.
 * Computed only for pixels that pass every other test: work grows with
 * what the image holds. */
static float
column_floor (SonarClusterer * c, WorkerScratch * ws, gsize d, guint i)
{
  const guint b = i / c->column_bins;
  float q = column_quartile (c, ws, d, b);

  if (b > 0)
    q = MAX (q, column_quartile (c, ws, d, b - 1));
  if (b + 1 < c->n_column_blocks)
    q = MAX (q, column_quartile (c, ws, d, b + 1));
  return c->column_gain * q;
}

/* Per range bin: sidelobe_db below the strongest pixel within
 * SONAR_CLUSTER_SIDELOBE_RANGE, over every direction (c->row_max, each
 * range's strongest, gathered by sonar_clusterer_process ()). */
static void
sidelobe_thresholds (SonarClusterer * c)
{
  const SonarImageGrid *g = &c->grid;
  const float ratio = (float) pow (10.0, c->params.sidelobe_db / 20.0);
  const int w = (int) ceil (SONAR_CLUSTER_SIDELOBE_RANGE /
      MAX (g->range_step, 1e-9));

  for (guint i = 0; i < g->n_range; i++) {
    float top = 0.0f;
    for (int j = MAX ((int) i - w, 0); j <= MIN ((int) i + w,
            (int) g->n_range - 1); j++)
      top = MAX (top, c->row_max[j]);
    c->sidelobe[i] = top * ratio;
  }
}

/* Whether any of the CHUNK @pixels reaches its @passing level (vector
 * code: one OR of comparisons). */
static inline gboolean
any_passing (const float *pixels, const float *passing)
{
  int any = 0;

  for (guint j = 0; j < CHUNK; j++)
    any |= pixels[j] >= passing[j];
  return any;
}

/* The index of @mask's lowest set bit (@mask not 0). */
static inline guint
lowest_bit (guint mask)
{
#if defined(__GNUC__)
  return (guint) __builtin_ctz (mask);
#else
  return (guint) g_bit_nth_lsf (mask, -1);
#endif
}

/* Bit j of a chunk's masks, from a table: a shift by the loop's index
 * keeps the compiler from vector code (SSE2 has no per-lane shifts). */
static const guint chunk_bit[CHUNK] = {
  1u << 0, 1u << 1, 1u << 2, 1u << 3, 1u << 4, 1u << 5, 1u << 6, 1u << 7,
  1u << 8, 1u << 9, 1u << 10, 1u << 11, 1u << 12, 1u << 13, 1u << 14,
  1u << 15,
};

/* Which of the CHUNK @pixels reach their @passing level: bit j for
 * pixel j. */
static inline guint
passing_mask (const float *pixels, const float *passing)
{
  guint mask = 0;

  for (guint j = 0; j < CHUNK; j++)
    mask |= chunk_bit[j] & -(guint) (pixels[j] >= passing[j]);
  return mask;
}

/* Which of the CHUNK @pixels neither range neighbour beats (beats ()
 * below, local_maximum ()'s first test), @pixels[-1] and @pixels[CHUNK]
 * being theirs: bit j for pixel j. Vector code: along an echo's flank
 * most pixels over the levels lose to one (half of find_peaks ()'s time
 * went to testing them one at a time). */
static inline guint
range_maximum_mask (const float *pixels)
{
  guint mask = 0;

  for (int j = 0; j < CHUNK; j++) {
    const float v = pixels[j], before = pixels[j - 1], after = pixels[j + 1];
    /* The earlier one beats an equal value, the later one does not. */
    const int beaten = ((before >= v) & (fabsf (before) < INFINITY))
        | ((after > v) & (fabsf (after) < INFINITY));
    mask |= chunk_bit[j] & ((guint) beaten - 1);
  }
  return mask;
}

/* Which of the CHUNK @pixels none of the three pixels about them in the
 * @next direction's column beats (@next[j - 1] to @next[j + 1] for pixel
 * j; @earlier: that column comes first in the image, and an equal value
 * beats): bit j for pixel j. Vector code, as range_maximum_mask (): a
 * ridge's pixels over the levels mostly lose to a neighbouring
 * direction's. */
static inline guint
direction_maximum_mask (const float *pixels, const float *next, int earlier)
{
  guint mask = 0;

  for (int j = 0; j < CHUNK; j++) {
    const float v = pixels[j];
    int beaten = 0;
    for (int di = -1; di <= 1; di++) {
      const float u = next[j + di];
      beaten |= ((u > v) | ((u == v) & earlier)) & (fabsf (u) < INFINITY);
    }
    mask |= chunk_bit[j] & ((guint) beaten - 1);
  }
  return mask;
}

/* Whether pixel @q, value @u, beats pixel @p, value @v, as a local
 * maximum: finite, and higher, or equal and earlier in the image (a
 * deterministic order). */
static inline gboolean
beats (float u, gsize q, float v, gsize p)
{
  return isfinite (u) && (u > v || (u == v && q < p));
}

/* Whether pixel @p (@e, @a, @i) of @image, value @v, is a local maximum:
 * no neighbour beats it. Its range neighbours first (contiguous; a
 * pixel on an echo's flank loses to one of them), then the other
 * directions'. */
static inline gboolean
local_maximum (const SonarImageGrid * g, const Pixels * im, gsize p,
    guint e, guint a, guint i, float v)
{
  const gsize stride_e = (gsize) g->n_azimuth * g->n_range;
  const int di_first = i == 0 ? 0 : -1;
  const int di_last = i + 1 == g->n_range ? 0 : 1;

  if ((i > 0 && beats (pixel_in_bin (im, p - 1, i - 1), p - 1, v, p))
      || (i + 1 < g->n_range && beats (pixel_in_bin (im, p + 1, i + 1), p + 1,
              v, p)))
    return FALSE;
  for (int de = e == 0 ? 0 : -1; de <= (e + 1 == g->n_elevation ? 0 : 1);
      de++)
    for (int da = a == 0 ? 0 : -1; da <= (a + 1 == g->n_azimuth ? 0 : 1);
        da++) {
      const gsize centre = p + de * (gssize) stride_e + da *
          (gssize) g->n_range;
      if (de == 0 && da == 0)
        continue;
      for (int di = di_first; di <= di_last; di++)
        if (beats (pixel_in_bin (im, centre + di, i + di), centre + di, v,
                p))
          return FALSE;
    }
  return TRUE;
}

/* Pixels @i0 - 1 to @i0 + CHUNK of @column (within the image's range
 * bins) as @im reads them: the column itself when it is not compensated
 * as it is read, else compensated into @out. Returns where pixel @i0 is. */
static inline const float *
chunk_pixels (const Pixels * im, const float *column, guint i0, float *out)
{
  if (!im->range)
    return column + i0;
  for (guint j = 0; j < CHUNK + 2; j++) {
    const float r = im->range[i0 - 1 + j];
    out[j] = column[i0 - 1 + j] * r * r;
  }
  return out + 1;
}

/* Worker @w's share of find_peaks (): the peaks of its run of
 * directions into its own heap. A pixel is a peak when it passes every
 * test; they are made cheapest first: one level per range bin over 16
 * pixels at a time (nearly every chunk holds no pixel that reaches it),
 * then per pixel the range bin's own tests, the local maximum, and last
 * the column floor (its quartiles are computed on demand: only at the
 * local maxima, a tenth of the pixels over the other levels). */
static void
find_peaks_share (gpointer data, guint w, guint n_workers)
{
  SonarClusterer *c = data;
  WorkerScratch *ws = &c->scratch[w];
  const SonarImageGrid *g = &c->grid;
  const Pixels *im = &c->pixels;
  const float threshold = c->threshold;
  const guint capacity = c->params.max_peaks;
  const gsize n_dirs = (gsize) g->n_azimuth * g->n_elevation;

  ws->peaks.n = ws->peaks.n_found = 0;
  for (gsize d = n_dirs * w / n_workers; d < n_dirs * (w + 1) / n_workers;
      d++) {
    const guint e = d / g->n_azimuth, a = d % g->n_azimuth;
    const float *column = im->values + d * g->n_range;
    for (guint i0 = 0; i0 < g->n_range; i0 += CHUNK) {
      const guint i1 = MIN (i0 + CHUNK, g->n_range);
      guint mask;

      /* Nearly every chunk holds no pixel that reaches its level. */
      if (i1 - i0 == CHUNK && !any_passing (column + i0,
              c->passing_raw + i0))
        continue;
      mask = i1 - i0 == CHUNK ? passing_mask (column + i0,
          c->passing_raw + i0) : (1u << (i1 - i0)) - 1;
      if (mask && i0 > 0 && i1 < g->n_range) {
        /* The chunk and the neighbouring directions' pixels about it,
         * with one pixel either side, compensated when they are read so. */
        float chunk[3][CHUNK + 2];
        const float *here = chunk_pixels (im, column, i0, chunk[0]);
        mask &= range_maximum_mask (here);
        if (mask && a > 0)
          mask &= direction_maximum_mask (here, chunk_pixels (im, column -
                  g->n_range, i0, chunk[1]), TRUE);
        if (mask && a + 1 < g->n_azimuth)
          mask &= direction_maximum_mask (here, chunk_pixels (im, column +
                  g->n_range, i0, chunk[2]), FALSE);
      }

      while (mask) {
        const guint i = i0 + lowest_bit (mask);
        const gsize p = d * g->n_range + i;
        const float v = pixel_in_bin (im, p, i);
        const float r = c->range[i];
        mask &= mask - 1;
        if (!(v >= c->passing[i]))
          continue;
        if (!(v >= threshold) || !(v >= c->floor[i])
            || !(v >= c->sidelobe[i]) || !isfinite (v)
            || !local_maximum (g, im, p, e, a, i, v)
            || !(v >= column_floor (c, ws, d, i) *
                (c->params.range_compensation ? r * r : 1.0f)))
          continue;
        keep_peak (&ws->peaks, capacity, v, p);
      }
    }
  }
}

/* A level below which a pixel v fails (v r) r >= @level: @level / r^2
 * less a margin over the products' and the quotient's rounding (a few
 * parts in 10^7, while no product is subnormal); -inf (no pixel fails)
 * where that does not hold. */
static float
raw_level (float level, float r)
{
  const float raw = level / (r * r) * (1.0f - 1e-5f);

  return r > 0.0f && isfinite (r * r) && level >= 1e-30f
      && raw >= 1e-30f && isfinite (raw) ? raw : -INFINITY;
}

/* The pixels of @image (range-compensated if so set) above @threshold,
 * their range bin's floor, their direction's column floor (of the
 * uncompensated image, so times r^2 when compensated) and their range's
 * sidelobe threshold that are local maxima, the max_peaks strongest of
 * them into c->peaks, strongest first. */
static void
find_peaks (SonarClusterer * c, float threshold)
{
  PeakHeap *h = &c->peaks;
  guint found = 0;

  c->threshold = threshold;
  /* A pixel below one of them fails that test too (fmaxf () passes a NaN
   * over, leaving the level lower: the tests themselves still apply). */
  for (guint i = 0; i < c->grid.n_range; i++) {
    c->passing[i] = fmaxf (threshold, fmaxf (c->floor[i], c->sidelobe[i]));
    c->passing_raw[i] = c->pixels.range ? raw_level (c->passing[i],
        c->range[i]) : c->passing[i];
  }
  sonar_workers_run (c->workers, find_peaks_share, c);
  h->n = 0;
  for (guint w = 0; w < sonar_workers_count (c->workers); w++) {
    const PeakHeap *share = &c->scratch[w].peaks;
    for (guint k = 0; k < share->n; k++)
      keep_peak (h, c->params.max_peaks, share->value[k], share->pixel[k]);
    found += share->n_found;
  }
  h->n_found = found;
  /* Heap sort of the min-heap: strongest first. */
  for (guint size = h->n; size > 1; size--) {
    peak_swap (h, 0, size - 1);
    peak_sift_down (h, size - 1, 0);
  }
}

/* Sub-step offset (-0.5..0.5) of the maximum of the parabola through the
 * logarithms of three samples, 0 when they do not allow one. */
static double
refine (const Pixels * im, gsize p, gsize stride, guint index, guint n)
{
  double lm, l0, lp, curvature;
  float before, after;

  if (index == 0 || index + 1 >= n)
    return 0.0;
  before = pixel (im, p - stride);
  after = pixel (im, p + stride);
  if (!(before > 0.0f && after > 0.0f && isfinite (before)
          && isfinite (after)))
    return 0.0;
  lm = log (before);
  l0 = log (pixel (im, p));
  lp = log (after);
  curvature = lm - 2.0 * l0 + lp;
  if (!(curvature < 0.0))
    return 0.0;
  return CLAMP (0.5 * (lm - lp) / curvature, -0.5, 0.5);
}

/* The maximum of the quadratic through the logarithms of the 3 x 3
 * samples around pixel @p (@a, @e) at its range, cross term included, as
 * offsets in grid steps along azimuth and elevation; FALSE (and nothing
 * written) at the grid's edge, where a sample is not a positive number,
 * or where the quadratic has no maximum. */
static gboolean
fit_direction (const Pixels * im, gsize p, guint a, guint e,
    const SonarImageGrid * g, double *offset_a, double *offset_e)
{
  const gsize stride_a = g->n_range;
  const gsize stride_e = (gsize) g->n_azimuth * g->n_range;
  double l[3][3], grad_a, grad_e, h_aa, h_ee, h_ae;

  if (a == 0 || a + 1 >= g->n_azimuth || e == 0 || e + 1 >= g->n_elevation)
    return FALSE;
  for (guint row = 0; row < 3; row++)
    for (guint col = 0; col < 3; col++) {
      const float v = pixel (im, p + row * stride_e + col * stride_a -
          stride_e - stride_a);
      if (!(v > 0.0f && isfinite (v)))
        return FALSE;
      l[row][col] = log (v);
    }
  grad_a = 0.5 * (l[1][2] - l[1][0]);
  grad_e = 0.5 * (l[2][1] - l[0][1]);
  h_aa = l[1][2] - 2.0 * l[1][1] + l[1][0];
  h_ee = l[2][1] - 2.0 * l[1][1] + l[0][1];
  h_ae = 0.25 * (l[2][2] - l[2][0] - l[0][2] + l[0][0]);
  return sonar_linalg_quadratic_peak (grad_a, grad_e, h_aa, h_ae, h_ee,
      offset_a, offset_e);
}

/* The neighbour's fits' weight along one axis, from where the fits of
 * the pixel and its neighbour put the peak (@position, steps from the
 * pixel towards the neighbour): none within BLEND_START of the pixel,
 * all within BLEND_START of the neighbour, linear between. */
#define BLEND_START 0.25

static double
neighbour_weight (double position)
{
  return CLAMP ((position - BLEND_START) / (1.0 - 2.0 * BLEND_START), 0.0,
      1.0);
}

/* Sub-step offsets along azimuth and elevation of the peak at pixel @p
 * (@a, @e): the fits (fit_direction ()) around the four pixels of the
 * 2 x 2 block the peak lies in (the pixel, its neighbours on the sides
 * its own fit points to, and their common neighbour), blended with
 * bilinear weights that go from the pixel's fit alone near its centre to
 * the neighbours' near theirs.
 * Why: the array's beam is tilted in azimuth and elevation (the eRTIS
 * layout has no symmetry), so parabolas along the peak's row and column
 * alone read an azimuth that depends on the row; and the log beam is not
 * a quadratic, so each pixel's fit errs its own way near the half step.
 * Taking one pixel's fit, or its neighbour's beyond the half step, made
 * the direction jump by up to 0.3 degrees as noise moved the peak pixel
 * across it (a still point's estimates in two clusters,
 * tools/uncertainty-3d.py --seeds); the blend is the same whichever of
 * the block's pixels is the peak, so it moves continuously. A
 * neighbour's weight follows the mean of the positions of the peak's
 * pixel and that neighbour (the fits of the one pair that both peak
 * pixels share). FALSE where the pixel's own fit does not hold (then the
 * separable parabolas); a neighbour's that does not hold is left out. */
static gboolean
refine_direction (const Pixels * im, gsize p, guint a, guint e,
    const SonarImageGrid * g, double *offset_a, double *offset_e)
{
  const gssize stride_a = g->n_range;
  const gssize stride_e = (gssize) g->n_azimuth * g->n_range;
  /* [row][column] of the block: 0 the pixel's, 1 the neighbour's; the
   * positions in steps from the pixel. */
  double x[2][2], y[2][2], weight_a, weight_e, sum = 0.0, sum_x = 0.0,
      sum_y = 0.0;
  gboolean held[2][2] = { {FALSE, FALSE}, {FALSE, FALSE} };
  int side_a, side_e;

  if (!fit_direction (im, p, a, e, g, &x[0][0], &y[0][0]))
    return FALSE;
  held[0][0] = TRUE;
  side_a = x[0][0] >= 0.0 ? 1 : -1;
  side_e = y[0][0] >= 0.0 ? 1 : -1;
  for (int row = 0; row < 2; row++)
    for (int col = 0; col < 2; col++) {
      const int da = col * side_a, de = row * side_e;
      double u, v;
      if ((row == 0 && col == 0) || (int) a + da < 0
          || (int) a + da >= (int) g->n_azimuth || (int) e + de < 0
          || (int) e + de >= (int) g->n_elevation)
        continue;
      held[row][col] = fit_direction (im, p + da * stride_a +
          de * stride_e, a + da, e + de, g, &u, &v);
      x[row][col] = da + u;
      y[row][col] = de + v;
    }
  weight_a = held[0][1] ? neighbour_weight (0.5 * side_a * (x[0][0] +
          x[0][1])) : 0.0;
  weight_e = held[1][0] ? neighbour_weight (0.5 * side_e * (y[0][0] +
          y[1][0])) : 0.0;
  for (int row = 0; row < 2; row++)
    for (int col = 0; col < 2; col++) {
      const double w = (col ? weight_a : 1.0 - weight_a) *
          (row ? weight_e : 1.0 - weight_e);
      if (!held[row][col] || !(w > 0.0))
        continue;
      sum += w;
      sum_x += w * x[row][col];
      sum_y += w * y[row][col];
    }
  if (!(sum > 0.0)) {
    /* Only the common neighbour weighs, and its fit does not hold. */
    sum = 1.0;
    sum_x = x[0][0];
    sum_y = y[0][0];
  }
  /* Within the cells of the block's pixels. */
  *offset_a = side_a * CLAMP (side_a * sum_x / sum, -0.5, 1.5);
  *offset_e = side_e * CLAMP (side_e * sum_y / sum, -0.5, 1.5);
  if (!(weight_a > 0.0))
    *offset_a = CLAMP (*offset_a, -0.5, 0.5);
  if (!(weight_e > 0.0))
    *offset_e = CLAMP (*offset_e, -0.5, 0.5);
  return TRUE;
}

static void
locate_peaks (SonarClusterer * c)
{
  const SonarImageGrid *g = &c->grid;
  const Pixels *im = &c->pixels;
  const gsize stride_e = (gsize) g->n_azimuth * g->n_range;

  for (guint k = 0; k < c->peaks.n; k++) {
    const gsize p = c->peaks.pixel[k];
    const guint i = p % g->n_range, a = (p / g->n_range) % g->n_azimuth;
    const guint e = p / stride_e;
    const double r = g->range_first + g->range_step *
        (i + refine (im, p, 1, i, g->n_range));
    double offset_a, offset_e, az, el;
    SonarVec3 u;

    if (!refine_direction (im, p, a, e, g, &offset_a, &offset_e)) {
      offset_a = refine (im, p, g->n_range, a, g->n_azimuth);
      offset_e = refine (im, p, stride_e, e, g->n_elevation);
    }
    az = g->azimuth_first + g->azimuth_step * (a + offset_a);
    el = g->elevation_first + g->elevation_step * (e + offset_e);
    u = sonar_vec3_from_direction (az, el);

    c->peak_range[k] = r;
    c->peak_direction[k] = u;
    c->points[3 * k] = r * u.x;
    c->points[3 * k + 1] = r * u.y;
    c->points[3 * k + 2] = r * u.z;
  }
}

/* Which rows the stop criterion refuses to merge. */
static void
refuse_links (SonarClusterer * c, const double *Z, guint n)
{
  const SonarClusterParams *p = &c->params;
  guint8 *refused = sonar_linkage_work_refused (c->linkage);
  const double *coefficient;
  const int *n_links;

  if (p->stop == SONAR_STOP_DISTANCE) {
    for (guint k = 0; k + 1 < n; k++)
      refused[k] = Z[4 * k + 2] > p->distance;
    return;
  }
  sonar_linkage_work_inconsistency (c->linkage, Z, n, p->depth, &coefficient,
      &n_links);
  for (guint k = 0; k + 1 < n; k++) {
    const double links = n_links[k];
    /* Over k links the coefficient cannot exceed (k - 1) / sqrt (k): when
     * that is within the threshold the coefficient cannot refuse anything,
     * and the height decides instead. */
    if ((links - 1.0) / sqrt (links) > p->inconsistency)
      refused[k] = coefficient[k] > p->inconsistency;
    else
      refused[k] = Z[4 * k + 2] > p->distance;
  }
}

/* @n pixels @in, times @range squared when it is not NULL, each finite
 * one into @row_max where it is higher (a select, without branches), and
 * into @compensated when not NULL: vector code for @n = CHUNK (restrict:
 * none of the arrays overlap). */
static inline void
compensate_pixels (float *restrict compensated, float *restrict row_max,
    const float *restrict in, const float *restrict range, guint n)
{
  if (range && compensated) {
    for (guint i = 0; i < n; i++) {
      const float v = in[i] * range[i] * range[i];
      compensated[i] = v;
      row_max[i] = v > row_max[i] && isfinite (v) ? v : row_max[i];
    }
  } else if (range) {
    for (guint i = 0; i < n; i++) {
      const float v = in[i] * range[i] * range[i];
      row_max[i] = v > row_max[i] && isfinite (v) ? v : row_max[i];
    }
  } else {
    for (guint i = 0; i < n; i++) {
      const float v = in[i];
      row_max[i] = v > row_max[i] && isfinite (v) ? v : row_max[i];
    }
  }
}

/* Worker @w's share of the first pass: the strongest pixel per range
 * bin of its run of directions (compensated when so set) into its
 * row_max, and the floors' rows among them into c->compensated. */
static void
compensate_share (gpointer data, guint w, guint n_workers)
{
  SonarClusterer *c = data;
  const SonarImageGrid *g = &c->grid;
  const gsize n_dirs = (gsize) g->n_azimuth * g->n_elevation;
  float *row_max = c->scratch[w].row_max;

  memset (row_max, 0, sizeof (float) * g->n_range);
  for (gsize d = n_dirs * w / n_workers; d < n_dirs * (w + 1) / n_workers;
      d++) {
    const float *in = c->pixels.values + d * g->n_range;
    const float *range = c->compensated ? c->range : NULL;
    float *compensated = c->compensated && d % c->floor_stride == 0 ?
        c->compensated + d / c->floor_stride * g->n_range : NULL;
    guint i = 0;

    for (; i + CHUNK <= g->n_range; i += CHUNK)
      compensate_pixels (compensated ? compensated + i : NULL, row_max + i,
          in + i, range ? range + i : NULL, CHUNK);
    compensate_pixels (compensated ? compensated + i : NULL, row_max + i,
        in + i, range ? range + i : NULL, g->n_range - i);
  }
}

guint
sonar_clusterer_process (SonarClusterer * c, const float *image,
    SonarCentroid * out, guint max_centroids)
{
  const SonarImageGrid *g;
  const float *raw = image;
  gsize n_pixels;
  const double *Z = NULL;
  float max = 0.0f, threshold;
  guint n, n_out = 0;

  g_return_val_if_fail (c && image, 0);
  g_return_val_if_fail (out || max_centroids == 0, 0);
  g = &c->grid;
  n_pixels = sonar_image_grid_size (g);
  /* One pass over the image, shared out: each range's strongest pixel
   * over the directions (for the sidelobe thresholds), and so the
   * image's, compensated when so set, and the floors' rows' copy. */
  c->pixels.values = image;
  c->pixels.range = NULL;
  c->pixels.n_range = g->n_range;
  sonar_workers_run (c->workers, compensate_share, c);
  memcpy (c->row_max, c->scratch[0].row_max, sizeof (float) * g->n_range);
  for (guint w = 1; w < sonar_workers_count (c->workers); w++)
    for (guint i = 0; i < g->n_range; i++)
      c->row_max[i] = MAX (c->row_max[i], c->scratch[w].row_max[i]);
  c->floor_rows = image;
  c->floor_pitch = c->floor_stride * g->n_range;
  if (c->compensated) {
    c->floor_rows = c->compensated;
    c->floor_pitch = g->n_range;
    if (c->n_floor_rows == n_pixels / g->n_range)
      c->pixels.values = c->compensated;
    else
      c->pixels.range = c->range;
  }
  for (guint i = 0; i < g->n_range; i++)
    max = MAX (max, c->row_max[i]);
  c->peaks.n_found = c->peaks.n = 0;
  if (!(max > 0.0f))
    return 0;
  threshold = MAX (max * pow (10.0, c->params.threshold_db / 20.0),
      c->params.absolute_threshold);
  noise_floors (c);
  sidelobe_thresholds (c);
  c->raw = raw;
  c->column_gain = (float) (SONAR_CLUSTER_COLUMN_MARGIN * sonar_cluster_floor_gain
      (c->params.pfa, sonar_cluster_effective_hypotheses
          (c->params.hypotheses)));
  for (gsize k = 0; k < n_pixels / g->n_range * c->n_column_blocks; k++)
    c->column_quartile[k] = NAN;
  find_peaks (c, threshold);
  n = c->peaks.n;
  if (n == 0)
    return 0;
  locate_peaks (c);

  if (n >= 2) {
    Z = sonar_linkage_work_run (c->linkage, c->points, n);
    refuse_links (c, Z, n);
  }
  sonar_linkage_work_flat_clusters (c->linkage, Z, n, c->labels);

  /* Peaks are strongest first, so clusters are numbered in the order of
   * their strongest peak; the output accumulates weighted sums first. */
  for (guint k = 0; k <= n; k++)
    c->slot[k] = -1;
  for (guint k = 0; k < n; k++) {
    const int label = c->labels[k];
    const double v = c->peaks.value[k], weight = v * v;
    SonarCentroid *o;
    if (c->slot[label] < 0) {
      const gsize p = c->peaks.pixel[k];
      if (n_out == max_centroids)
        continue;
      c->slot[label] = n_out;
      o = &out[n_out++];
      memset (o, 0, sizeof (*o));
      o->peak_value = v;
      o->peak_range_index = p % g->n_range;
      o->peak_azimuth_index = (p / g->n_range) % g->n_azimuth;
      o->peak_elevation_index = p / ((gsize) g->n_azimuth * g->n_range);
      o->peak_range = c->peak_range[k];
      o->range_min = o->range_max = c->peak_range[k];
    }
    o = &out[c->slot[label]];
    o->range_min = MIN (o->range_min, c->peak_range[k]);
    o->range_max = MAX (o->range_max, c->peak_range[k]);
    o->n_members++;
    o->energy += weight;
    o->range += weight * c->peak_range[k];
    o->position = sonar_vec3_add (o->position,
        sonar_vec3_scale (c->peak_direction[k], weight));
  }
  for (guint k = 0; k < n_out; k++) {
    SonarCentroid *o = &out[k];
    const double norm = sonar_vec3_norm (o->position);
    const SonarVec3 u = norm > 0.0 ?
        sonar_vec3_scale (o->position, 1.0 / norm) : sonar_vec3 (0, 0, 1);
    o->range /= o->energy;
    sonar_vec3_to_direction (u, &o->azimuth, &o->elevation);
    o->position = sonar_vec3_scale (u, o->range);
  }
  return n_out;
}
