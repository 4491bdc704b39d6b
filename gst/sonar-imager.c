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
/* coarse_pfa's default. */
#define DEFAULT_COARSE_PFA 1e-5
/* A coarse pixel that noise alone exceeds this rarely (over its range
 * bin's noise floor, as refine_pfa's gate at its default) marks its block
 * of HYPOTHESIS_BLOCK range bins as holding an echo: fixed, so that what
 * the image holds does not follow the gate's setting. */
#define ECHO_PFA DEFAULT_REFINE_PFA
/* Range bins gathered at a time for the noise floors over the coarse
 * directions: each direction's bins read in one run (one bin at a time
 * reads a cache line per value; sonar-cluster.c gathers so too). */
#define FLOOR_BLOCK 32

/* The sub-band coarse pass (coarse_band < 1): coarse directions whose
 * envelope of one hypothesis is also made over the whole band, to measure
 * the ratio of the two bands' noise levels (their lower quartiles over
 * the range); the map of sub-band to whole-band noise, tabulated against
 * (pixel / sigma)^2 up to MAP_SPAN in MAP_SIZE steps. */
#define CALIBRATION_DIRECTIONS 8
#define MAP_SIZE 2048
#define MAP_SPAN 64.0

#define MAX_DIRECTIONS 65536

#define UNIT(im, d, z) ((d) * ((im)->n_zones + 1) + (z))
/* Block @b (of HYPOTHESIS_BLOCK range bins) of coarse unit @u, in the
 * [coarse unit x block] arrays. */
#define COARSE_BLOCK(im, u, b) ((gsize) (u) * (im)->n_hypothesis_blocks + (b))

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
                                 * interpolation but where the corners'
                                 * echo is of those hypotheses */
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
  /* The zero-velocity transmit sum over the call's window of FFT bins
   * (sonar_scaled_transmit_table ()), which every hypothesis reads. */
  float *table_re, *table_im;
  SonarComplex *baseband;       /* M: the product, zero-padded */
  SonarComplex *lags;           /* M: its inverse transform (out of place:
                                 * FFTW's in-place transforms allocate on
                                 * every call) */
  float *envelope;              /* one hypothesis's, over the grid's ranges */
  float *block_top;             /* its peak per block of HYPOTHESIS_BLOCK */
  guint passes;                 /* unit x hypothesis passes of this call */
  /* The noise gate's range floors: [FLOOR_BLOCK x coarse direction]
   * gathered values, and one bin's scratch (2 x coarse directions); one
   * block of a coarse direction's column (column_quartile ()). */
  float *floor_values, *floor_scratch, *column_values;
  /* The largest magnitude of a part in the worker's share of the call's
   * data (split_share ()). */
  float data_peak;
  /* The sub-band coarse pass: its product and transform (sub_ifft_size),
   * one hypothesis's envelope and the maximum over them (sub_ifft_size +
   * 1: the last is the first again, the transform's period). */
  SonarComplex *sub_baseband, *sub_lags;
  float *sub_envelope, *sub_max;
  /* Its confirmation: the whole band's maximum over the confirmed
   * hypotheses (range bins), and per block of them its strongest. */
  float *confirm_max, *confirm_value;
  guint16 *confirm_hypothesis;
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
  /* Coarse pass on the sub-band: coarse hypotheses every hyp_step-th
   * (else 1); and which units of the call (cal_units[k], k < n_cal) keep
   * their envelope of hypothesis cal_hypothesis for the calibration. */
  gboolean sub;
  guint hyp_step;
  guint n_cal;
  guint cal_units[CALIBRATION_DIRECTIONS];
  guint cal_hypothesis;
  /* The hypotheses the noise floors' statistics assume (the coarse
   * image's, before and after the map). */
  guint floor_hypotheses;
  /* Coarse pass on the whole band after the sub-band's: per (unit of the
   * call x hypothesis), whether to image it (confirm_sub_image ()); the
   * image holds the mapped sub-band image, which it raises. */
  const guint8 *confirm;
  /* The window of FFT bins the hypotheses' transmit sums read
   * (sonar_scaled_transmit_window ()), and the emitters summed. */
  int window_first;
  guint window_n;
  guint first_emitter, end_emitter;
  /* mark_hot_over_noise (): the gate over the range floors, and whether
   * a pixel over it also marks its coarse neighbours. */
  float gate_gain;
  gboolean gate_neighbours;
  /* The call's data, while split_data () splits it. */
  const SonarComplex *mic_spectra;
} ImageJob;

struct _SonarImager
{
  SonarSetup *setup;
  SonarBand band;
  SonarSteering steering;
  SonarScaledTransmit *transmit;
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
  double coarse_pfa;            /* the sub-band's gate (coarse_band < 1) */
  double cluster_pfa;           /* wardcluster's default threshold's pfa */
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
   * not yet taken this call). */
  guint column_bins, n_column_blocks;
  float *column_quartile;
  float *range_weight;          /* [range bin] r^2, as wardcluster's */
  guint *units;                 /* [direction x zone]: the units to image */
  guint8 *hot;                  /* [direction x zone]: coarse, HOT_ bits */
  guint8 *imaging;              /* [direction x zone]: UnitImaging */
  guint n_imaged;               /* units imaged by the last call */
  guint n_passes;               /* unit x hypothesis passes of the last call */

  guint ifft_size;              /* M */
  guint first_lag;              /* IFFT sample of range bin 0 */
  fftwf_plan inverse;           /* made on scratch[0], run on every worker's */
  /* The sub-band coarse pass (coarse_band < 1 and a coarse grid): bins
   * [0, sub_bins) of the band, transforms of sub_ifft_size = M /
   * sub_ratio points (at least 1.5 times the bins: an envelope sampled
   * finely enough to interpolate), so that its lag l is lag sub_ratio l of the
   * whole band's; coarse hypotheses every sub_step-th. */
  gboolean sub;
  guint sub_bins, sub_ratio, sub_ifft_size, sub_step;
  guint sub_first_lag, sub_end_lag;     /* lags spanning the grid's ranges */
  fftwf_plan sub_inverse;
  float *sub_weight;            /* [sub lag] r^2 */
  /* The calibration: [CALIBRATION_DIRECTIONS x range bin] whole-band and
   * sub-band envelopes of one hypothesis; their quartiles' ratio. */
  float *cal_full, *cal_sub;
  float noise_ratio;
  /* The map: per range bin, 1 / sigma^2 of the sub-band's noise and the
   * whole band's sigma; per (x / sigma)^2 step, (y / sigma_full)^2 - (x /
   * sigma)^2, for the hypotheses map_hypotheses (and map_coarse). */
  float *map_inverse, *map_sigma;
  float map_table[MAP_SIZE + 1];
  float map_tail;
  guint map_hypotheses, map_coarse;
  guint8 *confirm;              /* [coarse unit x hypothesis] */
  gboolean level_echo;          /* the sub-band saw an echo */
  /* The call's data, split: microphones x K, scaled (split_data ()). */
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
  p->coarse_lobes = 0.0;
  p->refine_db = 20.0;
  p->refine_pfa = DEFAULT_REFINE_PFA;
  p->coarse_band = 1.0;
  p->coarse_pfa = DEFAULT_COARSE_PFA;
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

void
sonar_imager_params_fit_beam (SonarImagerParams * p)
{
  p->coarse_lobes = p->n_azimuth > 1 && p->n_elevation > 1 ? 2.0 : 1.0;
}

void
sonar_imager_params_set_grid (SonarImagerParams * p,
    const SonarImageGrid * g)
{
  p->azimuth_min = g->azimuth_first;
  p->azimuth_max = g->azimuth_first + (g->n_azimuth - 1) * g->azimuth_step;
  p->n_azimuth = g->n_azimuth;
  p->elevation_min = g->elevation_first;
  p->elevation_max = g->elevation_first +
      (g->n_elevation - 1) * g->elevation_step;
  p->n_elevation = g->n_elevation;
  /* Half a step inside the first lag and beyond the last, and the step a
   * hair longer: sonar_imager_new ()'s ceil and floor then land on the
   * grid's own lags and transform size, whatever the rounding. */
  p->range_min = g->range_first - 0.5 * g->range_step;
  p->range_max = g->range_first + (g->n_range - 0.5) * g->range_step;
  p->range_resolution = g->range_step * (1.0 + 1e-9);
}

