/* sonar-velocity.c: see sonar-velocity.h. */
#include "sonar-velocity.h"
#include "sonar-error.h"
#include "sonar-fftw.h"
#include "sonar-kernels.h"
#include "sonar-linalg.h"
#include "sonar-steering.h"
#include "sonar-uncertainty.h"
#include "sonar-workers.h"

#include <fftw3.h>
#include <gio/gio.h>
#include <math.h>
#include <string.h>

/* Added to every Doppler-ACF value before its logarithm: silence gives a
 * flat curve, not -inf. Far below the smallest float amplitude (1.4e-45),
 * so that it flattens no curve of a faint echo. */
#define ACF_FLOOR 1e-300

/* Bins per block of the lag sums (sonar_steering_emitter_blocks ()). */
#define LAG_BLOCK 16

/* Main lobes between two reflectors' peaks, at least: two echoes a main
 * lobe apart in velocity (0.4 m/s) showed theirs 0.9-1.0 apart; a local
 * maximum nearer is a shoulder of the first's own lobe. */
#define SECOND_APART 0.75

/* A second reflector's peak stands this many interquartile ranges of the
 * Doppler-ACF product's floor above its median (sonar-bench --sweep
 * split). */
#define SECOND_FLOOR_SPREADS 4.0

/* Range steps of the window, at most. */
#define MAX_WINDOW_RANGES 256

/* Image direction steps between a centroid and its strongest member
 * peak from which on the centroid may be a blend of two echoes the image
 * resolves (estimate ()): the MIMO beam is about 2 degrees wide (-3 dB),
 * the default grid's step 1 degree. BLEND_SEARCH: steps either side of
 * the other members' mean searched for their echo's peak. */
#define BLEND_STEPS 2.0
#define BLEND_SEARCH 2

/* -3 dB in amplitude. */
#define AGREEMENT_RATIO 0.7071067811865476

/* Range gating (gate_focus ()): baseband samples kept either side of a
 * template for its band-limited tails. With the recentred blocks
 * (GATE_BLOCK), every estimate of tests/data/golden-*.jsonl stayed within
 * 1e-4 m/s of the whole ping's, and sonar-bench's errors the same. */
#define GATE_TAIL 24
/* Range steps either side of the centroid that a gate holds beyond the
 * window's lags and the longest template: a centroid whose members spread
 * further is evaluated on the whole ping's spectra. */
#define GATE_RANGES 8
/* Bins per block of the gated lag sums: the gate's bins are gate_m /
 * gate_size times wider than the ping's, so its blocks are shorter and
 * recentred (outputs_at ()) to keep the lag phase's turn over a block
 * within the ping's (0.06 rad). 8: the gate's spectra are in the block8
 * layout (sonar_steering_emitter_blocks8 ()). */
#define GATE_BLOCK 8

/* Phasor tables of the lag reads (lag_table ()), at most: a window reads
 * its lags at offsets of whole and quarter range steps from its blocks'
 * centre, the same few dozen for every emitter, velocity and centroid,
 * and a lag read's ramp costs more to set up (its sincos, reseeds) than
 * to sum. A power of two; filled to three quarters at most, beyond which
 * the rare offsets left are read without a table. */
#define LAG_TABLES 64

/* Lag reads summed together, at most (lag_reads ()). */
#define LAG_BATCH 16

/* The templates' spectra on the gate's bins, shared by a pool's
 * estimators: [velocity][emitter][gate_padded bins], split, divided by
 * gate_m, in the block8 layout (SONAR_BLOCK8_INDEX ()). */
typedef struct
{
  gint ref;
  float *re, *im;
} GateTemplates;

struct _SonarVelocityEstimator
{
  SonarDopplerBank *bank;
  SonarSetup *setup;
  SonarBand band;
  SonarSteering steering;
  SonarImageGrid grid;
  SonarVelocityParams params;
  guint n_velocities, n_emitters;
  double min_coherence;         /* the coherence test's threshold */
  double min_pooled_snr;        /* pooled-snr-db as a power ratio; 0: off */
  /* The prescreen's interference power per emitter, pooled over every
   * pixel and hypothesis it evaluated at the chosen direction. */
  double interference;
  /* The highest power the emitters share over that pooled interference
   * of estimate ()'s prescreens: pool_cancel ()'s gate. */
  double screen_snr;
  double main_lobe;             /* m/s: one emitter's Doppler resolution */
  /* The window pixel focused on (focus ()): its legs and receive sum. */
  double *mic_legs, *emitter_legs;
  float *receive_re, *receive_im;       /* n_bins, split */
  /* sonar_velocity_estimate ()'s spectra, split (microphones x n_bins). */
  float *spectra_re, *spectra_im;
  /* One emitter's matched filter output by blocks of LAG_BLOCK bins. */
  SonarComplex *blocks;
  /* The window's range lags, in range steps from the centroid's range:
   * its members' span and window_ranges either side (set per centroid). */
  int lag_first, lag_last;
  gboolean spread;              /* the members reach beyond window_ranges */
  double complex *lag_sums;     /* [lag - lag_first]: sums over the emitters */
  double *lag_powers;           /* [lag - lag_first] */
  /* window_peak ()'s reads at the window's lags, [lag - lag_first], and
   * the blocks' centre each was read at. */
  double *peak_values, *peak_centres;
  /* The offsets (m) and outputs of a run of lag reads (outputs_at ()):
   * the window's lags, or the fine lags about its best. */
  double *read_offsets;
  SonarComplex *read_outputs;
  double *acf;                  /* [emitter][velocity], linear */
  double *log_product;          /* [velocity] */
  /* [emitter][velocity]: log (acf + ACF_FLOOR), as of the last fill. */
  double *log_acf;
  double *scratch;              /* [velocity] */
  guint8 *wanted, *done;        /* [velocity]: to evaluate, evaluated */
  guint8 *changed;              /* [velocity]: acf or done since the last fill */
  guint coarse_stride;          /* bank steps between coarse evaluations */
  guint n_hypotheses;           /* the prescreen's Doppler hypotheses */
  guint *hypotheses;

  /* The point focused on (focus ()): its receive sum is reused while the
   * point and the window's lags stay. */
  gboolean focused;
  SonarVec3 focus_direction;
  double focus_range;
  int focus_first, focus_last;

  /* Range gating. A bank evaluation is a dot product over the band's
   * bins, as many as the whole ping's transform has: the ping is 4-5 times
   * longer than a template, so most of those bins resolve echoes far
   * from the one evaluated. The focused receive sum is taken to baseband
   * (an inverse transform of gate_m points), the gate_size samples around
   * the echo kept, and transformed again: gate_bins bins that hold the
   * same correlations at the window's lags (the templates fit in the gate
   * with their tails), about a quarter of the work per evaluation. */
  gboolean gated;               /* the current focus is gated */
  guint gate_m, gate_size, gate_bins;
  guint gate_padded;            /* SONAR_BLOCK8_PADDED (gate_bins) */
  double gate_per_metre;        /* baseband samples per metre of path */
  guint gate_template;          /* the longest template, baseband samples */
  double stretch_min, stretch_max;      /* of the bank's velocities */
  SonarSteering gate_steering;  /* on the gate's bins, gate_padded */
  GateTemplates *gate_templates;
  fftwf_complex *gate_band, *gate_baseband;     /* gate_m */
  fftwf_complex *gate_time, *gate_spectrum;     /* gate_size */
  fftwf_plan gate_inverse, gate_forward;
  /* The gated receive sum, gate_padded, in the block8 layout. */
  float *gate_re, *gate_im;
  /* The emitter, velocity index and range of est->blocks, and the lag
   * offset (m) they are centred at. */
  guint blocks_emitter, blocks_velocity;
  double blocks_range, blocks_centre;

  /* The lag reads' phasor tables (lag_table ()), hashed by offset: its
   * bits and the blocks' kind (LAG_WHOLE or LAG_GATED; 0: free), and
   * lag_stride floats each of re and im. */
  guint64 *lag_offsets;
  guint8 *lag_kinds;
  float *lag_re, *lag_im;
  guint lag_stride, n_lag_tables;

  /* The gated reads of the window's lags, planned once per window
   * (gate_plan ()): outputs_at ()'s runs of reads between centrings,
   * each read's lag from its blocks' centre and phasor table (lag_table
   * (), -1: none), so that an evaluation neither hashes its offsets nor
   * walks outputs_at ()'s tests. plan_runs[r] is the first window lag
   * (from lag_first) of run r, plan_runs[n_plan_runs] the end. */
  gboolean planned;
  int plan_first, plan_last;
  guint n_plan_runs;
  guint *plan_runs;             /* [n_plan_runs + 1] */
  double *plan_run_centres;     /* [run]: the blocks' new centre (m), NAN
                                 * for none */
  gint *plan_slots;             /* [lag - lag_first] */
  double *plan_lags;            /* [lag - lag_first], m from the centre */
  float gate_scale;             /* outputs_at ()'s factor on gated reads */
  /* window_peak ()'s fine reads on gated blocks centred at the best
   * window lag dr: the phasor table of quarter step q (0-8) from it,
   * [(dr + MAX_WINDOW_RANGES) * 9 + q], FINE_UNKNOWN until first read. */
  gint *fine_slots;

  /* The prescreen's gated blocks, kept for the bank's evaluations of the
   * same emitter and velocity on the same focus (window_peak ()): at the
   * detection hypotheses (est->hypotheses), which the coarse pass
   * evaluates again where they fall on its stride. Per hypothesis and
   * emitter: the focus they were made on (est->focus_generation; 0:
   * none), the blocks after the window's reads, their centre, and the
   * window's outputs and the centre each was read at. */
  guint focus_generation;
  gint *hyp_index;              /* [velocity]: its hypothesis, or -1 */
  guint *hyp_generation;        /* [hypothesis][emitter] */
  SonarComplex *hyp_blocks;     /* [hypothesis][emitter][n_gate_blocks] */
  double *hyp_blocks_centre;    /* [hypothesis][emitter] */
  SonarComplex *hyp_outputs;    /* [hypothesis][emitter][HYP_LAGS] */
  double *hyp_centres;          /* [hypothesis][emitter][HYP_LAGS] */
  guint n_gate_blocks;          /* gate_padded / GATE_BLOCK */
};

/* Window lags the kept prescreen blocks hold, at most (the default
 * window reads 3). */
#define HYP_LAGS 8

/* fine_slots' value for a table not looked up yet. */
#define FINE_UNKNOWN (-2)

/* The blocks a lag is read from: of the whole ping's bins, of the gate's. */
enum
{ LAG_WHOLE = 1, LAG_GATED = 2 };

void
sonar_velocity_params_init_default (SonarVelocityParams * p)
{
  /* Measured with sonar-bench on Fig. 10: wider windows (up to 2
   * directions x 4 range steps) give the same errors for up to 5x the
   * work. */
  p->window_directions = 0;
  p->window_ranges = 1;
  p->refine = TRUE;
  p->min_variance = 0.0;
  p->min_agreeing_emitters = 5;
  /* 1.3e-5: 0.80 over 8 emitters, the fixed threshold this replaced.
   * Measured with sonar-bench --sweep crowded and the tests: 3e-5 (0.77)
   * finds up to 1.5 times the objects of a crowd, 1e-3 (0.63) several
   * times more, but a ghost 5.5 m/s off at 65 degrees passes at 0.77 in
   * test_foreign.py's split pairs, and a strong echo's cross-talk ridge at
   * 0.73 in test-velocityest's near-far case (pfa=1e-6): those ridges are
   * as coherent as a crowd's echoes. */
  p->coherence_pfa = 1.3e-5;
  p->min_coherence = 0.0;
  /* Measured with sonar-bench --sweep crowded and the tests: a crowd's
   * real echoes 13 dB or more above their interference in the oracle's
   * image stand 14.5 dB or more above the pooled interference; the ghosts
   * the coherence factor keeps out (a near-far cross-talk ridge, the
   * split pairs' ghost, noise peaks on the foreign recordings) 12 dB at
   * most, but the cross-term of two echoes at one range 25 degrees apart
   * in --sweep reflectors' 20-object scene 14.2 dB: 14 let it through.
   * 16 leaves 1.8 dB over that ghost, for scenes and arrays not measured
   * here, and finds as many of the grids' detectable objects as 14.5 (5,
   * 7 and 10 in test-crowded; 7, 10, 13 and 3 against 7, 10, 14 and 5 in
   * --sweep crowded), fewer of the undetectable ones. */
  p->pooled_snr_db = 16.0;
  /* A lone echo's cross-talk floor lies 11-14 dB below its peak: a
   * second reflector can stand out of it no lower than this. */
  p->second_peak_db = 12.0;
  p->emitters = 0;
}

double
sonar_velocity_coherence_threshold (double pfa, guint n_emitters)
{
  /* Interference independent across the emitters (circular Gaussian):
   * the power of their sum over N is one exponential share of their total,
   * the coherence factor Beta(1, N - 1) distributed. 1 - pfa^(1/(N-1))
   * without cancellation. */
  if (n_emitters < 2 || pfa >= 1.0)
    return 0.0;
  return -expm1 (log (pfa) / (n_emitters - 1.0));
}

/* pooled-snr-db as a power ratio, 0 when off. */
static double
pooled_snr (const SonarVelocityParams * params)
{
  return params->pooled_snr_db > 0.0 ? pow (10.0, params->pooled_snr_db /
      10.0) : 0.0;
}

double
sonar_velocity_params_coherence_threshold (const SonarVelocityParams *
    params, guint n_emitters)
{
  return MAX (params->min_coherence,
      sonar_velocity_coherence_threshold (params->coherence_pfa, n_emitters));
}

static gboolean
params_valid (const SonarVelocityParams * params, GError ** error)
{
  if (params->window_directions > 32
      || params->window_ranges > MAX_WINDOW_RANGES
      || !(params->second_peak_db > 0.0) || !(params->min_variance >= 0.0)
      || !(params->min_coherence >= 0.0 && params->min_coherence <= 1.0)
      || !(params->pooled_snr_db >= 0.0 && params->pooled_snr_db <= 100.0)
      || !(params->coherence_pfa > 0.0 && params->coherence_pfa <= 1.0)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "velocity: window half-widths must be at most 32 directions and 256 "
        "range steps, second-peak-db positive, min-variance >= 0, "
        "min-coherence in [0, 1], coherence-pfa in (0, 1] and pooled-snr-db "
        "in [0, 100]");
    return FALSE;
  }
  return TRUE;
}

/* Sizes the gate for @est (GATE_RANGES about a centroid, the longest
 * template, its tails), plans its transforms and takes the templates'
 * spectra onto its bins, or shares @share's. Leaves est->gate_size 0 where
 * a gate would not be shorter than the ping. */
static void
gate_init (SonarVelocityEstimator * est, const SonarVelocityEstimator * share)
{
  const SonarBand *band = &est->band;
  const SonarGeometry *geometry = &est->setup->geometry;
  const guint nv = est->n_velocities, n_bins = band->n_bins;
  const double c = est->setup->speed_of_sound;
  double reach = 0.0, span;
  guint m, g;

  est->stretch_min = sonar_steering_stretch (&est->steering,
      sonar_doppler_bank_velocity (est->bank, 0));
  est->stretch_max = sonar_steering_stretch (&est->steering,
      sonar_doppler_bank_velocity (est->bank, nv - 1));
  m = sonar_fft_fast_size (n_bins + 1);
  est->gate_per_metre = band->sample_rate * m / (band->fft_size * c);
  est->gate_template = (guint) ceil (sonar_doppler_bank_max_length
      (est->bank) * (double) m / band->fft_size);
  for (guint n = 0; n < geometry->n_emitters; n++)
    reach = MAX (reach, sonar_vec3_norm (geometry->emitters[n]));
  /* Path metres: the lags two ways, the emitter legs stretched. */
  span = 4.0 * GATE_RANGES * est->grid.range_step + 2.0 * reach *
      MAX (est->stretch_max, 1.0);
  g = sonar_fft_fast_size (est->gate_template + 2 * GATE_TAIL + 2 +
      (guint) ceil (span * est->gate_per_metre));
  if (g >= m)
    return;
  est->gate_m = m;
  est->gate_size = g;
  est->gate_bins = MIN (g, (guint) ceil ((double) n_bins * g / m) + 1);
  /* The block8 layout's padding stays zero. The gate's steering takes it
   * in as bins (their products are zero): its blocks fill whole vectors,
   * and the lag reads sum them without a tail. */
  est->gate_padded = SONAR_BLOCK8_PADDED (est->gate_bins);
  est->gate_steering = est->steering;
  est->gate_steering.n_bins = est->gate_padded;
  est->gate_steering.dk = est->steering.dk * m / g;
  est->gate_re = g_new0 (float, est->gate_padded);
  est->gate_im = g_new0 (float, est->gate_padded);
  est->gate_band = fftwf_alloc_complex (m);
  est->gate_baseband = fftwf_alloc_complex (m);
  est->gate_time = fftwf_alloc_complex (g);
  est->gate_spectrum = fftwf_alloc_complex (g);
  sonar_fftw_lock ();
  est->gate_inverse = fftwf_plan_dft_1d (m, est->gate_band,
      est->gate_baseband, FFTW_BACKWARD, SONAR_FFTW_PLANNING);
  est->gate_forward = fftwf_plan_dft_1d (g, est->gate_time,
      est->gate_spectrum, FFTW_FORWARD, SONAR_FFTW_PLANNING);
  sonar_fftw_unlock ();
  /* Beyond the band the baseband stays zero: out-of-place transforms
   * preserve their input. */
  memset (est->gate_band, 0, sizeof (fftwf_complex) * m);

  if (share) {
    est->gate_templates = share->gate_templates;
    g_atomic_int_inc (&est->gate_templates->ref);
    return;
  }
  est->gate_templates = g_new0 (GateTemplates, 1);
  est->gate_templates->ref = 1;
  est->gate_templates->re = g_new0 (float, (gsize) nv * est->n_emitters *
      est->gate_padded);
  est->gate_templates->im = g_new0 (float, (gsize) nv * est->n_emitters *
      est->gate_padded);
  for (guint v = 0; v < nv; v++) {
    const SonarSplitSpectra spectra = sonar_doppler_bank_spectra (est->bank,
        v);
    for (guint n = 0; n < est->n_emitters; n++) {
      const gsize at = ((gsize) v * est->n_emitters + n) * est->gate_padded;
      for (guint k = 0; k < n_bins; k++) {
        est->gate_band[k] = spectra.re[(gsize) n * n_bins + k] +
            I * spectra.im[(gsize) n * n_bins + k];
      }
      fftwf_execute (est->gate_inverse);
      /* The template starts at lag 0; its tails before it wrap round. */
      for (int j = -GATE_TAIL; j < (int) g - GATE_TAIL; j++) {
        const guint from = (guint) ((j + (int) m) % (int) m);
        const guint to = (guint) ((j + (int) g) % (int) g);
        est->gate_time[to] = est->gate_baseband[from];
      }
      fftwf_execute (est->gate_forward);
      for (guint q = 0; q < est->gate_bins; q++) {
        const gsize i = at + SONAR_BLOCK8_INDEX (q);
        est->gate_templates->re[i] = crealf (est->gate_spectrum[q]) / m;
        est->gate_templates->im[i] = cimagf (est->gate_spectrum[q]) / m;
      }
    }
  }
  memset (est->gate_band, 0, sizeof (fftwf_complex) * m);
}

static SonarVelocityEstimator *
estimator_new (SonarDopplerBank * bank, const SonarImageGrid * grid,
    const SonarVelocityParams * params, const SonarVelocityEstimator * share,
    GError ** error)
{
  const SonarBand *band = sonar_doppler_bank_band (bank);
  SonarVelocityEstimator *est;
  SonarSetup *setup;

  if (!band) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "velocity: the Doppler bank has no band spectra");
    return NULL;
  }
  if (!params_valid (params, error))
    return NULL;
  setup = sonar_doppler_bank_get_setup (bank);
  if (params->emitters > setup->geometry.n_emitters) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "velocity: emitters is %u, the set-up has only %u", params->emitters,
        setup->geometry.n_emitters);
    return NULL;
  }
  est = g_new0 (SonarVelocityEstimator, 1);
  est->bank = sonar_doppler_bank_ref (bank);
  est->setup = setup;
  est->band = *band;
  est->grid = *grid;
  est->params = *params;
  est->n_velocities = sonar_doppler_bank_n_velocities (bank);
  est->n_emitters = params->emitters ? params->emitters :
      setup->geometry.n_emitters;
  est->min_coherence = sonar_velocity_params_coherence_threshold (params,
      est->n_emitters);
  est->min_pooled_snr = pooled_snr (params);
  /* c / (2 f0 T): the Doppler resolution of one emission (physics notes). */
  est->main_lobe = setup->speed_of_sound / (2.0 * 0.5 * (setup->band_low +
          setup->band_high) * setup->waveform_length / setup->sample_rate);
  sonar_steering_init (&est->steering, setup, band);
  est->mic_legs = g_new (double, setup->geometry.n_microphones);
  est->emitter_legs = g_new (double, setup->geometry.n_emitters);
  est->receive_re = g_new (float, band->n_bins);
  est->receive_im = g_new (float, band->n_bins);
  est->spectra_re = g_new (float, (gsize) band->n_bins *
      setup->geometry.n_microphones);
  est->spectra_im = g_new (float, (gsize) band->n_bins *
      setup->geometry.n_microphones);
  est->lag_sums = g_new (double complex, 2 * MAX_WINDOW_RANGES + 1);
  est->lag_powers = g_new (double, 2 * MAX_WINDOW_RANGES + 1);
  est->peak_values = g_new (double, 2 * MAX_WINDOW_RANGES + 1);
  est->peak_centres = g_new (double, 2 * MAX_WINDOW_RANGES + 1);
  est->read_offsets = g_new (double, 2 * MAX_WINDOW_RANGES + 1);
  est->read_outputs = g_new (SonarComplex, 2 * MAX_WINDOW_RANGES + 1);
  est->acf = g_new (double, (gsize) est->n_emitters * est->n_velocities);
  est->log_product = g_new (double, est->n_velocities);
  est->log_acf = g_new (double, (gsize) est->n_emitters * est->n_velocities);
  est->scratch = g_new (double, est->n_velocities);
  est->wanted = g_new (guint8, est->n_velocities);
  est->done = g_new (guint8, est->n_velocities);
  est->changed = g_new (guint8, est->n_velocities);
  /* The curves are a main lobe wide: sampled every half of it (a quarter
   * measured the same errors in sonar-bench for twice the work), their
   * peak is found, then the bank is evaluated in full around it only. */
  est->coarse_stride = MAX (1, (guint) round (0.5 * est->main_lobe /
          sonar_doppler_bank_step (bank)));
  est->hypotheses = g_new (guint, est->n_velocities + 2);
  /* The prescreen's Doppler hypotheses: within a main lobe, the emitters
   * still in phase (sonar_setup_hypothesis_spacing ()), as the detection
   * image's. */
  est->n_hypotheses = sonar_doppler_bank_hypotheses (bank,
      sonar_setup_hypothesis_spacing (setup), est->hypotheses);
  gate_init (est, share);
  est->blocks = g_new (SonarComplex, MAX ((band->n_bins + LAG_BLOCK - 1) /
          LAG_BLOCK, est->gate_padded / GATE_BLOCK));
  est->lag_stride = sonar_steering_n_blocks (&est->steering, LAG_BLOCK);
  if (est->gate_size)
    est->lag_stride = MAX (est->lag_stride,
        sonar_steering_n_blocks (&est->gate_steering, GATE_BLOCK));
  est->lag_offsets = g_new0 (guint64, LAG_TABLES);
  est->lag_kinds = g_new0 (guint8, LAG_TABLES);
  est->lag_re = g_new (float, (gsize) LAG_TABLES * est->lag_stride);
  est->lag_im = g_new (float, (gsize) LAG_TABLES * est->lag_stride);
  est->plan_runs = g_new (guint, 2 * MAX_WINDOW_RANGES + 2);
  est->plan_run_centres = g_new (double, 2 * MAX_WINDOW_RANGES + 1);
  est->plan_slots = g_new (gint, 2 * MAX_WINDOW_RANGES + 1);
  est->plan_lags = g_new (double, 2 * MAX_WINDOW_RANGES + 1);
  est->fine_slots = g_new (gint, (2 * MAX_WINDOW_RANGES + 1) * 9);
  for (guint i = 0; i < (2 * MAX_WINDOW_RANGES + 1) * 9; i++)
    est->fine_slots[i] = FINE_UNKNOWN;
  if (est->gate_size) {
    const gsize entries = (gsize) est->n_hypotheses * est->n_emitters;
    est->gate_scale = 2.0f / ((float) est->band.fft_size * est->gate_size);
    est->n_gate_blocks = est->gate_padded / GATE_BLOCK;
    est->hyp_index = g_new (gint, est->n_velocities);
    for (guint v = 0; v < est->n_velocities; v++)
      est->hyp_index[v] = -1;
    for (guint i = 0; i < est->n_hypotheses; i++)
      est->hyp_index[est->hypotheses[i]] = i;
    est->hyp_generation = g_new0 (guint, entries);
    est->hyp_blocks = g_new (SonarComplex, entries * est->n_gate_blocks);
    est->hyp_blocks_centre = g_new (double, entries);
    est->hyp_outputs = g_new (SonarComplex, entries * HYP_LAGS);
    est->hyp_centres = g_new (double, entries * HYP_LAGS);
  }
  return est;
}

