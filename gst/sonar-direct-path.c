/* sonar-direct-path.c: the emissions heard straight from the emitters
 * (sonar-direct-path.h). */
#include "sonar-direct-path.h"

#include <math.h>

#include "sonar-error.h"
#include "sonar-kernels.h"
#include "sonar-linalg.h"

/* Added to the Gram matrix's diagonal, relative to its mean: a waveform's
 * shifts by whole samples are nearly dependent (the band fills a quarter
 * of the spectrum), and the fit's float correlations are good to about
 * 1e-6. This bounds what their errors do to the fitted model (below -60
 * dB) at no cost to what the taps can represent in the band. */
#define RIDGE 1e-7

struct _SonarDirectPath
{
  SonarSetup *setup;
  guint n_mics, n_emitters;
  guint n_taps;                 /* from lead before a path's delay on */
  guint n_params;               /* n_emitters n_taps */
  guint waveform_length;
  guint ping_length;
  /* [mic][emitter]: the sample of the ping where the window of the first
   * tap starts (the path's delay less the lead, at least 0). */
  guint *first;
  /* [emitter]: the waveform's energy (the probe's normalisation). */
  double *energy;
  /* [mic]: the samples the fit's columns span: from window[2 j] on,
   * window[2 j + 1] of them. */
  guint *window;
  /* [mic]: n_params^2, the Cholesky factor of the Gram matrix. */
  double *factor;
  /* The fit of SONAR_DIRECT_PATH_RINGING_TAPS taps, made on the first
   * ping that needs it (ringing_fit ()); NULL until then, RINGING_NONE
   * when it cannot be made (a ping too short for it). */
  SonarDirectPath *ringing;
};

#define RINGING_NONE ((SonarDirectPath *) &ringing_none)
static const int ringing_none;

/* sum_u w_a(u) w_b(u + lag), the waveforms zero outside their samples. */
static double
cross_correlation (const float *a, const float *b, guint length, gint lag)
{
  const guint from = lag < 0 ? (guint) - lag : 0;
  const guint to = lag > 0 ? length - MIN ((guint) lag, length) : length;
  double sum = 0.0;

  for (guint u = from; u < to; u++)
    sum += (double) a[u] * b[(gint) u + lag];
  return sum;
}

guint
sonar_direct_path_default_taps (const SonarSetup * setup)
{
  /* The built-in sensor's edge: 80 kHz at 450 kHz, 0.356 of Nyquist. */
  const double builtin_edge = 1.0 - 80000.0 / 225000.0;
  const double edge = 1.0 - setup->band_high / (0.5 * setup->sample_rate);

  if (!(edge > 0.0))
    return SONAR_DIRECT_PATH_MAX_TAPS;
  return (guint) CLAMP (ceil (SONAR_DIRECT_PATH_TAPS * builtin_edge / edge -
          1e-9), SONAR_DIRECT_PATH_TAPS, SONAR_DIRECT_PATH_MAX_TAPS);
}

