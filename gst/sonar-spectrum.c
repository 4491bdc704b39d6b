/* sonar-spectrum.c: see sonar-spectrum.h. */
#include "sonar-spectrum.h"
#include "sonar-cluster.h"          /* sonar_select_kth () */
#include "sonar-direct-path.h"
#include "sonar-fftw.h"
#include "sonar-kernels.h"
#include "sonar-workers.h"

#include <fftw3.h>
#include <math.h>
#include <string.h>

guint
sonar_fft_good_size (guint n)
{
  for (n = MAX (n, 1);; n++) {
    guint m = n;
    while (m % 2 == 0)
      m /= 2;
    while (m % 3 == 0)
      m /= 3;
    while (m % 5 == 0)
      m /= 5;
    if (m == 1)
      return n;
  }
}

guint
sonar_fft_fast_size (guint n)
{
  guint power = 1;

  while (power < n && 3 * power < n)
    power *= 2;
  return power >= n ? power : 3 * power;
}

void
sonar_band_init (SonarBand * band, double sample_rate, guint min_fft_size,
    double low, double high)
{
  const guint n = sonar_fft_good_size (min_fft_size);
  const double bin_width = sample_rate / n;
  const guint first = (guint) MAX (floor (low / bin_width) - 1.0, 0.0);
  const guint last = (guint) MIN (ceil (high / bin_width) + 1.0, n / 2.0);

  band->sample_rate = sample_rate;
  band->fft_size = n;
  band->first_bin = first;
  band->n_bins = last - first + 1;
}

struct _SonarSpectrum
{
  SonarBand band;
  float *input;
  gsize input_filled;           /* zero_padding () */
  fftwf_complex *output;
  fftwf_plan plan;
};

/* Zeroes @input from @used samples on where earlier samples lie (up to
 * *@filled: the FFT size for a new array) and sets *@filled to @used.
 * An out-of-place r2c plan keeps its input (FFTW_PRESERVE_INPUT, FFTW's
 * default but for c2r), so the padding stays zero from ping to ping:
 * pings of one length clear it once. */
static void
zero_padding (float *input, gsize used, gsize * filled)
{
  if (used < *filled)
    memset (input + used, 0, sizeof (float) * (*filled - used));
  *filled = used;
}

SonarSpectrum *
sonar_spectrum_new (const SonarBand * band)
{
  SonarSpectrum *s = g_new0 (SonarSpectrum, 1);

  s->band = *band;
  s->input = fftwf_alloc_real (band->fft_size);
  s->input_filled = band->fft_size;
  s->output = fftwf_alloc_complex (band->fft_size / 2 + 1);
  sonar_fftw_lock ();
  s->plan = fftwf_plan_dft_r2c_1d (band->fft_size, s->input, s->output,
      SONAR_FFTW_PLANNING);
  sonar_fftw_unlock ();
  return s;
}

void
sonar_spectrum_free (SonarSpectrum * s)
{
  if (!s)
    return;
  sonar_fftw_lock ();
  fftwf_destroy_plan (s->plan);
  sonar_fftw_unlock ();
  fftwf_free (s->input);
  fftwf_free (s->output);
  g_free (s);
}

void
sonar_spectrum_process (SonarSpectrum * s, const float *signal, gsize length,
    gsize stride, SonarComplex * out, guint * n_bad)
{
  const guint n = s->band.fft_size;
  const gsize used = MIN (length, (gsize) n);
  const guint bad = sonar_kernel_deinterleave (&s->input, 1, signal, stride,
      used);

  zero_padding (s->input, used, &s->input_filled);
  fftwf_execute (s->plan);
  memcpy (out, s->output + s->band.first_bin,
      sizeof (SonarComplex) * s->band.n_bins);
  if (n_bad)
    *n_bad += bad;
}

/* The peak |x| of @x's quiet stretches: the lower quartile of its
 * SONAR_GLITCH_BLOCKS blocks' peaks (one block when short). A ping's
 * loudest signals, the direct path and the nearest echoes, fill a quarter
 * of it at most, and a bad channel may hold glitches in many blocks: the
 * scale is its far echoes' and noise's, so that a glitch under the loud
 * ones stands out. Peaks, not energies: no float overflows or underflows
 * (samples may reach 10^30), and a maximum is one vector instruction a
 * lane. Sets *@peak to the largest |x|. */