SonarVelocityEstimator *
sonar_velocity_estimator_new (SonarDopplerBank * bank,
    const SonarImageGrid * grid, const SonarVelocityParams * params,
    GError ** error)
{
  return estimator_new (bank, grid, params, NULL, error);
}

void
sonar_velocity_estimator_free (SonarVelocityEstimator * est)
{
  if (!est)
    return;
  sonar_doppler_bank_unref (est->bank);
  g_free (est->mic_legs);
  g_free (est->emitter_legs);
  g_free (est->receive_re);
  g_free (est->receive_im);
  g_free (est->spectra_re);
  g_free (est->spectra_im);
  g_free (est->blocks);
  g_free (est->lag_sums);
  g_free (est->lag_powers);
  g_free (est->peak_values);
  g_free (est->peak_centres);
  g_free (est->read_offsets);
  g_free (est->read_outputs);
  g_free (est->acf);
  g_free (est->log_product);
  g_free (est->log_acf);
  g_free (est->scratch);
  g_free (est->wanted);
  g_free (est->done);
  g_free (est->changed);
  g_free (est->hypotheses);
  g_free (est->lag_offsets);
  g_free (est->lag_kinds);
  g_free (est->lag_re);
  g_free (est->lag_im);
  g_free (est->plan_runs);
  g_free (est->plan_run_centres);
  g_free (est->plan_slots);
  g_free (est->plan_lags);
  g_free (est->fine_slots);
  g_free (est->hyp_index);
  g_free (est->hyp_generation);
  g_free (est->hyp_blocks);
  g_free (est->hyp_blocks_centre);
  g_free (est->hyp_outputs);
  g_free (est->hyp_centres);
  if (est->gate_templates && g_atomic_int_dec_and_test
      (&est->gate_templates->ref)) {
    g_free (est->gate_templates->re);
    g_free (est->gate_templates->im);
    g_free (est->gate_templates);
  }
  if (est->gate_inverse || est->gate_forward) {
    sonar_fftw_lock ();
    if (est->gate_inverse)
      fftwf_destroy_plan (est->gate_inverse);
    if (est->gate_forward)
      fftwf_destroy_plan (est->gate_forward);
    sonar_fftw_unlock ();
  }
  fftwf_free (est->gate_band);
  fftwf_free (est->gate_baseband);
  fftwf_free (est->gate_time);
  fftwf_free (est->gate_spectrum);
  g_free (est->gate_re);
  g_free (est->gate_im);
  g_free (est);
}

/* Gates the receive sum focused at @range (est->gated: whether the
 * window's lags, the longest template and its tails fit in the gate).
 * Its baseband samples t of the gate go to t mod gate_size: their
 * transform is then the one of the whole ping's time axis, and the
 * steering's phases hold on the gate's bins unchanged. */
static void
gate_focus (SonarVelocityEstimator * est, double range)
{
  const double step = est->grid.range_step;
  const gint64 m = est->gate_m, g = est->gate_size;
  double leg_lo = 0.0, leg_hi = 0.0;
  gint64 first, end;

  est->gated = FALSE;
  if (!est->gate_size)
    return;
  for (guint n = 0; n < est->n_emitters; n++) {
    const double a = est->emitter_legs[n] * est->stretch_min;
    const double b = est->emitter_legs[n] * est->stretch_max;
    leg_lo = n ? MIN (leg_lo, MIN (a, b)) : MIN (a, b);
    leg_hi = n ? MAX (leg_hi, MAX (a, b)) : MAX (a, b);
  }
  /* window_peak () looks a range step beyond the window's lags. */
  first = (gint64) floor ((2.0 * (range + (est->lag_first - 1) * step) +
          leg_lo) * est->gate_per_metre) - GATE_TAIL;
  end = (gint64) ceil ((2.0 * (range + (est->lag_last + 1) * step) +
          leg_hi) * est->gate_per_metre) + est->gate_template + GATE_TAIL + 1;
  if (end - first > g)
    return;
  {
    /* Per evaluation: the gated blocks made once per 3 of the window's
     * lags and once more around the best, against one pass over the band;
     * the lags read (the window's and 8 fine) on blocks half as many. */
    const double lags = est->lag_last - est->lag_first + 1;
    const double gated = (ceil (lags / 3.0) + 1.0) * est->gate_bins +
        (lags + 8.0) * est->gate_bins / GATE_BLOCK;
    const double whole = est->band.n_bins + (lags + 8.0) * est->band.n_bins /
        LAG_BLOCK;
    if (gated >= whole)
      return;
  }
  first -= (g - (end - first)) / 2;
  for (guint k = 0; k < est->band.n_bins; k++) {
    est->gate_band[k] = est->receive_re[k] + I * est->receive_im[k];
  }
  fftwf_execute (est->gate_inverse);
  {
    /* t mod m and t mod g stepped, not divided: four divisions a sample
     * were most of a focus's own time. */
    gint64 from = ((first % m) + m) % m, to = ((first % g) + g) % g;
    for (gint64 i = 0; i < g; i++) {
      est->gate_time[to] = est->gate_baseband[from];
      if (++from == m)
        from = 0;
      if (++to == g)
        to = 0;
    }
  }
  fftwf_execute (est->gate_forward);
  for (guint q = 0; q < est->gate_bins; q++) {
    est->gate_re[SONAR_BLOCK8_INDEX (q)] = crealf (est->gate_spectrum[q]);
    est->gate_im[SONAR_BLOCK8_INDEX (q)] = cimagf (est->gate_spectrum[q]);
  }
  est->gated = TRUE;
}

/* Focuses on the point @range m along @direction: its legs and the
 * receive sum of @spectra there (gated if it can be), for
 * emitter_blocks (). The last focus holds while the point and the
 * window's lags stay (estimate () clears it for new spectra). */
static void
focus (SonarVelocityEstimator * est, const SonarSplitSpectra * spectra,
    SonarVec3 direction, double range)
{
  if (est->focused && est->focus_range == range
      && est->focus_direction.x == direction.x
      && est->focus_direction.y == direction.y
      && est->focus_direction.z == direction.z
      && est->focus_first == est->lag_first
      && est->focus_last == est->lag_last)
    return;
  sonar_steering_legs (&est->steering, direction, range, est->mic_legs,
      est->emitter_legs);
  sonar_steering_receive_sum (&est->steering, spectra, est->mic_legs,
      est->receive_re, est->receive_im);
  gate_focus (est, range);
  /* The prescreen's kept blocks were made on another focus. */
  if (++est->focus_generation == 0) {
    est->focus_generation = 1;
    if (est->hyp_generation)
      memset (est->hyp_generation, 0, sizeof (guint) * est->n_hypotheses *
          est->n_emitters);
  }
  est->focused = TRUE;
  est->focus_direction = direction;
  est->focus_range = range;
  est->focus_first = est->lag_first;
  est->focus_last = est->lag_last;
}

/* The direction (@da, @de) image grid steps off (@azimuth, @elevation),
 * held within +-90 degrees: a pixel of the window. */
static SonarVec3
window_direction (const SonarVelocityEstimator * est, double azimuth,
    double elevation, int da, int de)
{
  const SonarImageGrid *grid = &est->grid;

  return sonar_vec3_from_direction (CLAMP (azimuth + da * grid->azimuth_step,
          -90, 90), CLAMP (elevation + de * grid->elevation_step, -90, 90));
}

/* The gated blocks of est->blocks_emitter and _velocity centred at the
 * lag @centre m beyond est->blocks_range. */
static void
gated_blocks (SonarVelocityEstimator * est, double centre)
{
  const guint v = est->blocks_velocity, n = est->blocks_emitter;
  const gsize at = (gsize) v * est->n_emitters * est->gate_padded;
  const SonarSplitSpectra templates = { est->gate_templates->re + at,
    est->gate_templates->im + at
  };

  sonar_steering_emitter_blocks8 (&est->gate_steering, est->gate_re,
      est->gate_im, &templates, n, est->emitter_legs[n],
      sonar_steering_stretch (&est->steering,
          sonar_doppler_bank_velocity (est->bank, v)),
      est->blocks_range + centre, est->blocks);
  est->blocks_centre = centre;
}

/* Emitter @n's matched filter output at velocity index @v, at the lag of
 * the point focused on (range @range), by blocks of LAG_BLOCK bins into
 * est->blocks: its outputs at the lags of nearby ranges are then short
 * sums over the blocks (outputs_at ()), the window's dozen lags one pass
 * over the bins instead of a dozen. */
static void
emitter_blocks (SonarVelocityEstimator * est, guint n, guint v, double range)
{
  est->blocks_emitter = n;
  est->blocks_velocity = v;
  est->blocks_range = range;
  if (est->gated) {
    /* The window's lags are read from the first up: its first three
     * from the first blocks. */
    gated_blocks (est, MIN (est->lag_first + 1, est->lag_last) *
        est->grid.range_step);
  } else {
    const SonarSplitSpectra templates =
        sonar_doppler_bank_spectra (est->bank, v);
    sonar_steering_emitter_blocks (&est->steering, est->receive_re,
        est->receive_im, &templates, n, est->emitter_legs[n],
        sonar_steering_stretch (&est->steering,
            sonar_doppler_bank_velocity (est->bank, v)), range, LAG_BLOCK,
        est->blocks);
  }
}

/* The phasor table of the lag @offset m on est->blocks (of @kind, on
 * @steering by blocks of @block bins): its slot in est->lag_re, _im, made
 * on its first read, or -1 when the tables are full. */
static gint
lag_table (SonarVelocityEstimator * est, const SonarSteering * steering,
    guint block, guint8 kind, double offset)
{
  guint64 bits;
  guint slot;

  memcpy (&bits, &offset, sizeof bits);
  /* Fibonacci hashing: the offsets' bits differ most in their high
   * mantissa and exponent. */
  slot = (guint) (((bits ^ kind) * G_GUINT64_CONSTANT (0x9E3779B97F4A7C15))
      >> 57) & (LAG_TABLES - 1);
  for (;; slot = (slot + 1) & (LAG_TABLES - 1)) {
    const gsize at = (gsize) slot * est->lag_stride;
    if (est->lag_kinds[slot] == kind && est->lag_offsets[slot] == bits)
      return slot;
    if (est->lag_kinds[slot] == 0) {
      if (4 * (est->n_lag_tables + 1) > 3 * LAG_TABLES)
        return -1;
      sonar_steering_blocks_phasors (steering, block, offset,
          est->lag_re + at, est->lag_im + at);
      est->lag_kinds[slot] = kind;
      est->lag_offsets[slot] = bits;
      est->n_lag_tables++;
      return slot;
    }
  }
}

/* sonar_steering_blocks_at () of est->blocks at each of @n (at most
 * LAG_BATCH) @offsets into @out, bit for bit, on the phasor tables
 * (lag_table ()) summed together. */
static void
lag_reads (SonarVelocityEstimator * est, const SonarSteering * steering,
    guint block, guint8 kind, const double *offsets, guint n,
    SonarComplex * out)
{
  const float *re[LAG_BATCH], *im[LAG_BATCH];
  SonarComplex sums[LAG_BATCH];
  guint which[LAG_BATCH], n_tables = 0;

  for (guint i = 0; i < n; i++) {
    const gint slot = lag_table (est, steering, block, kind, offsets[i]);
    if (slot < 0) {
      out[i] = sonar_steering_blocks_at (steering, est->blocks, block,
          offsets[i]);
      continue;
    }
    re[n_tables] = est->lag_re + (gsize) slot * est->lag_stride;
    im[n_tables] = est->lag_im + (gsize) slot * est->lag_stride;
    which[n_tables++] = i;
  }
  if (n_tables)
    sonar_steering_blocks_sums (steering, est->blocks, block, re, im,
        n_tables, sums);
  for (guint t = 0; t < n_tables; t++)
    out[which[t]] = sums[t];
}

/* The outputs in est->blocks at the lags of @n @offsets m further in
 * range, read in turn, into @out, and the blocks' centre each was read
 * at into @centres (may be NULL). Gated blocks further than a range
 * step from an offset are centred first a step beyond it, where the next
 * lags read (the window's, from the first up) lie; the reads between two
 * centrings are made together. */
static void
outputs_at (SonarVelocityEstimator * est, const double *offsets, guint n,
    SonarComplex * out, double *centres)
{
  const double step = est->grid.range_step;
  double lags[LAG_BATCH];

  for (guint i = 0, end; i < n; i = end) {
    if (est->gated && fabs (offsets[i] - est->blocks_centre) > 1.001 * step)
      gated_blocks (est, offsets[i] + (offsets[i] > est->blocks_centre ?
              step : -step));
    for (end = i + 1; end < n && end - i < LAG_BATCH && !(est->gated
            && fabs (offsets[end] - est->blocks_centre) > 1.001 * step);
        end++);
    if (est->gated) {
      for (guint j = i; j < end; j++)
        lags[j - i] = offsets[j] - est->blocks_centre;
      lag_reads (est, &est->gate_steering, GATE_BLOCK, LAG_GATED, lags,
          end - i, out + i);
      for (guint j = i; j < end; j++)
        out[j] = out[j] * (2.0f / ((float) est->band.fft_size *
                est->gate_size));
    } else {
      lag_reads (est, &est->steering, LAG_BLOCK, LAG_WHOLE, offsets + i,
          end - i, out + i);
      for (guint j = i; j < end; j++)
        out[j] = out[j] * (2.0f / est->band.fft_size);
    }
    for (guint j = i; centres && j < end; j++)
      centres[j] = est->blocks_centre;
  }
}

/* Plans the gated reads of the window's lags (est->planned), as
 * outputs_at () makes them on the blocks emitter_blocks () centres: the
 * same centrings, lags and phasor tables, for every emitter and velocity
 * of the window. */
static void
gate_plan (SonarVelocityEstimator * est)
{
  const double step = est->grid.range_step;
  const guint n = est->lag_last - est->lag_first + 1;
  double centre = MIN (est->lag_first + 1, est->lag_last) * step;

  est->n_plan_runs = 0;
  for (guint i = 0, end; i < n; i = end) {
    const double at = (est->lag_first + (int) i) * step;
    const gboolean recentre = fabs (at - centre) > 1.001 * step;
    if (recentre)
      centre = at + (at > centre ? step : -step);
    for (end = i + 1; end < n && end - i < LAG_BATCH
        && !(fabs ((est->lag_first + (int) end) * step - centre) >
            1.001 * step); end++);
    est->plan_runs[est->n_plan_runs] = i;
    est->plan_run_centres[est->n_plan_runs++] = recentre ? centre : NAN;
    for (guint j = i; j < end; j++) {
      est->plan_lags[j] = (est->lag_first + (int) j) * step - centre;
      est->plan_slots[j] = lag_table (est, &est->gate_steering, GATE_BLOCK,
          LAG_GATED, est->plan_lags[j]);
    }
  }
  est->plan_runs[est->n_plan_runs] = n;
  est->plan_first = est->lag_first;
  est->plan_last = est->lag_last;
  est->planned = TRUE;
}

/* The gated blocks' sums at @n lags from their centre (@slots their
 * phasor tables, -1 for none) into @out, scaled as outputs_at () scales
 * them: lag_reads () without its look-ups. */
static void
gated_reads (SonarVelocityEstimator * est, const gint * slots,
    const double *lags, guint n, SonarComplex * out)
{
  const float *re[LAG_BATCH], *im[LAG_BATCH];
  SonarComplex sums[LAG_BATCH];
  guint which[LAG_BATCH], n_tables = 0;

  for (guint i = 0; i < n; i++) {
    if (slots[i] < 0) {
      out[i] = sonar_steering_blocks_at (&est->gate_steering, est->blocks,
          GATE_BLOCK, lags[i]);
      continue;
    }
    re[n_tables] = est->lag_re + (gsize) slots[i] * est->lag_stride;
    im[n_tables] = est->lag_im + (gsize) slots[i] * est->lag_stride;
    which[n_tables++] = i;
  }
  if (n_tables)
    sonar_steering_blocks_sums (&est->gate_steering, est->blocks, GATE_BLOCK,
        re, im, n_tables, sums);
  for (guint t = 0; t < n_tables; t++)
    out[which[t]] = sums[t];
  for (guint i = 0; i < n; i++)
    out[i] = out[i] * est->gate_scale;
}

/* outputs_at () of the window's lags on the gated blocks emitter_blocks
 * () made, bit for bit, on the plan (gate_plan ()): the outputs into
 * est->read_outputs, and the blocks' centre each was read at into
 * @centres (may be NULL). */
static void
gated_window_reads (SonarVelocityEstimator * est, double *centres)
{
  if (!est->planned || est->plan_first != est->lag_first
      || est->plan_last != est->lag_last)
    gate_plan (est);
  for (guint r = 0; r < est->n_plan_runs; r++) {
    const guint i = est->plan_runs[r], end = est->plan_runs[r + 1];
    if (!isnan (est->plan_run_centres[r]))
      gated_blocks (est, est->plan_run_centres[r]);
    gated_reads (est, est->plan_slots + i, est->plan_lags + i, end - i,
        est->read_outputs + i);
    for (guint j = i; centres && j < end; j++)
      centres[j] = est->blocks_centre;
  }
}

/* The kept prescreen entry of emitter @n at velocity index @v, or -1:
 * none for it (not a hypothesis, no gate, a window too wide). */
static gint
hyp_entry (const SonarVelocityEstimator * est, guint n, guint v)
{
  if (!est->hyp_index || est->hyp_index[v] < 0
      || est->lag_last - est->lag_first + 1 > HYP_LAGS)
    return -1;
  return est->hyp_index[v] * (gint) est->n_emitters + (gint) n;
}

/* Keeps the gated blocks and window outputs just made (emitter_blocks (),
 * gated_window_reads (), the window's centres in @centres) for
 * emitter @n at velocity index @v on the current focus. */
static void
hyp_keep (SonarVelocityEstimator * est, guint n, guint v,
    const double *centres)
{
  const gint e = hyp_entry (est, n, v);
  const guint lags = est->lag_last - est->lag_first + 1;

  if (e < 0)
    return;
  memcpy (est->hyp_blocks + (gsize) e * est->n_gate_blocks, est->blocks,
      sizeof (SonarComplex) * est->n_gate_blocks);
  memcpy (est->hyp_outputs + (gsize) e * HYP_LAGS, est->read_outputs,
      sizeof (SonarComplex) * lags);
  memcpy (est->hyp_centres + (gsize) e * HYP_LAGS, centres,
      sizeof (double) * lags);
  est->hyp_blocks_centre[e] = est->blocks_centre;
  est->hyp_generation[e] = est->focus_generation;
}

/* emitter_blocks () and gated_window_reads () of emitter @n at velocity
 * index @v and @range on the current gated focus from what hyp_keep ()
 * kept, the same numbers: FALSE when nothing is kept for them. */
static gboolean
hyp_take (SonarVelocityEstimator * est, guint n, guint v, double range,
    double *centres)
{
  const gint e = hyp_entry (est, n, v);
  const guint lags = est->lag_last - est->lag_first + 1;

  if (e < 0 || est->hyp_generation[e] != est->focus_generation)
    return FALSE;
  memcpy (est->blocks, est->hyp_blocks + (gsize) e * est->n_gate_blocks,
      sizeof (SonarComplex) * est->n_gate_blocks);
  memcpy (est->read_outputs, est->hyp_outputs + (gsize) e * HYP_LAGS,
      sizeof (SonarComplex) * lags);
  memcpy (centres, est->hyp_centres + (gsize) e * HYP_LAGS,
      sizeof (double) * lags);
  est->blocks_emitter = n;
  est->blocks_velocity = v;
  est->blocks_range = range;
  est->blocks_centre = est->hyp_blocks_centre[e];
  return TRUE;
}

static double parabola_offset (double a, double b, double c, double bound);

static double
cabs2 (double complex z)
{
  return creal (z) * creal (z) + cimag (z) * cimag (z);
}

