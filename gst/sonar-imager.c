/* sonar-imager.c: see sonar-imager.h. */
#include "sonar-imager.h"
#include "sonar-cluster.h"
#include "sonar-error.h"
#include "sonar-fftw.h"
#include "sonar-kernels.h"
#include "sonar-steering.h"
#include "sonar-workers.h"

#include <fftw3.h>
#include <gio/gio.h>
#include <math.h>
#include <string.h>

/* Range bins per block of the coarse pass's strongest hypothesis (2.7 mm
 * each: 4.3 cm, a few envelope widths). A pixel over refine-pfa's gate
 * is its block's strongest, or near it. */
#define HYPOTHESIS_BLOCK 16
/* refine_pfa's default. */
#define DEFAULT_REFINE_PFA 1e-5
/* A coarse pixel that noise alone exceeds this rarely (over its range
 * bin's noise floor, as refine_pfa's gate at its default) marks its block
 * of HYPOTHESIS_BLOCK range bins as holding an echo: fixed, so that what
 * the image holds does not follow the gate's setting. */
#define ECHO_PFA DEFAULT_REFINE_PFA
/* Range bins gathered at a time for the noise floors over the coarse
 * directions: each direction's bins read in one run (one bin at a time
 * reads a cache line per value; sonar-cluster.c gathers so too). */
#define FLOOR_BLOCK 32

#define MAX_DIRECTIONS 65536
#define MAX_FOCUS_ZONES 64

#define UNIT(im, d, z) ((d) * ((im)->n_zones + 1) + (z))

/* How the fine pass images a (direction, zone) unit of a coarse-to-fine
 * image. */
typedef enum
{
  UNIT_INTERPOLATED,            /* not: its pixels interpolated */
  UNIT_SOME_HYPOTHESES,         /* over some: its envelope's maximum taken
                                 * with the interpolation where the coarse
                                 * corners hold noise alone */
  UNIT_GATE_HYPOTHESES,         /* over those of the noise gate alone: its
                                 * envelope's maximum taken with the
                                 * interpolation everywhere */
  UNIT_EVERY_HYPOTHESIS         /* over all: its envelope written */
} UnitImaging;

/* Why a coarse (direction, zone) is hot: im->hot's bits. */
#define HOT_LEVEL 1             /* within refine_db of the maximum */
#define HOT_GATE 2              /* over the noise gate (refine_pfa) */

#define UNIT_DIRECTION(im, u) ((u) / ((im)->n_zones + 1))
#define UNIT_ZONE(im, u) ((u) % ((im)->n_zones + 1))

typedef struct
{
  guint first_range, end_range; /* range bins [first, end) of the grid */
  double focus;                 /* m */
  /* The legs (sonar-steering.h) of each direction's point at the focus. */
  double *mic_legs;             /* [direction][microphone] m_j, m */
  double *emitter_legs;         /* [direction][emitter] e_n, m */
} FocusZone;

/* Delay and sum output of one direction, then its inverse transform. The
 * sums are kept split, real and imaginary parts apart: the steering
 * kernels then need no shuffling of interleaved pairs (twice as fast). */
typedef struct
{
  float *receive_re, *receive_im;       /* K: sum over microphones */
  float *transmit_re, *transmit_im;     /* K: sum over emitters */
  SonarComplex *baseband;       /* M: the product, zero-padded */
  SonarComplex *lags;           /* M: its inverse transform (out of place:
                                 * FFTW's in-place transforms allocate on
                                 * every call) */
  float *envelope;              /* one hypothesis's, over the grid's ranges */
  guint passes;                 /* unit x hypothesis passes of this call */
  /* The noise gate's range floors: [FLOOR_BLOCK x coarse direction]
   * gathered values, and one bin's scratch (2 x coarse directions). */
  float *floor_values, *floor_scratch;
} Scratch;

/* One call's arguments, for the workers. */
typedef struct
{
  const guint *units;           /* UNIT (direction, zone) */
  guint n_units;
  guint n_coarse;               /* the noise gate's: coarse directions,
                                 * the first units */
  /* Coarse pass: per UNIT (coarse direction, zone) x hypothesis, the
   * hypothesis's r^2-weighted peak over the zone; else NULL. */
  float *zone_peaks;
  /* Coarse pass: per (coarse unit of the call, block of
   * HYPOTHESIS_BLOCK range bins), the hypothesis whose envelope is the
   * strongest there, and that envelope; else NULL. */
  guint16 *best_hypothesis;
  float *best_value;
  /* Fine pass: per UNIT (coarse direction, zone) x hypothesis, whether a
   * unit with that coarse corner images the hypothesis; NULL: all. */
  const guint8 *wanted;
  /* Fine pass: per UNIT, its UnitImaging (NULL: every hypothesis). */
  const guint8 *imaging;
  guint n_hypotheses;
  const SonarHypothesis *hypotheses;
  int emitter;
  float *image;
  gsize stride;
  float scale;
} ImageJob;

struct _SonarImager
{
  SonarSetup *setup;
  SonarBand band;
  SonarSteering steering;
  SonarImageGrid grid;
  guint n_directions;
  SonarVec3 *directions;
  guint n_zones;
  FocusZone *zones;

  /* Coarse to fine (see the header). Units of work, [direction x zone]
   * arrays: UNIT (d, z), z <= n_zones, the coarse zone n_zones. */
  guint coarse_azimuth, coarse_elevation;      /* grid steps per coarse step */
  float refine_ratio;           /* 10^(-refine_db / 20) */
  double refine_pfa;            /* the noise gate's pfa; 0: off */
  float sidelobe_ratio;         /* wardcluster's default sidelobe level */
  guint n_coarse;               /* coarse directions */
  float *range_floor;           /* [range bin] the noise gate over them */
  float *range_top;             /* [range bin] their strongest */
  float *range_echo;            /* [range bin] the level of ECHO_PFA */
  guint *coarse_unit;           /* [direction] its index among the coarse
                                 * ones, G_MAXUINT for the others */
  /* [coarse direction x block of HYPOTHESIS_BLOCK range bins]: no pixel of
   * the block over range_echo, noise alone (all FALSE: not known). */
  guint8 *noise_block;
  /* wardcluster's column floor on the coarse directions: blocks of
   * column_bins range bins, [coarse unit x block] lower quartiles (NaN:
   * not yet taken this call), column_values one block's values. */
  guint column_bins, n_column_blocks;
  float *column_quartile, *column_values;
  float *range_weight;          /* [range bin] r^2, as wardcluster's */
  guint *units;                 /* [direction x zone]: the units to image */
  guint8 *hot;                  /* [direction x zone]: coarse, HOT_ bits */
  guint8 *imaging;              /* [direction x zone]: UnitImaging */
  guint n_imaged;               /* units imaged by the last call */
  guint n_passes;               /* unit x hypothesis passes of the last call */

