/* test-detection.c: what the Doppler bank and the MIMO imager detect, against
 * the simulator's ground truth, without a pipeline: the bank's peak velocity,
 * movers in the detection image (maximum over Doppler hypotheses), MIMO
 * against one emitter, near-field focusing, and extreme inputs. */
#include <math.h>
#include <string.h>

#include "sonar-doppler-bank.h"
#include "sonar-imager.h"
#include "sonar-simulator.h"
#include "sonar-test-util.h"
#include "sonar-waveform.h"

typedef SonarTestChain Chain;

/* The full bank of the paper's Fig. 9 (-7..7 m/s by 0.05), made once for
 * the tests that need it. */
static Chain *
full_chain (void)
{
  static Chain chain;
  static gboolean made = FALSE;

  if (!made) {
    gint64 start = g_get_monotonic_time ();
    sonar_test_chain_init_with_bank (&chain, -7.0, 7.0, 0.05);
    g_test_message ("bank -7..7 m/s by 0.05: %u velocities, FFT %u, %u bins, "
        "made in %.2f s", sonar_doppler_bank_n_velocities (chain.bank),
        chain.band.fft_size, chain.band.n_bins,
        (g_get_monotonic_time () - start) / 1e6);
    made = TRUE;
  }
  return &chain;
}

static SonarImager *
chain_imager (Chain * c, const SonarImagerParams * p)
{
  GError *error = NULL;
  SonarImager *imager = sonar_imager_new (c->setup, &c->band, p, &error);

  g_assert_no_error (error);
  g_assert_nonnull (imager);
  return imager;
}

/* Image of the current spectra, maximum over the bank velocities
 * @indices; into @image (allocated when NULL). */
static float *
chain_image (Chain * c, SonarImager * imager, const guint * indices, guint n,
    int emitter, float *image)
{
  SonarHypothesis *hypotheses = g_new (SonarHypothesis, n);

  if (!image)
    image = g_new (float, sonar_image_grid_size (sonar_imager_grid (imager)));
  for (guint h = 0; h < n; h++)
    hypotheses[h] = sonar_doppler_bank_hypothesis (c->bank, indices[h]);
  sonar_imager_process (imager, c->mic_spectra, n, hypotheses, emitter,
      image);
  g_free (hypotheses);
  return image;
}

typedef struct
{
  float value;
  gsize index;
  guint azimuth_bin, range_bin;
  double azimuth, range;        /* degrees, m */
} Peak;

/* Largest pixel of a 2-D (one elevation) image. */
static Peak
image_peak (const float *image, const SonarImageGrid * grid)
{
  const gsize size = sonar_image_grid_size (grid);
  Peak p;

  p.index = 0;
  for (gsize i = 1; i < size; i++)
    if (image[i] > image[p.index])
      p.index = i;
  p.value = image[p.index];
  p.range_bin = p.index % grid->n_range;
  p.azimuth_bin = p.index / grid->n_range % grid->n_azimuth;
  p.range = grid->range_first + p.range_bin * grid->range_step;
  p.azimuth = grid->azimuth_first + p.azimuth_bin * grid->azimuth_step;
  return p;
}

static double
db (double ratio)
{
  return 20.0 * log10 (ratio);
}

/* Imager parameters for a small 2-D window around a place. */
static void
window_params (SonarImagerParams * p, double azimuth_min, double azimuth_max,
    guint n_azimuth, double range_min, double range_max, guint zones)
{
  sonar_imager_params_init_default (p);
  p->azimuth_min = azimuth_min;
  p->azimuth_max = azimuth_max;
  p->n_azimuth = n_azimuth;
  p->range_min = range_min;
  p->range_max = range_max;
  /* 1 mm: the envelope's -3 dB main lobe is about 3 mm of range, so that
   * pixel values sample peaks to a few tenths of a dB. */
  p->range_resolution = 0.001;
  p->focus_zones = zones;
  /* These tests measure the beamformer itself: every pixel in full. */
  p->coarse_spacing = 0.0;
}

/* 1. The bank's peak: for a still sensor and a noise-free point moving at
 * v, the image's peak over every bank velocity is at v (within one step),
 * single-emitter and MIMO. */