/* Coherence factor |sum|^2 / (N sum |.|^2) of the emitters' outputs at
 * the window pixel and velocity (of the @n_v indices @vs) where their sum
 * is largest; *@strength (may be NULL) receives that sum's power,
 * *@which (may be NULL) the position in @vs of that velocity, and *@lag
 * (may be NULL) its range offset from @range (m), refined between the
 * window's lags by a parabola through the logarithms (as wardcluster
 * refines its peaks), and *@interference (may be NULL) the interference
 * power per emitter pooled over every pixel and velocity evaluated: the
 * power the emitters' outputs do not share, sum |y|^2 - |sum|^2 / N, over
 * N - 1 (its mean for interference independent across the emitters). */
static double
coherence_over (SonarVelocityEstimator * est,
    const SonarSplitSpectra * spectra, double range, double azimuth,
    double elevation, const guint * vs, guint n_v, double *strength,
    guint * which, double *lag, double *interference)
{
  const SonarImageGrid *grid = &est->grid;
  const int wd = est->params.window_directions;
  const int we = grid->n_elevation > 1 ? wd : 0;
  const int first = est->lag_first, last = est->lag_last;
  double best_sum = -1.0, best = 0.0, best_lag = 0.0;
  double before = 0.0, after = 0.0;     /* the sum's power a lag either side */
  double unshared = 0.0;
  guint best_i = 0, n_pixels = 0;

  for (int de = -we; de <= we; de++) {
    for (int da = -wd; da <= wd; da++) {
      focus (est, spectra, window_direction (est, azimuth, elevation, da,
              de), range);
      for (guint i = 0; i < n_v; i++) {
        /* In double: float squares underflow below amplitudes of about
         * 1e-19 and overflow above 1e19. */
        double complex *sums = est->lag_sums - first;
        double *powers = est->lag_powers - first;
        for (int dr = first; dr <= last; dr++) {
          sums[dr] = 0.0;
          powers[dr] = 0.0;
        }
        for (guint n = 0; n < est->n_emitters; n++) {
          emitter_blocks (est, n, vs[i], range);
          if (est->gated) {
            gated_window_reads (est, est->peak_centres);
            hyp_keep (est, n, vs[i], est->peak_centres);
          } else {
            for (int dr = first; dr <= last; dr++)
              est->read_offsets[dr - first] = dr * grid->range_step;
            outputs_at (est, est->read_offsets, last - first + 1,
                est->read_outputs, NULL);
          }
          for (int dr = first; dr <= last; dr++) {
            const double complex y = est->read_outputs[dr - first];
            sums[dr] += y;
            powers[dr] += cabs2 (y);
          }
        }
        for (int dr = first; dr <= last; dr++) {
          const double sum_power = cabs2 (sums[dr]);
          unshared += MAX (powers[dr] - sum_power / est->n_emitters, 0.0);
          n_pixels++;
          if (sum_power > best_sum) {
            best_sum = sum_power;
            best_lag = dr;
            before = dr > first ? cabs2 (sums[dr - 1]) : 0.0;
            after = dr < last ? cabs2 (sums[dr + 1]) : 0.0;
            best = powers[dr] > 0.0 ? sum_power / (est->n_emitters *
                powers[dr]) : 0.0;
            best_i = i;
          }
        }
      }
    }
  }
  if (strength)
    *strength = best_sum;
  if (interference)
    *interference = n_pixels && est->n_emitters > 1 ? unshared / (n_pixels *
        (est->n_emitters - 1.0)) : 0.0;
  if (which)
    *which = best_i;
  if (lag) {
    if (before > 0.0 && after > 0.0 && best_sum > 0.0)
      best_lag += parabola_offset (log (before), log (best_sum), log (after),
          0.5);
    *lag = best_lag * grid->range_step;
  }
  return best;
}

/* Offsets of the direction search, in grid steps: -1/2 .. 1/2. */
#define DIRECTION_SUBSTEPS 2
/* Degrees: on a grid this fine the centroid lies within half a degree of
 * the 2-degree MIMO beam's peak, and no search is made (every searched
 * direction is one more chance for noise to look coherent). */
#define FINE_GRID_STEP 1.0
/* The search's sub-directions per axis: -DIRECTION_SUBSTEPS .. +. */
#define SEARCH_SIDE (2 * DIRECTION_SUBSTEPS + 1)

/* Whether refine_direction () searches along an axis of grid @step
 * (degrees): coarser than FINE_GRID_STEP. */
static inline gboolean
searches_axis (double step)
{
  return step > FINE_GRID_STEP + 1e-9;
}

/* The vertex (*x, *y) of the quadratic a + b x + c y + d x^2 + e xy +
 * g y^2 fitted by least squares to ln @f over the 3 x 3 points x, y in
 * {-1, 0, 1} (f[(y + 1) * 3 + x + 1]; with @two_d FALSE, the row y = 0
 * alone, *y = 0 and e = g = 0), and @hessian its second derivatives
 * (2d, e, 2g). FALSE where a value is not positive or the fit has no
 * maximum. On this regular patch the
 * normal equations are diagonal but for the constant and the squares:
 * b = sum f x / 6, e = sum f x y / 4, d = sum f (x^2 - 2/3) / 2. */
static gboolean
quadratic_vertex (const double f[9], gboolean two_d, double *x, double *y,
    double hessian[3])
{
  double l[9], b = 0.0, c = 0.0, d = 0.0, e = 0.0, g = 0.0;

  for (int k = 0; k < 9; k++) {
    if (!(f[k] > 0.0) && (two_d || k / 3 == 1))
      return FALSE;
    l[k] = f[k] > 0.0 ? log (f[k]) : 0.0;
  }
  if (two_d) {
    for (int k = 0; k < 9; k++) {
      const int px = k % 3 - 1, py = k / 3 - 1;
      b += l[k] * px / 6.0;
      c += l[k] * py / 6.0;
      d += l[k] * (px * px - 2.0 / 3.0) / 2.0;
      g += l[k] * (py * py - 2.0 / 3.0) / 2.0;
      e += l[k] * px * py / 4.0;
    }
  } else {
    b = 0.5 * (l[5] - l[3]);
    d = 0.5 * (l[3] + l[5]) - l[4];
    g = -1.0;                   /* any maximum along y: x alone is fitted */
  }
  if (!sonar_linalg_quadratic_peak (b, c, 2.0 * d, e, 2.0 * g, x, y))
    return FALSE;
  hessian[0] = 2.0 * d;
  hessian[1] = e;
  hessian[2] = two_d ? 2.0 * g : NAN;
  return TRUE;
}

/* Where refine_direction () looks: offsets in quarter grid steps from a
 * centre, along azimuth and elevation in degrees on a 2-D grid; on a 3-D
 * one along the direction cosines u_x and u_y, the array's plane, where
 * a planar array's beam keeps one shape at every direction. In degrees
 * it does not: near the hemisphere's rim a degree of azimuth moves the
 * beam little and one of elevation sweeps it sideways, the beam is a
 * long tilted ridge, and a 3 x 3 patch on a grid row beside the peak
 * fits that ridge far from it (an echo at (80, 75) degrees read (68.3,
 * 74.1) on the 2-degree grid, the peak of the row at 74). */
typedef struct
{
  gboolean cosines;             /* TRUE: offsets along u_x, u_y */
  double azimuth, elevation;    /* the centre, degrees */
  double ux, uy;                /* the centre's cosines (cosines) */
  double step_a, step_e;        /* an offset's step: degrees or cosine */
} SearchFrame;

/* The frame of a search about (@azimuth, @elevation). */
static void
search_frame_init (SearchFrame * f, const SonarImageGrid * g, double azimuth,
    double elevation, gboolean cosines)
{
  const double quarter = 1.0 / (2 * DIRECTION_SUBSTEPS);
  const SonarVec3 u = sonar_vec3_from_direction (azimuth, elevation);

  f->cosines = cosines;
  f->azimuth = azimuth;
  f->elevation = elevation;
  f->ux = u.x;
  f->uy = u.y;
  f->step_a = g->azimuth_step * quarter * (cosines ? G_PI / 180.0 : 1.0);
  f->step_e = g->elevation_step * quarter * (cosines ? G_PI / 180.0 : 1.0);
}

/* How far in front of the array a direction must be: its cosines' norm
 * at most this. */
#define FRONT (1.0 - 1e-9)

/* Whether the direction @oa, @oe offsets from @f's centre lies in front
 * of the array: in cosines, inside the unit circle (past it no echo
 * comes from); in degrees always (the offsets are held within +-90). */
static gboolean
search_frame_inside (const SearchFrame * f, double oa, double oe)
{
  const double ux = f->ux + oa * f->step_a, uy = f->uy + oe * f->step_e;

  return !f->cosines || ux * ux + uy * uy < FRONT * FRONT;
}

/* The direction @oa, @oe offsets (quarter steps, fractions too) from
 * @f's centre. */
static void
search_frame_direction (const SearchFrame * f, double oa, double oe,
    double *azimuth, double *elevation)
{
  double ux, uy;

  if (!f->cosines) {
    *azimuth = CLAMP (f->azimuth + oa * f->step_a, -90.0, 90.0);
    *elevation = CLAMP (f->elevation + oe * f->step_e, -90.0, 90.0);
    return;
  }
  ux = f->ux + oa * f->step_a;
  uy = f->uy + oe * f->step_e;
  sonar_vec3_to_direction (sonar_vec3 (ux, uy, sqrt (MAX (1.0 - ux * ux -
                  uy * uy, 0.0))), azimuth, elevation);
}

/* The curvature of ln (amplitude) per degree^2 of azimuth and elevation
 * at (@azimuth, @elevation) from @h, the patch's fit's second derivatives
 * of ln (power) per patch unit^2 (units @unit_a, @unit_e of @f's axes; 0:
 * no elevation): in degrees the same, scaled; in cosines J^T H J with J
 * the cosines' derivatives per degree, which near the rim leaves azimuth
 * little curvature: its sigma grows as the array's resolution in it
 * falls. */
static void
search_frame_curvature (const SearchFrame * f, const double h[3],
    double unit_a, double unit_e, double azimuth, double elevation,
    double curvature[3])
{
  const double degree = G_PI / 180.0;

  curvature[0] = 0.5 * h[0] / (unit_a * unit_a);
  curvature[1] = unit_e > 0.0 ? 0.5 * h[1] / (unit_a * unit_e) : NAN;
  curvature[2] = unit_e > 0.0 ? 0.5 * h[2] / (unit_e * unit_e) : NAN;
  if (f->cosines) {
    const double kxx = curvature[0], kxy = curvature[1], kyy = curvature[2];
    /* du_x/daz; du_x/del and du_y/del */
    const double ja = degree * cos (azimuth * degree) *
        cos (elevation * degree);
    const double jx = -degree * sin (azimuth * degree) *
        sin (elevation * degree);
    const double jy = degree * cos (elevation * degree);
    curvature[0] = ja * ja * kxx;
    curvature[1] = ja * (jx * kxx + jy * kxy);
    curvature[2] = jx * jx * kxx + 2.0 * jx * jy * kxy + jy * jy * kyy;
  }
}

/* The narrowest patch refine_direction () fits near the rim, a share of
 * its half step: the log of the beam over a quarter of it, an eighth of
 * a main lobe, is a parabola well enough to extrapolate the little a
 * patch moved off the rim must (a patch of the whole half step, moved,
 * put an echo at (-70, 80) degrees on the rim). */
#define PATCH_NARROWEST 0.25

/* Whether a patch @width (share of half a step) about offsets (@ci, @cj)
 * of @f lies in front of the array: its four corners do. */
static gboolean
patch_inside (const SearchFrame * f, int qa, int qe, double ci, double cj,
    double width)
{
  for (int corner = 0; corner < 4; corner++) {
    const double oi = ci + (corner & 1 ? 1 : -1) * width * qa;
    const double oj = cj + (corner & 2 ? 1 : -1) * width * qe;
    if (!search_frame_inside (f, oi, oj))
      return FALSE;
  }
  return TRUE;
}

/* A patch near the rim (above): the widest, down to PATCH_NARROWEST, that
 * lies in front at (*ci, *cj), and where even the narrowest does not,
 * (*ci, *cj) moved towards boresight as little as it must. Bisections of
 * 40 rounds: to 1e-12 of the range searched. */
static void
patch_fit (const SearchFrame * f, int qa, int qe, double *ci, double *cj,
    double *width)
{
  const double r = hypot (f->ux + *ci * f->step_a, f->uy + *cj * f->step_e);
  double lo, hi;

  if (patch_inside (f, qa, qe, *ci, *cj, 1.0))
    return;
  if (patch_inside (f, qa, qe, *ci, *cj, PATCH_NARROWEST)) {
    lo = PATCH_NARROWEST;
    hi = 1.0;
    for (int round = 0; round < 40; round++) {
      const double mid = 0.5 * (lo + hi);
      if (patch_inside (f, qa, qe, *ci, *cj, mid))
        lo = mid;
      else
        hi = mid;
    }
    *width = lo;
    return;
  }
  *width = PATCH_NARROWEST;
  {
    /* Offsets per unit of cosine towards boresight. */
    const double ux = f->ux + *ci * f->step_a, uy = f->uy + *cj * f->step_e;
    const double di = -ux / (r * f->step_a), dj = -uy / (r * f->step_e);
    lo = 0.0;
    hi = r;
    for (int round = 0; round < 40; round++) {
      const double mid = 0.5 * (lo + hi);
      if (patch_inside (f, qa, qe, *ci + mid * di, *cj + mid * dj,
              PATCH_NARROWEST))
        hi = mid;
      else
        lo = mid;
    }
    *ci += hi * di;
    *cj += hi * dj;
  }
}

/* On a coarse grid, moves (*azimuth, *elevation) to the strongest
 * sub-direction within half a grid step (steps of a quarter; along the
 * cosines in 3-D: SearchFrame), at the detection hypotheses; *coherence
 * receives the coherence factor there.
 * The search is along azimuth, then along elevation from the best
 * azimuth: 9 evaluations instead of 25 on a 3-D grid, the beam being
 * close to separable over half a step. Every hypothesis is evaluated at
 * the centroid's own direction, the other directions at its strongest
 * one and the neighbours either side only: an echo's Doppler does not
 * change within half a grid step (with the +-7 m/s bank, 47 hypotheses:
 * 3-D centroids cost a sixth).
 *
 * (*echo_azimuth, *echo_elevation) receive the echo's direction, which
 * its detection reports: the vertex of a quadratic in the logarithm of
 * the same strength over the 3 x 3 directions half a grid step apart
 * about the search's best (3 along azimuth on a 2-D grid), where the
 * patch is close to symmetric about the beam's peak (the beam's log is
 * no parabola over a whole step: a lopsided patch biases the vertex). The search
 * moves in quarter steps, too coarse for the beam's precision at high
 * SNR, and at low SNR its best step jumps with the noise; the given
 * direction (a centroid's members' weighted mean) is pulled over by the
 * noise peaks that join a strong echo's cluster. The fit has the image's
 * shape (a tilted beam's cross term included) without its grid; where it
 * has no maximum, or a 2-D patch crosses +-90 degrees, the search's
 * direction is reported. @curvature receives the fit's second
 * derivatives of ln (amplitude) per degree^2 (azimuth^2, azimuth x
 * elevation, elevation^2), the shape the direction's sigma is read from
 * (sonar-uncertainty.h); NaN without a fit (and off a 2-D grid's
 * azimuth). */
static void
refine_direction (SonarVelocityEstimator * est,
    const SonarSplitSpectra * spectra, double range, double *azimuth,
    double *elevation, double *coherence, double *strength_out,
    double *echo_azimuth, double *echo_elevation, double curvature[3])
{
  const SonarImageGrid *g = &est->grid;
  const int qa = searches_axis (g->azimuth_step) ?
      DIRECTION_SUBSTEPS : 0;
  const int qe = searches_axis (g->elevation_step) ?
      DIRECTION_SUBSTEPS : 0;
  /* The strengths evaluated, at quarter steps from the frame's centre
   * ([(j + 2) * SEARCH_SIDE + i + 2]; 0: not evaluated). */
  double searched[SEARCH_SIDE * SEARCH_SIDE] = { 0 };
  double best_strength, best_az, best_el, patch[9];
  int best_i = 0, best_j = 0;
  double centre_i, centre_j, width = 1.0;
  guint which, first, n_near;
  SearchFrame frame;

  search_frame_init (&frame, g, *azimuth, *elevation, qa > 0 && qe > 0);
  best_az = frame.azimuth;
  best_el = frame.elevation;
  *coherence = coherence_over (est, spectra, range, best_az, best_el,
      est->hypotheses, est->n_hypotheses, &best_strength, &which, NULL,
      &est->interference);
  searched[DIRECTION_SUBSTEPS * SEARCH_SIDE + DIRECTION_SUBSTEPS] =
      best_strength;
  first = which > 0 ? which - 1 : 0;
  n_near = MIN (which + 2, est->n_hypotheses) - first;
  for (int axis = 0; axis < 2; axis++) {
    const int q = axis == 0 ? qa : qe;
    const int i0 = best_i;
    for (int i = -q; i <= q; i++) {
      const int oi = axis == 0 ? i : i0, oj = axis == 1 ? i : 0;
      double az, el, strength, cf, interference;
      /* The centre of either line is already evaluated. */
      if (i == 0 || !search_frame_inside (&frame, oi, oj))
        continue;
      search_frame_direction (&frame, oi, oj, &az, &el);
      cf = coherence_over (est, spectra, range, az, el,
          est->hypotheses + first, n_near, &strength, NULL, NULL,
          &interference);
      searched[(oj + DIRECTION_SUBSTEPS) * SEARCH_SIDE + oi +
          DIRECTION_SUBSTEPS] = strength;
      if (strength > best_strength) {
        best_strength = strength;
        best_az = az;
        best_el = el;
        best_i = oi;
        best_j = oj;
        *coherence = cf;
        est->interference = interference;
      }
    }
  }
  *azimuth = best_az;
  *elevation = best_el;
  *strength_out = best_strength;
  *echo_azimuth = best_az;
  *echo_elevation = best_el;
  curvature[0] = curvature[1] = curvature[2] = NAN;
  if (qa == 0 || (!frame.cosines && (fabs (best_az) + qa * frame.step_a >
              90.0 || fabs (best_el) + qe * frame.step_e > 90.0)))
    return;
  /* The patch: half a step either side of the search's best; near the
   * rim, where that reaches past it, narrower, down to PATCH_NARROWEST
   * of that, and then moved towards boresight as far as it must
   * (patch_fit ()). Its evaluations where the search made them. */
  centre_i = best_i;
  centre_j = best_j;
  if (frame.cosines)
    patch_fit (&frame, qa, qe, &centre_i, &centre_j, &width);
  for (int pj = -1; pj <= 1; pj++) {
    for (int pi = -1; pi <= 1; pi++) {
      const double oi = centre_i + pi * width * qa;
      const double oj = centre_j + pj * width * qe;
      double *value = &patch[(pj + 1) * 3 + pi + 1];
      *value = 0.0;
      if (qe == 0 && pj != 0)
        continue;
      if (oi == rint (oi) && oj == rint (oj) && fabs (oi) <=
          DIRECTION_SUBSTEPS && fabs (oj) <= DIRECTION_SUBSTEPS)
        *value = searched[((int) oj + DIRECTION_SUBSTEPS) * SEARCH_SIDE +
            (int) oi + DIRECTION_SUBSTEPS];
      if (*value == 0.0) {
        double az, el;
        search_frame_direction (&frame, oi, oj, &az, &el);
        coherence_over (est, spectra, range, az, el,
            est->hypotheses + first, n_near, value, NULL, NULL, NULL);
      }
    }
  }
  {
    /* Patch units to the frame's offsets. */
    const double unit_a = width * qa * frame.step_a;
    const double unit_e = width * qe * frame.step_e;
    double x, y, h[3];
    if (quadratic_vertex (patch, qe > 0, &x, &y, h)) {
      if (frame.cosines) {
        /* Within the patch, or as far beyond it towards the rim as it
         * was moved from the best; in front. */
        const double from_a = (best_i - centre_i) / (width * qa);
        const double from_e = (best_j - centre_j) / (width * qe);
        double ux, uy, r;
        x = CLAMP (x, MIN (from_a, 0.0) - 1.0, MAX (from_a, 0.0) + 1.0);
        y = CLAMP (y, MIN (from_e, 0.0) - 1.0, MAX (from_e, 0.0) + 1.0);
        ux = frame.ux + centre_i * frame.step_a + x * unit_a;
        uy = frame.uy + centre_j * frame.step_e + y * unit_e;
        r = hypot (ux, uy);
        if (r > FRONT) {
          ux *= FRONT / r;
          uy *= FRONT / r;
        }
        sonar_vec3_to_direction (sonar_vec3 (ux, uy, sqrt (MAX (1.0 -
                        ux * ux - uy * uy, 0.0))), echo_azimuth,
            echo_elevation);
      } else {
        x = CLAMP (x, -1.0, 1.0);
        y = CLAMP (y, -1.0, 1.0);
        *echo_azimuth = best_az + x * unit_a;
        *echo_elevation = best_el + y * unit_e;
      }
      search_frame_curvature (&frame, h, unit_a, unit_e, *echo_azimuth,
          *echo_elevation, curvature);
    }
  }
}

/* The most the interference at the chosen pixel (the power the emitters'
 * outputs do not share there) may exceed the pooled interference for the
 * pooled test: interference independent across 8 emitters exceeds twice
 * its mean (chi-squared, 14 degrees of freedom) 1.4% of the time; where
 * the emitters disagree more at the pixel than around it, it is no single
 * echo (a blend of two within one beam, an alias of a regular grid). */
#define POOLED_MAX_EXCESS 2.0
/* An isolated echo's coherence factor (measured: 0.95 and more): its own
 * focus leaves up to 5% of its power unshared at the pixel, which the
 * pooled test allows on top of the interference. */
#define ISOLATED_COHERENCE 0.95

/* The coherence test. @coherence: the factor at the chosen pixel and
 * velocity; @strength: the power of the emitters' sum there. An echo
 * passes when its factor reaches the threshold set by coherence-pfa, or,
 * in a crowd, when the power the emitters share stands pooled-snr-db
 * above the interference pooled over the prescreen's pixels and
 * hypotheses (est->interference) and the interference at the pixel
 * itself is no more than POOLED_MAX_EXCESS times that (plus what an
 * isolated echo's own focus leaves unshared): the factor weighs
 * the shared power against the interference at the pixel alone (N - 1
 * complex degrees of freedom), and a real echo 13 dB above the others'
 * cross-talk scores only 0.75 on average; the pooled estimate has 21 or
 * more. min-coherence is a floor under both. */
static gboolean
coherent_enough (const SonarVelocityEstimator * est, double coherence,
    double strength)
{
  const double shared = strength / est->n_emitters;
  const double here = coherence > 0.0 && est->n_emitters > 1 ?
      shared * (1.0 / coherence - 1.0) / (est->n_emitters - 1.0) : INFINITY;

  return coherence >= est->min_coherence || (est->min_pooled_snr > 0.0
      && coherence >= est->params.min_coherence
      && shared >= est->min_pooled_snr * est->interference
      && here <= POOLED_MAX_EXCESS * est->interference + shared *
      (1.0 / ISOLATED_COHERENCE - 1.0) / (est->n_emitters - 1.0));
}