  guint ifft_size;              /* M */
  guint first_lag;              /* IFFT sample of range bin 0 */
  fftwf_plan inverse;           /* made on scratch[0], run on every worker's */
  /* The call's data, split: microphones x K, scaled (data_exponent ()). */
  float *mic_re, *mic_im;
  /* [UNIT x hypothesis], as job.zone_peaks and job.wanted, for
   * hypothesis_capacity hypotheses. */
  guint hypothesis_capacity;
  float *zone_peaks;
  guint8 *wanted;
  /* [coarse direction x block of range bins], as job.best_hypothesis */
  guint n_hypothesis_blocks;
  guint16 *best_hypothesis;
  float *best_value;
  /* Directions are shared out between workers, each with its scratch. */
  SonarWorkers *workers;
  Scratch scratch[SONAR_MAX_WORKERS];
  ImageJob job;
};

void
sonar_imager_params_init_default (SonarImagerParams * p)
{
  sonar_imager_params_set_view (p, SONAR_FIELD_OF_VIEW_FAN);
  p->range_min = 0.3;
  p->range_max = 0.0;
  p->range_resolution = 0.005;
  p->focus_zones = 4;
  p->refine_db = 20.0;
  p->refine_pfa = DEFAULT_REFINE_PFA;
  p->threads = 0;
}

void
sonar_imager_params_set_view (SonarImagerParams * p, SonarFieldOfView view)
{
  p->azimuth_min = -90.0;
  p->azimuth_max = 90.0;
  if (view == SONAR_FIELD_OF_VIEW_HEMISPHERE) {
    /* The 3-D grid of sonar-bench's hemisphere sweep: 2 degrees, coarse
     * 6, every object of its scenes found with the 2-D errors. */
    p->n_azimuth = 91;
    p->elevation_min = -90.0;
    p->elevation_max = 90.0;
    p->n_elevation = 91;
    p->coarse_spacing = 6.0;
  } else {
    p->n_azimuth = 181;
    p->elevation_min = 0.0;
    p->elevation_max = 0.0;
    p->n_elevation = 1;
    /* sonar-bench's coarse-spacing and refine-db sweeps: 3 degrees (a MIMO
     * main lobe) and 20 dB (wardcluster's -10 dB with 10 dB to spare) find
     * every object of Fig. 9 and 10 with the dense image's errors. */
    p->coarse_spacing = 3.0;
  }
}

double
sonar_imager_range_max (const SonarSetup * setup, double requested)
{
  /* Lags up to the window's end are free of the FFT's wrap-around. */
  const double window_end = floor (sonar_setup_window_range (setup) *
      1000.0) / 1000.0;

  if (requested <= 0.0)
    return sonar_setup_recorded_range (setup);
  return MIN (requested, window_end);
}

/* What is wrong with refine levels (set at start or while playing), or
 * NULL. */
static const char *
refine_problem (double refine_db, double refine_pfa)
{
  if (!(refine_db > 0.0 && refine_db <= 200.0))
    return "refine-db must be in (0, 200] dB";
  if (!(refine_pfa >= 0.0 && refine_pfa < 1.0))
    return "refine-pfa must be in [0, 1)";
  return NULL;
}

static gboolean
validate_params (const SonarImagerParams * p, double range_max,
    GError ** error)
{
  const char *problem = NULL;

  if (p->n_azimuth < 1 || p->n_elevation < 1
      || (guint64) p->n_azimuth * p->n_elevation > MAX_DIRECTIONS)
    problem = "the number of directions must be 1 to 65536";
  else if (!(p->azimuth_min >= -90.0 && p->azimuth_max <= 90.0
          && p->azimuth_min <= p->azimuth_max))
    problem = "azimuths must satisfy -90 <= min <= max <= 90 degrees";
  else if (!(p->elevation_min >= -90.0 && p->elevation_max <= 90.0
          && p->elevation_min <= p->elevation_max))
    problem = "elevations must satisfy -90 <= min <= max <= 90 degrees";
  else if (!(p->range_resolution > 0.0 && p->range_resolution <= 1.0))
    problem = "the range resolution must be in (0, 1] m";
  else if (p->focus_zones < 1 || p->focus_zones > MAX_FOCUS_ZONES)
    problem = "focus zones must be 1 to 64";
  else if (!(p->coarse_spacing >= 0.0 && p->coarse_spacing <= 90.0))
    problem = "the coarse spacing must be 0 to 90 degrees";
  else
    problem = refine_problem (p->refine_db, p->refine_pfa);
  if (problem) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "imager: %s", problem);
    return FALSE;
  }
  if (!(p->range_min > 0.0 && p->range_min < range_max)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "imager: range-min %g m must be above 0 and below the image's "
        "farthest range, %.3f m", p->range_min, range_max);
    return FALSE;
  }
  return TRUE;
}

/* A zone of range bins [first, end) focused at @focus m. */
static void
init_zone (SonarImager * im, FocusZone * zone, double focus, guint first,
    guint end)
{
  const SonarGeometry *g = &im->setup->geometry;

  zone->focus = focus;
  zone->first_range = first;
  zone->end_range = end;
  zone->mic_legs = g_new (double, (gsize) im->n_directions *
      g->n_microphones);
  zone->emitter_legs = g_new (double, (gsize) im->n_directions *
      g->n_emitters);
  for (guint d = 0; d < im->n_directions; d++)
    sonar_steering_legs (&im->steering, im->directions[d], focus,
        zone->mic_legs + (gsize) d * g->n_microphones,
        zone->emitter_legs + (gsize) d * g->n_emitters);
}

/* The focus zones, then (when there is a coarse pass) the coarse zone:
 * the whole range focused as one zone would be. */
static void
init_zones (SonarImager * im, const SonarImagerParams * p, double range_max)
{
  const double inv_near = 1.0 / p->range_min, inv_far = 1.0 / range_max;
  const guint n_range = im->grid.n_range;

  im->n_zones = p->focus_zones;
  im->zones = g_new0 (FocusZone, im->n_zones + 1);
  for (guint z = 0; z < im->n_zones; z++) {
    /* Focusing errors scale with 1 / r: zones are even in 1 / r, focused
     * at their middle in 1 / r. */
    const double inv_a = inv_near + (inv_far - inv_near) * z / im->n_zones;
    const double inv_b = inv_near + (inv_far - inv_near) * (z + 1) /
        im->n_zones;
    const double r_a = 1.0 / inv_a, r_b = 1.0 / inv_b;

    init_zone (im, &im->zones[z], 2.0 / (inv_a + inv_b),
        (guint) CLAMP (ceil ((r_a - im->grid.range_first) /
                im->grid.range_step), 0, n_range),
        z + 1 == im->n_zones ? n_range :
        (guint) CLAMP (ceil ((r_b - im->grid.range_first) /
                im->grid.range_step), 0, n_range));
  }
  if (im->coarse_azimuth * im->coarse_elevation > 1)
    init_zone (im, &im->zones[im->n_zones], 2.0 / (inv_near + inv_far), 0,
        n_range);
}