static gboolean
axis_equal (guint n_a, double first_a, double step_a, guint n_b,
    double first_b, double step_b)
{
  const double tolerance = 1e-9 * MAX (fabs (step_a), 1e-6);

  return n_a == n_b && fabs (first_a - first_b) <= tolerance
      && fabs (step_a - step_b) <= tolerance;
}

gboolean
sonar_image_grid_equal (const SonarImageGrid * a, const SonarImageGrid * b)
{
  return axis_equal (a->n_azimuth, a->azimuth_first, a->azimuth_step,
      b->n_azimuth, b->azimuth_first, b->azimuth_step)
      && axis_equal (a->n_elevation, a->elevation_first, a->elevation_step,
      b->n_elevation, b->elevation_first, b->elevation_step)
      && axis_equal (a->n_range, a->range_first, a->range_step, b->n_range,
      b->range_first, b->range_step);
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

double
sonar_imager_focus_turns (const SonarSetup * setup, double range_min,
    double range_max)
{
  const SonarGeometry *g = &setup->geometry;
  double rho_mic = 0.0, rho_emitter = 0.0, path;

  for (guint j = 0; j < g->n_microphones; j++)
    rho_mic = MAX (rho_mic, hypot (g->microphones[j].x,
            g->microphones[j].y));
  for (guint n = 0; n < g->n_emitters; n++)
    rho_emitter = MAX (rho_emitter, hypot (g->emitters[n].x,
            g->emitters[n].y));
  /* The zone's ends lie half its 1 / r span from its focus. */
  path = 0.5 * (rho_mic * rho_mic + rho_emitter * rho_emitter) * 0.5 *
      (1.0 / range_min - 1.0 / range_max);
  return path * setup->band_high / setup->speed_of_sound;
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
  else if (p->n_azimuth > 1 && p->azimuth_min == p->azimuth_max)
    problem = "several azimuths need min < max (one azimuth: a count of 1)";
  else if (p->n_elevation > 1 && p->elevation_min == p->elevation_max)
    problem = "several elevations need min < max (one elevation: a count "
        "of 1)";
  else if (!(p->range_resolution > 0.0 && p->range_resolution <= 1.0))
    problem = "the range resolution must be in (0, 1] m";
  else if (p->focus_zones < 1 || p->focus_zones > SONAR_IMAGER_MAX_FOCUS_ZONES)
    problem = "focus zones must be 1 to 64";
  else if (!(p->coarse_spacing >= 0.0 && p->coarse_spacing <= 90.0))
    problem = "the coarse spacing must be 0 to 90 degrees";
  else if (!(p->coarse_lobes >= 0.0 && p->coarse_lobes <= 30.0))
    problem = "the coarse spacing must be 0 to 30 main lobes";
  else if (!(p->coarse_band > 0.0 && p->coarse_band <= 1.0))
    problem = "the coarse band must be in (0, 1]";
  else if (!(p->coarse_pfa > 0.0 && p->coarse_pfa < 1.0))
    problem = "the coarse band's pfa must be in (0, 1)";
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

/* The sub-band coarse pass's sizes (coarse_band < 1 on a coarse grid of
 * at least 4 directions, which the noise floors need): the band's first
 * round (coarse_band K) bins; a transform of M / ratio points, ratio the
 * largest divisor of M leaving at least 1.5 times those bins (an envelope
 * sampled finely enough to interpolate linearly: 4 for 481 of 3072, 768
 * points; 2 for 961, 1536 points); the coarse hypotheses every sub_step-th, sub_step
 * the band's top frequency over the sub-band's (a stretch mismatch turns
 * the phase of the highest frequencies fastest: 80 / 30 kHz, 3). */
/* Degrees of @p's coarse_lobes main lobes of the array's beam, the
 * narrowest along the grid's axes of more than one direction (90: a
 * grid of one direction, which has no coarse pass). */
static double
coarse_lobes_spacing (const SonarImager * im, const SonarImagerParams * p)
{
  /* Wider than any array's main lobe a grid is set for: the search for
   * the 6 dB point starts there. */
  const double widest = 30.0;
  double width = widest;

  if (p->n_azimuth > 1)
    width = MIN (width, sonar_scaled_transmit_lobe_width (im->transmit,
            FALSE, widest));
  if (p->n_elevation > 1)
    width = MIN (width, sonar_scaled_transmit_lobe_width (im->transmit,
            TRUE, widest));
  return MIN (p->coarse_lobes * width, 90.0);
}

static void
init_sub (SonarImager * im, double coarse_band)
{
  const SonarBand *band = &im->band;
  const guint m = im->ifft_size;
  const guint bins = (guint) CLAMP (round (coarse_band * band->n_bins), 1,
      band->n_bins);
  guint ratio = 1;

  im->sub = coarse_band < 1.0 && bins < band->n_bins && im->n_coarse >= 4
      && im->coarse_azimuth * im->coarse_elevation > 1;
  if (!im->sub)
    return;
  for (guint r = 2 * m / (3 * bins); r > 1; r--)
    if (m % r == 0) {
      ratio = r;
      break;
    }
  im->sub_bins = bins;
  im->sub_ratio = ratio;
  im->sub_ifft_size = m / ratio;
  im->sub_step = MAX (1u, (guint) round (sonar_band_frequency (band,
              band->n_bins - 1) / sonar_band_frequency (band, bins - 1)));
  im->sub_first_lag = im->first_lag / ratio;
  im->sub_end_lag = MIN ((im->first_lag + im->grid.n_range - 1) / ratio + 2,
      im->sub_ifft_size + 1);
  im->sub_weight = g_new (float, im->sub_ifft_size + 1);
  for (guint l = 0; l <= im->sub_ifft_size; l++) {
    const double r = (double) l * ratio * im->grid.range_step;
    im->sub_weight[l] = (float) (r * r);
  }
  im->cal_full = g_new (float, (gsize) CALIBRATION_DIRECTIONS *
      im->grid.n_range);
  im->cal_sub = g_new (float, (gsize) CALIBRATION_DIRECTIONS *
      im->grid.n_range);
  im->map_inverse = g_new (float, im->grid.n_range);
  im->map_sigma = g_new (float, im->grid.n_range);
}

SonarImager *
sonar_imager_new (SonarSetup * setup, const SonarBand * band,
    const SonarImagerParams * p, GError ** error)
{
  const double c = setup->speed_of_sound, fs = setup->sample_rate;
  const double range_max = sonar_imager_range_max (setup, p->range_max);
  SonarImager *im;
  SonarImageGrid *grid;
  double lag_range, period_range, spacing;
  guint min_ifft;

  if (p->range_max <= 0.0 && range_max <= 0.0) {
    /* The image ends where a whole echo still fits the window. */
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "imager: a ping "
        "of %u samples holds no whole echo of a %u-sample waveform beyond "
        "the array's own size: the image would be empty (a longer "
        "ping-length or a shorter waveform)", setup->ping_length,
        setup->waveform_length);
    return NULL;
  }
  if (!validate_params (p, range_max, error))
    return NULL;

  im = g_new0 (SonarImager, 1);
  im->setup = sonar_setup_ref (setup);
  im->band = *band;
  sonar_steering_init (&im->steering, setup, band);
  im->transmit = sonar_scaled_transmit_new (&im->steering, setup, band);
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
  spacing = p->coarse_lobes > 0.0 ? coarse_lobes_spacing (im, p) :
      p->coarse_spacing;
  im->coarse_azimuth = grid->azimuth_step > 0.0 ? (guint) CLAMP (round
      (spacing / grid->azimuth_step), 1, 64) : 1;
  im->coarse_elevation = grid->elevation_step > 0.0 ? (guint) CLAMP (round
      (spacing / grid->elevation_step), 1, 64) : 1;
  init_zones (im, p, range_max);
  im->refine_ratio = (float) pow (10.0, -p->refine_db / 20.0);
  im->refine_pfa = p->refine_pfa;
  im->coarse_pfa = p->coarse_pfa;
  {
    SonarClusterParams cluster;
    sonar_cluster_params_init_default (&cluster);
    im->sidelobe_ratio = (float) pow (10.0, cluster.sidelobe_db / 20.0);
    im->cluster_pfa = cluster.pfa;
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
  init_sub (im, p->coarse_band);
  for (guint w = 0; w < sonar_workers_count (im->workers); w++) {
    im->scratch[w].receive_re = fftwf_alloc_real (band->n_bins);
    im->scratch[w].receive_im = fftwf_alloc_real (band->n_bins);
    im->scratch[w].table_re = fftwf_alloc_real
        (sonar_scaled_transmit_max_window (im->transmit));
    im->scratch[w].table_im = fftwf_alloc_real
        (sonar_scaled_transmit_max_window (im->transmit));
    im->scratch[w].baseband = fftwf_alloc_complex (im->ifft_size);
    im->scratch[w].lags = fftwf_alloc_complex (im->ifft_size);
    /* The padding stays zero: products fill the band's bins only, and an
     * out-of-place complex transform preserves its input. */
    memset (im->scratch[w].baseband, 0, sizeof (SonarComplex) *
        im->ifft_size);
    im->scratch[w].envelope = g_new (float, grid->n_range);
    im->scratch[w].block_top = g_new (float, im->n_hypothesis_blocks);
    im->scratch[w].floor_values = g_new (float, (gsize) FLOOR_BLOCK *
        im->n_coarse);
    im->scratch[w].floor_scratch = g_new (float, 2 * (gsize) im->n_coarse);
    im->scratch[w].column_values = g_new (float, im->column_bins);
    if (im->sub) {
      im->scratch[w].sub_baseband = fftwf_alloc_complex (im->sub_ifft_size);
      im->scratch[w].sub_lags = fftwf_alloc_complex (im->sub_ifft_size);
      memset (im->scratch[w].sub_baseband, 0, sizeof (SonarComplex) *
          im->sub_ifft_size);
      im->scratch[w].sub_envelope = g_new (float, im->sub_ifft_size + 1);
      im->scratch[w].sub_max = g_new (float, im->sub_ifft_size + 1);
      im->scratch[w].confirm_max = g_new (float, grid->n_range);
      im->scratch[w].confirm_value = g_new (float, im->n_hypothesis_blocks);
      im->scratch[w].confirm_hypothesis = g_new (guint16,
          im->n_hypothesis_blocks);
    }
  }
  sonar_fftw_lock ();
  /* FFTW's allocator aligns every array alike: the plan runs on each
   * worker's arrays with fftwf_execute_dft. */
  im->inverse = fftwf_plan_dft_1d (im->ifft_size, im->scratch[0].baseband,
      im->scratch[0].lags, FFTW_BACKWARD, SONAR_FFTW_PLANNING);
  if (im->sub)
    im->sub_inverse = fftwf_plan_dft_1d (im->sub_ifft_size,
        im->scratch[0].sub_baseband, im->scratch[0].sub_lags, FFTW_BACKWARD,
        SONAR_FFTW_PLANNING);
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
  g_free (im->units);
  g_free (im->hot);
  g_free (im->imaging);
  if (im->inverse || im->sub_inverse) {
    sonar_fftw_lock ();
    if (im->inverse)
      fftwf_destroy_plan (im->inverse);
    if (im->sub_inverse)
      fftwf_destroy_plan (im->sub_inverse);
    sonar_fftw_unlock ();
  }
  g_free (im->sub_weight);
  g_free (im->cal_full);
  g_free (im->cal_sub);
  g_free (im->map_inverse);
  g_free (im->map_sigma);
  for (guint w = 0; w < SONAR_MAX_WORKERS; w++) {
    fftwf_free (im->scratch[w].receive_re);
    fftwf_free (im->scratch[w].receive_im);
    fftwf_free (im->scratch[w].table_re);
    fftwf_free (im->scratch[w].table_im);
    fftwf_free (im->scratch[w].baseband);
    fftwf_free (im->scratch[w].lags);
    g_free (im->scratch[w].envelope);
    g_free (im->scratch[w].floor_values);
    g_free (im->scratch[w].floor_scratch);
    g_free (im->scratch[w].column_values);
    fftwf_free (im->scratch[w].sub_baseband);
    fftwf_free (im->scratch[w].sub_lags);
    g_free (im->scratch[w].sub_envelope);
    g_free (im->scratch[w].sub_max);
    g_free (im->scratch[w].confirm_max);
    g_free (im->scratch[w].confirm_value);
    g_free (im->scratch[w].block_top);
    g_free (im->scratch[w].confirm_hypothesis);
  }
  sonar_workers_free (im->workers);
  sonar_scaled_transmit_free (im->transmit);
  g_free (im->mic_re);
  g_free (im->mic_im);
  g_free (im->zone_peaks);
  g_free (im->wanted);
  g_free (im->confirm);
  sonar_setup_unref (im->setup);
  g_free (im);
}

const SonarImageGrid *
sonar_imager_grid (const SonarImager * im)
{
  return &im->grid;
}

/* The grid's steps along the axes it spans (0 along one it does not). */
static void
grid_steps (const SonarImager * im, double *azimuth, double *elevation)
{
  *azimuth = im->grid.n_azimuth > 1 ? fabs (im->grid.azimuth_step) : 0.0;
  *elevation = im->grid.n_elevation > 1 ? fabs (im->grid.elevation_step) :
      0.0;
}

double
sonar_imager_sampling_loss (const SonarImager * im)
{
  double azimuth, elevation;

  grid_steps (im, &azimuth, &elevation);
  return sonar_scaled_transmit_sampling_loss (im->transmit, azimuth,
      elevation);
}

void
sonar_imager_coarse_spacing (const SonarImager * im, double *azimuth,
    double *elevation)
{
  const gboolean coarse = im->coarse_azimuth * im->coarse_elevation > 1;

  grid_steps (im, azimuth, elevation);
  *azimuth = coarse ? *azimuth * im->coarse_azimuth : 0.0;
  *elevation = coarse ? *elevation * im->coarse_elevation : 0.0;
}

double
sonar_imager_step_factor (const SonarImager * im, double loss_db)
{
  double azimuth, elevation;

  grid_steps (im, &azimuth, &elevation);
  return sonar_scaled_transmit_step_factor (im->transmit, azimuth,
      elevation, loss_db);
}

/* Worker @w's share of the call's data (job.mic_spectra, microphones x
 * K): its microphones split into mic_re, mic_im, and the largest
 * magnitude of their parts (infinite when one is NaN) into its
 * data_peak. */
static void
split_share (gpointer data, guint w, guint n_workers)
{
  SonarImager *im = data;
  const guint n_mics = im->setup->geometry.n_microphones;
  const gsize n_bins = im->band.n_bins;
  const gsize first = n_mics * w / n_workers * n_bins;
  const gsize end = n_mics * (w + 1) / n_workers * n_bins;
  const SonarComplex *x = im->job.mic_spectra;
  float peak = 0.0f;

  sonar_kernel_split (im->mic_re + first, im->mic_im + first, x + first,
      end - first);
  for (gsize i = first; i < end; i++) {
    if (isnan (im->mic_re[i]) || isnan (im->mic_im[i]))
      peak = INFINITY;
    else
      peak = MAX (peak, MAX (fabsf (im->mic_re[i]), fabsf (im->mic_im[i])));
  }
  im->scratch[w].data_peak = peak;
}

/* The call's data split (split_share ()), and the binary exponent of its
 * largest part (0 when all are zero or one is not finite): data /
 * 2^exponent is below 1. */
static int
split_data (SonarImager * im, const SonarComplex * mic_spectra)
{
  float peak = 0.0f;
  int exponent = 0;

  im->job.mic_spectra = mic_spectra;
  sonar_workers_run (im->workers, split_share, im);
  im->job.mic_spectra = NULL;
  for (guint w = 0; w < sonar_workers_count (im->workers); w++)
    peak = MAX (peak, im->scratch[w].data_peak);
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

/* Whether the units with coarse corners @corners image hypothesis @h in
 * zone @z: some corner wants it there (im->wanted). */
static inline gboolean
images_hypothesis (const SonarImager * im, const guint corners[4], guint z,
    guint h)
{
  const guint n_hyp = im->job.n_hypotheses;

  for (guint k = 0; k < 4; k++)
    if (im->wanted[UNIT (im, corners[k], z) * n_hyp + h])
      return TRUE;
  return FALSE;
}

/* The coarse hypothesis that stands for hypothesis @h when they are
 * every @step-th of @n: the middle of its run of @step. */
static inline guint
coarse_hypothesis (guint h, guint step, guint n)
{
  return MIN (h / step * step + (step - 1) / 2, n - 1);
}

/* @out[i], i < @n, the grid's range bins from lag @first_lag of the whole
 * band's transform, linear between the samples of @sub (every @ratio-th
 * lag of it). */
static void
sub_to_grid (float *out, const float *sub, guint first_lag, guint ratio,
    guint n)
{
  const float step = 1.0f / ratio;
  guint l = first_lag / ratio, t = first_lag % ratio;

  for (guint i = 0; i < n; i++) {
    out[i] = sub[l] + t * step * (sub[l + 1] - sub[l]);
    if (++t == ratio) {
      t = 0;
      l++;
    }
  }
}

/* Worker @scratch's transmit table for direction @d in @zone: once per
 * unit, for every hypothesis. */
static void
transmit_table (const SonarImager * im, Scratch * scratch,
    const FocusZone * zone, guint d)
{
  const ImageJob *job = &im->job;

  sonar_scaled_transmit_table (im->transmit, zone->emitter_legs + (gsize) d *
      im->setup->geometry.n_emitters, job->first_emitter, job->end_emitter,
      job->window_first, job->window_n, scratch->table_re,
      scratch->table_im);
}

/* Hypothesis @h's delay-and-sum spectrum, the receive sum in @scratch
 * (bins @first to @first + @n - 1 of the band) times its transmit sum
 * read from the table, into @out. */
static void
transmit_product (const SonarImager * im, const Scratch * scratch, guint h,
    guint first, guint n, SonarComplex * out)
{
  const ImageJob *job = &im->job;

  sonar_scaled_transmit_product (im->transmit, scratch->table_re,
      scratch->table_im, job->window_first, sonar_steering_stretch
      (&im->steering, job->hypotheses[h].velocity), scratch->receive_re,
      scratch->receive_im, first, n, out);
}

/* Coarse unit @u (direction @d, the coarse zone) on the sub-band: for
 * every coarse hypothesis its r^2-weighted peak per zone, and per block of
 * range bins which is strongest, at the sub-band's lags; their maximum
 * onto the grid's range bins, into the image. */
static void
image_sub_unit (SonarImager * im, guint w, guint u, guint d,
    const FocusZone * zone)
{
  const ImageJob *job = &im->job;
  Scratch *scratch = &im->scratch[w];
  const SonarGeometry *g = &im->setup->geometry;
  const SonarSplitSpectra mic_spectra = { im->mic_re, im->mic_im };
  const guint n_range = im->grid.n_range, n_hyp = job->n_hypotheses;
  const guint ratio = im->sub_ratio, step = job->hyp_step;
  const guint l0 = im->sub_first_lag, l1 = im->sub_end_lag;
  const gsize blocks = COARSE_BLOCK (im, u, 0);
  guint16 *best = job->best_hypothesis + blocks;
  float *best_value = job->best_value + blocks;
  float *env = scratch->sub_envelope;
  int cal = -1;

  for (guint k = 0; k < job->n_cal; k++)
    if (job->cal_units[k] == u)
      cal = (int) k;
  sonar_steering_receive_sum_part (&im->steering, &mic_spectra,
      zone->mic_legs + (gsize) d * g->n_microphones, 0, im->sub_bins,
      scratch->receive_re, scratch->receive_im);
  transmit_table (im, scratch, zone, d);
  for (guint h0 = 0; h0 < n_hyp; h0 += step) {
    const guint h = coarse_hypothesis (h0, step, n_hyp);

    transmit_product (im, scratch, h, 0, im->sub_bins,
        scratch->sub_baseband);
    fftwf_execute_dft (im->sub_inverse, scratch->sub_baseband,
        scratch->sub_lags);
    sonar_kernel_envelope (env, scratch->sub_lags, im->sub_ifft_size,
        job->scale, FALSE);
    env[im->sub_ifft_size] = env[0];
    for (guint z = 0; z < im->n_zones; z++) {
      const FocusZone *part = &im->zones[z];
      const guint a = (im->first_lag + part->first_range) / ratio;
      const guint b = MIN ((im->first_lag + part->end_range + ratio - 1) /
          ratio + 1, l1);
      job->zone_peaks[UNIT (im, d, z) * n_hyp + h] = b > a ?
          sonar_kernel_peak (env + a, im->sub_weight + a, b - a) : 0.0f;
    }
    if (h0 == 0)
      memcpy (scratch->sub_max + l0, env + l0, (l1 - l0) * sizeof (float));
    else
      sonar_kernel_max (scratch->sub_max + l0, env + l0, l1 - l0);
    for (guint i0 = 0, b = 0; i0 < n_range; i0 += HYPOTHESIS_BLOCK, b++) {
      const guint a = (im->first_lag + i0) / ratio;
      const guint e = MIN ((im->first_lag + MIN (i0 + HYPOTHESIS_BLOCK,
                  n_range) - 1) / ratio + 2, l1);
      const float top = sonar_kernel_peak (env + a, NULL, e - a);
      if (h0 == 0 || top > best_value[b]) {
        best_value[b] = top;
        best[b] = (guint16) h;
      }
    }
    if (cal >= 0 && h == job->cal_hypothesis)
      sub_to_grid (im->cal_sub + (gsize) cal * n_range, env, im->first_lag,
          ratio, n_range);
    scratch->passes++;
  }
  sub_to_grid (job->image + (gsize) d * n_range, scratch->sub_max,
      im->first_lag, ratio, n_range);
}

/* Coarse unit @u (direction @d, the coarse zone) again over the whole
 * band, its confirmed hypotheses alone (confirm_sub_image ()), over the
 * mapped sub-band image: their zone peaks; their maximum, and which is
 * strongest per block of range bins, where they beat the mapped image's
 * block (the sub-band's stay elsewhere); the image the maximum of the two
 * where the sub-band saw noise alone, else the whole band's alone where it
 * sees the echo at least as strong (the sub-band's echo is wider in range
 * and direction), else their maximum. */
static void
image_confirm_unit (SonarImager * im, guint w, guint u, guint d,
    const FocusZone * zone)
{
  const ImageJob *job = &im->job;
  Scratch *scratch = &im->scratch[w];
  const SonarGeometry *g = &im->setup->geometry;
  const SonarSplitSpectra mic_spectra = { im->mic_re, im->mic_im };
  const guint n_range = im->grid.n_range, n_hyp = job->n_hypotheses;
  const guint n_blocks = im->n_hypothesis_blocks;
  const guint8 *confirm = job->confirm + (gsize) u * n_hyp;
  const guint8 *noise = im->noise_block + (gsize) u * n_blocks;
  guint16 *best = job->best_hypothesis + (gsize) u * n_blocks;
  float *row = job->image + (gsize) d * n_range;
  float *top = scratch->confirm_value;
  guint16 *which = scratch->confirm_hypothesis;
  gboolean first = TRUE;

  if (!memchr (confirm, 1, n_hyp))
    return;
  sonar_steering_receive_sum (&im->steering, &mic_spectra,
      zone->mic_legs + (gsize) d * g->n_microphones, scratch->receive_re,
      scratch->receive_im);
  transmit_table (im, scratch, zone, d);
  for (guint h = 0; h < n_hyp; h++) {
    float *envelope = first ? scratch->confirm_max : scratch->envelope;

    if (!confirm[h])
      continue;
    transmit_product (im, scratch, h, 0, im->band.n_bins, scratch->baseband);
    fftwf_execute_dft (im->inverse, scratch->baseband, scratch->lags);
    sonar_kernel_envelope (envelope, scratch->lags + im->first_lag, n_range,
        job->scale, FALSE);
    for (guint z = 0; z < im->n_zones; z++) {
      const FocusZone *part = &im->zones[z];
      job->zone_peaks[UNIT (im, d, z) * n_hyp + h] = sonar_kernel_peak
          (envelope + part->first_range, im->range_weight +
          part->first_range, part->end_range - part->first_range);
    }
    if (!first)
      sonar_kernel_max (scratch->confirm_max, envelope, n_range);
    sonar_kernel_block_peaks (scratch->block_top, envelope, n_range,
        HYPOTHESIS_BLOCK);
    for (guint b = 0; b < n_blocks; b++) {
      if (first || scratch->block_top[b] > top[b]) {
        top[b] = scratch->block_top[b];
        which[b] = (guint16) h;
      }
    }
    first = FALSE;
    scratch->passes++;
  }
  /* The mapped image's block peaks, before the blocks are written. */
  sonar_kernel_block_peaks (scratch->block_top, row, n_range,
      HYPOTHESIS_BLOCK);
  for (guint i0 = 0, b = 0; i0 < n_range; i0 += HYPOTHESIS_BLOCK, b++) {
    const guint len = MIN (HYPOTHESIS_BLOCK, n_range - i0);
    const float mapped = scratch->block_top[b];
    if (top[b] >= mapped)
      best[b] = which[b];
    if (!noise[b] && top[b] >= mapped)
      memcpy (row + i0, scratch->confirm_max + i0, len * sizeof (float));
    else
      sonar_kernel_max (row + i0, scratch->confirm_max + i0, len);
  }
}

/* Worker @w's share of a call: units w, w + n, ... */
static void
image_units (gpointer data, guint w, guint n_workers)
{
  SonarImager *im = data;
  const ImageJob *job = &im->job;
  Scratch *scratch = &im->scratch[w];
  const SonarGeometry *g = &im->setup->geometry;
  const guint n_bins = im->band.n_bins, n_range = im->grid.n_range;
  const SonarSplitSpectra mic_spectra = { im->mic_re, im->mic_im };

  for (guint u = w; u < job->n_units; u += n_workers) {
    const guint d = UNIT_DIRECTION (im, job->units[u]);
    const FocusZone *zone = &im->zones[UNIT_ZONE (im, job->units[u])];
    const guint first = zone->first_range;
    const guint count = zone->end_range - zone->first_range;
    const double *mic_legs = zone->mic_legs + (gsize) d * g->n_microphones;
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
    if (job->sub) {
      image_sub_unit (im, w, u, d, zone);
      continue;
    }
    if (job->confirm) {
      image_confirm_unit (im, w, u, d, zone);
      continue;
    }
    if (job->wanted)
      coarse_corners (im, d, corners);
    /* Receive side and the transmit table: once per direction for every
     * hypothesis. */
    sonar_steering_receive_sum (&im->steering, &mic_spectra, mic_legs,
        scratch->receive_re, scratch->receive_im);
    transmit_table (im, scratch, zone, d);

    for (guint h = 0; h < n_hyp; h++) {
      const guint z = UNIT_ZONE (im, job->units[u]);
      const SonarComplex *lags;

      if (job->wanted && !images_hypothesis (im, corners, z, h))
        continue;
      transmit_product (im, scratch, h, 0, n_bins, scratch->baseband);
      fftwf_execute_dft (im->inverse, scratch->baseband, scratch->lags);
      lags = scratch->lags + im->first_lag + first;
      if (job->zone_peaks) {
        /* Coarse unit (the whole range): each zone's peak of this
         * hypothesis, then the maximum over the hypotheses and which. */
        const gsize blocks = COARSE_BLOCK (im, u, 0);
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
        sonar_kernel_block_peaks (scratch->block_top, scratch->envelope,
            count, HYPOTHESIS_BLOCK);
        for (guint b = 0; b * HYPOTHESIS_BLOCK < count; b++) {
          if (overwrite || scratch->block_top[b] > best_value[b]) {
            best_value[b] = scratch->block_top[b];
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
  const guint n_hyp = im->job.n_hypotheses, step = im->job.hyp_step;
  float top = 0.0f, level;

  /* On the sub-band the coarse hypotheses' peaks stand for their runs. */
  for (guint u = 0; u < n_coarse; u++) {
    const guint d = UNIT_DIRECTION (im, im->units[u]);
    for (guint z = 0; z < im->n_zones; z++)
      for (guint h = 0; h < n_hyp; h += step)
        top = MAX (top, im->zone_peaks[UNIT (im, d, z) * n_hyp +
                coarse_hypothesis (h, step, n_hyp)]);
  }
  level = top * im->refine_ratio;
  memset (im->hot, 0, (gsize) im->n_directions * (im->n_zones + 1));
  for (guint u = 0; u < n_coarse; u++) {
    const guint d = UNIT_DIRECTION (im, im->units[u]);
    for (guint z = 0; z < im->n_zones; z++) {
      const gsize unit = UNIT (im, d, z);
      for (guint h = 0; h < n_hyp; h++) {
        im->wanted[unit * n_hyp + h] = im->zone_peaks[unit * n_hyp +
            coarse_hypothesis (h, step, n_hyp)] >= level;
        im->hot[unit] |= im->wanted[unit * n_hyp + h] ? HOT_LEVEL : 0;
      }
    }
  }
}

/* The lower quartile of block @b of the column of coarse unit @u (its
 * direction @d). */
static float
column_quartile (SonarImager * im, Scratch * scratch, const float *image,
    guint u, guint d, guint b)
{
  float *q = &im->column_quartile[(gsize) u * im->n_column_blocks + b];

  if (isnan (*q)) {
    const guint n_range = im->grid.n_range;
    const guint i0 = b * im->column_bins;
    const guint n = MIN (i0 + im->column_bins, n_range) - i0;
    memcpy (scratch->column_values, image + (gsize) d * n_range + i0,
        n * sizeof (float));
    *q = sonar_select_kth (scratch->column_values, n, n / 4);
  }
  return *q;
}

/* wardcluster's floor along coarse direction @d at range bin @i, over
 * @gain: its block's and neighbours' largest quartile (sonar-cluster.c,
 * column_floor ()), a strong echo's cross-talk ridge along it. */
static float
column_gate (SonarImager * im, Scratch * scratch, const float *image,
    guint u, guint d, guint i, float gain)
{
  const guint b = i / im->column_bins;
  float q = column_quartile (im, scratch, image, u, d, b);

  if (b > 0)
    q = MAX (q, column_quartile (im, scratch, image, u, d, b - 1));
  if (b + 1 < im->n_column_blocks)
    q = MAX (q, column_quartile (im, scratch, image, u, d, b + 1));
  return (float) SONAR_CLUSTER_COLUMN_MARGIN * gain * q;
}

/* Coarse direction @d's coarse neighbours along azimuth and elevation,
 * into @neighbours: how many. Whether coarse direction @d's pixel at range
 * bin @i is at least theirs: a peak of the coarse image (a flank's unit
 * has a stronger neighbour, refined if it passes). */
static guint
coarse_neighbours (const SonarImager * im, guint d, guint neighbours[4])
{
  const guint n_az = im->grid.n_azimuth, n_el = im->grid.n_elevation;
  const guint a = d % n_az, e = d / n_az;
  guint lo, hi, n = 0;

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
  return n;
}

static gboolean
coarse_peak (const SonarImager * im, const float *image, guint d, guint i)
{
  const guint n_range = im->grid.n_range;
  const float v = image[(gsize) d * n_range + i];
  guint neighbours[4], n = coarse_neighbours (im, d, neighbours);

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
  Scratch *scratch = &im->scratch[w];
  const guint n_range = im->grid.n_range, n_coarse = im->job.n_coarse;
  const guint n_blocks = (n_range + FLOOR_BLOCK - 1) / FLOOR_BLOCK;
  const double k_eff = sonar_cluster_effective_hypotheses
      (im->job.floor_hypotheses);
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
        im->noise_block[COARSE_BLOCK (im, u, i / HYPOTHESIS_BLOCK)] = noise;
      }
    }
  }
}

/* Worker @w's share of the calibration of a sub-band coarse pass: the
 * whole band's envelope of hypothesis job.cal_hypothesis along the
 * calibration's coarse directions (the coarse zone's focus), into
 * cal_full. */
static void
calibrate_share (gpointer data, guint w, guint n_workers)
{
  SonarImager *im = data;
  const ImageJob *job = &im->job;
  Scratch *scratch = &im->scratch[w];
  const SonarGeometry *g = &im->setup->geometry;
  const SonarSplitSpectra mic_spectra = { im->mic_re, im->mic_im };
  const FocusZone *zone = &im->zones[im->n_zones];
  const guint n_range = im->grid.n_range;

  for (guint k = w; k < job->n_cal; k += n_workers) {
    const guint d = UNIT_DIRECTION (im, job->units[job->cal_units[k]]);
    sonar_steering_receive_sum (&im->steering, &mic_spectra,
        zone->mic_legs + (gsize) d * g->n_microphones, scratch->receive_re,
        scratch->receive_im);
    transmit_table (im, scratch, zone, d);
    transmit_product (im, scratch, job->cal_hypothesis, 0, im->band.n_bins,
        scratch->baseband);
    fftwf_execute_dft (im->inverse, scratch->baseband, scratch->lags);
    sonar_kernel_envelope (im->cal_full + (gsize) k * n_range,
        scratch->lags + im->first_lag, n_range, job->scale, FALSE);
    scratch->passes++;
  }
}

/* sqrt (-ln (1 - 4^(-1/K))): the lower quartile of the maximum of K
 * independent Rayleigh envelopes of sigma 1 (E |x|^2 = sigma^2). */
static double
rayleigh_max_quartile (double k)
{
  return sqrt (-log (-expm1 (log (0.25) / k)));
}

/* The map of a sub-band coarse image onto the whole band's noise: a noise
 * pixel x of the sub-band image is the maximum of K_s Rayleigh envelopes
 * of sigma_s, P (x < t) = (1 - exp (-t^2 / sigma_s^2))^K_s; the whole
 * band's, of K Rayleigh envelopes of sigma_f. y of the same probability,
 *
 *   y^2 / sigma_f^2 = -ln (1 - (1 - exp (-x^2 / sigma_s^2))^(K_s / K)),
 *
 * is a whole-band noise pixel: the noise floors, the noise gate and
 * wardcluster's tests meet the same quartile and tail everywhere, the
 * whole band's where the fine pass images and the map's elsewhere. An echo
 * far over the noise keeps its ratio to it (y^2 / sigma_f^2 = x^2 /
 * sigma_s^2 + ln (K / K_s)). sigma_s per range bin is its floor (the
 * censored lower quartile over the coarse directions) over the quartile of
 * the maximum; sigma_f / sigma_s, the two bands' noise ratio, is measured
 * on one hypothesis's envelopes along a few coarse directions (their lower
 * quartiles over the range: noise, whatever the band's noise spectrum and
 * the templates' weights). Tabulated: (y / sigma_f)^2 - (x / sigma_s)^2
 * against (x / sigma_s)^2, which tends to ln (K / K_s). */
static void
map_table (SonarImager * im, guint n_hyp, guint n_coarse_hyp)
{
  const double a = sonar_cluster_effective_hypotheses (n_coarse_hyp) /
      sonar_cluster_effective_hypotheses (n_hyp);

  if (im->map_hypotheses == n_hyp && im->map_coarse == n_coarse_hyp)
    return;
  for (guint k = 0; k <= MAP_SIZE; k++) {
    const double s = k * MAP_SPAN / MAP_SIZE;
    const double g = -log (-expm1 (a * log1p (-exp (-s))));
    im->map_table[k] = (float) (g - s);
  }
  im->map_tail = (float) -log (a);
  im->map_hypotheses = n_hyp;
  im->map_coarse = n_coarse_hyp;
}

/* Worker @w's share of the map: coarse directions w, w + n, ... of the
 * call's units, in place. */
static void
map_share (gpointer data, guint w, guint n_workers)
{
  SonarImager *im = data;
  const guint n_range = im->grid.n_range;
  const float to_index = (float) (MAP_SIZE / MAP_SPAN);

  for (guint u = w; u < im->job.n_coarse; u += n_workers) {
    float *row = im->job.image + (gsize) UNIT_DIRECTION (im,
        im->units[u]) * n_range;
    for (guint i = 0; i < n_range; i++) {
      const float inv = im->map_inverse[i];
      float s, extra;
      if (inv < 0.0f) {
        row[i] *= im->map_sigma[i];
        continue;
      }
      s = row[i] * row[i] * inv;
      if (s < (float) MAP_SPAN) {
        const float x = s * to_index;
        const guint k = (guint) x;
        extra = im->map_table[k] + (x - k) * (im->map_table[k + 1] -
            im->map_table[k]);
      } else {
        extra = im->map_tail;
      }
      row[i] = im->map_sigma[i] * sqrtf (MAX (s + extra, 0.0f));
    }
  }
}

/* The sub-band coarse image (im->units' first @n_coarse, the job's
 * image) mapped onto the whole band's noise (map_table ()): the
 * calibration, the floors of the sub-band image, the map. */
static void
map_sub_image (SonarImager * im, guint n_coarse)
{
  const guint n_range = im->grid.n_range, n_hyp = im->job.n_hypotheses;
  const guint n_coarse_hyp = (n_hyp + im->job.hyp_step - 1) /
      im->job.hyp_step;
  const gsize n_cal = (gsize) im->job.n_cal * n_range;
  const double quartile = rayleigh_max_quartile
      (sonar_cluster_effective_hypotheses (n_coarse_hyp));
  float full, sub;

  sonar_workers_run (im->workers, calibrate_share, im);
  full = sonar_select_kth (im->cal_full, n_cal, n_cal / 4);
  sub = sonar_select_kth (im->cal_sub, n_cal, n_cal / 4);
  /* White noise, should the envelopes be silent: the bins' ratio. */
  im->noise_ratio = full > 0.0f && sub > 0.0f && isfinite (full / sub) ?
      full / sub : (float) sqrt ((double) im->band.n_bins / im->sub_bins);
  im->job.floor_hypotheses = n_coarse_hyp;
  sonar_workers_run (im->workers, range_floors_share, im);
  map_table (im, n_hyp, n_coarse_hyp);
  for (guint i = 0; i < n_range; i++) {
    const double sigma = im->range_floor[i] / quartile;
    if (sigma > 0.0 && isfinite (1.0 / (sigma * sigma))) {
      im->map_inverse[i] = (float) (1.0 / (sigma * sigma));
      im->map_sigma[i] = (float) (im->noise_ratio * sigma);
    } else {
      im->map_inverse[i] = -1.0f;
      im->map_sigma[i] = im->noise_ratio;
    }
  }
  sonar_workers_run (im->workers, map_share, im);
  im->job.floor_hypotheses = n_hyp;
}

static void mark_hot (SonarImager * im, guint n_coarse);

/* On the mapped sub-band image (its floors in range_floor): a pixel
 * within refine_db of the strongest (both weighted by r^2, as mark_hot ()
 * weighs the zone peaks) confirms its block's strongest run of
 * hypotheses and the next either side where it also stands over its
 * range bin's floor by what noise exceeds with probability coarse_pfa:
 * the echoes, their sidelobes and their cross-talk within the level,
 * which a whole-band coarse pass refines for the level (and a pixel within
 * 10 dB of the maximum comes out as the dense image's), not the noise
 * that the r^2 weight lifts to it far out. */
static void
mark_level_over_noise (SonarImager * im, guint n_coarse)
{
  const guint n_range = im->grid.n_range, n_hyp = im->job.n_hypotheses;
  const guint step = im->job.hyp_step;
  /* A pixel near the strongest echo has its best hypothesis (over the
   * whole band) within a run either side of the sub-band's best, or the
   * next beyond: the sub-band's Doppler response is as wide as a run, and
   * near a strong echo its sidelobes' best hypothesis is not the whole
   * band's (tests/test-imaging.c, coarse-band). */
  const guint reach = step + 1;
  const double k_eff = sonar_cluster_effective_hypotheses (n_hyp);
  const float gain = (float) sonar_cluster_floor_gain (im->coarse_pfa,
      k_eff);
  const float echo = (float) sonar_cluster_floor_gain (im->cluster_pfa,
      k_eff);
  const float *image = im->job.image;
  float top = 0.0f, level;

  /* The strongest echo: over wardcluster's threshold (its range bin's
   * floor, its direction's along the range) and a peak among its coarse
   * neighbours. None: the level would be the noise's, and refine the noise
   * within it. */
  for (gsize k = 0; k < (gsize) n_coarse * im->n_column_blocks; k++)
    im->column_quartile[k] = NAN;
  for (guint u = 0; u < n_coarse; u++) {
    const guint d = UNIT_DIRECTION (im, im->units[u]);
    const float *row = image + (gsize) d * n_range;
    for (guint i = 0; i < n_range; i++)
      if (row[i] > echo * im->range_floor[i]
          && row[i] * im->range_weight[i] > top && coarse_peak (im, image,
              d, i) && row[i] > column_gate (im, &im->scratch[0], image, u, d, i,
              echo)) {
        top = row[i] * im->range_weight[i];
      }
  }
  im->level_echo = top > 0.0f;
  if (top == 0.0f)
    return;
  level = top * im->refine_ratio;
  for (guint u = 0; u < n_coarse; u++) {
    const guint d = UNIT_DIRECTION (im, im->units[u]);
    const float *row = image + (gsize) d * n_range;
    const guint16 *best = im->best_hypothesis + COARSE_BLOCK (im, u, 0);
    for (guint z = 0; z < im->n_zones; z++) {
      const FocusZone *zone = &im->zones[z];
      guint8 *wanted = im->wanted + UNIT (im, d, z) * n_hyp;
      for (guint i = zone->first_range; i < zone->end_range; i++) {
        guint r0;
        if (!(row[i] * im->range_weight[i] >= level
                && row[i] > gain * im->range_floor[i]))
          continue;
        r0 = best[i / HYPOTHESIS_BLOCK] / step * step;
        for (guint h = r0 >= reach ? r0 - reach : 0; h < MIN (r0 + step +
                reach, n_hyp); h++)
          wanted[h] = TRUE;
      }
    }
  }
}
static void mark_hot_over_noise (SonarImager * im, guint n_coarse,
    double pfa, gboolean neighbours);

/* After the sub-band coarse pass (coarse_band < 1): its image mapped onto
 * the whole band's noise (map_sub_image ()) and its floors; then what it
 * sees is confirmed, imaged again over the whole band on the coarse
 * directions, the hypotheses it found alone: pixels within refine_db of
 * the strongest echo and over the noise (mark_level_over_noise ()), and
 * pixels over the noise gate at coarse_pfa with their coarse neighbours
 * that stand over it too (mark_hot_over_noise ()); each confirms its
 * block's strongest run of hypotheses and the next either side (a run
 * either side for the level's), and the strongest coarse pixel its own.
 * The coarse image is then the maximum of the two where the sub-band saw
 * noise alone, the whole band's where it sees the echo (its main lobe is
 * narrower, its range sidelobes lower: image_confirm_unit ()), and the
 * mapped image where nothing was confirmed. The zone peaks are the whole
 * band's (0 for the hypotheses not imaged again), so that the refinement
 * that follows (its level, its hypotheses, its gate) is a whole-band
 * coarse pass's where the sub-band saw something. Where it saw no echo
 * (none over wardcluster's threshold), the level refines nothing: a level
 * under the noise's maximum refines the noise (image_coarse_to_fine ()). */
static void
confirm_sub_image (SonarImager * im, guint n_coarse)
{
  const guint n_hyp = im->job.n_hypotheses, step = im->job.hyp_step;
  guint top_unit = G_MAXUINT, top_hypothesis = 0;
  float top = 0.0f;

  map_sub_image (im, n_coarse);
  im->job.sub = FALSE;
  sonar_workers_run (im->workers, range_floors_share, im);
  memset (im->wanted, 0, (gsize) im->n_directions * (im->n_zones + 1) *
      n_hyp);
  mark_level_over_noise (im, n_coarse);
  mark_hot_over_noise (im, n_coarse, im->coarse_pfa, TRUE);
  /* The strongest zone peak (r^2 weighted), wherever it stands: what the
   * refine level is relative to. */
  for (guint u = 0; u < n_coarse; u++) {
    const guint d = UNIT_DIRECTION (im, im->units[u]);
    for (guint z = 0; z < im->n_zones; z++)
      for (guint h = 0; h < n_hyp; h += step) {
        const guint c = coarse_hypothesis (h, step, n_hyp);
        const float v = im->zone_peaks[UNIT (im, d, z) * n_hyp + c];
        if (v > top) {
          top = v;
          top_unit = u;
          top_hypothesis = c;
        }
      }
  }
  for (guint u = 0; u < n_coarse; u++) {
    const guint d = UNIT_DIRECTION (im, im->units[u]);
    guint8 *confirm = im->confirm + (gsize) u * n_hyp;
    memset (confirm, 0, n_hyp);
    if (u == top_unit) {
      /* Its run and the next either side, as the gate's. */
      const guint r0 = top_hypothesis / step * step;
      for (guint h = r0 > 0 ? r0 - 1 : 0; h <= MIN (r0 + step, n_hyp - 1);
          h++)
        confirm[h] = 1;
    }
    for (guint z = 0; z < im->n_zones; z++) {
      const guint8 *wanted = im->wanted + UNIT (im, d, z) * n_hyp;
      float *peaks = im->zone_peaks + UNIT (im, d, z) * n_hyp;
      for (guint h = 0; h < n_hyp; h++)
        confirm[h] |= wanted[h];
      memset (peaks, 0, n_hyp * sizeof (float));
    }
  }
  im->job.hyp_step = 1;
  im->job.confirm = im->confirm;
  run_units (im, n_coarse);
  im->job.confirm = NULL;
  /* The units imaged again: those with a hypothesis confirmed. */
  for (guint u = 0; u < n_coarse; u++)
    if (!memchr (im->confirm + (gsize) u * n_hyp, 1, n_hyp))
      im->n_imaged--;
}

/* Worker @w's share of mark_hot_over_noise (): every n_workers-th coarse
 * unit from @w (those near an echo test more pixels). A unit writes its
 * own hot bit, wanted hypotheses and column quartiles; with the
 * neighbours (job.gate_neighbours) it writes theirs too, and runs alone. */
static void
hot_over_noise_share (gpointer data, guint w, guint n_workers)
{
  SonarImager *im = data;
  Scratch *scratch = &im->scratch[w];
  const guint n_range = im->grid.n_range, n_hyp = im->job.n_hypotheses;
  const guint step = im->job.hyp_step;
  const float gain = im->job.gate_gain;
  const float *image = im->job.image;

  for (guint u = w; u < im->job.n_coarse; u += n_workers) {
    const guint d = UNIT_DIRECTION (im, im->units[u]);
    const float *row = image + (gsize) d * n_range;
    const guint16 *best = im->best_hypothesis + COARSE_BLOCK (im, u, 0);

    for (guint z = 0; z < im->n_zones; z++) {
      const FocusZone *zone = &im->zones[z];
      const gsize unit = UNIT (im, d, z);

      for (guint i = zone->first_range; i < zone->end_range; i++) {
        guint top;
        if (!(row[i] > im->range_floor[i] && coarse_peak (im, image, d, i)
                && row[i] > column_gate (im, scratch, image, u, d, i,
                    gain)))
          continue;
        im->hot[unit] |= HOT_GATE;
        /* The strongest (on the sub-band, its run of step hypotheses)
         * and the next either side. */
        top = best[i / HYPOTHESIS_BLOCK] / step * step;
        for (guint h = top > 0 ? top - 1u : 0u; h <= MIN (top + step,
                n_hyp - 1); h++)
          im->wanted[unit * n_hyp + h] = TRUE;
        if (im->job.gate_neighbours) {
          /* The flanks that see the echo over the gate too: the whole
           * band's coarse pass would have put them within the refine
           * level. */
          guint around[4], n = coarse_neighbours (im, d, around);
          for (guint k = 0; k < n; k++) {
            const gsize other = UNIT (im, around[k], z);
            if (!(image[(gsize) around[k] * n_range + i] >
                    im->range_floor[i]))
              continue;
            for (guint h = top > 0 ? top - 1u : 0u; h <= MIN (top + step,
                    n_hyp - 1); h++)
              im->wanted[other * n_hyp + h] = TRUE;
          }
        }
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
 * keep the interpolation wherever it is higher (UNIT_GATE_HYPOTHESES),
 * but not where the corners hold an echo whose strongest hypothesis
 * they image (echo_imaged ()): the interpolation there is that echo
 * imaged at the coarse pass's one focus for the whole range, whose
 * broader beam filled the flanks of a faint far echo and made a second
 * peak at a coarse direction 1.3 degrees from its own (reported twice:
 * tests/test_foreign.py, faint-mover). */
static void
mark_hot_over_noise (SonarImager * im, guint n_coarse, double pfa,
    gboolean neighbours)
{
  const SonarImageGrid *grid = &im->grid;
  const guint n_range = grid->n_range, n_hyp = im->job.n_hypotheses;
  const double k_eff = sonar_cluster_effective_hypotheses (n_hyp);
  const float gain = (float) sonar_cluster_floor_gain (pfa, k_eff);
  const int reach = (int) ceil (SONAR_CLUSTER_SIDELOBE_RANGE /
      grid->range_step);

  g_assert (n_coarse == im->job.n_coarse);
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
  im->job.gate_gain = gain;
  im->job.gate_neighbours = neighbours;
  if (neighbours)
    hot_over_noise_share (im, 0, 1);
  else
    sonar_workers_run (im->workers, hot_over_noise_share, im);
}

/* Whether the block of HYPOTHESIS_BLOCK range bins holding bin @i holds
 * noise alone at the four coarse directions @corners. */
static gboolean
noise_block (const SonarImager * im, const guint corners[4], guint i)
{
  const guint b = i / HYPOTHESIS_BLOCK;

  for (guint k = 0; k < 4; k++)
    if (!im->noise_block[COARSE_BLOCK (im, im->coarse_unit[corners[k]], b)])
      return FALSE;
  return TRUE;
}

/* Whether, in the block of range bin @i, the coarse corners @corners
 * that hold an echo (one at least) have their strongest hypothesis there
 * among those the units of zone @z between them image: their fine
 * envelope then holds that echo, at the zone's own focus. */
static gboolean
echo_imaged (const SonarImager * im, const guint corners[4], guint z,
    guint i)
{
  const guint b = i / HYPOTHESIS_BLOCK;
  gboolean echo = FALSE;

  for (guint k = 0; k < 4; k++) {
    const gsize block = COARSE_BLOCK (im, im->coarse_unit[corners[k]], b);
    const guint h = im->best_hypothesis[block];
    if (im->noise_block[block])
      continue;
    echo = TRUE;
    if (!images_hypothesis (im, corners, z, h))
      return FALSE;
  }
  return echo;
}

/* Whether a unit imaged @imaging (UnitImaging) with coarse corners
 * @corners in zone @z holds its own envelope alone at range bin @i, not
 * its maximum with the interpolation: some hypotheses, where a corner
 * holds an echo; the noise gate's, where the corners' echo is of them.
 * The same throughout a block of HYPOTHESIS_BLOCK range bins. */
static gboolean
envelope_alone (const SonarImager * im, guint imaging,
    const guint corners[4], guint z, guint i)
{
  return imaging == UNIT_SOME_HYPOTHESES ? !noise_block (im, corners, i) :
      imaging == UNIT_GATE_HYPOTHESES && echo_imaged (im, corners, z, i);
}

/* Before the fine pass, from the coarse pass's values: the pixels of the
 * UNIT_INTERPOLATED and UNIT_GATE_HYPOTHESES units, bilinear between the
 * direction's coarse corners (which the former do not image again: none
 * is hot in that zone); in the UNIT_SOME_HYPOTHESES units, the same where
 * the corners hold noise alone and 0 elsewhere (their fine envelope
 * written there), the coarse directions' own pixels included, and in the
 * UNIT_GATE_HYPOTHESES units 0 where the corners' echo is of the
 * hypotheses they image (echo_imaged ()). */
static void
interpolate_share (gpointer data, guint worker, guint n_workers)
{
  SonarImager *im = data;
  float *image = im->job.image;
  const guint n_range = im->grid.n_range, n_az = im->grid.n_azimuth;
  guint corners[4];

  for (guint d = worker; d < im->n_directions; d += n_workers) {
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
      gboolean alone = FALSE;
      if (imaging == UNIT_EVERY_HYPOTHESIS)
        continue;
      for (guint i = zone->first_range; i < zone->end_range; i++) {
        if (i == zone->first_range || i % HYPOTHESIS_BLOCK == 0)
          alone = envelope_alone (im, imaging, corners, z, i);
        out[i] = alone ? 0.0f : w[0] * p[0][i] + w[1] * p[1][i] +
            w[2] * p[2][i] + w[3] * p[3][i];
      }
    }
  }
}

static void
interpolate (SonarImager * im, float *image)
{
  const guint n_range = im->grid.n_range;
  guint corners[4];

  g_assert (image == im->job.image);
  sonar_workers_run (im->workers, interpolate_share, im);
  /* The coarse directions last: the others read their pixels above. */
  for (guint d = 0; d < im->n_directions; d++) {
    float *out = image + (gsize) d * n_range;
    coarse_corners (im, d, corners);
    if (corners[0] != d || corners[3] != d)
      continue;
    for (guint z = 0; z < im->n_zones; z++) {
      const FocusZone *zone = &im->zones[z];
      const guint imaging = im->imaging[UNIT (im, d, z)];
      if (imaging != UNIT_SOME_HYPOTHESES && imaging != UNIT_GATE_HYPOTHESES)
        continue;
      for (guint i = zone->first_range; i < zone->end_range; i++)
        if (envelope_alone (im, imaging, corners, z, i))
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
  for (guint h = 0; h < im->job.n_hypotheses; h++)
    if (!images_hypothesis (im, corners, z, h))
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
  im->job.n_coarse = n_coarse;
  im->job.floor_hypotheses = im->job.n_hypotheses;
  /* The sub-band: its coarse hypotheses, and a few coarse directions
   * (spread over them) to calibrate the map on, with the hypothesis
   * nearest the middle of the bank. */
  im->job.sub = im->sub && n_coarse >= 4;
  im->job.hyp_step = im->job.sub ? MIN (im->sub_step,
      im->job.n_hypotheses) : 1;
  im->job.n_cal = im->job.sub ? MIN (CALIBRATION_DIRECTIONS, n_coarse) : 0;
  for (guint k = 0; k < im->job.n_cal; k++)
    im->job.cal_units[k] = (guint) (((2 * k + 1) * (guint64) n_coarse) /
        (2 * im->job.n_cal));
  im->job.cal_hypothesis = coarse_hypothesis (im->job.n_hypotheses / 2,
      im->job.hyp_step, im->job.n_hypotheses);
  run_units (im, n_coarse);
  if (im->job.sub)
    confirm_sub_image (im, n_coarse);
  im->job.zone_peaks = NULL;
  im->job.best_hypothesis = NULL;
  im->job.best_value = NULL;
  /* On the sub-band, where it saw no echo, the noise gate alone. */
  if (im->sub && n_coarse >= 4 && !im->level_echo) {
    memset (im->hot, 0, (gsize) im->n_directions * (im->n_zones + 1));
    memset (im->wanted, 0, (gsize) im->n_directions * (im->n_zones + 1) *
        im->job.n_hypotheses);
  } else
    mark_hot (im, n_coarse);
  /* The noise floors over the coarse directions, for the gate and for
   * the units imaged over some hypotheses (none with one hypothesis):
   * which blocks hold noise alone. Too few coarse directions for a
   * quartile: every block may hold an echo. */
  floors = n_coarse >= 4 && (im->refine_pfa > 0.0 ||
      im->job.n_hypotheses > 1);
  if (floors) {
    sonar_workers_run (im->workers, range_floors_share, im);
  } else {
    memset (im->noise_block, 0, (gsize) im->n_coarse *
        im->n_hypothesis_blocks);
  }
  if (floors && im->refine_pfa > 0.0)
    mark_hot_over_noise (im, n_coarse, im->refine_pfa, FALSE);

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
  const int exponent = split_data (im, mic_spectra);

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
    g_free (im->confirm);
    im->zone_peaks = g_new (float, n_units * n_hypotheses);
    im->wanted = g_new (guint8, n_units * n_hypotheses);
    im->confirm = g_new (guint8, (gsize) im->n_coarse * n_hypotheses);
    im->hypothesis_capacity = n_hypotheses;
  }
  im->job.n_hypotheses = n_hypotheses;
  im->job.hypotheses = hypotheses;
  im->job.emitter = emitter;
  im->job.first_emitter = emitter < 0 ? 0 : (guint) emitter;
  im->job.end_emitter = emitter < 0 ? im->setup->geometry.n_emitters :
      (guint) emitter + 1;
  {
    double hi = 0.0;
    for (guint h = 0; h < n_hypotheses; h++)
      hi = MAX (hi, sonar_steering_stretch (&im->steering,
              hypotheses[h].velocity));
    sonar_scaled_transmit_window (im->transmit, hi, &im->job.window_first,
        &im->job.window_n);
    /* The bank's velocities, |v| < c / 4, fit the tables. */
    g_return_if_fail (im->job.window_n <=
        sonar_scaled_transmit_max_window (im->transmit));
  }
  im->job.image = image;
  im->job.stride = stride;
  im->job.scale = scale;
  im->job.hyp_step = 1;
  im->job.floor_hypotheses = n_hypotheses;
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