/* |@z|, as glibc's cabsf () computes it (the root in double of the
 * squares, exact there) without its call: window_peak () takes a dozen
 * per evaluation, and the calls cost as much as the roots. */
static inline double
magnitude (SonarComplex z)
{
  const double re = crealf (z), im = cimagf (z);

  return (float) sqrt (re * re + im * im);
}

/* Whether @a and @b are the same double, bit for bit (a lag read's
 * output depends on its offset's bits, the sign of a zero included). */
static gboolean
same_bits (double a, double b)
{
  return memcmp (&a, &b, sizeof a) == 0;
}

/* Envelope peak of emitter @n's output at velocity index @v over the
 * window's lags around @range. The image's range bins are about
 * one envelope width apart: their sampled maximum would scallop
 * differently for every velocity (the peak's lag moves with the Doppler
 * mismatch) and bias the curve. So the best bin is refined on a grid four
 * times finer, and the peak read off a parabola through the logarithms of
 * the best fine sample and its neighbours. */
static double
window_peak (SonarVelocityEstimator * est, guint n, guint v, double range)
{
  const double step = est->grid.range_step;
  double *values = est->peak_values - est->lag_first;
  double *centres = est->peak_centres - est->lag_first;
  double fine[9], best_value = -1.0, best_lag = 0.0;
  double fine_offsets[8], fine_lags[8] = { 0 };
  SonarComplex fine_outputs[8];
  int best = 4, best_dr = 0, fine_q[8], fine_slots[8] = { 0 };
  guint n_fine = 0;

  if (est->gated && hyp_take (est, n, v, range, est->peak_centres)) {
    /* The prescreen made these blocks and reads. */
  } else if ((emitter_blocks (est, n, v, range), est->gated)) {
    gated_window_reads (est, est->peak_centres);
  } else {
    for (int dr = est->lag_first; dr <= est->lag_last; dr++)
      est->read_offsets[dr - est->lag_first] = dr * step;
    outputs_at (est, est->read_offsets, est->lag_last - est->lag_first + 1,
        est->read_outputs, est->peak_centres);
  }
  for (int dr = est->lag_first; dr <= est->lag_last; dr++) {
    const double y = magnitude (est->read_outputs[dr - est->lag_first]);
    values[dr] = y;
    if (y > best_value) {
      best_value = y;
      best_lag = dr * step;
      best_dr = dr;
    }
  }
  /* Quarter steps from -1 to +1 bin around the best, read at the best's
   * centre (none a step from it needs another). */
  if (est->gated && best_lag != est->blocks_centre)
    gated_blocks (est, best_lag);
  for (int q = 0; q < 9; q++) {
    const double offset = best_lag + (q - 4) * 0.25 * step;
    const int dr = best_dr + (q == 0 ? -1 : 1);
    if (q == 4) {
      fine[q] = best_value;
    } else if ((q == 0 || q == 8) && dr >= est->lag_first
        && dr <= est->lag_last && same_bits (offset, dr * step)
        && same_bits (centres[dr], est->blocks_centre)) {
      /* The same lag on the same blocks as a window lag read above (as
       * the offset is exactly that lag's): the same output. */
      fine[q] = values[dr];
    } else {
      fine_q[n_fine] = q;
      fine_offsets[n_fine++] = offset;
    }
  }
  if (est->gated) {
    /* outputs_at () on the blocks centred at the best lag, whose lags
     * from it depend on best_dr and q alone: their tables are looked up
     * once. */
    gint *slots = est->fine_slots + (best_dr + MAX_WINDOW_RANGES) * 9;
    for (guint i = 0; i < n_fine; i++) {
      fine_lags[i] = fine_offsets[i] - est->blocks_centre;
      if (slots[fine_q[i]] == FINE_UNKNOWN)
        slots[fine_q[i]] = lag_table (est, &est->gate_steering, GATE_BLOCK,
            LAG_GATED, fine_lags[i]);
      fine_slots[i] = slots[fine_q[i]];
    }
    gated_reads (est, fine_slots, fine_lags, n_fine, fine_outputs);
  } else {
    outputs_at (est, fine_offsets, n_fine, fine_outputs, NULL);
  }
  for (guint i = 0; i < n_fine; i++)
    fine[fine_q[i]] = magnitude (fine_outputs[i]);
  for (int q = 1; q < 8; q++)
    if (fine[q] > fine[best])
      best = q;
  if (fine[best - 1] > 0.0 && fine[best] > 0.0 && fine[best + 1] > 0.0) {
    const double la = log (fine[best - 1]), lb = log (fine[best]);
    const double lc = log (fine[best + 1]);
    const double x = parabola_offset (la, lb, lc, 0.5);
    /* The vertex's height: lb - (la - lc) x / 4, at least lb. */
    return exp (lb - 0.25 * (la - lc) * x);
  }
  return fine[best];
}

/* Takes the maximum of the window's single-emitter image values into
 * est->acf, at the velocities wanted and not yet done. */
static void
evaluate_window (SonarVelocityEstimator * est,
    const SonarSplitSpectra * spectra, double range, double azimuth,
    double elevation)
{
  const SonarImageGrid *grid = &est->grid;
  const int wd = est->params.window_directions;
  const int we = grid->n_elevation > 1 ? wd : 0;

  for (int de = -we; de <= we; de++) {
    for (int da = -wd; da <= wd; da++) {
      /* The receive sum focused exactly at this pixel's point. */
      focus (est, spectra, window_direction (est, azimuth, elevation, da,
              de), range);
      for (guint n = 0; n < est->n_emitters; n++) {
        for (guint v = 0; v < est->n_velocities; v++) {
          double *acf = &est->acf[(gsize) n * est->n_velocities + v];
          if (est->wanted[v] && !est->done[v])
            *acf = MAX (*acf, window_peak (est, n, v, range));
        }
      }
    }
  }
  for (guint v = 0; v < est->n_velocities; v++) {
    est->changed[v] |= est->wanted[v] && !est->done[v];
    est->done[v] |= est->wanted[v];
  }
}

/* Wants the velocities within half a main lobe (plus a coarse step) of
 * index @p, and evaluates them. */
static void
evaluate_around (SonarVelocityEstimator * est,
    const SonarSplitSpectra * spectra, double range, double azimuth,
    double elevation, guint p)
{
  const double vp = sonar_doppler_bank_velocity (est->bank, p);
  const double reach = 0.5 * est->main_lobe + est->coarse_stride *
      sonar_doppler_bank_step (est->bank);

  for (guint v = 0; v < est->n_velocities; v++)
    est->wanted[v] = fabs (sonar_doppler_bank_velocity (est->bank, v) - vp)
        <= reach;
  evaluate_window (est, spectra, range, azimuth, elevation);
}

/* Fills the curves between evaluated velocities (linearly in the log
 * domain: they are smooth at a quarter of a main lobe), sums the log
 * product into est->log_product and returns its peak's index. A gap
 * whose ends and values have not changed since the last fill
 * (est->changed) keeps its values: the same numbers. */
static guint
fill_and_multiply (SonarVelocityEstimator * est)
{
  const guint nv = est->n_velocities;
  const guint8 *changed = est->changed;
  double *lp = est->log_product;
  guint peak = 0;

  for (guint v = 0; v < nv; v++)
    lp[v] = 0.0;
  for (guint n = 0; n < est->n_emitters; n++) {
    double *acf = est->acf + (gsize) n * nv;
    double *la = est->log_acf + (gsize) n * nv;
    int prev = -1;
    for (guint v = 0; v < nv; v++)
      if (est->done[v] && changed[v])
        la[v] = log (acf[v] + ACF_FLOOR);
    for (guint v = 0, end; v < nv; v = end) {
      gboolean stale;
      if (est->done[v]) {
        prev = v;
        end = v + 1;
        continue;
      }
      /* The gap from v to the next evaluated velocity, end. */
      for (end = v + 1; end < nv && !est->done[end]; end++);
      stale = (prev >= 0 && changed[prev]) || (end < nv && changed[end]);
      for (guint u = v; u < end && !stale; u++)
        stale = changed[u];
      for (guint u = v; stale && u < end; u++) {
        if (prev < 0 || end >= nv) {
          acf[u] = prev < 0 ? acf[end < nv ? end : u] : acf[prev];
        } else {
          const double t = (double) (u - prev) / (end - prev);
          acf[u] = exp ((1.0 - t) * la[prev] + t * la[end]);
        }
        la[u] = log (acf[u] + ACF_FLOOR);
      }
    }
    for (guint v = 0; v < nv; v++)
      lp[v] += la[v];
  }
  memset (est->changed, 0, nv);
  for (guint v = 0; v < nv; v++)
    if (lp[v] > lp[peak])
      peak = v;
  return peak;
}

/* Vertex of the parabola through (-1, a), (0, b), (1, c): offset in
 * steps, within +-@bound (0.5 about the strongest of three samples); 0
 * where it has no maximum. */
static double
parabola_offset (double a, double b, double c, double bound)
{
  const double denom = a - 2.0 * b + c;
  return denom < 0.0 ? CLAMP (0.5 * (a - c) / denom, -bound, bound) : 0.0;
}

/* Vertex, in steps from @p, of the least-squares parabola through lp[]
 * over the middle of the main lobe (+-0.4 of its width, at least one step
 * each side). The curves are a main lobe wide (about 0.33 m/s): a parabola
 * through the top three points alone follows their small wiggles. */
static double
fit_vertex (const double *lp, guint n, guint p, double lobe_steps)
{
  const int half = MAX (1, (int) floor (0.4 * lobe_steps));
  const int lo = MAX (-half, -(int) p), hi = MIN (half, (int) (n - 1 - p));
  double s[5] = { 0 }, t[3] = { 0 }, det, b, c;

  /* Normal equations of y = a + b x + c x^2. */
  for (int x = lo; x <= hi; x++) {
    double xp = 1.0;
    for (int k = 0; k < 5; k++) {
      s[k] += xp;
      if (k < 3)
        t[k] += xp * lp[p + x];
      xp *= x;
    }
  }
  det = s[0] * (s[2] * s[4] - s[3] * s[3]) - s[1] * (s[1] * s[4] - s[3] *
      s[2]) + s[2] * (s[1] * s[3] - s[2] * s[2]);
  if (hi - lo < 2 || fabs (det) < 1e-12)
    return parabola_offset (lp[p - 1], lp[p], lp[p + 1], 0.5);
  b = (s[0] * (t[1] * s[4] - s[3] * t[2]) - t[0] * (s[1] * s[4] - s[3] *
          s[2]) + s[2] * (s[1] * t[2] - t[1] * s[2])) / det;
  c = (s[0] * (s[2] * t[2] - t[1] * s[3]) - s[1] * (s[1] * t[2] - t[1] *
          s[2]) + t[0] * (s[1] * s[3] - s[2] * s[2])) / det;
  return c < 0.0 ? CLAMP (-b / (2.0 * c), lo, hi) : 0.0;
}

/* The log product's curvature at index @p, per (m/s)^2, over the span
 * fit_vertex () reads the peak from. */
static double
product_curvature (SonarVelocityEstimator * est, guint p)
{
  const double step = sonar_doppler_bank_step (est->bank);
  const guint half = MAX (1, (int) floor (0.4 * est->main_lobe / step));

  return sonar_uncertainty_curvature (est->log_product, est->n_velocities,
      p, half) / (step * step);
}

static int
compare_doubles (const void *a, const void *b)
{
  const double x = *(const double *) a, y = *(const double *) b;
  return (x > y) - (x < y);
}

/* Describes the product's peak at index @p and tests it. With a second
 * reflector in the centroid, its peak at index @other (else -1), each
 * peak is judged on the velocities nearer to it than to the other: there
 * the other's main lobe does not count against it. */
static void
describe_peak (SonarVelocityEstimator * est,
    const SonarSplitSpectra * spectra, double centre, guint p, int other,
    double median, SonarVelocityEstimate * out)
{
  const guint nv = est->n_velocities;
  const double step = sonar_doppler_bank_step (est->bank);
  const double *lp = est->log_product;
  double v = sonar_doppler_bank_velocity (est->bank, p);
  double mean = 0.0, mean2 = 0.0, lag, strength;
  guint agree = 0, n_own = 0;

  if (est->params.refine && p > 0 && p + 1 < nv)
    v += step * fit_vertex (lp, nv, p, est->main_lobe / step);
  out->radial_velocity = v;
  out->bank_index = p;
  out->at_bank_edge = p == 0 || p + 1 == nv;
  /* Amplitude dB per emitter: the product of N curves is N times as steep. */
  out->peak_db = 20.0 / G_LN10 * (lp[p] - median) / est->n_emitters;
  out->velocity_curvature = product_curvature (est, p);

  /* The paper's variance test, on the product normalised to its peak. */
  for (guint i = 0; i < nv; i++) {
    double x;
    if (other >= 0 && abs ((int) i - other) < abs ((int) i - (int) p))
      continue;
    x = exp (lp[i] - lp[p]);
    mean += x;
    mean2 += x * x;
    n_own++;
  }
  mean /= n_own;
  out->variance = mean2 / n_own - mean * mean;

  /* Emitter n agrees when its own curve, within half a main lobe of the
   * product's peak, comes within 3 dB of its maximum: with two reflectors
   * of about the same strength in one centroid every emitter has two
   * peaks, and either may be the larger. */
  for (guint n = 0; n < est->n_emitters; n++) {
    const double *acf = est->acf + (gsize) n * nv;
    const double vp = sonar_doppler_bank_velocity (est->bank, p);
    double global = 0.0, near = 0.0;
    for (guint i = 0; i < nv; i++) {
      if (other >= 0 && abs ((int) i - other) < abs ((int) i - (int) p))
        continue;
      global = MAX (global, acf[i]);
      if (fabs (sonar_doppler_bank_velocity (est->bank, i) - vp) <=
          0.5 * est->main_lobe)
        near = MAX (near, acf[i]);
    }
    agree += near >= AGREEMENT_RATIO * global;
  }
  out->agreeing_emitters = agree;
  out->coherence = coherence_over (est, spectra, centre, out->azimuth,
      out->elevation, &p, 1, &strength, NULL, &lag, NULL);
  /* A centroid whose members lie beyond the window around it, or that
   * holds two reflectors, is a blend of echoes at different ranges: each
   * estimate takes its own echo's. */
  out->range = est->spread || other >= 0 ? centre + lag : centre;
  out->valid = agree >= MIN (est->params.min_agreeing_emitters,
      est->n_emitters) && out->variance >= est->params.min_variance
      && coherent_enough (est, out->coherence, strength);
  out->second = FALSE;
}

/* Sets the window's lags: the centroid's members' ranges and
 * window_ranges steps either side. A span that does not hold the
 * centroid's range (not filled in) counts as none. */
static void
set_window_lags (SonarVelocityEstimator * est, const SonarCentroid * c)
{
  const double step = est->grid.range_step;
  const int wr = est->params.window_ranges;
  const gboolean span = c->range_min <= c->range + 0.5 * step
      && c->range_max >= c->range - 0.5 * step;
  const double near = span ? MIN (c->range_min - c->range, 0.0) / step : 0.0;
  const double far = span ? MAX (c->range_max - c->range, 0.0) / step : 0.0;

  est->lag_first = MAX (-(int) MAX_WINDOW_RANGES, -wr + (int) floor (near +
          1e-6));
  est->lag_last = MIN ((int) MAX_WINDOW_RANGES, wr + (int) ceil (far -
          1e-6));
  est->spread = est->lag_first < -wr || est->lag_last > wr;
}

/* The product's floor away from the main lobes of the peaks at indices
 * @p and @q: the echoes' cross-talk through the other emitters' templates,
 * 11-14 dB per emitter below a lone echo's peak. *@level receives its
 * median, *@spread its interquartile range. FALSE when the bank holds
 * less than two main lobes of it to measure. */
static gboolean
floor_spread (SonarVelocityEstimator * est, guint p, guint q, double *level,
    double *spread)
{
  const double vp = sonar_doppler_bank_velocity (est->bank, p);
  const double vq = sonar_doppler_bank_velocity (est->bank, q);
  double *x = est->scratch;
  guint n = 0;

  for (guint v = 0; v < est->n_velocities; v++) {
    const double vv = sonar_doppler_bank_velocity (est->bank, v);
    if (fabs (vv - vp) > est->main_lobe && fabs (vv - vq) > est->main_lobe)
      x[n++] = est->log_product[v];
  }
  if (n * sonar_doppler_bank_step (est->bank) < 2.0 * est->main_lobe)
    return FALSE;
  qsort (x, n, sizeof (double), compare_doubles);
  *level = x[n / 2];
  *spread = x[3 * n / 4] - x[n / 4];
  return TRUE;
}

/* With two reflectors in the window, each one's curves near its peak
 * also hold the other's main lobe, which pulls its peak towards the
 * other's velocity. Where their echoes lie apart in range, @e's velocity
 * is measured again on window_ranges around its own echo only (the bank
 * around its peak, index @p, evaluated anew there). */
static void
refine_alone (SonarVelocityEstimator * est, const SonarSplitSpectra * spectra,
    guint p, SonarVelocityEstimate * e)
{
  const guint nv = est->n_velocities;
  const double vp = sonar_doppler_bank_velocity (est->bank, p);
  const int first = est->lag_first, last = est->lag_last;
  const double *lp = est->log_product;
  guint top = p;

  est->lag_first = -(int) est->params.window_ranges;
  est->lag_last = est->params.window_ranges;
  for (guint v = 0; v < nv; v++) {
    if (fabs (sonar_doppler_bank_velocity (est->bank, v) - vp) >
        0.5 * est->main_lobe + est->coarse_stride *
        sonar_doppler_bank_step (est->bank))
      continue;
    est->done[v] = FALSE;
    est->changed[v] = TRUE;
    for (guint n = 0; n < est->n_emitters; n++)
      est->acf[(gsize) n * nv + v] = 0.0;
  }
  evaluate_around (est, spectra, e->range, e->azimuth, e->elevation, p);
  fill_and_multiply (est);
  for (guint v = 0; v < nv; v++)
    if (fabs (sonar_doppler_bank_velocity (est->bank, v) - vp) <=
        0.5 * est->main_lobe && lp[v] > lp[top])
      top = v;
  e->radial_velocity = sonar_doppler_bank_velocity (est->bank, top);
  if (est->params.refine && top > 0 && top + 1 < nv)
    e->radial_velocity += sonar_doppler_bank_step (est->bank) *
        fit_vertex (lp, nv, top, est->main_lobe /
        sonar_doppler_bank_step (est->bank));
  e->bank_index = top;
  e->at_bank_edge = top == 0 || top + 1 == nv;
  e->velocity_curvature = product_curvature (est, top);
  est->lag_first = first;
  est->lag_last = last;
}

/* Where estimate_at () reports the echo's range. */
typedef enum
{
  ECHO_AT_PEAK,                 /* the centroid's strongest member peak */
  ECHO_AT_EVALUATED,            /* where the bank was evaluated */
} EchoRange;

/* Sets the echo's range (SonarVelocityEstimate) of @out's @count
 * estimates at @centroid. A lone estimate whose window lag (whole range
 * steps, describe_peak ()) lands within a step of the strongest member
 * peak is that peak's echo, whose fit is finer. */
static void
place_echo_ranges (const SonarVelocityEstimator * est,
    const SonarCentroid * centroid, EchoRange echo,
    SonarVelocityEstimate * out, guint count)
{
  const gboolean at_peak = echo == ECHO_AT_PEAK;

  for (guint i = 0; i < count; i++) {
    out[i].echo_range = at_peak && count == 1 && (!est->spread
        || fabs (out[i].range - centroid->peak_range) <=
        est->grid.range_step) ? centroid->peak_range : out[i].range;
  }
}

/* estimate () at (@azimuth, @elevation) instead of the centroid's
 * direction (its range and span of ranges kept). */