static void coarse_corners (const SonarImager * im, guint d,
    guint corners[4]);

SonarImager *
sonar_imager_new (SonarSetup * setup, const SonarBand * band,
    const SonarImagerParams * p, GError ** error)
{
  const double c = setup->speed_of_sound, fs = setup->sample_rate;
  const double range_max = sonar_imager_range_max (setup, p->range_max);
  SonarImager *im;
  SonarImageGrid *grid;
  double lag_range, period_range;
  guint min_ifft;

  if (!validate_params (p, range_max, error))
    return NULL;

  im = g_new0 (SonarImager, 1);
  im->setup = sonar_setup_ref (setup);
  im->band = *band;
  sonar_steering_init (&im->steering, setup, band);
  grid = &im->grid;

  grid->n_azimuth = p->n_azimuth;
  grid->azimuth_first = p->azimuth_min;
  grid->azimuth_step = p->n_azimuth > 1 ?
      (p->azimuth_max - p->azimuth_min) / (p->n_azimuth - 1) : 0.0;
  grid->n_elevation = p->n_elevation;
  grid->elevation_first = p->elevation_min;
  grid->elevation_step = p->n_elevation > 1 ?
      (p->elevation_max - p->elevation_min) / (p->n_elevation - 1) : 0.0;
  im->n_directions = p->n_azimuth * p->n_elevation;
  im->directions = g_new (SonarVec3, im->n_directions);
  for (guint e = 0; e < grid->n_elevation; e++)
    for (guint a = 0; a < grid->n_azimuth; a++)
      im->directions[e * grid->n_azimuth + a] =
          sonar_vec3_from_direction (grid->azimuth_first +
          a * grid->azimuth_step,
          grid->elevation_first + e * grid->elevation_step);

  /* The inverse transform of M points spans the FFT's period: one sample is
   * period / M in time, period_range / M in range. M holds the band (no
   * aliasing) and reaches the requested range step. */
  period_range = 0.5 * c * band->fft_size / fs;
  min_ifft = MAX (band->n_bins, (guint) ceil (period_range /
          p->range_resolution));
  im->ifft_size = sonar_fft_fast_size (min_ifft);
  lag_range = period_range / im->ifft_size;
  grid->range_step = lag_range;
  im->first_lag = (guint) ceil (p->range_min / lag_range);
  grid->range_first = im->first_lag * lag_range;
  grid->n_range = (guint) floor (range_max / lag_range) - im->first_lag + 1;

  /* The coarse grid is every k-th direction, k steps nearest the
   * spacing; 1 (no coarse pass) on grids as coarse as it. */
  im->coarse_azimuth = grid->azimuth_step > 0.0 ? (guint) CLAMP (round
      (p->coarse_spacing / grid->azimuth_step), 1, 64) : 1;
  im->coarse_elevation = grid->elevation_step > 0.0 ? (guint) CLAMP (round
      (p->coarse_spacing / grid->elevation_step), 1, 64) : 1;
  init_zones (im, p, range_max);
  im->refine_ratio = (float) pow (10.0, -p->refine_db / 20.0);
  im->refine_pfa = p->refine_pfa;
  {
    SonarClusterParams cluster;
    sonar_cluster_params_init_default (&cluster);
    im->sidelobe_ratio = (float) pow (10.0, cluster.sidelobe_db / 20.0);
  }
  im->n_coarse = 0;
  im->coarse_unit = g_new (guint, im->n_directions);
  for (guint d = 0; d < im->n_directions; d++) {
    guint corners[4];
    coarse_corners (im, d, corners);
    im->coarse_unit[d] = corners[0] == d && corners[3] == d ?
        im->n_coarse++ : G_MAXUINT;
  }
  im->range_floor = g_new (float, grid->n_range);
  im->range_top = g_new (float, grid->n_range);
  im->range_echo = g_new (float, grid->n_range);
  im->n_hypothesis_blocks = (grid->n_range + HYPOTHESIS_BLOCK - 1) /
      HYPOTHESIS_BLOCK;
  im->best_hypothesis = g_new (guint16, (gsize) im->n_coarse *
      im->n_hypothesis_blocks);
  im->best_value = g_new (float, (gsize) im->n_coarse *
      im->n_hypothesis_blocks);
  im->noise_block = g_new0 (guint8, (gsize) im->n_coarse *
      im->n_hypothesis_blocks);
  im->column_bins = sonar_cluster_column_bins (grid);
  im->n_column_blocks = (grid->n_range + im->column_bins - 1) /
      im->column_bins;
  im->column_quartile = g_new (float, (gsize) im->n_coarse *
      im->n_column_blocks);
  im->column_values = g_new (float, im->column_bins);
  im->range_weight = g_new (float, grid->n_range);
  for (guint i = 0; i < grid->n_range; i++) {
    const double r = grid->range_first + i * grid->range_step;
    im->range_weight[i] = (float) (r * r);
  }
  im->units = g_new (guint, (gsize) im->n_directions * (im->n_zones + 1));
  im->hot = g_new (guint8, (gsize) im->n_directions * (im->n_zones + 1));
  im->imaging = g_new (guint8, (gsize) im->n_directions *
      (im->n_zones + 1));

  im->mic_re = g_new (float, (gsize) band->n_bins *
      setup->geometry.n_microphones);
  im->mic_im = g_new (float, (gsize) band->n_bins *
      setup->geometry.n_microphones);
  im->workers = sonar_workers_new (p->threads, error);
  if (!im->workers) {
    sonar_imager_free (im);
    return NULL;
  }
  for (guint w = 0; w < sonar_workers_count (im->workers); w++) {
    im->scratch[w].receive_re = fftwf_alloc_real (band->n_bins);
    im->scratch[w].receive_im = fftwf_alloc_real (band->n_bins);
    im->scratch[w].transmit_re = fftwf_alloc_real (band->n_bins);
    im->scratch[w].transmit_im = fftwf_alloc_real (band->n_bins);
    im->scratch[w].baseband = fftwf_alloc_complex (im->ifft_size);
    im->scratch[w].lags = fftwf_alloc_complex (im->ifft_size);
    /* The padding stays zero: products fill the band's bins only, and an
     * out-of-place complex transform preserves its input. */
    memset (im->scratch[w].baseband, 0, sizeof (SonarComplex) *
        im->ifft_size);
    im->scratch[w].envelope = g_new (float, grid->n_range);
    im->scratch[w].floor_values = g_new (float, (gsize) FLOOR_BLOCK *
        im->n_coarse);
    im->scratch[w].floor_scratch = g_new (float, 2 * (gsize) im->n_coarse);
  }
  sonar_fftw_lock ();
  /* FFTW's allocator aligns every array alike: the plan runs on each
   * worker's arrays with fftwf_execute_dft. */
  im->inverse = fftwf_plan_dft_1d (im->ifft_size, im->scratch[0].baseband,
      im->scratch[0].lags, FFTW_BACKWARD, SONAR_FFTW_PLANNING);
  sonar_fftw_unlock ();
  return im;
}