static void
test_bank_peak (void)
{
  Chain *c = full_chain ();
  const double speeds[] = { -7, -3, -0.5, -0.1, 0.1, 0.5, 3, 7 };
  const guint n_bank = sonar_doppler_bank_n_velocities (c->bank);
  const double step = sonar_doppler_bank_step (c->bank);
  double *curve = g_new (double, n_bank);

  for (guint s = 0; s < G_N_ELEMENTS (speeds); s++) {
    g_autofree char *json = g_strdup_printf ("{\"reflectors\": [{\"range\": "
        "2.0, \"azimuth\": 15, \"radial-velocity\": %g}]}", speeds[s]);
    const SonarTruth truth = sonar_test_chain_simulate (c, json, 0.0);
    SonarImagerParams p;
    SonarImager *imager;
    float *image = NULL;

    g_assert_cmpfloat (fabs (truth.radial_velocity - speeds[s]), <, 1e-6);
    /* A window of +-1 degree, +-4 cm around the truth (paper eq. 15). */
    window_params (&p, truth.azimuth - 1, truth.azimuth + 1, 3,
        truth.range - 0.04, truth.range + 0.04, 1);
    imager = chain_imager (c, &p);
    for (int emitter = 0; emitter >= -1; emitter--) {
      guint best = 0, zero = sonar_doppler_bank_nearest (c->bank, 0.0);
      double width_lo, width_hi;
      for (guint i = 0; i < n_bank; i++) {
        image = chain_image (c, imager, &i, 1, emitter, image);
        curve[i] = image_peak (image, sonar_imager_grid (imager)).value;
        if (curve[i] > curve[best])
          best = i;
      }
      /* -3 dB width of the Doppler curve (bank steps, not interpolated). */
      width_lo = width_hi = sonar_doppler_bank_velocity (c->bank, best);
      for (guint i = best; i > 0 && curve[i - 1] >= curve[best] / M_SQRT2;
          i--)
        width_lo = sonar_doppler_bank_velocity (c->bank, i - 1);
      for (guint i = best; i + 1 < n_bank
          && curve[i + 1] >= curve[best] / M_SQRT2; i++)
        width_hi = sonar_doppler_bank_velocity (c->bank, i + 1);
      g_test_message ("v %+5.2f m/s, %s: bank peak at %+5.2f m/s, -3 dB "
          "%+5.2f..%+5.2f m/s; the 0 m/s filter is %.1f dB below", speeds[s],
          emitter < 0 ? "MIMO     " : "emitter 0",
          sonar_doppler_bank_velocity (c->bank, best), width_lo, width_hi,
          -db (curve[zero] / curve[best]));
      g_assert_cmpfloat (curve[best], >, 0.0);
      g_assert_cmpfloat (fabs (sonar_doppler_bank_velocity (c->bank, best) -
              speeds[s]), <=, step + 1e-9);
    }
    g_free (image);
    sonar_imager_free (imager);
  }
  g_free (curve);
}

/* 2. Movers in the detection image: as strong (within 3 dB) as a still
 * reflector at the same place, and where the truth says; the image at
 * 0 m/s alone loses them. */