SonarDirectPath *
sonar_direct_path_new (SonarSetup * setup, guint n_taps, GError ** error)
{
  g_autoptr (SonarDirectPath) dp = g_new0 (SonarDirectPath, 1);
  const guint n_mics = setup->geometry.n_microphones;
  const guint n_emitters = setup->geometry.n_emitters;
  const guint w = setup->waveform_length;
  const guint lead = SONAR_DIRECT_PATH_LEAD;
  const guint p = n_emitters * n_taps;
  gint *lag_min;
  double **table;
  guint last = 0;

  if (n_taps <= lead || n_taps > SONAR_DIRECT_PATH_MAX_TAPS) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "direct path: %u taps: between %u and %u", n_taps, lead + 1,
        SONAR_DIRECT_PATH_MAX_TAPS);
    return NULL;
  }

  dp->setup = sonar_setup_ref (setup);
  dp->n_mics = n_mics;
  dp->n_emitters = n_emitters;
  dp->n_taps = n_taps;
  dp->n_params = p;
  dp->waveform_length = w;
  dp->ping_length = setup->ping_length;
  dp->first = g_new (guint, (gsize) n_mics * n_emitters);
  for (guint j = 0; j < n_mics; j++)
    for (guint n = 0; n < n_emitters; n++) {
      const double path = sonar_vec3_norm (sonar_vec3_sub
          (setup->geometry.microphones[j], setup->geometry.emitters[n]));
      const guint delay = (guint) lround (path / setup->speed_of_sound *
          setup->sample_rate);
      /* A path shorter than the lead still lies within the taps. */
      const guint first = MAX (delay, lead) - lead;
      dp->first[(gsize) j * n_emitters + n] = first;
      last = MAX (last, first + n_taps - 1 + w);
    }
  dp->window = g_new (guint, 2 * (gsize) n_mics);
  for (guint j = 0; j < n_mics; j++) {
    guint from = G_MAXUINT, to = 0;
    for (guint n = 0; n < n_emitters; n++) {
      from = MIN (from, dp->first[(gsize) j * n_emitters + n]);
      to = MAX (to, dp->first[(gsize) j * n_emitters + n] + n_taps - 1 + w);
    }
    dp->window[2 * j] = from;
    dp->window[2 * j + 1] = to - from;
  }
  if (last > setup->ping_length) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "direct path: a ping of %u samples cannot hold the emissions' "
        "direct path to the microphones (%u samples)", setup->ping_length,
        last);
    return NULL;
  }
  dp->energy = g_new (double, n_emitters);
  for (guint n = 0; n < n_emitters; n++)
    dp->energy[n] = cross_correlation (sonar_setup_waveform (setup, n),
        sonar_setup_waveform (setup, n), w, 0);

  /* The Gram matrix of mic j: entry ((n, l), (m, k)) is R_nm (first_nj +
   * l - first_mj - k), R_nm (d) = sum_u w_n (u) w_m (u + d): the lags a
   * pair of emitters takes over every microphone, each computed once. */
  lag_min = g_new (gint, (gsize) n_emitters * n_emitters);
  table = g_new0 (double *, (gsize) n_emitters * n_emitters);
  for (guint n = 0; n < n_emitters; n++)
    for (guint m = 0; m < n_emitters; m++) {
      gint lo = G_MAXINT, hi = G_MININT;
      for (guint j = 0; j < n_mics; j++) {
        const gint d = (gint) dp->first[(gsize) j * n_emitters + n] -
            (gint) dp->first[(gsize) j * n_emitters + m];
        lo = MIN (lo, d - (gint) n_taps + 1);
        hi = MAX (hi, d + (gint) n_taps - 1);
      }
      lag_min[n * n_emitters + m] = lo;
      table[n * n_emitters + m] = g_new (double, hi - lo + 1);
      for (gint d = lo; d <= hi; d++)
        table[n * n_emitters + m][d - lo] = m < n ?
            table[m * n_emitters + n][-d - lag_min[m * n_emitters + n]] :
            cross_correlation (sonar_setup_waveform (setup, n),
            sonar_setup_waveform (setup, m), w, d);
    }

  dp->factor = g_new (double, (gsize) n_mics * p * p);
  for (guint j = 0; j < n_mics; j++) {
    double *g = dp->factor + (gsize) j * p * p;
    double trace = 0.0;
    for (guint n = 0; n < n_emitters; n++)
      for (guint l = 0; l < n_taps; l++)
        for (guint m = 0; m < n_emitters; m++)
          for (guint k = 0; k < n_taps; k++) {
            const gint d = (gint) (dp->first[(gsize) j * n_emitters + n] + l)
                - (gint) (dp->first[(gsize) j * n_emitters + m] + k);
            g[(gsize) (n * n_taps + l) * p + m * n_taps + k] =
                table[n * n_emitters + m][d - lag_min[n * n_emitters + m]];
          }
    for (guint c = 0; c < p; c++)
      trace += g[(gsize) c * p + c];
    for (guint c = 0; c < p; c++)
      g[(gsize) c * p + c] += RIDGE * trace / p;
    if (!sonar_linalg_cholesky (g, p)) {
      g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
          "direct path: the emissions are silent or alike, so their direct "
          "paths to microphone %u cannot be told apart", j);
      dp = NULL;
      break;
    }
  }
  for (guint c = 0; c < n_emitters * n_emitters; c++)
    g_free (table[c]);
  g_free (table);
  g_free (lag_min);
  return g_steal_pointer (&dp);
}

void
sonar_direct_path_free (SonarDirectPath * dp)
{
  if (!dp)
    return;
  if (dp->setup)
    sonar_setup_unref (dp->setup);
  g_free (dp->first);
  g_free (dp->energy);
  g_free (dp->window);
  g_free (dp->factor);
  if (dp->ringing != RINGING_NONE)
    sonar_direct_path_free (dp->ringing);
  g_free (dp);
}