static guint
estimate_at (SonarVelocityEstimator * est,
    const SonarSplitSpectra * mic_spectra, const SonarCentroid * centroid,
    double azimuth, double elevation, EchoRange echo,
    SonarVelocityEstimate * out, float *curves)
{
  const guint nv = est->n_velocities;
  const double range = centroid->range;
  double *lp = est->log_product;
  double median, lowest, floor_level, spread, strength;
  guint peak = 0, count = 1;
  int second = -1;

  est->focused = FALSE;
  set_window_lags (est, centroid);
  out[0].range = range;
  out[0].azimuth = azimuth;
  out[0].elevation = elevation;

  /* Prescreen: a centroid whose emitters do not add up coherently at any
   * detection hypothesis is a ghost (measured: isolated objects 0.95 and
   * more, cross-talk ridges up to 0.8). Rejecting it here spares the whole
   * bank's evaluation, most of the work of a ping. The centroid's direction
   * is only as good as the image's grid, and the MIMO beam is about 2
   * degrees wide: the prescreen also takes the strongest direction within
   * half a grid step, where the bank is then evaluated. */
  refine_direction (est, mic_spectra, range, &azimuth, &elevation,
      &out[0].coherence, &strength, &out[0].echo_azimuth,
      &out[0].echo_elevation, out[0].direction_curvature);
  out[0].azimuth = azimuth;
  out[0].elevation = elevation;
  if (est->interference > 0.0)
    est->screen_snr = MAX (est->screen_snr, strength / est->n_emitters /
        est->interference);
  if (!coherent_enough (est, out[0].coherence, strength)) {
    out[0].radial_velocity = NAN;
    out[0].bank_index = 0;
    out[0].peak_db = out[0].variance = 0.0;
    out[0].velocity_curvature = NAN;
    out[0].agreeing_emitters = 0;
    out[0].at_bank_edge = out[0].valid = out[0].second = FALSE;
    out[0].evaluated_velocities = 0;
    if (curves)
      for (gsize i = 0; i < (gsize) (est->n_emitters + 1) * nv; i++)
        curves[i] = NAN;
    place_echo_ranges (est, centroid, echo, out, 1);
    return 1;
  }

  /* Coarse pass over the bank, then every velocity around the peak. */
  for (gsize i = 0; i < (gsize) est->n_emitters * nv; i++)
    est->acf[i] = 0.0;
  for (guint v = 0; v < nv; v++) {
    est->done[v] = FALSE;
    est->changed[v] = TRUE;
    est->wanted[v] = v % est->coarse_stride == 0 || v + 1 == nv;
  }
  evaluate_window (est, mic_spectra, range, azimuth, elevation);
  peak = fill_and_multiply (est);
  evaluate_around (est, mic_spectra, range, azimuth, elevation, peak);
  peak = fill_and_multiply (est);
  memcpy (est->scratch, lp, sizeof (double) * nv);
  qsort (est->scratch, nv, sizeof (double), compare_doubles);
  median = est->scratch[nv / 2];

  describe_peak (est, mic_spectra, range, peak, -1, median, &out[0]);

  /* A second reflector of another speed in the centroid: the highest
   * local maximum of the product SECOND_APART main lobes from the first,
   * within second_peak_db of it, that stands out of the product's floor
   * (floor_spread ()). Found on the coarse pass (a spread lower: its top
   * may lie between the coarse velocities), tested on its exact top. */
  lowest = lp[peak] - est->n_emitters * est->params.second_peak_db *
      G_LN10 / 20.0;
  for (guint v = 1; v + 1 < nv; v++) {
    if (lp[v] >= lp[v - 1] && lp[v] >= lp[v + 1] && lp[v] >= lowest
        && fabs (sonar_doppler_bank_velocity (est->bank, v) -
            sonar_doppler_bank_velocity (est->bank, peak)) >=
        SECOND_APART * est->main_lobe && (second < 0 || lp[v] > lp[second]))
      second = v;
  }
  if (second >= 0 && floor_spread (est, peak, second, &floor_level, &spread)
      && lp[second] >= floor_level + (SECOND_FLOOR_SPREADS - 1.0) * spread) {
    /* Its neighbourhood in full, and its exact top there. */
    const double vs = sonar_doppler_bank_velocity (est->bank, second);
    evaluate_around (est, mic_spectra, range, azimuth, elevation, second);
    fill_and_multiply (est);
    for (guint v = 0; v < nv; v++)
      if (fabs (sonar_doppler_bank_velocity (est->bank, v) - vs) <=
          0.5 * est->main_lobe && lp[v] > lp[second])
        second = v;
    out[1] = out[0];
    describe_peak (est, mic_spectra, range, second, peak, median, &out[1]);
    out[1].second = TRUE;
    if (out[1].valid && fabs (out[1].radial_velocity -
            out[0].radial_velocity) >= SECOND_APART * est->main_lobe
        && lp[second] >= floor_level + SECOND_FLOOR_SPREADS * spread
        && lp[second] >= lowest) {
      /* The first judged on its side of the bank too. */
      describe_peak (est, mic_spectra, range, peak, second, median, &out[0]);
      count = 2;
      refine_alone (est, mic_spectra, peak, &out[0]);
      refine_alone (est, mic_spectra, second, &out[1]);
    }
  }
  out[0].evaluated_velocities = 0;
  for (guint v = 0; v < nv; v++)
    out[0].evaluated_velocities += est->done[v];
  if (count == 2)
    out[1].evaluated_velocities = out[0].evaluated_velocities;

  if (curves) {
    for (guint n = 0; n < est->n_emitters; n++)
      for (guint v = 0; v < nv; v++)
        curves[(gsize) n * nv + v] = (float) (20.0 * log10
            (est->acf[(gsize) n * nv + v] + ACF_FLOOR));
    for (guint v = 0; v < nv; v++)
      curves[(gsize) est->n_emitters * nv + v] = (float) (20.0 / G_LN10 *
          lp[v] / est->n_emitters);
  }
  place_echo_ranges (est, centroid, echo, out, count);
  return count;
}

/* The direction of @centroid's strongest member peak. */
static void
strongest_direction (const SonarVelocityEstimator * est,
    const SonarCentroid * centroid, double *azimuth, double *elevation)
{
  const SonarImageGrid *g = &est->grid;

  *azimuth = g->azimuth_first + MIN (centroid->peak_azimuth_index,
      g->n_azimuth - 1) * g->azimuth_step;
  *elevation = g->n_elevation > 1 ? g->elevation_first +
      MIN (centroid->peak_elevation_index, g->n_elevation - 1) *
      g->elevation_step : centroid->elevation;
}

/* Degrees between two directions. */
static double
angle_between (double az_a, double el_a, double az_b, double el_b)
{
  const double d = sonar_vec3_dot (sonar_vec3_from_direction (az_a, el_a),
      sonar_vec3_from_direction (az_b, el_b));

  return acos (CLAMP (d, -1.0, 1.0)) * (180.0 / G_PI);
}

/* sonar_velocity_estimate () on split spectra. A centroid is the
 * energy-weighted mean of its member peaks: when they lie further apart
 * than the beam (BLEND_STEPS image steps and more between the centroid
 * and its strongest member), the centroid may be a blend of two echoes
 * the image resolves, between them and on neither. When the estimate at
 * the centroid fails, the echo is looked for at the strongest member
 * peak, and, found there, the other members' weighted mean direction is
 * looked at for a second. */
static guint
estimate (SonarVelocityEstimator * est, const SonarSplitSpectra * mic_spectra,
    const SonarCentroid * centroid, SonarVelocityEstimate * out,
    float *curves)
{
  const SonarImageGrid *g = &est->grid;
  const double step = g->n_elevation > 1 ? MIN (g->azimuth_step,
      g->elevation_step) : g->azimuth_step;
  double az, el;
  guint count;

  est->screen_snr = 0.0;
  count = estimate_at (est, mic_spectra, centroid, centroid->azimuth,
      centroid->elevation, ECHO_AT_PEAK, out, curves);
  if (out[0].valid || centroid->n_members < 2)
    return count;
  strongest_direction (est, centroid, &az, &el);
  if (angle_between (az, el, centroid->azimuth, centroid->elevation) <
      BLEND_STEPS * step - 1e-9)
    return count;
  count = estimate_at (est, mic_spectra, centroid, az, el,
      ECHO_AT_EVALUATED, out, curves);
  if (!out[0].valid || count > 1)
    return count;
  {
    /* The other members' weighted mean: the centroid's direction vector
     * times its energy less the strongest peak's share. */
    const double w = centroid->peak_value * centroid->peak_value;
    const SonarVec3 rest = sonar_vec3_sub (sonar_vec3_scale
        (sonar_vec3_from_direction (centroid->azimuth, centroid->elevation),
            centroid->energy), sonar_vec3_scale (sonar_vec3_from_direction
            (az, el), w));
    double raz, rel;
    SonarVelocityEstimate other[2];
    if (!(centroid->energy > w) || sonar_vec3_norm (rest) <= 0.0)
      return count;
    sonar_vec3_to_direction (rest, &raz, &rel);
    if (g->n_elevation <= 1)
      rel = centroid->elevation;
    /* On the image's grid. */
    raz = g->azimuth_first + lround ((raz - g->azimuth_first) /
        g->azimuth_step) * g->azimuth_step;
    if (angle_between (raz, rel, az, el) < BLEND_STEPS * step - 1e-9)
      return count;
    {
      /* The mean of the members lies within a couple of steps of their
       * echo's peak (the members of the strongest echo but its top pull
       * it over): the strongest sum at the detection hypotheses along
       * azimuth there, no nearer the strongest member than BLEND_STEPS. */
      const double a0 = raz;
      double best = -1.0;
      for (int i = -BLEND_SEARCH; i <= BLEND_SEARCH; i++) {
        const double a = CLAMP (a0 + i * g->azimuth_step, -90.0, 90.0);
        double strength;
        if (angle_between (a, rel, az, el) < BLEND_STEPS * step - 1e-9)
          continue;
        coherence_over (est, mic_spectra, centroid->range, a, rel,
            est->hypotheses, est->n_hypotheses, &strength, NULL, NULL, NULL);
        if (strength > best) {
          best = strength;
          raz = a;
        }
      }
    }
    estimate_at (est, mic_spectra, centroid, raz, rel, ECHO_AT_EVALUATED,
        other, NULL);
    if (other[0].valid) {
      out[1] = other[0];
      out[1].second = TRUE;
      count = 2;
    }
  }
  return count;
}

guint
sonar_velocity_estimate (SonarVelocityEstimator * est,
    const SonarComplex * mic_spectra, const SonarCentroid * centroid,
    SonarVelocityEstimate * out, float *curves)
{
  const SonarSplitSpectra split = { est->spectra_re, est->spectra_im };

  sonar_kernel_split (est->spectra_re, est->spectra_im, mic_spectra,
      (gsize) est->setup->geometry.n_microphones * est->band.n_bins);
  return estimate (est, &split, centroid, out, curves);
}

SonarCentroid
sonar_velocity_point (double range, double azimuth, double elevation)
{
  SonarCentroid c = { 0 };

  c.range = c.range_min = c.range_max = c.peak_range = range;
  c.azimuth = azimuth;
  c.elevation = elevation;
  c.position = sonar_vec3_scale (sonar_vec3_from_direction (azimuth,
          elevation), range);
  c.n_members = 1;
  return c;
}

/* The pool -----------------------------------------------------------------*/

/* One worker's echo models (echo_model () and its users: cancel_echo (),
 * echo_shape (), split_blend ()): the estimator it runs, the spectra its
 * echoes were found on, and its buffers, so that the workers examine
 * echoes side by side (split_first ()). */
typedef struct
{
  SonarVelocityEstimator *est;
  SonarSplitSpectra spectra;
  float *model_re, *model_im;   /* echo_shape ()'s, from the first use */
  float *split_re, *split_im;   /* split_blend ()'s, from the first use */
  float *split_t_re, *split_t_im;       /* its candidates' transmit sums */
  double *split_legs;           /* and their microphone legs */
  guint models_reused;          /* by split_blend (), this ping */
  gboolean check_models;        /* made again to compare (tests) */
  float *transmit_re, *transmit_im, *transmit2_re, *transmit2_im;
  float *receive_re, *receive_im;
  double *mic_legs, *emitter_legs;
} EchoWorker;

struct _SonarVelocityPool
{
  SonarWorkers *workers;
  SonarVelocityEstimator *estimators[SONAR_MAX_WORKERS];

  /* The ping being estimated, shared with the workers: its spectra split
   * once for all centroids. */
  float *spectra_re, *spectra_im;
  SonarSplitSpectra spectra;
  const SonarCentroid *centroids;
  guint n_centroids;
  SonarVelocityEstimate *results;
  guint *counts;
  gint next_centroid;           /* the next to estimate, shared */
  /* split_first ()'s: echoes examined, whether any was split. */
  gint n_examined, any_split;

  EchoWorker echo[SONAR_MAX_WORKERS];
  /* Successive cancellation (pool_cancel ()): the spectra less the
   * accepted echoes' models, split; per centroid (grown to the largest
   * ping's, then kept): the failed ones' copies, indices and estimates on
   * the residual, and which estimates are cancelled. */
  float *residual_re, *residual_im;
  guint capacity;
  SonarCentroid *failed;
  guint *failed_index, *failed_counts;
  SonarVelocityEstimate *failed_results;
  gboolean *cancelled;
  double *screens;              /* [centroid]: screen_snr, when not NULL */
  double *screen_snr;           /* [centroid] of the ping (capacity) */
  /* sonar_velocity_pool_residual ()'s valid estimates, each where its
   * model is placed (model_direction ()); grown to the largest ping's. */
  SonarVelocityEstimate *placed;
  guint n_placed, placed_capacity;
};

/* Whether @a and @b are one echo: within the band's range resolution c/2B
 * of each other (or a range step, where coarser: near the rim one echo's
 * estimates from two centroids on its beam's ridge lay 2.85 mm apart, a step
 * and a little more, the range of its peak moving with the direction focused
 * on), their directions within an image step as it spans at boresight
 * (compared in the array's plane, x and y of the unit vectors, where the
 * beam is as wide everywhere: off boresight a degree spans less of it, and
 * at 60 degrees of elevation one echo's estimates lay 3.4 degrees of azimuth
 * apart), their velocities within half a Doppler main lobe. */
static gboolean
same_echo (const SonarVelocityEstimator * est, const SonarVelocityEstimate * a,
    const SonarVelocityEstimate * b)
{
  const SonarImageGrid *g = &est->grid;
  const SonarVec3 ua = sonar_vec3_from_direction (a->azimuth, a->elevation);
  const SonarVec3 ub = sonar_vec3_from_direction (b->azimuth, b->elevation);
  const double step = sin (G_PI / 180.0 * MAX (g->azimuth_step,
          g->elevation_step));
  const double resolution = MAX (g->range_step, est->setup->speed_of_sound /
      (2.0 * (est->setup->band_high - est->setup->band_low)));

  return a->valid && b->valid && fabs (a->range - b->range) <= resolution
      && hypot (ua.x - ub.x, ua.y - ub.y) <= step
      && fabs (a->radial_velocity - b->radial_velocity) <= 0.5 *
      est->main_lobe;
}

/* Centroids a few millimetres apart (wardcluster's distance set that low)
 * may each see both of two echoes: an estimate of an echo that a centroid
 * before it reports is dropped. */
static void
drop_duplicates (const SonarVelocityEstimator * est, guint n_centroids,
    SonarVelocityEstimate * results, guint * counts)
{
  for (guint k = 1; k < n_centroids; k++) {
    for (guint i = 0; i < counts[k];) {
      gboolean seen = FALSE;
      for (guint j = 0; j < k && !seen; j++)
        for (guint m = 0; m < counts[j] && !seen; m++)
          seen = same_echo (est, &results[2 * k + i], &results[2 * j + m]);
      if (!seen) {
        i++;
        continue;
      }
      if (i == 0 && counts[k] == 2)
        results[2 * k] = results[2 * k + 1];
      counts[k]--;
    }
  }
}

/* Worker @w takes the next centroid not taken until none is left: a
 * centroid the prescreen rejects costs a tenth of one it does not, so a
 * fixed share (w, w + n, ...) left one thread waiting on the other. Each
 * estimate depends on its centroid alone: the results do not depend on
 * which thread made them. */
static void
estimate_share (gpointer data, guint w, guint n)
{
  SonarVelocityPool *pool = data;

  (void) n;
  for (;;) {
    const guint k = (guint) g_atomic_int_add (&pool->next_centroid, 1);
    if (k >= pool->n_centroids)
      break;
    pool->counts[k] = estimate (pool->estimators[w], &pool->spectra,
        &pool->centroids[k], &pool->results[2 * k], NULL);
    if (pool->screens)
      pool->screens[k] = pool->estimators[w]->screen_snr;
  }
}

SonarVelocityPool *
sonar_velocity_pool_new (SonarDopplerBank * bank, const SonarImageGrid * grid,
    const SonarVelocityParams * params, guint n_threads, GError ** error)
{
  SonarVelocityPool *pool = g_new0 (SonarVelocityPool, 1);
  const SonarBand *band = sonar_doppler_bank_band (bank);
  const gsize size = band ? (gsize) band->n_bins *
      sonar_doppler_bank_get_setup (bank)->geometry.n_microphones : 0;

  pool->spectra_re = g_new (float, size);
  pool->spectra_im = g_new (float, size);
  pool->residual_re = g_new (float, size);
  pool->residual_im = g_new (float, size);
  pool->spectra.re = pool->spectra_re;
  pool->spectra.im = pool->spectra_im;
  pool->workers = sonar_workers_new (n_threads, error);
  if (!pool->workers)
    goto failed;
  for (guint w = 0; w < sonar_workers_count (pool->workers); w++) {
    const SonarSetup *setup = sonar_doppler_bank_get_setup (bank);
    EchoWorker *ew = &pool->echo[w];
    pool->estimators[w] = estimator_new (bank, grid, params,
        w ? pool->estimators[0] : NULL, error);
    if (!pool->estimators[w])
      goto failed;
    ew->est = pool->estimators[w];
    ew->transmit_re = g_new (float, band->n_bins);
    ew->transmit_im = g_new (float, band->n_bins);
    ew->transmit2_re = g_new (float, band->n_bins);
    ew->transmit2_im = g_new (float, band->n_bins);
    ew->receive_re = g_new (float, band->n_bins);
    ew->receive_im = g_new (float, band->n_bins);
    ew->mic_legs = g_new (double, setup->geometry.n_microphones);
    ew->emitter_legs = g_new (double, setup->geometry.n_emitters);
  }
  return pool;

failed:
  sonar_velocity_pool_free (pool);
  return NULL;
}

gboolean
sonar_velocity_estimator_retune (SonarVelocityEstimator * est,
    const SonarVelocityParams * params, GError ** error)
{
  SonarVelocityParams tuned = est->params;

  g_return_val_if_fail (est && params, FALSE);
  if (params->window_directions != est->params.window_directions
      || params->window_ranges != est->params.window_ranges
      || !params->refine != !est->params.refine
      || params->emitters != est->params.emitters) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "velocity: "
        "window-directions, window-ranges, refine and emitters are set when "
        "the estimator is made, not between pings");
    return FALSE;
  }
  tuned.min_variance = params->min_variance;
  tuned.min_agreeing_emitters = params->min_agreeing_emitters;
  tuned.min_coherence = params->min_coherence;
  tuned.pooled_snr_db = params->pooled_snr_db;
  tuned.coherence_pfa = params->coherence_pfa;
  tuned.second_peak_db = params->second_peak_db;
  if (!params_valid (&tuned, error))
    return FALSE;
  est->params = tuned;
  est->min_coherence = sonar_velocity_params_coherence_threshold (&tuned,
      est->n_emitters);
  est->min_pooled_snr = pooled_snr (&tuned);
  return TRUE;
}

gboolean
sonar_velocity_pool_retune (SonarVelocityPool * pool,
    const SonarVelocityParams * params, GError ** error)
{
  const guint n = sonar_workers_count (pool->workers);

  /* All or none: the first estimator checks for every one. */
  if (!sonar_velocity_estimator_retune (pool->estimators[0], params, error))
    return FALSE;
  for (guint w = 1; w < n; w++)
    sonar_velocity_estimator_retune (pool->estimators[w], params, NULL);
  return TRUE;
}

void
sonar_velocity_pool_free (SonarVelocityPool * pool)
{
  if (!pool)
    return;
  for (guint w = 0; w < SONAR_MAX_WORKERS; w++) {
    EchoWorker *ew = &pool->echo[w];
    sonar_velocity_estimator_free (pool->estimators[w]);
    g_free (ew->model_re);
    g_free (ew->model_im);
    g_free (ew->split_re);
    g_free (ew->split_im);
    g_free (ew->split_t_re);
    g_free (ew->split_t_im);
    g_free (ew->split_legs);
    g_free (ew->transmit_re);
    g_free (ew->transmit_im);
    g_free (ew->transmit2_re);
    g_free (ew->transmit2_im);
    g_free (ew->receive_re);
    g_free (ew->receive_im);
    g_free (ew->mic_legs);
    g_free (ew->emitter_legs);
  }
  sonar_workers_free (pool->workers);
  g_free (pool->spectra_re);
  g_free (pool->spectra_im);
  g_free (pool->residual_re);
  g_free (pool->residual_im);
  g_free (pool->failed);
  g_free (pool->failed_index);
  g_free (pool->failed_counts);
  g_free (pool->failed_results);
  g_free (pool->cancelled);
  g_free (pool->screen_snr);
  g_free (pool->placed);
  g_free (pool);
}

/* The model of an echo at the position of @e and the bank velocity @index:
 * every emitter's template on its path to each microphone (sonar-steering.h's
 * delay model: X_j(k) = a sum_n S_n(k) exp (-i (k0 + k dk) (2 r + e_n /
 * alpha + m_j))). Sets ew->mic_legs and the transmit sum @t_re, @t_im
 * (conjugated templates); subtract_model () and model_dot () read them. */
static void
echo_model (EchoWorker * ew, const SonarVelocityEstimate * e,
    guint index, float *t_re, float *t_im)
{
  const SonarVelocityEstimator *est = ew->est;
  const SonarSteering *st = &est->steering;
  const guint n_emitters = est->setup->geometry.n_emitters;
  const double v = sonar_doppler_bank_velocity (est->bank, index);
  const SonarSplitSpectra templates = sonar_doppler_bank_spectra (est->bank,
      index);

  sonar_steering_legs (st, sonar_vec3_from_direction (e->azimuth,
          e->elevation), e->range, ew->mic_legs, ew->emitter_legs);
  sonar_steering_transmit_sum (st, &templates, ew->emitter_legs,
      sonar_steering_stretch (st, v), 0, n_emitters, t_re, t_im);
}

/* Microphones whose models subtract_model () makes together: one vector
 * of each value, a lane a microphone. */
#define MODEL_LANES 4
typedef float ModelLanes __attribute__ ((vector_size (MODEL_LANES *
            sizeof (float))));

/* The phasors of the models of the @lanes microphones from @j on, at
 * the band's first bin (@start: amplitude times exp (-i k0 path)) and
 * their turn a bin (@turn: exp (-i dk path)), path their echo's at
 * @range m (ew->mic_legs), lane l's amplitude @a times gains[j + l]
 * (@gains NULL: 1); in float: the phasor's drift over the band's bins
 * stays far below the model's own error. */
static inline __attribute__ ((always_inline)) void
model_lane_phasors (const EchoWorker * ew, double range, double complex a,
    const double complex * gains, guint j, guint lanes, ModelLanes * start_re,
    ModelLanes * start_im, ModelLanes * turn_re, ModelLanes * turn_im)
{
  const SonarSteering *st = &ew->est->steering;

  for (guint l = 0; l < lanes; l++) {
    const double path = 2.0 * range + ew->mic_legs[j + l];
    const double complex p0 = (gains ? a * gains[j + l] : a) *
        cexp (-I * st->k0 * path);
    (*turn_re)[l] = (float) cos (st->dk * path);
    (*turn_im)[l] = (float) -sin (st->dk * path);
    (*start_re)[l] = (float) creal (p0);
    (*start_im)[l] = (float) cimag (p0);
  }
}

/* subtract_model () on the @lanes (at most MODEL_LANES) microphones from
 * @j on: each one's phasor turns a bin at a time, a chain of dependent
 * products that waits on each step alone; the lanes' chains run side by
 * side in vectors. Each lane's arithmetic is one microphone's as it was
 * (the same float operations, element by element). With @from_zero, the
 * output is subtracted from zero, not read: what cleared buffers would
 * hold, bit for bit, without clearing them. */
static inline __attribute__ ((always_inline)) void
subtract_model_lanes (const EchoWorker * ew, double range, double complex a,
    const double complex * gains, const float *t_re, const float *t_im,
    float *re_out, float *im_out, guint j, guint lanes, gboolean from_zero)
{
  const guint nb = ew->est->band.n_bins;
  ModelLanes sr = { 0.0f }, si = { 0.0f }, pr = { 0.0f }, pi = { 0.0f };
  float *re[MODEL_LANES], *im[MODEL_LANES];

  /* a exp (-i k path) conj (t(k)) */
  model_lane_phasors (ew, range, a, gains, j, lanes, &pr, &pi, &sr, &si);
  for (guint l = 0; l < lanes; l++) {
    re[l] = re_out + (gsize) (j + l) * nb;
    im[l] = im_out + (gsize) (j + l) * nb;
  }
  for (guint k = 0; k < nb; k++) {
    const float tr = t_re[k], ti = -t_im[k];
    const ModelLanes m_re = pr * tr - pi * ti, m_im = pr * ti + pi * tr;
    const ModelLanes q = pr * sr - pi * si;
    pi = pr * si + pi * sr;
    pr = q;
    /* MODEL_LANES (the pragma takes no macro). */
#pragma GCC unroll 4
    for (guint l = 0; l < lanes; l++) {
      re[l][k] = (from_zero ? 0.0f : re[l][k]) - m_re[l];
      im[l][k] = (from_zero ? 0.0f : im[l][k]) - m_im[l];
    }
  }
}