static void
test_movers_detection_image (void)
{
  Chain *c = full_chain ();
  const double speeds[] = { 0.5, -0.5, 1, -1, 3, -3, 7, -7 };
  const guint n_bank = sonar_doppler_bank_n_velocities (c->bank);
  guint *hyps = g_new (guint, n_bank + 2);
  const guint n_hyps = sonar_doppler_bank_hypotheses (c->bank, 0.3, hyps);
  const guint zero = sonar_doppler_bank_nearest (c->bank, 0.0);
  SonarImagerParams p;
  SonarImager *imager;
  const SonarImageGrid *grid;
  float *image = NULL;
  Peak still_det, still_zero;
  SonarTruth truth;

  /* -6.9, -6.6, ..., 6.9 m/s: 47 hypotheses (the ends are within 0.15). */
  g_assert_cmpuint (n_hyps, ==, 47);
  g_assert_cmpfloat (fabs (sonar_doppler_bank_velocity (c->bank, hyps[0]) +
          6.9), <, 1e-9);
  /* The near field matters little at 2 m: one focus zone. At 40 degrees
   * a fast mover's echo would be imaged 2 degrees off without the Doppler
   * correction of the emitters' paths (physics notes). */
  window_params (&p, 20, 60, 41, 1.7, 2.3, 1);
  imager = chain_imager (c, &p);
  grid = sonar_imager_grid (imager);

  truth = sonar_test_chain_simulate (c, "{\"reflectors\": [{\"range\": 2.0, "
      "\"azimuth\": 40}]}", 0.0);
  image = chain_image (c, imager, hyps, n_hyps, -1, image);
  still_det = image_peak (image, grid);
  image = chain_image (c, imager, &zero, 1, -1, image);
  still_zero = image_peak (image, grid);
  g_test_message ("still: detection peak %.4g at %.1f deg %.4f m, 0 m/s "
      "image peak %.4g (%.2f dB)", still_det.value, still_det.azimuth,
      still_det.range, still_zero.value,
      db (still_zero.value / still_det.value));
  g_assert_cmpfloat (fabs (still_det.azimuth - truth.azimuth), <=,
      grid->azimuth_step + 1e-9);
  g_assert_cmpfloat (fabs (still_det.range - truth.range), <=, 0.01);
  /* The still reflector is imaged at its own speed either way. */
  g_assert_cmpfloat (fabs (db (still_zero.value / still_det.value)), <, 0.1);

  for (guint s = 0; s < G_N_ELEMENTS (speeds); s++) {
    g_autofree char *json = g_strdup_printf ("{\"reflectors\": [{\"range\": "
        "2.0, \"azimuth\": 40, \"radial-velocity\": %g}]}", speeds[s]);
    Peak det, zero_peak;
    double det_db, zero_db;

    truth = sonar_test_chain_simulate (c, json, 0.0);
    image = chain_image (c, imager, hyps, n_hyps, -1, image);
    det = image_peak (image, grid);
    image = chain_image (c, imager, &zero, 1, -1, image);
    zero_peak = image_peak (image, grid);
    det_db = db (det.value / still_det.value);
    zero_db = db (zero_peak.value / still_det.value);
    g_test_message ("v %+4.1f m/s (truth %.4f m %.1f deg): detection image "
        "%+5.2f dB at %.1f deg %.4f m; 0 m/s image %+6.2f dB", speeds[s],
        truth.range, truth.azimuth, det_db, det.azimuth, det.range, zero_db);
    g_assert_cmpfloat (det_db, >, -3.0);
    g_assert_cmpfloat (fabs (det.azimuth - truth.azimuth), <=,
        grid->azimuth_step + 1e-9);
    g_assert_cmpfloat (fabs (det.range - truth.range), <=, 0.02);
    if (fabs (speeds[s]) >= 1.0)
      g_assert_cmpfloat (zero_db, <, -6.0);
  }
  g_free (image);
  g_free (hyps);
  sonar_imager_free (imager);
}

typedef struct
{
  double width;                 /* -3 dB main lobe, degrees */
  double psl;                   /* peak sidelobe, dB below the peak */
} Lobe;

/* Main lobe and sidelobes of an azimuth cut (@n values at @step degrees)
 * with its maximum at @peak. */
static Lobe
measure_lobe (const double *cut, guint n, guint peak, double step)
{
  const double half = cut[peak] / M_SQRT2;
  double left = 0, right = (n - 1) * step, side = 0;
  guint lo = peak, hi = peak;
  Lobe lobe;

  for (guint i = peak; i > 0; i--)
    if (cut[i - 1] < half) {
      left = (i - 1 + (half - cut[i - 1]) / (cut[i] - cut[i - 1])) * step;
      break;
    }
  for (guint i = peak; i + 1 < n; i++)
    if (cut[i + 1] < half) {
      right = (i + (cut[i] - half) / (cut[i] - cut[i + 1])) * step;
      break;
    }
  /* The main lobe ends at the first minimum each side. */
  while (lo > 0 && cut[lo - 1] <= cut[lo])
    lo--;
  while (hi + 1 < n && cut[hi + 1] <= cut[hi])
    hi++;
  for (guint i = 0; i < n; i++)
    if (i < lo || i > hi)
      side = MAX (side, cut[i]);
  lobe.width = right - left;
  lobe.psl = db (side / cut[peak]);
  return lobe;
}

/* 3. The MIMO virtual array against one emitter: same scene, same
 * microphones; the MIMO point spread is narrower. */