static float
quiet_peak (const float *x, gsize n, float *peak)
{
  const guint blocks = n >= 64 * SONAR_GLITCH_BLOCKS ? SONAR_GLITCH_BLOCKS :
      1;
  float block_peak[SONAR_GLITCH_BLOCKS];

  *peak = 0.0f;
  for (guint b = 0; b < blocks; b++) {
    const gsize start = n * b / blocks, end = n * (b + 1) / blocks;
    float lane[16] = { 0 }, largest = 0.0f;
    gsize i;

    for (i = start; i + 16 <= end; i += 16)
      for (guint l = 0; l < 16; l++) {
        const float a = fabsf (x[i + l]);
        lane[l] = a > lane[l] ? a : lane[l];
      }
    for (; i < end; i++)
      largest = MAX (largest, fabsf (x[i]));
    for (guint l = 0; l < 16; l++)
      largest = MAX (largest, lane[l]);
    block_peak[b] = largest;
    *peak = MAX (*peak, largest);
  }
  /* Insertion sort: 16 values. */
  for (guint b = 1; b < blocks; b++)
    for (guint k = b; k > 0 && block_peak[k - 1] > block_peak[k]; k--) {
      const float t = block_peak[k];
      block_peak[k] = block_peak[k - 1];
      block_peak[k - 1] = t;
    }
  return block_peak[(blocks - 1) / 4];
}

G_STATIC_ASSERT (SONAR_GLITCH_FLANK >= SONAR_GLITCH_MAX_RUN);

guint
sonar_remove_glitches (float *x, gsize n, float *largest, float *quiet)
{
  float peak, loud, level;
  guint zeroed = 0;
  gsize i;

  if (quiet)
    *quiet = 0.0f;
  if (n == 0)
    return 0;
  level = quiet_peak (x, n, &peak);
  if (quiet)
    *quiet = level;
  loud = SONAR_GLITCH_OVER_QUIET * level;
  if (!(peak > loud))
    return 0;

  for (i = 0; i < n; i++) {
    const float a = fabsf (x[i]);
    gsize start, end;
    gboolean glitch = TRUE;

    /* From the loud local peaks (a run's first largest sample), the run
     * over a tenth of the peak, then its flanks. */
    if (!(a > loud) || (i > 0 && fabsf (x[i - 1]) >= a) || (i + 1 < n
            && fabsf (x[i + 1]) > a))
      continue;
    level = a / SONAR_GLITCH_OVER_NEIGHBOURS;
    /* Whatever the run, its flanks hold x[i -+ SONAR_GLITCH_MAX_RUN]
     * (the flanks are no shorter than a run): most of a loud signal's
     * peaks end here. */
    if ((i >= SONAR_GLITCH_MAX_RUN
            && fabsf (x[i - SONAR_GLITCH_MAX_RUN]) > level)
        || (i + SONAR_GLITCH_MAX_RUN < n
            && fabsf (x[i + SONAR_GLITCH_MAX_RUN]) > level))
      continue;
    start = i;
    end = i + 1;
    while (start > 0 && fabsf (x[start - 1]) > level
        && end - start <= SONAR_GLITCH_MAX_RUN)
      start--;
    while (end < n && fabsf (x[end]) > level
        && end - start <= SONAR_GLITCH_MAX_RUN)
      end++;
    if (end - start > SONAR_GLITCH_MAX_RUN)
      continue;
    for (gsize k = start > SONAR_GLITCH_FLANK ? start - SONAR_GLITCH_FLANK :
        0; k < start && glitch; k++)
      glitch = fabsf (x[k]) <= level;
    for (gsize k = end; k < MIN (n, end + SONAR_GLITCH_FLANK) && glitch; k++)
      glitch = fabsf (x[k]) <= level;
    if (glitch) {
      memset (x + start, 0, sizeof (float) * (end - start));
      zeroed += end - start;
      if (largest)
        *largest = MAX (*largest, a);
    }
  }
  return zeroed;
}

/* Channels a worker deinterleaves together (sonar_channel_spectra_process
 * ()): all of a worker's on two processors and 32 microphones (16 x 86
 * KB of input held per worker; 8 made it 5 % slower). */
#define SPECTRA_GROUP 16

/* What a worker's glitch removal found (sonar_remove_glitches ()). */
typedef struct
{
  guint zeroed;
  float largest;
} GlitchWork;

/* A worker's direct-path subtraction (sonar-direct-path.h): what it
 * needs and what it found. */
typedef struct
{
  const SonarDirectPath *path;  /* NULL: none */
  SonarDirectPathMode mode;
  double *scratch;
  guint removed;                /* channels it was subtracted from */
  double largest_db;            /* the largest fit over the rest, dB */
} DirectPathWork;