/* Over the @lanes (at most MODEL_LANES) microphones from @j on, as
 * subtract_model_lanes () makes their models m_j (of transmit sum @t_re,
 * @t_im at @range m): <m_j, X_j> into @dot, |m_j|^2 into @model and
 * |X_j|^2 into @data, summed over the band in float (one lane a
 * microphone: their phasors' chains side by side). */
static inline __attribute__ ((always_inline)) void
model_dots_lanes (const EchoWorker * ew, double range, const float *t_re,
    const float *t_im, const float *x_re, const float *x_im, guint j,
    guint lanes, double complex * dot, double *model, double *data)
{
  const guint nb = ew->est->band.n_bins;
  ModelLanes sr = { 0.0f }, si = { 0.0f }, pr = { 0.0f }, pi = { 0.0f };
  ModelLanes d_re = { 0.0f }, d_im = { 0.0f }, mm = { 0.0f }, xx = { 0.0f };
  const float *re[MODEL_LANES], *im[MODEL_LANES];

  model_lane_phasors (ew, range, 1.0, NULL, j, lanes, &pr, &pi, &sr, &si);
  for (guint l = 0; l < lanes; l++) {
    re[l] = x_re + (gsize) (j + l) * nb;
    im[l] = x_im + (gsize) (j + l) * nb;
  }
  for (guint k = 0; k < nb; k++) {
    const float tr = t_re[k], ti = -t_im[k];
    const ModelLanes m_re = pr * tr - pi * ti, m_im = pr * ti + pi * tr;
    const ModelLanes q = pr * sr - pi * si;
    ModelLanes v_re = { 0.0f }, v_im = { 0.0f };
    pi = pr * si + pi * sr;
    pr = q;
#pragma GCC unroll 4
    for (guint l = 0; l < lanes; l++) {
      v_re[l] = re[l][k];
      v_im[l] = im[l][k];
    }
    d_re += m_re * v_re + m_im * v_im;
    d_im += m_re * v_im - m_im * v_re;
    mm += m_re * m_re + m_im * m_im;
    xx += v_re * v_re + v_im * v_im;
  }
  for (guint l = 0; l < lanes; l++) {
    dot[j + l] = d_re[l] + I * d_im[l];
    model[j + l] = mm[l];
    data[j + l] = xx[l];
  }
}

/* subtract_model () and model_into () over every microphone; with
 * @gains (NULL: 1), microphone j's model times gains[j]. */
static inline __attribute__ ((always_inline)) void
subtract_model_mics (EchoWorker * ew, double range, double complex a,
    const double complex * gains, const float *t_re, const float *t_im,
    float *re_out, float *im_out, gboolean from_zero)
{
  const guint n_mics = ew->est->setup->geometry.n_microphones;
  guint j = 0;

  for (; j + MODEL_LANES <= n_mics; j += MODEL_LANES)
    subtract_model_lanes (ew, range, a, gains, t_re, t_im, re_out, im_out,
        j, MODEL_LANES, from_zero);
  for (; j < n_mics; j++)
    subtract_model_lanes (ew, range, a, gains, t_re, t_im, re_out, im_out,
        j, 1, from_zero);
}

/* Subtracts @a times the model of transmit sum @t_re, @t_im (of an echo at
 * @range m, ew->mic_legs its legs) from the spectra @re_out, @im_out. */
static void
subtract_model (EchoWorker * ew, double range, double complex a,
    const float *t_re, const float *t_im, float *re_out, float *im_out)
{
  subtract_model_mics (ew, range, a, NULL, t_re, t_im, re_out, im_out,
      FALSE);
}

/* The model of transmit sum @t_re, @t_im (of an echo at @range m,
 * ew->mic_legs its legs) into @re_out, @im_out: subtract_model () of -1
 * times it from zeroed spectra, in one pass over them instead of two. */
static void
model_into (EchoWorker * ew, double range, const float *t_re,
    const float *t_im, float *re_out, float *im_out)
{
  subtract_model_mics (ew, range, -1.0, NULL, t_re, t_im, re_out, im_out,
      TRUE);
}

/* <model, X> over every microphone and bin, for the model of transmit sum
 * @t_re, @t_im at @range m: sum_k t(k) exp (i k 2 r) R(k), R the receive
 * sum of X (ew->receive_re, _im); the phasor turned a bin at a time
 * (real arithmetic: C's complex product checks for NaN). *@power
 * receives sum_k |t(k)|^2. */
static double complex
model_dot (const EchoWorker * ew, double range, const float *t_re,
    const float *t_im, double *power)
{
  const SonarVelocityEstimator *est = ew->est;
  const SonarSteering *st = &est->steering;
  const guint nb = est->band.n_bins;
  const double path = 2.0 * range;
  const double sr = cos (st->dk * path), si = sin (st->dk * path);
  double pr = cos (st->k0 * path), pi = sin (st->k0 * path);
  double nr = 0.0, ni = 0.0, den = 0.0;

  for (guint k = 0; k < nb; k++) {
    const double tr = t_re[k], ti = t_im[k];
    const double rr = ew->receive_re[k], ri = ew->receive_im[k];
    /* t ph */
    const double ar = tr * pr - ti * pi, ai = tr * pi + ti * pr;
    const double q = pr * sr - pi * si;
    nr += ar * rr - ai * ri;
    ni += ar * ri + ai * rr;
    den += tr * tr + ti * ti;
    pi = pr * si + pi * sr;
    pr = q;
  }
  *power = den;
  return nr + I * ni;
}

/* The least-squares complex amplitudes @x of two models m_a, m_b fitted
 * to the spectra X: the 2 x 2 normal equations, @g_aa = |m_a|^2, @g_bb =
 * |m_b|^2, @g_ab = <m_a, m_b>, @n_a = <m_a, X>, @n_b = <m_b, X>. FALSE
 * (and @x untouched) when the determinant is no more than @min_condition
 * g_aa g_bb: models too alike to be told apart. */
static gboolean
fit_two_models (double g_aa, double g_bb, double complex g_ab,
    double complex n_a, double complex n_b, double min_condition,
    double complex x[2])
{
  const double det = g_aa * g_bb - cabs2 (g_ab);

  if (!(g_aa > 0.0 && g_bb > 0.0 && det > min_condition * g_aa * g_bb))
    return FALSE;
  x[0] = (g_bb * n_a - g_ab * n_b) / det;
  x[1] = (g_aa * n_b - conj (g_ab) * n_a) / det;
  return TRUE;
}

/* The spectral shapes an echo's model may take across the band (the
 * echo's amplitude a polynomial in frequency, of this many terms):
 * what the emissions do not say of a real recording tilts each echo's
 * spectrum, and a model of the emissions' own spectrum leaves that tilt.
 * Air absorbs 20-80 kHz at 0.5-2.6 dB/m (ISO 9613-1): at 4 m an echo's
 * top is 28 dB under its bottom, and a flat model leaves -6.3 dB of it,
 * a cubic -44 dB (numpy fit over the band); a resonance the emissions
 * file lacks colours each emitter smoothly likewise. */
#define MODEL_SHAPES 4
/* The shapes are taken only where the data show them: when the energy
 * they explain beyond one amplitude a template, per real degree of
 * freedom, is this many times what is left over the spectra per degree
 * (an F test: noise alone gives about 1, past 4 once in 10^5 for the 12
 * degrees of two templates' shapes), so that a faint echo's model is not
 * bent to its noise. */
#define SHAPE_EVIDENCE 4.0

/* Legendre polynomials P_0 .. P_{MODEL_SHAPES - 1} at bin @k of @n
 * (x from -1 at the band's first bin to 1 at its last): nearly
 * orthogonal over the band, so the shapes' normal equations stay well
 * conditioned. */
static inline void
model_shapes (guint k, guint n, double g[MODEL_SHAPES])
{
  const double x = n > 1 ? 2.0 * k / (n - 1) - 1.0 : 0.0;

  g[0] = 1.0;
  g[1] = x;
  for (guint p = 2; p < MODEL_SHAPES; p++)
    g[p] = ((2.0 * p - 1.0) * x * g[p - 1] - (p - 1.0) * g[p - 2]) / p;
}

/* The least-squares amplitudes of the @n models listed in @use (indices
 * into @gram and @dots): the normal equations G a = dots, G[i][j] =
 * @gram's lower triangle times @n_mics (Hermitian), solved as the real
 * symmetric [[A, -B], [B, A]] [u; v] = [c; d] for G = A + i B,
 * a = u + i v, by Cholesky. @a receives every model's amplitude (0 for
 * those not used); returns the energy the fit explains, a^H G a = Re
 * sum conj (a_i) dots_i, or -1 when G is not positive definite (models
 * too alike to be told apart). */
static double
solve_models (double complex gram[2 * MODEL_SHAPES][2 * MODEL_SHAPES],
    const double complex * dots, const guint * use, guint n, guint n_mics,
    double complex a[2 * MODEL_SHAPES])
{
  double system[16 * MODEL_SHAPES * MODEL_SHAPES], x[4 * MODEL_SHAPES];
  double explained = 0.0;

  for (guint i = 0; i < n; i++)
    for (guint j = 0; j < n; j++) {
      const guint r = use[i], c = use[j];
      const double complex gij = (c <= r ? gram[r][c] : conj (gram[c][r])) *
          n_mics;
      system[i * 2 * n + j] = creal (gij);
      system[i * 2 * n + n + j] = -cimag (gij);
      system[(n + i) * 2 * n + j] = cimag (gij);
      system[(n + i) * 2 * n + n + j] = creal (gij);
    }
  for (guint i = 0; i < n; i++) {
    x[i] = creal (dots[use[i]]);
    x[n + i] = cimag (dots[use[i]]);
  }
  if (!(creal (gram[use[0]][use[0]]) > 0.0)
      || !sonar_linalg_cholesky (system, 2 * n))
    return -1.0;
  sonar_linalg_cholesky_solve (system, 2 * n, x);
  for (guint i = 0; i < 2 * MODEL_SHAPES; i++)
    a[i] = 0.0;
  for (guint i = 0; i < n; i++) {
    a[use[i]] = x[i] + I * x[n + i];
    explained += creal (conj (a[use[i]]) * dots[use[i]]);
  }
  return explained;
}

/* sum |X|^2 over the @n values of @spectra: in float lanes side by side
 * (a chain of dependent double sums waited on each add: a third of
 * fit_echo ()'s time), each lane's sum of n / 8 values within 1e-4 of
 * the exact; what the F test of fit_echo () needs. */
static double
spectra_energy (const SonarSplitSpectra * spectra, gsize n)
{
  typedef float EnergyLanes __attribute__ ((vector_size (8 * sizeof (float))));
  EnergyLanes sum = { 0.0f };
  double energy = 0.0;
  gsize i = 0;

  for (; i + 8 <= n; i += 8) {
    EnergyLanes re, im;
    memcpy (&re, spectra->re + i, sizeof re);
    memcpy (&im, spectra->im + i, sizeof im);
    sum += re * re + im * im;
  }
  for (guint l = 0; l < 8; l++)
    energy += sum[l];
  for (; i < n; i++)
    energy += (double) spectra->re[i] * spectra->re[i] +
        (double) spectra->im[i] * spectra->im[i];
  return energy;
}

/* Fits the model of the echo @e to @spectra: a point at its range and
 * direction, its template between the two bank velocities either side
 * of its own (the bank is 0.05 m/s apart by default: the nearest one
 * alone leaves up to half a step's error in the model, which the echoes
 * accepted on a residual inherit), each with an amplitude that is a
 * polynomial in frequency of @shapes terms (1 to MODEL_SHAPES; more than
 * one where SHAPE_EVIDENCE says so): the least-squares fit of those
 * models (echo_model () times the shapes) over every
 * microphone and bin, their complex amplitudes from the normal equations
 * (Hermitian, solved as the real symmetric system twice their size by
 * Cholesky). The models are X_j(k) = A(k) exp (-i k path_j) conj (t(k)):
 * their inner products with the spectra are model_dot ()'s sums weighted
 * by the shapes, and with each other the transmit sums' products times
 * the microphones' count. The fitted model's transmit sum (amplitudes
 * folded in) into ew->transmit_re, _im, its legs in ew->mic_legs; FALSE
 * when no model fits (spectra of zeros). */
static gboolean
fit_echo (EchoWorker * ew, const SonarVelocityEstimate * e,
    const SonarSplitSpectra * spectra, guint shapes)
{
  enum { N = 2 * MODEL_SHAPES };
  const SonarVelocityEstimator *est = ew->est;
  const SonarSteering *st = &est->steering;
  const guint n_mics = est->setup->geometry.n_microphones;
  const guint nb = est->band.n_bins;
  const guint nv = est->n_velocities;
  const guint b0 = e->bank_index;
  const double v0 = sonar_doppler_bank_velocity (est->bank, b0);
  const double path = 2.0 * e->range;
  const double sr = cos (st->dk * path), si = sin (st->dk * path);
  double pr = cos (st->k0 * path), pi = sin (st->k0 * path);
  const float *t_re[2] = { ew->transmit_re, ew->transmit2_re };
  const float *t_im[2] = { ew->transmit_im, ew->transmit2_im };
  double complex gram[N][N] = { {0.0} }, dots[N] = { 0.0 };
  double complex amplitudes[N] = { 0.0 }, shaped[N];
  double energy = 0.0;
  gboolean fitted = FALSE;
  double g00[MODEL_SHAPES][MODEL_SHAPES] = { {0.0} };
  double g11[MODEL_SHAPES][MODEL_SHAPES] = { {0.0} };
  double g10r[MODEL_SHAPES][MODEL_SHAPES] = { {0.0} };
  double g10i[MODEL_SHAPES][MODEL_SHAPES] = { {0.0} };
  guint b1, n_templates;

  if (isfinite (e->radial_velocity) && e->radial_velocity > v0)
    b1 = b0 + 1 < nv ? b0 + 1 : b0;
  else
    b1 = b0 > 0 ? b0 - 1 : b0;
  n_templates = b1 != b0 ? 2 : 1;
  echo_model (ew, e, b0, ew->transmit_re, ew->transmit_im);
  if (b1 != b0)
    echo_model (ew, e, b1, ew->transmit2_re, ew->transmit2_im);
  sonar_steering_receive_sum (st, spectra, ew->mic_legs,
      ew->receive_re, ew->receive_im);
  /* The F test's (the rounds' fits of one shape need none). */
  if (shapes > 1)
    energy = spectra_energy (spectra, (gsize) n_mics * nb);
  /* Model i = (template i / MODEL_SHAPES, shape i % MODEL_SHAPES):
   * dots[i] = <X, m_i>, gram[i][i'] = <m_i', m_i> / n_mics
   * = sum_k g_p g_p' t_b conj (t_b'), gathered per template pair (b, b')
   * and shape pair p <= p' < @shapes (g_p g_p' is symmetric): |t_0|^2,
   * |t_1|^2 and t_0 conj (t_1) once a bin. */
  for (guint k = 0; k < nb; k++) {
    const double rr = ew->receive_re[k], ri = ew->receive_im[k];
    const double t0r = t_re[0][k], t0i = t_im[0][k];
    /* t_0 (k) exp (i k 2 r) R(k), and t_1's */
    const double a0r = t0r * pr - t0i * pi, a0i = t0r * pi + t0i * pr;
    const double d0r = a0r * rr - a0i * ri, d0i = a0r * ri + a0i * rr;
    const double w00 = t0r * t0r + t0i * t0i;
    double g[MODEL_SHAPES], q;
    model_shapes (k, nb, g);
    for (guint p = 0; p < shapes; p++) {
      dots[p] += g[p] * (d0r + I * d0i);
      for (guint p2 = 0; p2 <= p; p2++)
        g00[p][p2] += g[p] * g[p2] * w00;
    }
    if (n_templates == 2) {
      const double t1r = t_re[1][k], t1i = t_im[1][k];
      const double a1r = t1r * pr - t1i * pi, a1i = t1r * pi + t1i * pr;
      const double d1r = a1r * rr - a1i * ri, d1i = a1r * ri + a1i * rr;
      const double w11 = t1r * t1r + t1i * t1i;
      /* t_1 conj (t_0) */
      const double w10r = t1r * t0r + t1i * t0i, w10i = t1i * t0r - t1r * t0i;
      for (guint p = 0; p < shapes; p++) {
        dots[MODEL_SHAPES + p] += g[p] * (d1r + I * d1i);
        for (guint p2 = 0; p2 <= p; p2++) {
          const double gg = g[p] * g[p2];
          g11[p][p2] += gg * w11;
          g10r[p][p2] += gg * w10r;
          g10i[p][p2] += gg * w10i;
        }
      }
    }
    q = pr * sr - pi * si;
    pi = pr * si + pi * sr;
    pr = q;
  }
  for (guint p = 0; p < shapes; p++)
    for (guint p2 = 0; p2 <= p; p2++) {
      gram[p][p2] = g00[p][p2];
      gram[MODEL_SHAPES + p][MODEL_SHAPES + p2] = g11[p][p2];
      /* rows of template 1, columns of template 0: t_1 conj (t_0),
       * every shape pair (the lower triangle holds them all) */
      gram[MODEL_SHAPES + p][p2] = g10r[p][p2] + I * g10i[p][p2];
      gram[MODEL_SHAPES + p2][p] = g10r[p][p2] + I * g10i[p][p2];
    }
  /* One amplitude a template, and the shapes where the data show them;
   * both templates, or (their models too alike) the nearest alone. */
  for (guint b = n_templates; b > 0; b--) {
    guint flat[2], every[2 * MODEL_SHAPES];
    double e_flat, e_every, degrees;
    for (guint i = 0; i < b; i++)
      flat[i] = i * MODEL_SHAPES;
    for (guint i = 0; i < b * shapes; i++)
      every[i] = i / shapes * MODEL_SHAPES + i % shapes;
    e_flat = solve_models (gram, dots, flat, b, n_mics, amplitudes);
    if (e_flat < 0.0)
      continue;
    fitted = TRUE;
    n_templates = b;
    if (shapes == 1)
      break;
    e_every = solve_models (gram, dots, every, b * shapes, n_mics, shaped);
    /* Real degrees of freedom: the shapes', and what is left's. */
    degrees = 2.0 * n_mics * nb - 2.0 * b * shapes;
    if (e_every > e_flat && (e_every - e_flat) / (2.0 * b * (shapes - 1)) >
        SHAPE_EVIDENCE * (energy - e_every) / degrees)
      memcpy (amplitudes, shaped, sizeof (amplitudes));
    break;
  }
  if (!fitted)
    return FALSE;
  /* The model's transmit sum, conj (A_b (k)) t_b (k) over the templates,
   * into the first's. */
  for (guint k = 0; k < nb; k++) {
    double g[MODEL_SHAPES];
    double complex sum = 0.0;
    model_shapes (k, nb, g);
    for (guint b = 0; b < n_templates; b++) {
      double complex amplitude = 0.0;
      for (guint p = 0; p < shapes; p++)
        amplitude += g[p] * amplitudes[b * MODEL_SHAPES + p];
      sum += conj (amplitude) * (t_re[b][k] + I * t_im[b][k]);
    }
    ew->transmit_re[k] = (float) creal (sum);
    ew->transmit_im[k] = (float) cimag (sum);
  }
  return TRUE;
}

/* model_direction ()'s steps either side of an echo's direction, in
 * image steps: a quarter (a quarter of a degree on the fan, half a degree
 * on the hemisphere), where the logarithm of a 3-degree beam is a
 * parabola to well within the 0.01 degree the vertex is wanted to. */
#define MODEL_DIRECTION_STEP 0.25

/* The power the model m of @e at its bank velocity (one template, one
 * amplitude), placed in direction (@azimuth, @elevation), explains in
 * @spectra: |<m, X>|^2 / |m|^2, times the microphones. */
static double
explained_power (EchoWorker * ew, const SonarVelocityEstimate * e,
    double azimuth, double elevation, const SonarSplitSpectra * spectra)
{
  SonarVelocityEstimate at = *e;
  double power;
  double complex dot;

  at.azimuth = CLAMP (azimuth, -90.0, 90.0);
  at.elevation = CLAMP (elevation, -90.0, 90.0);
  echo_model (ew, &at, e->bank_index, ew->transmit_re, ew->transmit_im);
  sonar_steering_receive_sum (&ew->est->steering, spectra, ew->mic_legs,
      ew->receive_re, ew->receive_im);
  dot = model_dot (ew, e->range, ew->transmit_re, ew->transmit_im, &power);
  return power > 0.0 ? cabs2 (dot) / power : 0.0;
}

/* Moves the direction of @e, where its model is placed, to the vertex
 * of a parabola in the logarithm of explained_power () through it and
 * MODEL_DIRECTION_STEP image steps either side: along azimuth, then on a
 * 3-D grid along elevation; @curvature (may be NULL) receives the
 * parabolas' second derivatives of ln (amplitude) per degree^2, along
 * azimuth and elevation (NaN where none was fitted). On the fan an
 * estimate's direction is its centroid's, 0.01-0.1 degree off a lone
 * echo's (the members' weighted mean); 0.1 degree leaves the echo at -28
 * dB in the residual image, the vertex at -41 (-43 with each
 * microphone's gain; tests/test-residual.c). */
static void
model_direction (EchoWorker * ew, SonarVelocityEstimate * e,
    const SonarSplitSpectra * spectra, double curvature[2])
{
  const SonarImageGrid *g = &ew->est->grid;
  const double steps[2] = { MODEL_DIRECTION_STEP * g->azimuth_step,
    MODEL_DIRECTION_STEP * g->elevation_step
  };

  if (curvature)
    curvature[0] = curvature[1] = NAN;
  for (guint axis = 0; axis < (g->n_elevation > 1 ? 2u : 1u); axis++) {
    double power[3], l[3];
    double *angle = axis == 0 ? &e->azimuth : &e->elevation;
    if (!(steps[axis] > 0.0))
      continue;
    for (int i = -1; i <= 1; i++)
      power[i + 1] = explained_power (ew, e, e->azimuth + (axis == 0 ? i *
              steps[0] : 0.0), e->elevation + (axis == 1 ? i * steps[1] :
              0.0), spectra);
    if (!(power[0] > 0.0 && power[1] > 0.0 && power[2] > 0.0))
      continue;
    for (guint i = 0; i < 3; i++)
      l[i] = log (power[i]);
    /* Within the half space in front of the array (a vertex beyond 90
     * degrees would be behind it), as the probes are. */
    *angle = CLAMP (*angle + steps[axis] * parabola_offset (l[0], l[1],
            l[2], 1.0), -90.0, 90.0);
    if (curvature)
      curvature[axis] = 0.5 * (l[0] + l[2] - 2.0 * l[1]) /
          (steps[axis] * steps[axis]);
  }
}