static void
test_mimo_beats_single_emitter (void)
{
  Chain c;
  const guint zero = 0;
  SonarImagerParams p;
  SonarImager *imager;
  const SonarImageGrid *grid;
  float *image = NULL;
  double *cut;
  Lobe lobes[2];
  SonarTruth truth;

  sonar_test_chain_init_with_bank (&c, 0.0, 0.0, 0.05);
  window_params (&p, -90, 90, 721, 1.9, 2.1, 1);
  imager = chain_imager (&c, &p);
  grid = sonar_imager_grid (imager);
  cut = g_new (double, grid->n_azimuth);
  truth = sonar_test_chain_simulate (&c, "{\"reflectors\": [{\"range\": 2.0, "
      "\"azimuth\": 20}]}", 0.0);
  for (guint m = 0; m < 2; m++) {
    const int emitter = m == 0 ? -1 : 0;
    Peak peak;
    image = chain_image (&c, imager, &zero, 1, emitter, image);
    peak = image_peak (image, grid);
    g_assert_cmpfloat (fabs (peak.azimuth - truth.azimuth), <=,
        grid->azimuth_step + 1e-9);
    g_assert_cmpfloat (fabs (peak.range - truth.range), <=, 0.01);
    /* The azimuth cut through the peak's range. */
    for (guint a = 0; a < grid->n_azimuth; a++)
      cut[a] = image[(gsize) a * grid->n_range + peak.range_bin];
    lobes[m] = measure_lobe (cut, grid->n_azimuth, peak.azimuth_bin,
        grid->azimuth_step);
    g_test_message ("%s: peak %.4g at %.2f deg %.4f m, -3 dB width %.2f deg, "
        "peak sidelobe %.1f dB", emitter < 0 ? "MIMO     " : "emitter 0",
        peak.value, peak.azimuth, peak.range, lobes[m].width, lobes[m].psl);
  }
  /* The virtual array is about twice as wide as the microphone array: a
   * narrower main lobe; and the sum over emitters averages the sidelobes
   * of 8 different virtual sub-arrays (and the cross-talk). */
  g_assert_cmpfloat (lobes[0].width, <, 0.8 * lobes[1].width);
  g_assert_cmpfloat (lobes[0].psl, <, lobes[1].psl - 1.5);
  g_free (cut);
  g_free (image);
  sonar_imager_free (imager);
  sonar_test_chain_clear (&c);
}

/* 4. Near-field focusing: reflectors at 0.3, 0.5 and 1 m imaged with 1, 4
 * (the default) and 8 focus zones over the default 0.3-5 m. */
static void
test_focus_zones (void)
{
  Chain c;
  const guint zero = 0;
  const double ranges[] = { 0.3, 0.5, 1.0 };
  const guint zones[] = { 1, 4, 8 };
  double peak[3][3], width[3][3];
  double *cut = NULL;

  sonar_test_chain_init_with_bank (&c, 0.0, 0.0, 0.05);
  for (guint r = 0; r < G_N_ELEMENTS (ranges); r++) {
    g_autofree char *json = g_strdup_printf ("{\"reflectors\": [{\"range\": "
        "%g, \"azimuth\": 20}]}", ranges[r]);
    const SonarTruth truth = sonar_test_chain_simulate (&c, json, 0.0);
    for (guint z = 0; z < G_N_ELEMENTS (zones); z++) {
      SonarImagerParams p;
      SonarImager *imager;
      const SonarImageGrid *grid;
      float *image;
      Peak pk;
      Lobe lobe;

      sonar_imager_params_init_default (&p);
      p.azimuth_min = 0;
      p.azimuth_max = 40;
      p.n_azimuth = 81;
      p.range_resolution = 0.0005;
      p.focus_zones = zones[z];
      imager = chain_imager (&c, &p);
      grid = sonar_imager_grid (imager);
      image = chain_image (&c, imager, &zero, 1, -1, NULL);
      pk = image_peak (image, grid);
      g_assert_cmpfloat (fabs (pk.azimuth - truth.azimuth), <=,
          grid->azimuth_step + 1e-9);
      g_assert_cmpfloat (fabs (pk.range - truth.range), <=, 0.01);
      cut = g_renew (double, cut, grid->n_azimuth);
      for (guint a = 0; a < grid->n_azimuth; a++)
        cut[a] = image[(gsize) a * grid->n_range + pk.range_bin];
      lobe = measure_lobe (cut, grid->n_azimuth, pk.azimuth_bin,
          grid->azimuth_step);
      peak[r][z] = pk.value;
      width[r][z] = lobe.width;
      g_free (image);
      sonar_imager_free (imager);
    }
  }
  g_test_message ("range | peak (dB re 8 zones), -3 dB azimuth width (deg)");
  g_test_message ("      | 1 zone          4 zones         8 zones");
  for (guint r = 0; r < G_N_ELEMENTS (ranges); r++)
    g_test_message ("%.1f m | %+5.2f dB %4.2f  %+5.2f dB %4.2f  %+5.2f dB "
        "%4.2f", ranges[r], db (peak[r][0] / peak[r][2]), width[r][0],
        db (peak[r][1] / peak[r][2]), width[r][1], 0.0, width[r][2]);
  /* The default 4 zones are within 1 dB of 8 at 0.3 m, where one zone
   * (focused at 0.57 m) loses more. */
  g_assert_cmpfloat (db (peak[0][1] / peak[0][2]), >, -1.0);
  g_assert_cmpfloat (db (peak[0][0] / peak[0][2]), <,
      db (peak[0][1] / peak[0][2]) - 0.3);
  g_free (cut);
  sonar_test_chain_clear (&c);
}