guint64
sonar_direct_path_memory (const SonarSetup * setup, guint n_taps)
{
  const guint64 n_mics = setup->geometry.n_microphones;
  const guint64 p = (guint64) setup->geometry.n_emitters * n_taps;

  /* With the ringing fit it may make (ringing_fit ()). */
  return n_mics * p * p * sizeof (double) + n_mics *
      (setup->geometry.n_emitters + 2) * sizeof (guint) +
      (n_taps < SONAR_DIRECT_PATH_RINGING_TAPS ?
      sonar_direct_path_memory (setup, SONAR_DIRECT_PATH_RINGING_TAPS) : 0);
}

gsize
sonar_direct_path_scratch_size (const SonarDirectPath * dp)
{
  /* The correlations in float, then in double; for the ringing fit's
   * parameters when it may be made. */
  const gsize p = MAX (dp->n_params, (gsize) dp->n_emitters *
      SONAR_DIRECT_PATH_RINGING_TAPS);
  return p + (p + 1) / 2;
}

/* Lags just past the fit's taps whose correlations tell ringing
 * (rings ()). */
#define RINGING_PROBE_LAGS 4

/* What each emitter's waveform explains of microphone @mic's @signal at
 * RINGING_PROBE_LAGS lags from @lag past the paths' delays less the lead
 * (dp->first), one lag at a time: sum of the correlations squared over
 * the waveforms' energies. -1 when the ping ends before. */
static double
probe_at (const SonarDirectPath * dp, guint mic, const float *signal,
    guint lag, float *correlations)
{
  const guint *first = dp->first + (gsize) mic * dp->n_emitters;
  double probe = 0.0;

  for (guint n = 0; n < dp->n_emitters; n++) {
    if (first[n] + lag + RINGING_PROBE_LAGS - 1 + dp->waveform_length >
        dp->ping_length)
      return -1.0;
    sonar_kernel_correlate (correlations, signal + first[n] + lag,
        sonar_setup_waveform (dp->setup, n), dp->waveform_length,
        RINGING_PROBE_LAGS);
    for (guint l = 0; l < RINGING_PROBE_LAGS; l++)
      probe += (double) correlations[l] * correlations[l] / dp->energy[n];
  }
  return probe;
}

/* Whether an emitter rings past the fit of @dp's taps on microphone
 * @mic: what each emitter's waveform explains of what the fit left
 * (@left, the power over the direct path's samples) at RINGING_PROBE_LAGS
 * lags just past the taps, per column, against @left per sample (an F
 * ratio). Measured: 0.01-0.08 on noise (sonarsrc's empty scene at
 * coupling 1e-4: the window's noise fills the whole spectrum, the
 * columns see the band), 0.06-0.33 where echoes fill what is left (its
 * Fig. 10 at 0.01), 2.7-20 for a resonance of Q 1.5-3 the waveforms
 * lack (tests/foreign_sim.py at 0.1). */
static gboolean
rings (const SonarDirectPath * dp, guint mic, const float *signal,
    float *correlations, double left)
{
  const double probe = probe_at (dp, mic, signal, dp->n_taps, correlations);
  const double columns = (double) dp->n_emitters * RINGING_PROBE_LAGS;
  const double samples = dp->window[2 * (gsize) mic + 1];

  return probe > 0.0 && probe / columns > SONAR_DIRECT_PATH_RINGING_F *
      left / samples;
}

/* The ringing fit of @dp (see dp->ringing), made once: the first worker
 * that needs it makes it while the others wait. NULL when it cannot be
 * made or @dp has as many taps. */
static const SonarDirectPath *
ringing_fit (const SonarDirectPath * dp)
{
  SonarDirectPath *mutable = (SonarDirectPath *) dp;

  if (dp->n_taps >= SONAR_DIRECT_PATH_RINGING_TAPS)
    return NULL;
  if (g_once_init_enter (&mutable->ringing)) {
    SonarDirectPath *fit = sonar_direct_path_new (dp->setup,
        SONAR_DIRECT_PATH_RINGING_TAPS, NULL);
    g_once_init_leave (&mutable->ringing, fit ? fit : RINGING_NONE);
  }
  return dp->ringing == RINGING_NONE ? NULL : dp->ringing;
}