/* The spread of a microphone's complex gain about the model's that
 * subtract_model_per_microphone () expects: the legs' spreading across
 * the array (a few per cent at 1 m and 20 degrees), what is left of the
 * direction, an uncalibrated microphone's gain and phase (1.5 dB and 10
 * degrees: 0.2). 0.1: a gain within 1 dB and 6 degrees. */
#define MICROPHONE_GAIN_SPREAD 0.1

/* Subtracts the model of transmit sum ew->transmit_re, _im at @range m
 * (ew->mic_legs its legs) from each microphone of @re, @im times the
 * microphone's own complex gain: the least-squares gain over the band,
 * <m_j, X_j> / |m_j|^2, shrunk towards 1 (the model's) by its noise, the
 * power the model leaves in X_j per bin over |m_j|^2 (a Wiener weight,
 * spread^2 / (spread^2 + variance)): a strong echo takes its own gains,
 * a faint one, whose gains the noise and its neighbours would set, the
 * model's. Microphones 3 dB and 20 degrees off left a lone echo at -36.5
 * dB with one gain over the array, at -43 with these
 * (tests/test-residual.c). */
static void
subtract_model_per_microphone (EchoWorker * ew, double range, float *re,
    float *im)
{
  const guint n_mics = ew->est->setup->geometry.n_microphones;
  const guint nb = ew->est->band.n_bins;
  const double spread2 = MICROPHONE_GAIN_SPREAD * MICROPHONE_GAIN_SPREAD;
  double complex dot[SONAR_MAX_MICROPHONES], gains[SONAR_MAX_MICROPHONES];
  double model[SONAR_MAX_MICROPHONES], data[SONAR_MAX_MICROPHONES];
  guint j = 0;

  for (; j + MODEL_LANES <= n_mics; j += MODEL_LANES)
    model_dots_lanes (ew, range, ew->transmit_re, ew->transmit_im, re, im,
        j, MODEL_LANES, dot, model, data);
  for (; j < n_mics; j++)
    model_dots_lanes (ew, range, ew->transmit_re, ew->transmit_im, re, im,
        j, 1, dot, model, data);
  for (j = 0; j < n_mics; j++) {
    gains[j] = 1.0;
    if (model[j] > 0.0) {
      const double left = MAX (data[j] - cabs2 (dot[j]) / model[j], 0.0);
      const double variance = left / nb / model[j];
      const double weight = spread2 / (spread2 + variance);
      gains[j] = 1.0 + weight * (dot[j] / model[j] - 1.0);
    }
  }
  subtract_model_mics (ew, range, 1.0, gains, ew->transmit_re,
      ew->transmit_im, re, im, FALSE);
}

/* Subtracts from the residual @re, @im the model of the echo @e fitted
 * to it (fit_echo (), @shapes terms at most). The successive
 * cancellation's rounds fit one amplitude a template: shaped models
 * there took in part of the neighbours they re-estimate (test-crowded's
 * 20 x 20 grid: 5 false objects, the 10 x 10 grid's worst velocity error
 * 0.0471 -> 0.0515 m/s); the residual search cancels with the shapes
 * (sonar_velocity_pool_residual ()). */
static void
cancel_echo (EchoWorker * ew, const SonarVelocityEstimate * e, float *re,
    float *im, guint shapes)
{
  const SonarSplitSpectra residual = { re, im };

  if (fit_echo (ew, e, &residual, shapes))
    subtract_model (ew, e->range, 1.0, ew->transmit_re, ew->transmit_im,
        re, im);
}

/* Cancels the echo @e, placed by model_direction (), from the residual
 * @re, @im as deep as its model goes (the residual search's,
 * sonar_velocity_pool_residual ()): shaped (MODEL_SHAPES), each
 * microphone with its own gain (subtract_model_per_microphone ()). */
static void
cancel_echo_deep (EchoWorker * ew, const SonarVelocityEstimate * e,
    float *re, float *im)
{
  const SonarSplitSpectra residual = { re, im };

  if (fit_echo (ew, e, &residual, MODEL_SHAPES))
    subtract_model_per_microphone (ew, e->range, re, im);
}

/* echo_shape (): steps either side of an echo's direction at most, and the
 * fall of a lone point's beam (dB) down to which its sides are
 * compared. */
#define SHAPE_STEPS 8
#define SHAPE_DB 3.0
/* The least fraction of a lone point's fall a side must show. Measured
 * (sonar-bench --sweep crowded, the echoes accepted on a residual):
 * single echoes 0.93 and more on their steeper side (the other flatter
 * where a neighbour's main lobe lies), blends of two unresolved echoes
 * 8 degrees apart near +-72 degrees 0.18-0.64 (0.89 for one that stands
 * on one of the two). */
#define SHAPE_FALL 0.8

/* How the echo @e (of @centroid, found on ew->spectra) falls either side
 * of its direction along azimuth: the power of the emitters' sum at its
 * velocity against the model of a lone point there (echo_model ()), summed
 * over the image steps down to SHAPE_DB of the model's fall; a side
 * falls as one point when it shows SHAPE_FALL of the model's dB at
 * least. A lone echo falls so on both sides; an echo beside another
 * (a neighbour not cancelled, or the other of two the beam does not
 * resolve, on which it stands) on one; a blend of two on neither.
 * *@half_width (may be NULL): image steps to the model's SHAPE_DB fall,
 * the wider side's. */
typedef enum
{
  ECHO_BLEND,
  ECHO_ONE_SIDE,
  ECHO_LONE,
} EchoShape;

static EchoShape
echo_shape (EchoWorker * ew, const SonarCentroid * centroid,
    const SonarVelocityEstimate * e, guint * half_width)
{
  SonarVelocityEstimator *est = ew->est;
  const SonarSplitSpectra model = { ew->model_re, ew->model_im };
  const double step = est->grid.azimuth_step;
  guint v = e->bank_index;
  double model_top, top, fall[2] = { 0.0, 0.0 }, model_fall[2] = { 0.0, 0.0 };
  int reach[2] = { 0, 0 };
  guint sides = 0;

  if (half_width)
    *half_width = 0;
  if (!(step > 0.0) || est->grid.n_azimuth < 2)
    return ECHO_LONE;
  set_window_lags (est, centroid);
  /* The model fitted to the echo, its spectrum's shape with it: air's
   * absorption narrows an echo's band, and widens its beam beyond a
   * model of the emissions' own spectrum, which then calls a lone far
   * echo a blend. */
  echo_model (ew, e, e->bank_index, ew->transmit_re, ew->transmit_im);
  model_into (ew, e->range, ew->transmit_re, ew->transmit_im, ew->model_re,
      ew->model_im);
  est->focused = FALSE;
  coherence_over (est, &model, e->range, e->azimuth, e->elevation, &v, 1,
      &model_top, NULL, NULL, NULL);
  if (!(model_top > 0.0)) {
    est->focused = FALSE;
    return ECHO_LONE;
  }
  for (int side = 0; side < 2; side++)
    for (int k = 1; k <= SHAPE_STEPS; k++) {
      const double az = e->azimuth + (side ? k : -k) * step;
      double s;
      if (az < -90.0 || az > 90.0)
        break;
      coherence_over (est, &model, e->range, az, e->elevation, &v, 1, &s,
          NULL, NULL, NULL);
      /* 120 dB at most (a null). */
      s = 10.0 * log10 (model_top / MAX (s, 1e-12 * model_top));
      model_fall[side] += s;
      reach[side] = k;
      if (s >= SHAPE_DB)
        break;
    }
  est->focused = FALSE;
  coherence_over (est, &ew->spectra, e->range, e->azimuth, e->elevation,
      &v, 1, &top, NULL, NULL, NULL);
  if (!(top > 0.0)) {
    est->focused = FALSE;
    return ECHO_BLEND;
  }
  for (int side = 0; side < 2; side++) {
    for (int k = 1; k <= reach[side]; k++) {
      double s;
      coherence_over (est, &ew->spectra, e->range, e->azimuth + (side ? k :
              -k) * step, e->elevation, &v, 1, &s, NULL, NULL, NULL);
      fall[side] += MAX (10.0 * log10 (top / MAX (s, 1e-12 * top)), 0.0);
    }
    sides += model_fall[side] > 0.0
        && fall[side] >= SHAPE_FALL * model_fall[side];
  }
  est->focused = FALSE;
  if (half_width)
    *half_width = (guint) MAX (reach[0], reach[1]);
  if (reach[0] == 0 && reach[1] == 0)
    return ECHO_LONE;
  return sides >= 2 ? ECHO_LONE : sides == 1 ? ECHO_ONE_SIDE : ECHO_BLEND;
}

/* split_blend (): candidate directions per image step, either side of
 * the blend out to twice the lone model's half width (echo_shape ()) and
 * one step more, SHAPE_STEPS at most (two echoes the beam does not
 * resolve lie within its width of each other, so each within it of the
 * blend); and the least conditioning of a pair's 2 x 2 normal equations
 * (two directions whose models are nearly the same cannot be told
 * apart). */
#define SPLIT_SUBSTEPS 2
#define SPLIT_MIN_CONDITION 1e-3
/* The power two points' fit explains, over the best one point's, from
 * which on an echo is two (sonar-bench --sweep crowded, the echoes that
 * echo_shape () found not lone on a residual: single echoes 1.00-1.07,
 * blends of two 8 degrees apart near +-72 degrees and echoes beside
 * another 1.33-2.1). */
#define SPLIT_GAIN 1.2
/* The most of the blend's own power (its projection on the model at its
 * direction) the pair's fit may leave: a third echo between the two is
 * left whole (measured: 0.94-1.30 of it left where the pair was the
 * outer two of three; 0.005 at most for the pairs that were the blend). */
#define SPLIT_LEFT 0.1
/* The power each half shares over the pooled interference, in pooled-snr's,
 * at least: a half's direction is the pair's fit's, which interference
 * moves more than it moves a lone echo's peak (the beam near +-72 degrees
 * is three times as wide as at boresight). Measured (sonar-bench --sweep
 * crowded, 400-object grid): the halves a degree off their objects (8 cm
 * at 4.6 m) shared 1.0-1.3 pooled-snr's, those within 0.5 degree 2.5 and
 * more. */
#define SPLIT_HALF_SNR 2.0

/* A pair of split_blend ()'s candidates and their least-squares fit. */
typedef struct
{
  int a, b;
  double explained;             /* power the fit explains: n^H x */
  double complex x[2];          /* complex amplitudes */
} PairFit;

/* <m_a, m_b> of split_blend ()'s candidate @b with each of @n_as
 * candidates @as into @grams: the model of @b in @model_re, @model_im
 * (made there unless @made says they hold it), then its receive sum at
 * each a's legs dotted with a's transmit sum (the steering kernels, as
 * model_dot () does on the spectra). */
static void
candidate_grams (EchoWorker * ew, double range, int b, float *model_re,
    float *model_im, gboolean made, const int *as, guint n_as,
    double complex *grams)
{
  const SonarVelocityEstimator *est = ew->est;
  const SonarSteering *st = &est->steering;
  const guint n_mics = est->setup->geometry.n_microphones;
  const guint nb = est->band.n_bins;
  const SonarSplitSpectra model = { model_re, model_im };

  if (!made) {
    memcpy (ew->mic_legs, ew->split_legs + (gsize) b * n_mics,
        n_mics * sizeof (double));
    model_into (ew, range, ew->split_t_re + (gsize) b * nb,
        ew->split_t_im + (gsize) b * nb, model_re, model_im);
  }
  for (guint i = 0; i < n_as; i++) {
    double power;
    sonar_steering_receive_sum (st, &model, ew->split_legs +
        (gsize) as[i] * n_mics, ew->receive_re, ew->receive_im);
    grams[i] = model_dot (ew, range, ew->split_t_re +
        (gsize) as[i] * nb, ew->split_t_im + (gsize) as[i] * nb, &power);
  }
}

/* Tests (ew->check_models): whether candidate @b's model kept in buffer
 * @kept of @models_re, @models_im is the one made anew in the other. */
static gboolean
kept_model_same (EchoWorker * ew, double range, int b,
    float *const models_re[2], float *const models_im[2], int kept)
{
  const gsize size = (gsize) ew->est->setup->geometry.n_microphones *
      ew->est->band.n_bins;

  candidate_grams (ew, range, b, models_re[1 - kept], models_im[1 - kept],
      FALSE, NULL, 0, NULL);
  return !memcmp (models_re[0], models_re[1], size * sizeof (float))
      && !memcmp (models_im[0], models_im[1], size * sizeof (float));
}

/* Fits candidates @a and @b (<m_a, X> @dots, |m|^2 @norms, <m_a, m_b>
 * @gab) and keeps the fit in @best when it explains more. */
static void
fit_pair (const double complex *dots, const double *norms, int a, int b,
    double complex gab, PairFit * best)
{
  double complex x[2];
  double explained;

  if (!fit_two_models (norms[a], norms[b], gab, dots[a], dots[b],
          SPLIT_MIN_CONDITION, x))
    return;
  explained = creal (conj (dots[a]) * x[0] + conj (dots[b]) * x[1]);
  if (explained > best->explained) {
    best->a = a;
    best->b = b;
    best->explained = explained;
    best->x[0] = x[0];
    best->x[1] = x[1];
  }
}

/* Whether the echo @blend (of @centroid, found on ew->spectra), which
 * echo_shape () finds not lone, is two echoes, and where. The beam does
 * not resolve them; the least-squares fit of two points does (each point
 * an echo model at the blend's range and bank velocity, echo_model ();
 * their complex amplitudes from the 2 x 2 normal equations over every
 * microphone and bin): the pair of directions, one either side of the
 * blend along azimuth within 2 @half_width + 1 image steps, whose fit
 * explains the most power, searched on whole steps, then refined by half
 * steps. When it explains SPLIT_GAIN times the best one point's power
 * and leaves at most SPLIT_LEFT of the blend's own, the echo is two:
 * each is then estimated on the spectra less the other's fitted model,
 * as a centroid there would be, and found when valid, standing
 * SPLIT_HALF_SNR pooled-snr's over the pooled interference, and not a
 * blend itself (echo_shape ()): both into @halves. */
static gboolean
split_blend (EchoWorker * ew, const SonarCentroid * centroid,
    const SonarVelocityEstimate * blend, guint half_width,
    SonarVelocityEstimate halves[2])
{
  SonarVelocityEstimator *est = ew->est;
  const SonarSteering *st = &est->steering;
  const guint n_mics = est->setup->geometry.n_microphones;
  const guint nb = est->band.n_bins;
  const gsize size = (gsize) n_mics * nb;
  const double step = est->grid.azimuth_step / SPLIT_SUBSTEPS;
  const int reach = (int) MIN (2 * half_width + 1, SHAPE_STEPS) *
      SPLIT_SUBSTEPS;
  const int n_candidates = 2 * reach + 1;
  const SonarSplitSpectra spectra = ew->spectra;
  double complex dots[2 * SHAPE_STEPS * SPLIT_SUBSTEPS + 1];
  double norms[2 * SHAPE_STEPS * SPLIT_SUBSTEPS + 1];
  double complex grams[SHAPE_STEPS + 1];
  int as[SHAPE_STEPS + 1];
  PairFit best = { -1, -1, 0.0, {0.0, 0.0} };
  /* The candidates' models: the best pair's b's kept for the half steps,
   * the next one's made in the other buffer (echo_shape ()'s, free until
   * the halves are examined). */
  float *const models_re[2] = { ew->split_re, ew->model_re };
  float *const models_im[2] = { ew->split_im, ew->model_im };
  int kept = 1;
  SonarVelocityEstimate found[2];
  double one = 0.0;
  guint n_as = 0;

  if (!(step > 0.0) || est->grid.n_azimuth < 2)
    return FALSE;

  /* Each candidate's model: its transmit sum, legs, <m, X> and |m|^2. */
  for (int c = 0; c < n_candidates; c++) {
    SonarVelocityEstimate at = *blend;
    at.azimuth = blend->azimuth + (c - reach) * step;
    norms[c] = 0.0;
    if (at.azimuth < -90.0 || at.azimuth > 90.0)
      continue;
    echo_model (ew, &at, blend->bank_index, ew->split_t_re +
        (gsize) c * nb, ew->split_t_im + (gsize) c * nb);
    memcpy (ew->split_legs + (gsize) c * n_mics, ew->mic_legs,
        n_mics * sizeof (double));
    sonar_steering_receive_sum (st, &spectra, ew->mic_legs,
        ew->receive_re, ew->receive_im);
    dots[c] = model_dot (ew, blend->range, ew->split_t_re +
        (gsize) c * nb, ew->split_t_im + (gsize) c * nb, &norms[c]);
    norms[c] *= n_mics;
    if (norms[c] > 0.0)
      one = MAX (one, cabs2 (dots[c]) / norms[c]);
  }

  /* Whole steps: a left of or at the blend, b right of it. */
  for (int a = reach; a >= 0; a -= SPLIT_SUBSTEPS)
    if (norms[a] > 0.0)
      as[n_as++] = a;
  for (int b = reach + SPLIT_SUBSTEPS; b < n_candidates; b += SPLIT_SUBSTEPS) {
    if (!(norms[b] > 0.0))
      continue;
    candidate_grams (ew, blend->range, b, models_re[1 - kept],
        models_im[1 - kept], FALSE, as, n_as, grams);
    for (guint i = 0; i < n_as; i++)
      fit_pair (dots, norms, as[i], b, grams[i], &best);
    if (best.b == b)
      kept = 1 - kept;
  }
  /* Half steps around the best. */
  if (best.a >= 0) {
    const int a0 = best.a, b0 = best.b;
    n_as = 0;
    for (int a = MAX (a0 - 1, 0); a <= MIN (a0 + 1, reach); a++)
      if (norms[a] > 0.0)
        as[n_as++] = a;
    for (int b = MAX (b0 - 1, reach + 1); b <= MIN (b0 + 1, n_candidates - 1);
        b++) {
      /* b0's model is kept from the whole steps, its pair with a0 fitted
       * there. */
      const int in = b == b0 ? kept : 1 - kept;
      int others[3];
      guint n_others = 0;
      if (!(norms[b] > 0.0))
        continue;
      for (guint i = 0; i < n_as; i++)
        if (as[i] != a0 || b != b0)
          others[n_others++] = as[i];
      if (b == b0)
        ew->models_reused += !ew->check_models
            || kept_model_same (ew, blend->range, b, models_re, models_im,
            kept);
      candidate_grams (ew, blend->range, b, models_re[in], models_im[in],
          b == b0, others, n_others, grams);
      for (guint i = 0; i < n_others; i++)
        fit_pair (dots, norms, others[i], b, grams[i], &best);
    }
  }
  if (best.a < 0 || !(best.explained > SPLIT_GAIN * one))
    return FALSE;
  {
    /* What the pair leaves at the blend's own direction: <m_0, X - fit>. */
    const int pair[2] = { best.a, best.b };
    double complex g[2], left;
    candidate_grams (ew, blend->range, reach, models_re[0], models_im[0],
        FALSE, pair, 2, g);
    left = dots[reach] - conj (g[0]) * best.x[0] - conj (g[1]) * best.x[1];
    if (!(cabs2 (left) <= SPLIT_LEFT * cabs2 (dots[reach])))
      return FALSE;
  }

  for (int i = 0; i < 2; i++) {
    const int own = i ? best.b : best.a, other = i ? best.a : best.b;
    const SonarSplitSpectra rest = { ew->split_re, ew->split_im };
    SonarVelocityEstimate out[2];
    EchoShape shape;
    memcpy (ew->split_re, spectra.re, size * sizeof (float));
    memcpy (ew->split_im, spectra.im, size * sizeof (float));
    memcpy (ew->mic_legs, ew->split_legs + (gsize) other * n_mics,
        n_mics * sizeof (double));
    subtract_model (ew, blend->range, best.x[1 - i], ew->split_t_re +
        (gsize) other * nb, ew->split_t_im + (gsize) other * nb,
        ew->split_re, ew->split_im);
    est->screen_snr = 0.0;
    estimate_at (est, &rest, centroid, blend->azimuth + (own - reach) *
        step, blend->elevation, ECHO_AT_EVALUATED, out, NULL);
    if (!out[0].valid || est->screen_snr < SPLIT_HALF_SNR *
        est->min_pooled_snr)
      return FALSE;
    ew->spectra = rest;
    shape = echo_shape (ew, centroid, &out[0], NULL);
    ew->spectra = spectra;
    if (shape == ECHO_BLEND)
      return FALSE;
    found[i] = out[0];
    found[i].second = i == 1;
  }
  halves[0] = found[0];
  halves[1] = found[1];
  return TRUE;
}

/* Rounds of successive cancellation at most: each cancels the echoes the
 * last accepted, until one accepts none (sonar-bench --sweep crowded's
 * 400-object grid: 117 found in 16, 112 in 6). Echoes accepted on a
 * residual carry the errors of the models cancelled before them (worst
 * velocity errors 0.044-0.066 m/s on the grids, 0.042 in one round), and
 * blends of two objects the image does not resolve (8 degrees apart near
 * +-72 degrees, where the beam is about 6.5 degrees wide) pass the
 * coherence tests once their neighbours are gone: echo_shape () rejects
 * them. */
#define CANCEL_ROUNDS 16

/* The gate of the rounds after the first, a fraction of pooled-snr's
 * (-3 dB): a ping reaches them only when the first round found echoes
 * to cancel, where the pooled interference measured on the recording
 * (pool->screen_snr) overstates what is left. Measured on sonar-bench
 * --sweep crowded's grids: 16, 47, 112, 117 found, no false object (the
 * first round's gate in every round: 16, 32, 60, 58; none: 16, 48, 112,
 * 117 with worst errors 0.068 m/s on the 10 x 10 grid where this keeps
 * 0.044). */
#define CANCEL_LATER_GATE 0.5

/* Whether the pooled test, hence the cancellation it gates, is on. */
static gboolean
est_pooled (const SonarVelocityPool * pool)
{
  return pool->estimators[0]->min_pooled_snr > 0.0;
}

/* Every worker's models of echo_shape () and split_blend (), made on the
 * first ping that needs them and kept (the presets never do: 2.2 MB a
 * worker not held): all at once, so that no later ping allocates
 * whichever worker meets its first blend there. */