static gboolean
all_finite (const float *x, gsize n)
{
  for (gsize i = 0; i < n; i++)
    if (!isfinite (x[i]))
      return FALSE;
  return TRUE;
}

/* 5. Extremes: silence images to exact zeros; a huge close echo stays
 * finite and in place. */
static void
test_core_extremes (void)
{
  Chain c;
  guint all[5];
  SonarImagerParams p;
  SonarImager *imager;
  const SonarImageGrid *grid;
  float *image;
  gsize size;
  SonarTruth truth;
  Peak pk;

  sonar_test_chain_init_with_bank (&c, -0.1, 0.1, 0.05);
  for (guint i = 0; i < 5; i++)
    all[i] = i;
  window_params (&p, -90, 90, 61, 0.3, 3.0, 4);
  p.range_resolution = 0.005;
  imager = chain_imager (&c, &p);
  grid = sonar_imager_grid (imager);
  size = sonar_image_grid_size (grid);

  memset (c.ping, 0, sizeof (float) * c.setup->ping_length *
      c.setup->geometry.n_microphones);
  sonar_test_chain_spectra (&c);
  for (int emitter = -1; emitter < 1; emitter++) {
    image = chain_image (&c, imager, all, 5, emitter, NULL);
    for (gsize i = 0; i < size; i++)
      g_assert_cmpfloat (image[i], ==, 0.0f);
    g_free (image);
  }

  truth = sonar_test_chain_simulate (&c, "{\"reflectors\": [{\"range\": 0.3, "
      "\"azimuth\": -30, \"strength\": 1000000}]}", 0.0);
  image = chain_image (&c, imager, all, 5, -1, NULL);
  g_assert_true (all_finite (image, size));
  pk = image_peak (image, grid);
  g_test_message ("strength 1e6 at 0.3 m: peak %.4g at %.1f deg %.4f m",
      pk.value, pk.azimuth, pk.range);
  g_assert_cmpfloat (pk.value, >, 1e3);
  g_assert_cmpfloat (fabs (pk.azimuth - truth.azimuth), <=,
      grid->azimuth_step + 1e-9);
  g_assert_cmpfloat (fabs (pk.range - truth.range), <=, 0.01);
  g_free (image);

  /* Linearity over the float range: the same echo scaled by 1e-30 and by
   * 1e+25 images to the same place, scaled alike. */
  truth = sonar_test_chain_simulate (&c, "{\"reflectors\": [{\"range\": 1.2, "
      "\"azimuth\": 40}]}", 0.0);
  image = chain_image (&c, imager, all, 5, -1, NULL);
  pk = image_peak (image, grid);
  g_free (image);
  g_assert_cmpfloat (fabs (pk.azimuth - truth.azimuth), <=,
      grid->azimuth_step + 1e-9);
  {
    const double scales[] = { 1e-30, 1e25 };
    const gsize n = (gsize) c.setup->ping_length *
        c.setup->geometry.n_microphones;
    for (guint s = 0; s < G_N_ELEMENTS (scales); s++) {
      float *copy = g_memdup2 (c.ping, sizeof (float) * n);
      Peak scaled;
      for (gsize i = 0; i < n; i++)
        c.ping[i] = (float) (copy[i] * scales[s]);
      sonar_test_chain_spectra (&c);
      image = chain_image (&c, imager, all, 5, -1, NULL);
      g_assert_true (all_finite (image, size));
      scaled = image_peak (image, grid);
      g_test_message ("echo scaled by %g: peak %.4g (%.6f of the scaled "
          "unscaled peak) at %.1f deg %.4f m", scales[s], scaled.value,
          scaled.value / (pk.value * scales[s]), scaled.azimuth,
          scaled.range);
      g_assert_cmpuint (scaled.index, ==, pk.index);
      g_assert_cmpfloat (fabs (scaled.value / (pk.value * scales[s]) - 1.0),
          <, 1e-3);
      memcpy (c.ping, copy, sizeof (float) * n);
      g_free (copy);
      g_free (image);
    }
  }

  /* A few samples of 1e30 (a broken ADC): finite. */
  memset (c.ping, 0, sizeof (float) * c.setup->ping_length *
      c.setup->geometry.n_microphones);
  for (guint j = 0; j < c.setup->geometry.n_microphones; j += 5)
    c.ping[(gsize) j * c.setup->ping_length + 3000 + 7 * j] = 1e30f;
  sonar_test_chain_spectra (&c);
  image = chain_image (&c, imager, all, 5, -1, NULL);
  pk = image_peak (image, grid);
  g_test_message ("samples of 1e30: image peak %.4g", pk.value);
  g_assert_true (all_finite (image, size));
  g_assert_cmpfloat (pk.value, >, 0.0);
  g_free (image);

  sonar_imager_free (imager);
  sonar_test_chain_clear (&c);
}