/* sonar_spectrum_process () of @count <= SPECTRA_GROUP channels of the
 * interleaved @samples (@stride a frame), channels @first on, into
 * @out (n_bins each, one after another): each frame's samples of the
 * group are read together into the group's @inputs (FFTW-aligned, as
 * @s's own; their padding's extents in @filled), each one's glitches
 * removed (counted in @glitches; its quiet peak into @quiet[k]) and
 * direct path subtracted as @direct
 * says, then @s's plan runs on each (the same plan on arrays of the same alignment: the same spectra
 * bit for bit). Reading one channel at a time read a cache line (a
 * frame) per sample, 32 times over; it was half of the stage's time. */
static void
spectrum_process_group (SonarSpectrum * s, float *const *inputs,
    gsize * filled, guint count, const float *samples, gsize length,
    gsize stride, guint first, SonarComplex * out, guint * n_bad,
    GlitchWork * glitches, float *quiet, DirectPathWork * direct)
{
  const guint n = s->band.fft_size;
  const gsize used = MIN (length, (gsize) n);
  const guint bad = sonar_kernel_deinterleave (inputs, count,
      samples + first, stride, used);

  for (guint k = 0; k < count; k++) {
    glitches->zeroed += sonar_remove_glitches (inputs[k], used,
        &glitches->largest, &quiet[k]);
    if (direct->path) {
      gboolean removed;
      const double db = sonar_direct_path_remove (direct->path, first + k,
          inputs[k], used, direct->mode, direct->scratch, &removed);
      direct->removed += removed;
      direct->largest_db = MAX (direct->largest_db, db);
    }
    zero_padding (inputs[k], used, &filled[k]);
    fftwf_execute_dft_r2c (s->plan, inputs[k], s->output);
    memcpy (out + (gsize) k * s->band.n_bins, s->output + s->band.first_bin,
        sizeof (SonarComplex) * s->band.n_bins);
  }
  if (n_bad)
    *n_bad += bad;
}

struct _SonarChannelSpectra
{
  SonarWorkers *workers;
  SonarSpectrum *per_worker[SONAR_MAX_WORKERS];
  float *inputs[SONAR_MAX_WORKERS][SPECTRA_GROUP];
  gsize inputs_filled[SONAR_MAX_WORKERS][SPECTRA_GROUP];
  guint n_bad[SONAR_MAX_WORKERS];
  GlitchWork glitches[SONAR_MAX_WORKERS];
  DirectPathWork direct[SONAR_MAX_WORKERS];
  guint n_channels;
  guint n_bins;
  float *quiet;                 /* each channel's quiet peak */
  float *sorted;                /* the same, reordered for the median */
  guint n_loud, first_loud;     /* loud channels, read as 0 */
  double loudest_db;
  /* The call's, for the workers. */
  const float *samples;
  gsize length;
  SonarComplex *out;
};

SonarChannelSpectra *
sonar_channel_spectra_new (const SonarBand * band, guint n_channels,
    guint threads, GError ** error)
{
  g_autoptr (SonarChannelSpectra) s = g_new0 (SonarChannelSpectra, 1);

  s->n_channels = n_channels;
  s->n_bins = band->n_bins;
  s->quiet = g_new0 (float, MAX (n_channels, 1));
  s->sorted = g_new0 (float, MAX (n_channels, 1));
  /* No more workers than channels: each would plan for nothing. */
  s->workers = sonar_workers_new (MIN (MIN (threads ? threads :
              g_get_num_processors (), MAX (n_channels, 1)),
          SONAR_MAX_WORKERS), error);
  if (!s->workers)
    return NULL;
  for (guint w = 0; w < sonar_workers_count (s->workers); w++) {
    const guint n = sonar_workers_count (s->workers);
    /* The most channels a worker's run holds, at most a group. */
    const guint group = MIN (SPECTRA_GROUP, (n_channels + n - 1) / n);
    s->per_worker[w] = sonar_spectrum_new (band);
    for (guint k = 0; k < group; k++) {
      s->inputs[w][k] = fftwf_alloc_real (band->fft_size);
      s->inputs_filled[w][k] = band->fft_size;
    }
  }
  return g_steal_pointer (&s);
}

void
sonar_channel_spectra_free (SonarChannelSpectra * s)
{
  if (!s)
    return;
  sonar_workers_free (s->workers);
  for (guint w = 0; w < SONAR_MAX_WORKERS; w++) {
    sonar_spectrum_free (s->per_worker[w]);
    g_free (s->direct[w].scratch);
    for (guint k = 0; k < SPECTRA_GROUP; k++)
      fftwf_free (s->inputs[w][k]);
  }
  g_free (s->quiet);
  g_free (s->sorted);
  g_free (s);
}