void
sonar_imager_free (SonarImager * im)
{
  if (!im)
    return;
  for (guint z = 0; z <= im->n_zones && im->zones; z++) {
    g_free (im->zones[z].mic_legs);
    g_free (im->zones[z].emitter_legs);
  }
  g_free (im->zones);
  g_free (im->directions);
  g_free (im->range_weight);
  g_free (im->range_floor);
  g_free (im->range_top);
  g_free (im->range_echo);
  g_free (im->coarse_unit);
  g_free (im->noise_block);
  g_free (im->best_hypothesis);
  g_free (im->best_value);
  g_free (im->column_quartile);
  g_free (im->column_values);
  g_free (im->units);
  g_free (im->hot);
  g_free (im->imaging);
  if (im->inverse) {
    sonar_fftw_lock ();
    fftwf_destroy_plan (im->inverse);
    sonar_fftw_unlock ();
  }
  for (guint w = 0; w < SONAR_MAX_WORKERS; w++) {
    fftwf_free (im->scratch[w].receive_re);
    fftwf_free (im->scratch[w].receive_im);
    fftwf_free (im->scratch[w].transmit_re);
    fftwf_free (im->scratch[w].transmit_im);
    fftwf_free (im->scratch[w].baseband);
    fftwf_free (im->scratch[w].lags);
    g_free (im->scratch[w].envelope);
    g_free (im->scratch[w].floor_values);
    g_free (im->scratch[w].floor_scratch);
  }
  sonar_workers_free (im->workers);
  g_free (im->mic_re);
  g_free (im->mic_im);
  g_free (im->zone_peaks);
  g_free (im->wanted);
  sonar_setup_unref (im->setup);
  g_free (im);
}

const SonarImageGrid *
sonar_imager_grid (const SonarImager * im)
{
  return &im->grid;
}

/* Binary exponent of the largest component of @x (0 when all zero or not
 * finite): x / 2^exponent is below 1. */
static int
data_exponent (const SonarComplex * x, gsize n)
{
  float peak = 0.0f;
  int exponent = 0;

  for (gsize i = 0; i < n; i++)
    peak = MAX (peak, MAX (fabsf (crealf (x[i])), fabsf (cimagf (x[i]))));
  if (peak > 0.0f && isfinite (peak))
    frexpf (peak, &exponent);
  return exponent;
}

/* Coarse indices of a grid axis of @n points: every @step-th and the
 * last. @i lies between coarse indices *lo <= i <= *hi (equal when i is
 * coarse). */
static void
coarse_bracket (guint i, guint n, guint step, guint * lo, guint * hi)
{
  if (i % step == 0 || i == n - 1) {
    *lo = *hi = i;
  } else {
    *lo = i - i % step;
    *hi = MIN (*lo + step, n - 1);
  }
}

/* The four coarse directions around direction @d (repeated where @d is
 * on a coarse row or column). */
static void
coarse_corners (const SonarImager * im, guint d, guint corners[4])
{
  const guint n_az = im->grid.n_azimuth;
  guint a0, a1, e0, e1;

  coarse_bracket (d % n_az, n_az, im->coarse_azimuth, &a0, &a1);
  coarse_bracket (d / n_az, im->grid.n_elevation, im->coarse_elevation, &e0,
      &e1);
  corners[0] = e0 * n_az + a0;
  corners[1] = e0 * n_az + a1;
  corners[2] = e1 * n_az + a0;
  corners[3] = e1 * n_az + a1;
}