/* The front end reads NaN and infinite samples as zeros and counts them. */
static void
test_spectrum_non_finite (void)
{
  SonarBand band;
  g_autoptr (SonarSpectrum) spectrum = NULL;
  const guint length = 3000, stride = 3;
  float *clean = g_new0 (float, length * stride);
  float *dirty = g_new0 (float, length * stride);
  SonarComplex *a, *b;
  guint n_bad = 5;

  sonar_band_init (&band, 450000.0, 4096, 20000.0, 80000.0);
  spectrum = sonar_spectrum_new (&band);
  a = g_new (SonarComplex, band.n_bins);
  b = g_new (SonarComplex, band.n_bins);
  for (guint i = 0; i < length * stride; i++)
    clean[i] = dirty[i] = (float) sin (0.7 * i) * (i % 7 == 0 ? 2.0 : 1.0);
  /* Bad samples in the channel read (offset 0, stride 3) and one in
   * another channel, which must not count. */
  dirty[30 * stride] = NAN;
  dirty[100 * stride] = INFINITY;
  dirty[2999 * stride] = -INFINITY;
  dirty[40 * stride + 1] = NAN;
  clean[30 * stride] = clean[100 * stride] = clean[2999 * stride] = 0.0f;

  sonar_spectrum_process (spectrum, clean, length, stride, a, NULL);
  sonar_spectrum_process (spectrum, dirty, length, stride, b, &n_bad);
  g_assert_cmpuint (n_bad, ==, 5 + 3);
  for (guint k = 0; k < band.n_bins; k++) {
    g_assert_true (isfinite (crealf (b[k])) && isfinite (cimagf (b[k])));
    g_assert_true (a[k] == b[k]);
  }
  /* A clean signal counts nothing. */
  n_bad = 0;
  sonar_spectrum_process (spectrum, clean, length, stride, b, &n_bad);
  g_assert_cmpuint (n_bad, ==, 0);
  g_free (a);
  g_free (b);
  g_free (clean);
  g_free (dirty);
}

int
main (int argc, char **argv)
{
  int ret;

  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/detection/bank-peak", test_bank_peak);
  g_test_add_func ("/detection/movers-detection-image",
      test_movers_detection_image);
  g_test_add_func ("/detection/mimo-beats-single-emitter",
      test_mimo_beats_single_emitter);
  g_test_add_func ("/detection/focus-zones", test_focus_zones);
  g_test_add_func ("/detection/core-extremes", test_core_extremes);
  g_test_add_func ("/detection/spectrum-non-finite",
      test_spectrum_non_finite);
  ret = g_test_run ();
  return ret;
}