/* Worker @w's share: a contiguous run of the channels, SPECTRA_GROUP at
 * a time. */
static void
channel_spectra_share (gpointer data, guint w, guint n_workers)
{
  SonarChannelSpectra *s = data;
  const guint end = s->n_channels * (w + 1) / n_workers;

  s->n_bad[w] = 0;
  s->glitches[w].zeroed = 0;
  s->glitches[w].largest = 0.0f;
  s->direct[w].removed = 0;
  s->direct[w].largest_db = -INFINITY;
  for (guint j = s->n_channels * w / n_workers; j < end;
      j += SPECTRA_GROUP)
    spectrum_process_group (s->per_worker[w], s->inputs[w],
        s->inputs_filled[w], MIN (SPECTRA_GROUP, end - j), s->samples,
        s->length, s->n_channels, j, s->out + (gsize) j * s->n_bins,
        &s->n_bad[w], &s->glitches[w], s->quiet + j, &s->direct[w]);
}

/* A channel louder than SONAR_LOUD_CHANNEL_RATIO times the median channel
 * where they record no echo (their quiet peaks) holds a hum or a bad
 * channel's noise: its spectrum is read as 0. */
static void
read_loud_channels_as_zero (SonarChannelSpectra * s)
{
  float median;

  s->n_loud = 0;
  s->loudest_db = -INFINITY;
  if (s->n_channels < SONAR_LOUD_CHANNEL_MIN_CHANNELS)
    return;
  memcpy (s->sorted, s->quiet, sizeof (float) * s->n_channels);
  median = sonar_select_kth (s->sorted, s->n_channels,
      (s->n_channels - 1) / 2);
  if (!(median > 0.0f))
    return;
  for (guint j = 0; j < s->n_channels; j++) {
    if (!(s->quiet[j] > SONAR_LOUD_CHANNEL_RATIO * median))
      continue;
    if (s->n_loud++ == 0)
      s->first_loud = j;
    s->loudest_db = MAX (s->loudest_db, 20.0 * log10 (s->quiet[j] /
            median));
    memset (s->out + (gsize) j * s->n_bins, 0,
        sizeof (SonarComplex) * s->n_bins);
  }
}

guint
sonar_channel_spectra_loud (const SonarChannelSpectra * s, guint * first,
    double *loudest_db)
{
  if (first)
    *first = s->n_loud ? s->first_loud : 0;
  if (loudest_db)
    *loudest_db = s->loudest_db;
  return s->n_loud;
}

guint
sonar_channel_spectra_process (SonarChannelSpectra * s,
    const float *samples, gsize length, SonarComplex * out)
{
  guint bad = 0;

  s->samples = samples;
  s->length = length;
  s->out = out;
  sonar_workers_run (s->workers, channel_spectra_share, s);
  for (guint w = 0; w < sonar_workers_count (s->workers); w++)
    bad += s->n_bad[w];
  read_loud_channels_as_zero (s);
  return bad;
}

guint
sonar_channel_spectra_glitches (const SonarChannelSpectra * s,
    float *largest)
{
  guint zeroed = 0;

  if (largest)
    *largest = 0.0f;
  for (guint w = 0; w < sonar_workers_count (s->workers); w++) {
    zeroed += s->glitches[w].zeroed;
    if (largest)
      *largest = MAX (*largest, s->glitches[w].largest);
  }
  return zeroed;
}

void
sonar_channel_spectra_set_direct_path (SonarChannelSpectra * s,
    const SonarDirectPath * path, SonarDirectPathMode mode)
{
  for (guint w = 0; w < sonar_workers_count (s->workers); w++) {
    DirectPathWork *d = &s->direct[w];
    g_clear_pointer (&d->scratch, g_free);
    d->path = mode == SONAR_DIRECT_PATH_OFF ? NULL : path;
    d->mode = mode;
    if (d->path)
      d->scratch = g_new (double, sonar_direct_path_scratch_size (path));
  }
}

guint
sonar_channel_spectra_direct_path_removed (const SonarChannelSpectra * s,
    double *largest_db)
{
  guint removed = 0;
  double largest = -INFINITY;

  for (guint w = 0; w < sonar_workers_count (s->workers); w++) {
    removed += s->direct[w].removed;
    largest = MAX (largest, s->direct[w].largest_db);
  }
  if (largest_db)
    *largest_db = largest;
  return removed;
}