/* Worker @w's share of a call: units w, w + n, ... */
static void
image_units (gpointer data, guint w, guint n_workers)
{
  SonarImager *im = data;
  const ImageJob *job = &im->job;
  const Scratch *scratch = &im->scratch[w];
  const SonarGeometry *g = &im->setup->geometry;
  const guint n_bins = im->band.n_bins, n_range = im->grid.n_range;
  const SonarSplitSpectra mic_spectra = { im->mic_re, im->mic_im };
  const guint n_first = job->emitter < 0 ? 0 : (guint) job->emitter;
  const guint n_end = job->emitter < 0 ? g->n_emitters :
      (guint) job->emitter + 1;

  for (guint u = w; u < job->n_units; u += n_workers) {
    const guint d = UNIT_DIRECTION (im, job->units[u]);
    const FocusZone *zone = &im->zones[UNIT_ZONE (im, job->units[u])];
    const guint first = zone->first_range;
    const guint count = zone->end_range - zone->first_range;
    const double *mic_legs = zone->mic_legs + (gsize) d * g->n_microphones;
    const double *emitter_legs = zone->emitter_legs +
        (gsize) d * g->n_emitters;
    const gsize pixels = (gsize) d * n_range + first;
    const guint n_hyp = job->n_hypotheses;
    /* Whether the next envelope is written over the pixels, or its
     * maximum with them kept: a unit imaging some hypotheses only starts
     * from the pixels interpolate () left there. */
    gboolean overwrite = !job->imaging || job->imaging[job->units[u]] ==
        UNIT_EVERY_HYPOTHESIS;
    guint corners[4];

    if (count == 0)
      continue;
    if (job->wanted)
      coarse_corners (im, d, corners);
    /* Receive side: once per direction for every hypothesis. */
    sonar_steering_receive_sum (&im->steering, &mic_spectra, mic_legs,
        scratch->receive_re, scratch->receive_im);

    for (guint h = 0; h < n_hyp; h++) {
      const SonarHypothesis *hypothesis = &job->hypotheses[h];
      const guint z = UNIT_ZONE (im, job->units[u]);
      const SonarComplex *lags;

      if (job->wanted && !job->wanted[UNIT (im, corners[0], z) * n_hyp + h]
          && !job->wanted[UNIT (im, corners[1], z) * n_hyp + h]
          && !job->wanted[UNIT (im, corners[2], z) * n_hyp + h]
          && !job->wanted[UNIT (im, corners[3], z) * n_hyp + h])
        continue;
      sonar_steering_transmit_sum (&im->steering, &hypothesis->templates,
          emitter_legs, sonar_steering_stretch (&im->steering,
              hypothesis->velocity), n_first, n_end, scratch->transmit_re,
          scratch->transmit_im);
      sonar_kernel_multiply_split (scratch->baseband, scratch->receive_re,
          scratch->receive_im, scratch->transmit_re, scratch->transmit_im,
          n_bins);
      fftwf_execute_dft (im->inverse, scratch->baseband, scratch->lags);
      lags = scratch->lags + im->first_lag + first;
      if (job->zone_peaks) {
        /* Coarse unit (the whole range): each zone's peak of this
         * hypothesis, then the maximum over the hypotheses and which. */
        const gsize blocks = (gsize) u * im->n_hypothesis_blocks;
        guint16 *best = job->best_hypothesis + blocks;
        float *best_value = job->best_value + blocks;

        sonar_kernel_envelope (scratch->envelope, lags, count, job->scale,
            FALSE);
        for (guint zz = 0; zz < im->n_zones; zz++) {
          const FocusZone *part = &im->zones[zz];
          job->zone_peaks[UNIT (im, d, zz) * n_hyp + h] = sonar_kernel_peak
              (scratch->envelope + part->first_range, im->range_weight +
              part->first_range, part->end_range - part->first_range);
        }
        if (overwrite)
          memcpy (job->image + pixels, scratch->envelope,
              count * sizeof (float));
        else
          sonar_kernel_max (job->image + pixels, scratch->envelope, count);
        /* Which hypothesis is strongest, per block of range bins: a
         * branch per block, not per bin (on noise every other
         * comparison would mispredict). */
        for (guint b = 0; b * HYPOTHESIS_BLOCK < count; b++) {
          const guint i0 = b * HYPOTHESIS_BLOCK;
          const float top = sonar_kernel_peak (scratch->envelope + i0, NULL,
              MIN (HYPOTHESIS_BLOCK, count - i0));
          if (overwrite || top > best_value[b]) {
            best_value[b] = top;
            best[b] = (guint16) h;
          }
        }
      } else {
        sonar_kernel_envelope (job->image + h * job->stride + pixels, lags,
            count, job->scale, job->stride == 0 && !overwrite);
      }
      overwrite = FALSE;
      im->scratch[w].passes++;
    }
  }
}

/* Images the @n units listed in im->units. */
static void
run_units (SonarImager * im, guint n)
{
  im->job.units = im->units;
  im->job.n_units = n;
  for (guint w = 0; w < sonar_workers_count (im->workers); w++)
    im->scratch[w].passes = 0;
  sonar_workers_run (im->workers, image_units, im);
  im->n_imaged += n;
  for (guint w = 0; w < sonar_workers_count (im->workers); w++)
    im->n_passes += im->scratch[w].passes;
}

/* From the coarse pass's zone peaks: a (coarse direction, zone) is hot
 * when a hypothesis's r^2-weighted peak there comes within the refine
 * level of the coarse image's maximum, and the fine units around it image
 * those hypotheses only. A pixel within 10 dB of the maximum has its best
 * hypothesis among them: 1.5 degrees off, at a coarse corner, the beam
 * loses at most 6 dB of the 20. wardcluster keeps fainter pixels too (it
 * has no relative threshold by default): those are interpolated between
 * coarse directions, which keep their peaks (a 40 dB weaker object beside
 * a strong one is found: tests/test-velocityest.c, near-far). */
static void
mark_hot (SonarImager * im, guint n_coarse)
{
  const guint n_hyp = im->job.n_hypotheses;
  float top = 0.0f, level;

  for (guint u = 0; u < n_coarse; u++) {
    const guint d = UNIT_DIRECTION (im, im->units[u]);
    for (guint z = 0; z < im->n_zones; z++)
      for (guint h = 0; h < n_hyp; h++)
        top = MAX (top, im->zone_peaks[UNIT (im, d, z) * n_hyp + h]);
  }
  level = top * im->refine_ratio;
  memset (im->hot, 0, (gsize) im->n_directions * (im->n_zones + 1));
  for (guint u = 0; u < n_coarse; u++) {
    const guint d = UNIT_DIRECTION (im, im->units[u]);
    for (guint z = 0; z < im->n_zones; z++) {
      const gsize unit = UNIT (im, d, z);
      for (guint h = 0; h < n_hyp; h++) {
        im->wanted[unit * n_hyp + h] = im->zone_peaks[unit * n_hyp + h] >=
            level;
        im->hot[unit] |= im->wanted[unit * n_hyp + h] ? HOT_LEVEL : 0;
      }
    }
  }
}

/* The lower quartile of block @b of the column of coarse unit @u (its
 * direction @d). */
static float
column_quartile (SonarImager * im, const float *image, guint u, guint d,
    guint b)
{
  float *q = &im->column_quartile[(gsize) u * im->n_column_blocks + b];

  if (isnan (*q)) {
    const guint n_range = im->grid.n_range;
    const guint i0 = b * im->column_bins;
    const guint n = MIN (i0 + im->column_bins, n_range) - i0;
    memcpy (im->column_values, image + (gsize) d * n_range + i0,
        n * sizeof (float));
    *q = sonar_select_kth (im->column_values, n, n / 4);
  }
  return *q;
}

/* wardcluster's floor along coarse direction @d at range bin @i, over
 * @gain: its block's and neighbours' largest quartile (sonar-cluster.c,
 * column_floor ()), a strong echo's cross-talk ridge along it. */
static float
column_gate (SonarImager * im, const float *image, guint u, guint d,
    guint i, float gain)
{
  const guint b = i / im->column_bins;
  float q = column_quartile (im, image, u, d, b);

  if (b > 0)
    q = MAX (q, column_quartile (im, image, u, d, b - 1));
  if (b + 1 < im->n_column_blocks)
    q = MAX (q, column_quartile (im, image, u, d, b + 1));
  return (float) SONAR_CLUSTER_COLUMN_MARGIN * gain * q;
}

/* Whether coarse direction @d's pixel at range bin @i is at least its
 * coarse neighbours' along azimuth and elevation: a peak of the coarse
 * image (a flank's unit has a stronger neighbour, refined if it passes). */