double
sonar_direct_path_remove (const SonarDirectPath * dp, guint mic,
    float *signal, gsize length, SonarDirectPathMode mode, double *scratch,
    gboolean * removed)
{
  const guint n_emitters = dp->n_emitters, n_taps = dp->n_taps;
  const guint at_path = SONAR_DIRECT_PATH_LEAD, p = dp->n_params;
  const guint *first = dp->first + (gsize) mic * n_emitters;
  const guint *window = dp->window + 2 * (gsize) mic;
  double *b = scratch;
  float *correlations = (float *) (scratch + p);
  double explained = 0.0, share;
  float power;

  if (removed)
    *removed = FALSE;
  g_return_val_if_fail (mic < dp->n_mics, -INFINITY);
  if (mode == SONAR_DIRECT_PATH_OFF || length < dp->ping_length)
    return -INFINITY;
  sonar_kernel_correlate (&power, signal + window[0], signal + window[0],
      window[1], 1);
  if (!(power > 0.0f) || !isfinite (power))
    return -INFINITY;

  if (mode == SONAR_DIRECT_PATH_AUTO) {
    /* The probe: each emitter's tap at its path's delay alone, apart. */
    double probe = 0.0;
    for (guint n = 0; n < n_emitters; n++) {
      sonar_kernel_correlate (correlations, signal + first[n] + at_path,
          sonar_setup_waveform (dp->setup, n), dp->waveform_length, 1);
      probe += (double) correlations[0] * correlations[0] / dp->energy[n];
    }
    share = probe / power;
    if (share < SONAR_DIRECT_PATH_MIN_SHARE / 2)
      return 10.0 * log10 (share / MAX (1.0 - share, 1e-12));
  }

  for (guint n = 0; n < n_emitters; n++)
    sonar_kernel_correlate (correlations + n * n_taps, signal + first[n],
        sonar_setup_waveform (dp->setup, n), dp->waveform_length, n_taps);
  for (guint c = 0; c < p; c++)
    b[c] = correlations[c];
  sonar_linalg_cholesky_solve (dp->factor + (gsize) mic * p * p, p, b);
  for (guint c = 0; c < p; c++)
    explained += b[c] * correlations[c];
  share = CLAMP (explained / power, 0.0, 1.0);
  if (mode == SONAR_DIRECT_PATH_AUTO && share < SONAR_DIRECT_PATH_MIN_SHARE)
    return 10.0 * log10 (share / MAX (1.0 - share, 1e-12));

  for (guint n = 0; n < n_emitters; n++)
    for (guint l = 0; l < n_taps; l++)
      sonar_kernel_axpy (signal + first[n] + l, sonar_setup_waveform
          (dp->setup, n), (float) -b[n * n_taps + l], dp->waveform_length);
  if (removed)
    *removed = TRUE;
  /* What is left: the echoes and noise there, and the fit's error. */
  sonar_kernel_correlate (&power, signal + window[0], signal + window[0],
      window[1], 1);
  /* An emitter that rings past the taps leaves its ringing: fitted again
   * with the ringing fit's taps, whose columns hold these, on what is
   * left (the same as that fit on the ping). */
  /* Ringing is the emitters': once one microphone's path told it, every
   * microphone whose fit leaves that much is fitted again. */
  if (power > SONAR_DIRECT_PATH_RINGING_LEFT * explained
      && (sonar_direct_path_rang (dp)
          || rings (dp, mic, signal, correlations, power))) {
    const SonarDirectPath *ringing = ringing_fit (dp);
    if (ringing) {
      const double before = power;
      sonar_direct_path_remove (ringing, mic, signal, length,
          SONAR_DIRECT_PATH_ALWAYS, scratch, NULL);
      sonar_kernel_correlate (&power, signal + window[0], signal +
          window[0], window[1], 1);
      explained += MAX (before - power, 0.0);
    }
  }
  return 10.0 * log10 (explained / MAX ((double) power, 1e-30));
}

gboolean
sonar_direct_path_rang (const SonarDirectPath * dp)
{
  /* Written once by ringing_fit (), perhaps by another worker. */
  const SonarDirectPath *ringing =
      g_atomic_pointer_get (&((SonarDirectPath *) dp)->ringing);

  return ringing != NULL && ringing != RINGING_NONE;
}