static void
echo_models_ensure (SonarVelocityPool * pool)
{
  const SonarVelocityEstimator *est = pool->estimators[0];
  const guint n_mics = est->setup->geometry.n_microphones;
  const guint nb = est->band.n_bins;
  /* split_blend ()'s candidates, at most. */
  const gsize most = 2 * SHAPE_STEPS * SPLIT_SUBSTEPS + 1;

  for (guint w = 0; w < sonar_workers_count (pool->workers); w++) {
    EchoWorker *ew = &pool->echo[w];
    if (ew->model_re)
      continue;
    ew->model_re = g_new (float, (gsize) n_mics * nb);
    ew->model_im = g_new (float, (gsize) n_mics * nb);
    ew->split_re = g_new (float, (gsize) n_mics * nb);
    ew->split_im = g_new (float, (gsize) n_mics * nb);
    ew->split_t_re = g_new (float, most * nb);
    ew->split_t_im = g_new (float, most * nb);
    ew->split_legs = g_new (double, most * n_mics);
  }
}

/* Whether split_first () examines centroid @k's estimate: one, valid,
 * less coherent than a lone echo. */
static gboolean
may_be_blend (const SonarVelocityEstimate * results, const guint * counts,
    guint k)
{
  const SonarVelocityEstimate *e = &results[2 * k];

  return counts[k] == 1 && e->valid && e->coherence < ISOLATED_COHERENCE;
}

/* Worker @w's share of split_first (): the next centroid not taken, as
 * estimate_share () takes them. A crowd holds many echoes to examine
 * (sonar-bench --sweep reflectors, 50 objects: 22 a ping, over half the
 * stage's CPU time, all of it on one thread before they were shared).
 * Each depends on its centroid's estimate alone. */
static void
split_share (gpointer data, guint w, guint n)
{
  SonarVelocityPool *pool = data;
  EchoWorker *ew = &pool->echo[w];

  (void) n;
  ew->spectra = pool->spectra;
  for (;;) {
    const guint k = (guint) g_atomic_int_add (&pool->next_centroid, 1);
    SonarVelocityEstimate *e;
    guint half_width;
    if (k >= pool->n_centroids)
      break;
    if (!may_be_blend (pool->results, pool->counts, k))
      continue;
    e = &pool->results[2 * k];
    g_atomic_int_inc (&pool->n_examined);
    if (echo_shape (ew, &pool->centroids[k], e, &half_width) != ECHO_LONE
        && split_blend (ew, &pool->centroids[k], e, half_width, e)) {
      pool->counts[k] = 2;
      g_atomic_int_set (&pool->any_split, 1);
    }
  }
}

/* The first estimates' blends: two echoes at one range the beam does not
 * resolve pass the coherence tests as one, between them, when nothing
 * else is near (their coherence factor 0.88-0.94 where a lone echo's is
 * ISOLATED_COHERENCE and more). Such an echo, when echo_shape () finds it
 * not lone, is split when split_blend () finds its two. */
static void
split_first (SonarVelocityPool * pool, const SonarCentroid * centroids,
    guint n_centroids, SonarVelocityEstimate * results, guint * counts)
{
  guint k = 0;

  while (k < n_centroids && !may_be_blend (results, counts, k))
    k++;
  if (k == n_centroids)
    return;
  echo_models_ensure (pool);
  pool->centroids = centroids;
  pool->n_centroids = n_centroids;
  pool->results = results;
  pool->counts = counts;
  pool->any_split = 0;
  g_atomic_int_set (&pool->next_centroid, 0);
  sonar_workers_run (pool->workers, split_share, pool);
  /* A half may be an echo another centroid reports. */
  if (pool->any_split)
    drop_duplicates (pool->estimators[0], n_centroids, results, counts);
}

/* On a residual (pool->echo[0].spectra), whose cancelled neighbours no
 * longer hold a blend of two unresolved echoes down, each estimate of
 * @centroid (@results, *@count of them) is one echo or none: an echo not
 * lone may be two (both kept when found, *@count then 2); else it is
 * kept when it falls as one point on at least one side. Returns whether
 * one is valid. */
static gboolean
judge_on_residual (SonarVelocityPool * pool, const SonarCentroid * centroid,
    SonarVelocityEstimate * results, guint * count)
{
  gboolean any = FALSE;

  for (guint i = 0; i < *count; i++) {
    SonarVelocityEstimate *e = &results[i];
    EchoShape shape;
    guint half_width;
    if (!e->valid)
      continue;
    shape = echo_shape (&pool->echo[0], centroid, e, &half_width);
    if (shape != ECHO_LONE && *count == 1
        && split_blend (&pool->echo[0], centroid, e, half_width, results)) {
      *count = 2;
      return TRUE;
    }
    e->valid = shape != ECHO_BLEND;
    any |= e->valid;
  }
  return any;
}

/* The first @n centroids of pool->failed estimated again on the residual
 * (pool->residual_re and _im), into pool->failed_results and
 * failed_counts; the caller puts pool->spectra back. */
static void
estimate_on_residual (SonarVelocityPool * pool, guint n)
{
  pool->spectra.re = pool->residual_re;
  pool->spectra.im = pool->residual_im;
  pool->centroids = pool->failed;
  pool->n_centroids = n;
  pool->results = pool->failed_results;
  pool->counts = pool->failed_counts;
  pool->screens = NULL;
  g_atomic_int_set (&pool->next_centroid, 0);
  sonar_workers_run (pool->workers, estimate_share, pool);
}

/* Successive cancellation: the centroids whose estimates all failed are
 * estimated again on the spectra less the models of the echoes accepted
 * (cancel_echo ()), in rounds, each cancelling what the last accepted. */
static void
pool_cancel (SonarVelocityPool * pool, const SonarCentroid * centroids,
    guint n_centroids, SonarVelocityEstimate * results, guint * counts)
{
  const SonarVelocityEstimator *est = pool->estimators[0];
  const gsize size = (gsize) est->setup->geometry.n_microphones *
      est->band.n_bins;
  const SonarSplitSpectra spectra = pool->spectra;
  const double gate = est->min_pooled_snr;
  gboolean copied = FALSE;

  memset (pool->cancelled, 0, 2 * (gsize) n_centroids * sizeof (gboolean));
  for (guint round = 0; round < CANCEL_ROUNDS; round++) {
    guint n_cancelled = 0, n_failed = 0;
    /* The centroids to estimate again: none valid, and the power the
     * emitters share standing pooled-snr above the pooled interference
     * (what fails so is interfered at its own pixel: a neighbour's
     * cross-talk that cancelling it removes); after the first round,
     * CANCEL_LATER_GATE of that. */
    for (guint k = 0; k < n_centroids; k++) {
      gboolean any = FALSE;
      for (guint i = 0; i < counts[k]; i++)
        any |= results[2 * k + i].valid;
      if (!any && pool->screen_snr[k] >= (round > 0 ?
              CANCEL_LATER_GATE * gate : gate)) {
        pool->failed_index[n_failed] = k;
        pool->failed[n_failed++] = centroids[k];
      }
    }
    if (!n_failed)
      break;
    if (!copied) {
      echo_models_ensure (pool);
      memcpy (pool->residual_re, pool->spectra_re, size * sizeof (float));
      memcpy (pool->residual_im, pool->spectra_im, size * sizeof (float));
      copied = TRUE;
    }
    for (guint k = 0; k < n_centroids; k++)
      for (guint i = 0; i < counts[k]; i++)
        if (results[2 * k + i].valid && !pool->cancelled[2 * k + i]) {
          cancel_echo (&pool->echo[0], &results[2 * k + i],
              pool->residual_re, pool->residual_im, 1);
          pool->cancelled[2 * k + i] = TRUE;
          n_cancelled++;
        }
    if (!n_cancelled)
      break;
    estimate_on_residual (pool, n_failed);
    pool->echo[0].spectra = pool->spectra;
    for (guint f = 0; f < n_failed; f++) {
      const guint k = pool->failed_index[f];
      if (!judge_on_residual (pool, &pool->failed[f],
              &pool->failed_results[2 * f], &pool->failed_counts[f]))
        continue;
      counts[k] = pool->failed_counts[f];
      for (guint i = 0; i < counts[k]; i++) {
        results[2 * k + i] = pool->failed_results[2 * f + i];
        pool->cancelled[2 * k + i] = FALSE;
      }
    }
    drop_duplicates (est, n_centroids, results, counts);
  }
  pool->spectra = spectra;
}

/* A valid estimate this much weaker than another valid one (their
 * centroids' peaks in the image) within a pulse length of its range
 * (c T / 2, as far as cross-talk reaches) may be that echo seen through
 * the array's sidelobes or its cross-talk. On the 3-D foreign recordings
 * (tools/foreign-scenes.py --view hemisphere --seed 4) two such passed
 * every test: with air's absorption (scene 4) an echo's sidelobe 70
 * degrees away, 3 cm nearer and 25 dB down, at its velocity (8 emitters
 * agreeing, coherence 0.803 against 0.80); with the microphones
 * uncalibrated (scene 1) a ridge 27 dB under the strongest echo, 0.1-0.2
 * m from three others, at +6.0 m/s, where nothing moves so (5 emitters
 * agreeing, coherence 0.85). A MIMO image's sidelobes lie 18-22 dB below
 * the peak (README), cross-talk about 20 dB. */
#define SIDELOBE_CHECK_DB 12.0
/* m/s: the estimate found again within this of the first: half a
 * Doppler main lobe (c / (2 f0 T) = 0.33 m/s at -3 dB). */
#define SIDELOBE_VELOCITY 0.15

/* Whether estimate @i of centroid @k may be a sidelobe or the cross-talk
 * of a stronger valid echo (above). */
static gboolean
may_be_sidelobe (const SonarVelocityEstimator * est,
    const SonarCentroid * centroids, guint n_centroids,
    const SonarVelocityEstimate * results, const guint * counts, guint k,
    guint i)
{
  const SonarVelocityEstimate *w = &results[2 * k + i];
  const double pulse = 0.5 * est->setup->speed_of_sound *
      est->setup->waveform_length / est->setup->sample_rate;
  const double stronger = centroids[k].peak_value *
      pow (10.0, SIDELOBE_CHECK_DB / 20.0);

  if (!w->valid)
    return FALSE;
  for (guint m = 0; m < n_centroids; m++) {
    if (m == k || !(centroids[m].peak_value >= stronger))
      continue;
    for (guint j = 0; j < counts[m]; j++) {
      const SonarVelocityEstimate *s = &results[2 * m + j];
      if (s->valid && fabs (s->echo_range - w->echo_range) <= pulse)
        return TRUE;
    }
  }
  return FALSE;
}

/* The estimates that may be a stronger echo's sidelobe or cross-talk
 * (may_be_sidelobe ()) are estimated again on the spectra less the
 * models of every other accepted echo: a sidelobe or cross-talk goes
 * with its echo, an object stays. One that finds no valid estimate at
 * its velocity there is rejected. A ping without such an estimate costs
 * nothing; Fig. 9's world, whose weaker objects lie near stronger ones,
 * 2-7 % more CPU. */
static void
pool_sidelobes (SonarVelocityPool * pool, const SonarCentroid * centroids,
    guint n_centroids, SonarVelocityEstimate * results, guint * counts)
{
  const SonarVelocityEstimator *est = pool->estimators[0];
  const gsize size = (gsize) est->setup->geometry.n_microphones *
      est->band.n_bins;
  const SonarSplitSpectra spectra = pool->spectra;
  guint n_suspects = 0;

  /* pool->cancelled marks the suspects here: the echoes left in. */
  memset (pool->cancelled, 0, 2 * (gsize) n_centroids * sizeof (gboolean));
  for (guint k = 0; k < n_centroids; k++) {
    gboolean suspect = FALSE;
    for (guint i = 0; i < counts[k]; i++)
      if (may_be_sidelobe (est, centroids, n_centroids, results, counts, k,
              i))
        suspect = pool->cancelled[2 * k + i] = TRUE;
    if (suspect) {
      pool->failed_index[n_suspects] = k;
      pool->failed[n_suspects++] = centroids[k];
    }
  }
  if (!n_suspects)
    return;
  echo_models_ensure (pool);
  memcpy (pool->residual_re, spectra.re, size * sizeof (float));
  memcpy (pool->residual_im, spectra.im, size * sizeof (float));
  for (guint k = 0; k < n_centroids; k++)
    for (guint i = 0; i < counts[k]; i++)
      if (results[2 * k + i].valid && !pool->cancelled[2 * k + i])
        cancel_echo (&pool->echo[0], &results[2 * k + i], pool->residual_re,
            pool->residual_im, 1);
  estimate_on_residual (pool, n_suspects);
  for (guint f = 0; f < n_suspects; f++) {
    const guint k = pool->failed_index[f];
    for (guint i = 0; i < counts[k]; i++) {
      SonarVelocityEstimate *w = &results[2 * k + i];
      gboolean stays = FALSE;
      if (!pool->cancelled[2 * k + i])
        continue;
      for (guint j = 0; j < pool->failed_counts[f]; j++) {
        const SonarVelocityEstimate *again = &pool->failed_results[2 * f + j];
        stays |= again->valid && fabs (again->radial_velocity -
            w->radial_velocity) <= SIDELOBE_VELOCITY;
      }
      w->valid = stays;
    }
  }
  pool->spectra = spectra;
}

/* Whether the directions @est reports are model_direction ()'s: on a
 * grid where refine_direction () fits none (a degree or finer along
 * both axes). */
static gboolean
reports_model_direction (const SonarVelocityEstimator * est)
{
  return !searches_axis (est->grid.azimuth_step)
      && !searches_axis (est->grid.elevation_step);
}

/* The workers' share of report_directions (): each valid estimate's
 * direction and its curvature, model_direction ()'s on the spectra it
 * was found on. */
static void
report_share (gpointer data, guint w, guint n)
{
  SonarVelocityPool *pool = data;

  (void) n;
  for (;;) {
    const guint slot = (guint) g_atomic_int_add (&pool->next_centroid, 1);
    SonarVelocityEstimate *e, placed;
    double curvature[2];
    if (slot >= 2 * pool->n_centroids)
      break;
    e = &pool->results[slot];
    if (slot % 2 >= pool->counts[slot / 2] || !e->valid)
      continue;
    placed = *e;
    model_direction (&pool->echo[w], &placed, &pool->spectra, curvature);
    e->echo_azimuth = placed.azimuth;
    e->echo_elevation = placed.elevation;
    /* The two parabolas measure no cross term: the axes' sigmas come
     * out independent (sonar-uncertainty.h). */
    e->direction_curvature[0] = curvature[0];
    e->direction_curvature[1] = isfinite (curvature[1]) ? 0.0 : NAN;
    e->direction_curvature[2] = curvature[1];
  }
}

/* On a grid where refine_direction () fits no direction, the centroid's
 * (its members' weighted mean) is 0.01-0.1 degree off a lone echo's
 * on the fan: each valid estimate reports the vertex of the power its
 * model explains instead (model_direction ()), and that parabola's
 * curvature for its sigma (sonar-uncertainty.h). Measured on the 2-D
 * foreign scenes (tools/foreign-scenes.py seeds 3 and 1): the azimuth's
 * rms error 0.10-0.13 -> 0.07-0.08 degree, the median distance to the
 * truth 2.0-2.7 -> 0.8 mm. */
static void
report_directions (SonarVelocityPool * pool, guint n_centroids,
    SonarVelocityEstimate * results, guint * counts)
{
  if (!reports_model_direction (pool->estimators[0]))
    return;
  /* The ping's own: the cancellation and the sidelobe check pointed
   * them at their residual's. */
  pool->n_centroids = n_centroids;
  pool->results = results;
  pool->counts = counts;
  echo_models_ensure (pool);
  g_atomic_int_set (&pool->next_centroid, 0);
  sonar_workers_run (pool->workers, report_share, pool);
}

void
sonar_velocity_pool_estimate (SonarVelocityPool * pool,
    const SonarComplex * mic_spectra, const SonarCentroid * centroids,
    guint n_centroids, SonarVelocityEstimate * results, guint * counts)
{
  sonar_kernel_split (pool->spectra_re, pool->spectra_im, mic_spectra,
      (gsize) pool->estimators[0]->setup->geometry.n_microphones *
      pool->estimators[0]->band.n_bins);
  pool->centroids = centroids;
  pool->n_centroids = n_centroids;
  pool->results = results;
  pool->counts = counts;
  if (n_centroids > pool->capacity) {
    /* Grown to the largest ping's centroids, then kept. */
    pool->capacity = n_centroids;
    pool->failed = g_renew (SonarCentroid, pool->failed, n_centroids);
    pool->failed_index = g_renew (guint, pool->failed_index, n_centroids);
    pool->failed_counts = g_renew (guint, pool->failed_counts, n_centroids);
    pool->failed_results = g_renew (SonarVelocityEstimate,
        pool->failed_results, 2 * (gsize) n_centroids);
    pool->cancelled = g_renew (gboolean, pool->cancelled,
        2 * (gsize) n_centroids);
    pool->screen_snr = g_renew (double, pool->screen_snr, n_centroids);
  }
  pool->screens = pool->screen_snr;
  pool->n_examined = 0;
  for (guint w = 0; w < sonar_workers_count (pool->workers); w++)
    pool->echo[w].models_reused = 0;
  g_atomic_int_set (&pool->next_centroid, 0);
  sonar_workers_run (pool->workers, estimate_share, pool);
  pool->screens = NULL;
  drop_duplicates (pool->estimators[0], n_centroids, results, counts);
  if (est_pooled (pool) && n_centroids > 0) {
    split_first (pool, centroids, n_centroids, results, counts);
    pool_cancel (pool, centroids, n_centroids, results, counts);
  }
  if (n_centroids > 1)
    pool_sidelobes (pool, centroids, n_centroids, results, counts);
  report_directions (pool, n_centroids, results, counts);
}

/* The workers' share of sonar_velocity_pool_residual (): each takes the
 * next of pool->placed and places its model (model_direction ()) on the
 * ping's spectra, its neighbours in them: an echo strong enough for its
 * place to matter stands far over their sidelobes. */
static void
place_share (gpointer data, guint w, guint n)
{
  SonarVelocityPool *pool = data;

  (void) n;
  for (;;) {
    const guint i = (guint) g_atomic_int_add (&pool->next_centroid, 1);
    if (i >= pool->n_placed)
      break;
    if (reports_model_direction (pool->estimators[w])) {
      /* The direction reported is the vertex, on these spectra. */
      pool->placed[i].azimuth = pool->placed[i].echo_azimuth;
      pool->placed[i].elevation = pool->placed[i].echo_elevation;
    } else {
      model_direction (&pool->echo[w], &pool->placed[i], &pool->spectra,
          NULL);
    }
  }
}

void
sonar_velocity_pool_residual (SonarVelocityPool * pool,
    const SonarVelocityEstimate * results, const guint * counts,
    guint n_centroids, SonarComplex * residual)
{
  const SonarVelocityEstimator *est = pool->estimators[0];
  const gsize size = (gsize) est->setup->geometry.n_microphones *
      est->band.n_bins;

  echo_models_ensure (pool);
  if (2 * n_centroids > pool->placed_capacity) {
    pool->placed_capacity = 2 * n_centroids;
    pool->placed = g_renew (SonarVelocityEstimate, pool->placed,
        pool->placed_capacity);
  }
  pool->n_placed = 0;
  for (guint k = 0; k < n_centroids; k++)
    for (guint i = 0; i < counts[k]; i++)
      if (results[2 * k + i].valid)
        pool->placed[pool->n_placed++] = results[2 * k + i];
  g_atomic_int_set (&pool->next_centroid, 0);
  sonar_workers_run (pool->workers, place_share, pool);
  memcpy (pool->residual_re, pool->spectra_re, size * sizeof (float));
  memcpy (pool->residual_im, pool->spectra_im, size * sizeof (float));
  for (guint i = 0; i < pool->n_placed; i++)
    cancel_echo_deep (&pool->echo[0], &pool->placed[i], pool->residual_re,
        pool->residual_im);
  for (gsize i = 0; i < size; i++)
    residual[i] = CMPLXF (pool->residual_re[i], pool->residual_im[i]);
}

void
sonar_velocity_pool_estimate_residual (SonarVelocityPool * pool,
    const SonarComplex * residual, const SonarCentroid * centroids,
    guint n_centroids, SonarVelocityEstimate * results, guint * counts)
{
  sonar_velocity_pool_estimate (pool, residual, centroids, n_centroids,
      results, counts);
  echo_models_ensure (pool);
  pool->echo[0].spectra = pool->spectra;
  for (guint k = 0; k < n_centroids; k++)
    judge_on_residual (pool, &centroids[k], &results[2 * k], &counts[k]);
  drop_duplicates (pool->estimators[0], n_centroids, results, counts);
}

void
sonar_velocity_pool_work (const SonarVelocityPool * pool,
    SonarVelocityWork * work)
{
  const SonarVelocityEstimator *est = pool->estimators[0];
  const SonarImageGrid *g = &est->grid;
  const guint qa = searches_axis (g->azimuth_step) ?
      DIRECTION_SUBSTEPS : 0;
  const guint qe = searches_axis (g->elevation_step) ?
      DIRECTION_SUBSTEPS : 0;

  work->bins = est->gate_size ? est->gate_bins : est->band.n_bins;
  work->block = est->gate_size ? GATE_BLOCK : LAG_BLOCK;
  work->gate_inverse = est->gate_m;
  work->gate_forward = est->gate_size;
  /* refine_direction ()'s lines: along azimuth, then along elevation
   * without their common centre. */
  work->directions = 2 * qa + 1 + 2 * qe;
  /* Every hypothesis at the centroid's direction, three elsewhere. */
  work->screens = est->n_hypotheses + (work->directions - 1) *
      MIN (3, est->n_hypotheses);
}

guint
sonar_velocity_pool_last_examined (const SonarVelocityPool * pool)
{
  return (guint) g_atomic_int_get (&pool->n_examined);
}

guint
sonar_velocity_pool_last_reused (const SonarVelocityPool * pool)
{
  guint n = 0;

  for (guint w = 0; w < sonar_workers_count (pool->workers); w++)
    n += pool->echo[w].models_reused;
  return n;
}

void
sonar_velocity_pool_check_models (SonarVelocityPool * pool, gboolean check)
{
  for (guint w = 0; w < SONAR_MAX_WORKERS; w++)
    pool->echo[w].check_models = check;
}

double
sonar_velocity_centre_range (double range, double radial_velocity,
    double speed_of_sound, double emission_centre, double *delay)
{
  const double v = isfinite (radial_velocity) ? radial_velocity : 0.0;
  const double later = emission_centre / (1.0 - v / speed_of_sound);

  *delay = range / speed_of_sound + later;
  return range + v * later;
}

gboolean
sonar_velocity_approaching (double radial_velocity)
{
  return round (radial_velocity * 100.0) < 0.0;
}