static gboolean
coarse_peak (const SonarImager * im, const float *image, guint d, guint i)
{
  const guint n_az = im->grid.n_azimuth, n_el = im->grid.n_elevation;
  const guint n_range = im->grid.n_range, a = d % n_az, e = d / n_az;
  const float v = image[(gsize) d * n_range + i];
  guint lo, hi, neighbours[4], n = 0;

  /* The nearest coarse index either side along each axis. */
  if (a > 0) {
    coarse_bracket (a - 1, n_az, im->coarse_azimuth, &lo, &hi);
    neighbours[n++] = e * n_az + lo;
  }
  if (a + 1 < n_az) {
    coarse_bracket (a + 1, n_az, im->coarse_azimuth, &lo, &hi);
    neighbours[n++] = e * n_az + hi;
  }
  if (e > 0) {
    coarse_bracket (e - 1, n_el, im->coarse_elevation, &lo, &hi);
    neighbours[n++] = lo * n_az + a;
  }
  if (e + 1 < n_el) {
    coarse_bracket (e + 1, n_el, im->coarse_elevation, &lo, &hi);
    neighbours[n++] = hi * n_az + a;
  }
  for (guint k = 0; k < n; k++)
    if (image[(gsize) neighbours[k] * n_range + i] > v)
      return FALSE;
  return TRUE;
}

/* Worker @w's share of the coarse image's noise floors: for a contiguous
 * run of the blocks of FLOOR_BLOCK range bins, each bin's censored lower
 * quartile (range_floor, wardcluster's statistic) and strongest pixel over
 * the job.n_coarse coarse directions (im->units, gathered into its own
 * scratch), the level of ECHO_PFA over it, and which coarse directions'
 * blocks of HYPOTHESIS_BLOCK bins stay under that level. The quartiles do
 * not depend on the share (the guess only speeds the selection up). */
static void
range_floors_share (gpointer data, guint w, guint n_workers)
{
  SonarImager *im = data;
  const Scratch *scratch = &im->scratch[w];
  const guint n_range = im->grid.n_range, n_coarse = im->job.n_coarse;
  const guint n_blocks = (n_range + FLOOR_BLOCK - 1) / FLOOR_BLOCK;
  const double k_eff = sonar_cluster_effective_hypotheses
      (im->job.n_hypotheses);
  const float censor = (float) sonar_cluster_floor_gain
      (SONAR_CLUSTER_CENSOR_SHARE, k_eff);
  const float echo = (float) sonar_cluster_floor_gain (ECHO_PFA, k_eff);
  const float *image = im->job.image;
  float guess = NAN;

  G_STATIC_ASSERT (FLOOR_BLOCK % HYPOTHESIS_BLOCK == 0);

  for (guint k = n_blocks * w / n_workers; k < n_blocks * (w + 1) /
      n_workers; k++) {
    const guint i0 = k * FLOOR_BLOCK, block = MIN (FLOOR_BLOCK,
        n_range - i0);
    for (guint u = 0; u < n_coarse; u++) {
      const float *pixels = image + (gsize) UNIT_DIRECTION (im,
          im->units[u]) * n_range + i0;
      for (guint b = 0; b < block; b++)
        scratch->floor_values[(gsize) b * n_coarse + u] = pixels[b];
    }
    for (guint b = 0; b < block; b++) {
      float *values = scratch->floor_values + (gsize) b * n_coarse;
      float top = 0.0f;
      for (guint u = 0; u < n_coarse; u++)
        top = MAX (top, values[u]);
      im->range_top[i0 + b] = top;
      guess = im->range_floor[i0 + b] = sonar_cluster_censored_quartile
          (values, n_coarse, censor, guess, scratch->floor_scratch);
      im->range_echo[i0 + b] = echo * guess;
    }
    for (guint u = 0; u < n_coarse; u++) {
      const float *pixels = image + (gsize) UNIT_DIRECTION (im,
          im->units[u]) * n_range;
      for (guint i = i0; i < i0 + block; i += HYPOTHESIS_BLOCK) {
        gboolean noise = TRUE;
        for (guint j = i; j < MIN (i + HYPOTHESIS_BLOCK, n_range); j++)
          noise &= pixels[j] <= im->range_echo[j];
        im->noise_block[(gsize) u * im->n_hypothesis_blocks + i /
            HYPOTHESIS_BLOCK] = noise;
      }
    }
  }
}

/* From the coarse image (the maximum over the hypotheses): a (coarse
 * direction, zone) is hot when one of its pixels could pass wardcluster's
 * tests once imaged in full: it exceeds its range bin's noise floor over
 * the coarse directions (wardcluster's censored lower quartile,
 * sonar-cluster.h) times what noise exceeds with probability refine_pfa,
 * and is within wardcluster's default sidelobe level of the strongest
 * coarse pixel within SONAR_CLUSTER_SIDELOBE_RANGE of its range (a strong
 * echo's sidelobes stand over the noise in every direction at its range,
 * and no peak is kept there), and over its direction's floor along the
 * range (a cross-talk ridge), and is a peak among its coarse
 * neighbours. An interpolated pixel never exceeds its coarse corners, so
 * every peak wardcluster would find over this gate is
 * refined, however far below the strongest. The unit images the
 * hypotheses that made its pixels over the gate (their blocks'
 * strongest) and their neighbours (they are about a Doppler main lobe
 * apart: between coarse directions the best may be the next), and no
 * others: in 3-D a strong echo's cross-talk passes the gate in hundreds
 * of units, where every hypothesis within refine_db of each unit's
 * strongest (nearly all of them) made three quarters of the image's
 * passes (a 3-D scene of tests/test_foreign.py: 18.3 % of the dense
 * image's passes against 4.9 %). So that their noise stays the maximum
 * over every hypothesis, as elsewhere, the fine units of such corners
 * keep the interpolation wherever it is higher (UNIT_GATE_HYPOTHESES);
 * the echo's own peak, over its coarse corners, is the fine image's. */
static void
mark_hot_over_noise (SonarImager * im, guint n_coarse)
{
  const SonarImageGrid *grid = &im->grid;
  const guint n_range = grid->n_range, n_hyp = im->job.n_hypotheses;
  const double k_eff = sonar_cluster_effective_hypotheses (n_hyp);
  const float gain = (float) sonar_cluster_floor_gain (im->refine_pfa,
      k_eff);
  const int reach = (int) ceil (SONAR_CLUSTER_SIDELOBE_RANGE /
      grid->range_step);
  const float *image = im->job.image;

  for (gsize k = 0; k < (gsize) n_coarse * im->n_column_blocks; k++)
    im->column_quartile[k] = NAN;
  /* range_floor: each range bin's quartile (range_floors_share ()), then
   * the gate. */
  for (guint i = 0; i < n_range; i++) {
    float top = 0.0f;
    for (int j = MAX ((int) i - reach, 0); j <= MIN ((int) i + reach,
            (int) n_range - 1); j++)
      top = MAX (top, im->range_top[j]);
    im->range_floor[i] = MAX (im->range_floor[i] * gain,
        top * im->sidelobe_ratio);
  }
  for (guint u = 0; u < n_coarse; u++) {
    const guint d = UNIT_DIRECTION (im, im->units[u]);
    const float *row = image + (gsize) d * n_range;
    const guint16 *best = im->best_hypothesis + (gsize) u *
        im->n_hypothesis_blocks;

    for (guint z = 0; z < im->n_zones; z++) {
      const FocusZone *zone = &im->zones[z];
      const gsize unit = UNIT (im, d, z);

      for (guint i = zone->first_range; i < zone->end_range; i++) {
        guint top;
        if (!(row[i] > im->range_floor[i] && coarse_peak (im, image, d, i)
                && row[i] > column_gate (im, image, u, d, i, gain)))
          continue;
        im->hot[unit] |= HOT_GATE;
        top = best[i / HYPOTHESIS_BLOCK];
        for (guint h = top > 0 ? top - 1u : 0u; h <= MIN (top + 1u,
                n_hyp - 1); h++)
          im->wanted[unit * n_hyp + h] = TRUE;
      }
    }
  }
}

/* Whether the block of HYPOTHESIS_BLOCK range bins holding bin @i holds
 * noise alone at the four coarse directions @corners. */
static gboolean
noise_block (const SonarImager * im, const guint corners[4], guint i)
{
  const guint b = i / HYPOTHESIS_BLOCK;

  for (guint k = 0; k < 4; k++)
    if (!im->noise_block[(gsize) im->coarse_unit[corners[k]] *
            im->n_hypothesis_blocks + b])
      return FALSE;
  return TRUE;
}

/* Before the fine pass, from the coarse pass's values: the pixels of the
 * UNIT_INTERPOLATED and UNIT_GATE_HYPOTHESES units, bilinear between the
 * direction's coarse corners (which the former do not image again: none
 * is hot in that zone); in the UNIT_SOME_HYPOTHESES units, the same where
 * the corners hold noise alone and 0 elsewhere (their fine envelope
 * written there), the coarse directions' own pixels included. */
static void
interpolate (SonarImager * im, float *image)
{
  const guint n_range = im->grid.n_range, n_az = im->grid.n_azimuth;
  guint corners[4];

  for (guint d = 0; d < im->n_directions; d++) {
    float *out = image + (gsize) d * n_range;
    const guint a = d % n_az, e = d / n_az;
    const float *p[4];
    float w[4], ta, te;

    coarse_corners (im, d, corners);
    if (corners[0] == d && corners[3] == d)
      continue;
    ta = corners[1] > corners[0] ? (float) (a - corners[0] % n_az) /
        (corners[1] - corners[0]) : 0.0f;
    te = corners[2] > corners[0] ? (float) (e - corners[0] / n_az) /
        ((corners[2] - corners[0]) / n_az) : 0.0f;
    w[0] = (1 - te) * (1 - ta);
    w[1] = (1 - te) * ta;
    w[2] = te * (1 - ta);
    w[3] = te * ta;
    for (guint k = 0; k < 4; k++)
      p[k] = image + (gsize) corners[k] * n_range;
    for (guint z = 0; z < im->n_zones; z++) {
      const FocusZone *zone = &im->zones[z];
      const guint imaging = im->imaging[UNIT (im, d, z)];
      if (imaging == UNIT_EVERY_HYPOTHESIS)
        continue;
      for (guint i = zone->first_range; i < zone->end_range; i++)
        out[i] = imaging == UNIT_SOME_HYPOTHESES && !noise_block (im,
            corners, i) ? 0.0f : w[0] * p[0][i] + w[1] * p[1][i] +
            w[2] * p[2][i] + w[3] * p[3][i];
    }
  }
  /* The coarse directions last: the others read their pixels above. */
  for (guint d = 0; d < im->n_directions; d++) {
    float *out = image + (gsize) d * n_range;
    coarse_corners (im, d, corners);
    if (corners[0] != d || corners[3] != d)
      continue;
    for (guint z = 0; z < im->n_zones; z++) {
      const FocusZone *zone = &im->zones[z];
      if (im->imaging[UNIT (im, d, z)] != UNIT_SOME_HYPOTHESES)
        continue;
      for (guint i = zone->first_range; i < zone->end_range; i++)
        if (!noise_block (im, corners, i))
          out[i] = 0.0f;
    }
  }
}

/* Whether the units with coarse corners @corners in zone @z image every
 * hypothesis: some corner wants each one. */
static gboolean
wants_every_hypothesis (const SonarImager * im, const guint corners[4],
    guint z)
{
  const guint n_hyp = im->job.n_hypotheses;
  const guint8 *wanted[4];

  for (guint k = 0; k < 4; k++)
    wanted[k] = im->wanted + UNIT (im, corners[k], z) * n_hyp;
  for (guint h = 0; h < n_hyp; h++)
    if (!wanted[0][h] && !wanted[1][h] && !wanted[2][h] && !wanted[3][h])
      return FALSE;
  return TRUE;
}

/* Coarse pass: the coarse directions over the whole range, focused as one
 * zone (at worst 0.8 dB off the zones' focus at 0.3 m, measured by
 * test-detection). Then every (direction, zone) is interpolated that the
 * fine pass does not image over every hypothesis. Fine pass: every
 * (direction, zone) with a hot coarse corner, the coarse directions
 * included, with the zone's own focus and its corners' wanted hypotheses.
 * Where those are some of them only, a pixel whose coarse corners hold
 * noise alone keeps the maximum of the fine image and the interpolated
 * (or coarse) one: noise imaged over a few hypotheses is the maximum of
 * fewer values than elsewhere, several dB lower, and a range bin whose
 * directions mix the two has a noise floor too low for the rest (in 3-D,
 * where a strong echo's units reach far beyond it, that let noise peaks
 * through wardcluster's floors). Near an echo the fine image stands
 * alone: there the interpolation would fill the main lobe's flanks and
 * shift the peaks wardcluster refines. */
static void
image_coarse_to_fine (SonarImager * im, float *image)
{
  const guint coarse_zone = im->n_zones;
  guint corners[4], n = 0, n_coarse;
  gboolean floors;

  for (guint d = 0; d < im->n_directions; d++) {
    coarse_corners (im, d, corners);
    if (corners[0] == d && corners[3] == d)
      im->units[n++] = UNIT (im, d, coarse_zone);
  }
  n_coarse = n;
  im->job.zone_peaks = im->zone_peaks;
  im->job.best_hypothesis = im->best_hypothesis;
  im->job.best_value = im->best_value;
  run_units (im, n_coarse);
  im->job.zone_peaks = NULL;
  im->job.best_hypothesis = NULL;
  im->job.best_value = NULL;
  mark_hot (im, n_coarse);
  /* The noise floors over the coarse directions, for the gate and for
   * the units imaged over some hypotheses (none with one hypothesis):
   * which blocks hold noise alone. Too few coarse directions for a
   * quartile: every block may hold an echo. */
  floors = n_coarse >= 4 && (im->refine_pfa > 0.0 ||
      im->job.n_hypotheses > 1);
  if (floors) {
    im->job.n_coarse = n_coarse;
    sonar_workers_run (im->workers, range_floors_share, im);
  } else {
    memset (im->noise_block, 0, (gsize) im->n_coarse *
        im->n_hypothesis_blocks);
  }
  if (floors && im->refine_pfa > 0.0)
    mark_hot_over_noise (im, n_coarse);

  n = 0;
  memset (im->imaging, UNIT_INTERPOLATED, (gsize) im->n_directions *
      (im->n_zones + 1));
  for (guint d = 0; d < im->n_directions; d++) {
    coarse_corners (im, d, corners);
    /* One zone is the coarse zone: its coarse directions are done. */
    if (im->n_zones == 1 && corners[0] == d && corners[3] == d)
      continue;
    for (guint z = 0; z < im->n_zones; z++) {
      const gsize unit = UNIT (im, d, z);
      const guint hot = im->hot[UNIT (im, corners[0], z)]
          | im->hot[UNIT (im, corners[1], z)]
          | im->hot[UNIT (im, corners[2], z)]
          | im->hot[UNIT (im, corners[3], z)];
      if (hot) {
        im->units[n++] = unit;
        im->imaging[unit] = wants_every_hypothesis (im, corners, z) ?
            UNIT_EVERY_HYPOTHESIS : hot & HOT_LEVEL ? UNIT_SOME_HYPOTHESES :
            UNIT_GATE_HYPOTHESES;
      }
    }
  }
  interpolate (im, image);
  im->job.wanted = im->wanted;
  im->job.imaging = im->imaging;
  run_units (im, n);
  im->job.wanted = NULL;
  im->job.imaging = NULL;
}

/* The images of every hypothesis: their maximum into @image (stride 0),
 * or hypothesis h into image + h * stride. The receive sum, the costly
 * half, is made once per direction and zone for all of them. */
static void
image_hypotheses (SonarImager * im, const SonarComplex * mic_spectra,
    guint n_hypotheses, const SonarHypothesis * hypotheses, int emitter,
    float *image, gsize stride)
{
  const guint n_bins = im->band.n_bins;
  const gsize n_data = (gsize) im->setup->geometry.n_microphones * n_bins;
  const gsize n_units = (gsize) im->n_directions * (im->n_zones + 1);
  /* 2 / N: the analytic signal of an inverse real FFT's positive half. */
  const float scale = 2.0f / im->band.fft_size;
  /* The envelope squares float sums of up to N J K products: far from
   * unity (a recording scaled by 1e-30, spikes of 1e30) they underflow or
   * overflow. Such data are imaged scaled by a power of two (exact), and
   * the envelope scaled back. */
  const int exponent = data_exponent (mic_spectra, n_data);

  sonar_kernel_split (im->mic_re, im->mic_im, mic_spectra, n_data);
  if (ABS (exponent) > 30) {
    const float factor = ldexpf (1.0f, -exponent);
    for (gsize i = 0; i < n_data; i++) {
      im->mic_re[i] *= factor;
      im->mic_im[i] *= factor;
    }
  }
  /* Grown when a call brings more hypotheses than any before: a stream's
   * calls bring the same number, so steady state allocates nothing. */
  if (n_hypotheses > im->hypothesis_capacity) {
    g_free (im->zone_peaks);
    g_free (im->wanted);
    im->zone_peaks = g_new (float, n_units * n_hypotheses);
    im->wanted = g_new (guint8, n_units * n_hypotheses);
    im->hypothesis_capacity = n_hypotheses;
  }
  im->job.n_hypotheses = n_hypotheses;
  im->job.hypotheses = hypotheses;
  im->job.emitter = emitter;
  im->job.image = image;
  im->job.stride = stride;
  im->job.scale = scale;
  im->n_imaged = 0;
  im->n_passes = 0;
  if (stride == 0 && im->coarse_azimuth * im->coarse_elevation > 1) {
    image_coarse_to_fine (im, image);
  } else {
    guint n = 0;
    for (guint d = 0; d < im->n_directions; d++)
      for (guint z = 0; z < im->n_zones; z++)
        im->units[n++] = UNIT (im, d, z);
    run_units (im, n);
  }
  /* The envelope scaled back, in C: ORC flushes denormal results, which
   * the envelope of a recording near 1e-40 is. */
  if (ABS (exponent) > 30) {
    const float factor = ldexpf (1.0f, exponent);
    const gsize size = sonar_image_grid_size (&im->grid);
    for (guint h = 0; h < (stride ? n_hypotheses : 1); h++)
      for (gsize i = 0; i < size; i++)
        image[h * stride + i] *= factor;
  }
}

void
sonar_imager_process (SonarImager * im, const SonarComplex * mic_spectra,
    guint n_hypotheses, const SonarHypothesis * hypotheses, int emitter,
    float *image)
{
  image_hypotheses (im, mic_spectra, n_hypotheses, hypotheses, emitter,
      image, 0);
}

void
sonar_imager_process_each (SonarImager * im,
    const SonarComplex * mic_spectra, guint n_hypotheses,
    const SonarHypothesis * hypotheses, int emitter, float *images,
    gsize stride)
{
  image_hypotheses (im, mic_spectra, n_hypotheses, hypotheses, emitter,
      images, stride);
}

gboolean
sonar_imager_set_refine (SonarImager * im, double refine_db,
    double refine_pfa, GError ** error)
{
  const char *problem = refine_problem (refine_db, refine_pfa);

  if (problem) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "imager: %s",
        problem);
    return FALSE;
  }
  im->refine_ratio = (float) pow (10.0, -refine_db / 20.0);
  im->refine_pfa = refine_pfa;
  return TRUE;
}

void
sonar_imager_last_work (const SonarImager * im, guint * units,
    guint * dense_units, guint * passes, guint * dense_passes)
{
  *units = im->n_imaged;
  *dense_units = im->n_directions * im->n_zones;
  *passes = im->n_passes;
  *dense_passes = *dense_units * im->job.n_hypotheses;
}
