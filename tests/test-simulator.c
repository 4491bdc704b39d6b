/* test-simulator.c: the simulator is the ground truth of every later stage,
 * so its physics is checked against independent computations: delays and
 * amplitudes of every emitter-microphone pair, the Doppler time-scale
 * measured on the recording, a sample-by-sample comparison with an
 * analytic waveform and an iterative (not closed-form) geometry solver, the
 * truth, noise statistics and air absorption against ISO 9613-1. */
#include <fftw3.h>
#include <math.h>
#include <string.h>

#include "sonar-error.h"
#include "sonar-simulator.h"
#include "sonar-test-util.h"
#include "sonar-waveform.h"

#define FS SONAR_DEFAULT_SAMPLE_RATE
#define C SONAR_DEFAULT_SPEED_OF_SOUND
#define L SONAR_DEFAULT_WAVEFORM_LENGTH

static const float *
default_waveforms (void)
{
  static float *waveforms;

  if (!waveforms) {
    SonarWaveformParams p;
    GError *error = NULL;

    sonar_waveform_params_init_default (&p);
    waveforms = g_new (float, (gsize) p.n_emitters * p.length);
    g_assert_true (sonar_waveform_generate (&p, waveforms, &error));
    g_assert_no_error (error);
  }
  return waveforms;
}

static SonarSetup *
make_setup (const SonarGeometry * geometry, const float *waveforms,
    guint ping_length)
{
  GError *error = NULL;
  SonarSetup *setup = sonar_setup_new (&(SonarSetupParams) {
        .sample_rate = FS, .speed_of_sound = C,
        .band_low = SONAR_DEFAULT_BAND_LOW,
        .band_high = SONAR_DEFAULT_BAND_HIGH, .geometry = geometry,
        .waveform_length = L, .waveforms = waveforms,
        .ping_length = ping_length}, &error);

  g_assert_no_error (error);
  return setup;
}

/* The default array; only emitter @emitter sends when it is >= 0, so that
 * its echo can be measured without the other emitters' cross-talk. */
static SonarSetup *
default_setup (gint emitter, guint ping_length)
{
  SonarGeometry geometry;
  float *waveforms = g_memdup2 (default_waveforms (),
      sizeof (float) * SONAR_DEFAULT_N_EMITTERS * L);
  SonarSetup *setup;

  sonar_geometry_init_default (&geometry);
  for (gint n = 0; emitter >= 0 && n < SONAR_DEFAULT_N_EMITTERS; n++) {
    if (n != emitter)
      memset (waveforms + (gsize) n * L, 0, sizeof (float) * L);
  }
  setup = make_setup (&geometry, waveforms, ping_length);
  sonar_geometry_clear (&geometry);
  g_free (waveforms);
  return setup;
}

/* One emitter and one microphone. */
static SonarSetup *
pair_setup (SonarVec3 emitter, SonarVec3 microphone, const float *waveform,
    guint ping_length)
{
  SonarGeometry geometry = { 1, &microphone, 1, &emitter };
  return make_setup (&geometry, waveform, ping_length);
}

static void
scene_init (SonarScene * scene, guint n_reflectors)
{
  memset (scene, 0, sizeof (*scene));
  scene->dimensions = 3;
  scene->n_reflectors = n_reflectors;
  scene->reflectors = g_new0 (SonarReflector, MAX (n_reflectors, 1));
  for (guint k = 0; k < n_reflectors; k++)
    scene->reflectors[k].strength = 1.0;
}

static SonarVec3
direction_point (double range, double azimuth, double elevation)
{
  return sonar_vec3_scale (sonar_vec3_from_direction (azimuth, elevation),
      range);
}

static SonarSimulatorParams
quiet_params (void)
{
  SonarSimulatorParams params;

  sonar_simulator_params_init_default (&params);
  params.noise_amplitude = 0.0;
  return params;
}

/* Renders ping @ping at @ping_time with a simulator made for it. */
static float *
render (SonarSetup * setup, const SonarScene * scene,
    const SonarSimulatorParams * params, guint64 ping, double ping_time,
    SonarTruth * truth)
{
  GError *error = NULL;
  SonarSimulator *sim = sonar_simulator_new (setup, params, &error);
  float *out = g_new (float, (gsize) setup->geometry.n_microphones *
      setup->ping_length);

  g_assert_no_error (error);
  sonar_simulator_render (sim, scene, ping, ping_time, out, truth);
  sonar_simulator_free (sim);
  return out;
}

static double
energy (const float *x, gsize n)
{
  double e = 0.0;
  for (gsize i = 0; i < n; i++)
    e += (double) x[i] * x[i];
  return e;
}

static gboolean
all_finite (const float *x, gsize n)
{
  for (gsize i = 0; i < n; i++) {
    if (!isfinite (x[i]))
      return FALSE;
  }
  return TRUE;
}

/* Delay in samples of @w in @channel, searched within +-search of @guess;
 * the recording is cropped around it to keep the correlation short. */
static double
measure_delay (const float *channel, guint length, const float *w,
    guint w_length, double guess, double search, double *peak)
{
  const gssize start = CLAMP ((gssize) floor (guess - search), 0,
      (gssize) length);
  const gssize end = MIN ((gssize) length,
      (gssize) ceil (guess + search) + (gssize) w_length);

  return start + sonar_test_delay (channel + start, end - start, w, w_length,
      guess - search - start, guess + search - start, peak);
}

/* Leg shortening of a cylinder for one pair, as the header of
 * sonar-simulator.c models it, from axis point @axis. */
static double
cylinder_h (SonarVec3 axis, double rho, SonarVec3 e, SonarVec3 m)
{
  const SonarVec3 a = sonar_vec3_sub (e, axis), b = sonar_vec3_sub (m, axis);
  const double cos_theta = (a.x * b.x + a.z * b.z) / (hypot (a.x, a.z)
      * hypot (b.x, b.z));
  return rho * sqrt (0.5 * (1.0 + cos_theta));
}

/* Static reflectors: the delay of every emitter-microphone pair to 0.02
 * samples, and the amplitude law strength / (r_e + r_m)^2 to 1 %. */
static void
test_static_delays (void)
{
  const guint ping_length = 12000;
  const SonarVec3 point = direction_point (1.2, 20.0, 10.0);
  const SonarVec3 axis = sonar_vec3 (-0.4, 0.0, 1.7);
  const double rho = 0.15, strength = 2.5;
  const float *waveforms = default_waveforms ();
  SonarSimulatorParams params = quiet_params ();
  double worst_delay = 0.0, worst_amp = 0.0, worst_cyl = 0.0;

  for (guint n = 0; n < SONAR_DEFAULT_N_EMITTERS; n++) {
    SonarSetup *setup = default_setup (n, ping_length);
    const SonarGeometry *g = &setup->geometry;
    const float *w = waveforms + (gsize) n * L;
    const double w_energy = energy (w, L);
    SonarScene scene;
    float *out, *cyl;

    scene_init (&scene, 1);
    scene.reflectors[0].position = point;
    scene.reflectors[0].strength = strength;
    out = render (setup, &scene, &params, 0, 0.0, NULL);
    scene.reflectors[0].kind = SONAR_REFLECTOR_CYLINDER;
    scene.reflectors[0].position = axis;
    scene.reflectors[0].radius = rho;
    cyl = render (setup, &scene, &params, 0, 0.0, NULL);

    for (guint j = 0; j < g->n_microphones; j++) {
      const SonarVec3 e = g->emitters[n], m = g->microphones[j];
      const double path = sonar_vec3_norm (sonar_vec3_sub (point, e))
          + sonar_vec3_norm (sonar_vec3_sub (m, point));
      const double expected = path / C * FS;
      const double cyl_path = sonar_vec3_norm (sonar_vec3_sub (axis, e))
          + sonar_vec3_norm (sonar_vec3_sub (m, axis))
          - 2.0 * cylinder_h (axis, rho, e, m);
      double peak, measured, cyl_measured;

      measured = measure_delay (out + (gsize) j * ping_length, ping_length,
          w, L, expected, 50.0, &peak);
      worst_delay = MAX (worst_delay, fabs (measured - expected));
      worst_amp = MAX (worst_amp, fabs (peak / w_energy * path * path
              / strength - 1.0));
      cyl_measured = measure_delay (cyl + (gsize) j * ping_length,
          ping_length, w, L, cyl_path / C * FS, 50.0, NULL);
      worst_cyl = MAX (worst_cyl, fabs (cyl_measured - cyl_path / C * FS));
    }
    g_free (out);
    g_free (cyl);
    g_free (scene.reflectors);
    sonar_setup_unref (setup);
  }
  g_test_message ("static point, 256 pairs: worst delay error %.2e samples, "
      "worst amplitude error %.2e", worst_delay, worst_amp);
  g_test_message ("static cylinder, 256 pairs: worst delay error %.2e "
      "samples", worst_cyl);
  g_assert_cmpfloat (worst_delay, <, 0.02);
  g_assert_cmpfloat (worst_amp, <, 0.01);
  g_assert_cmpfloat (worst_cyl, <, 0.02);
}

/* Band-limited evaluation of @w at times alpha * i (i < *n_out): the
 * exact DFT interpolation of @w zero-padded to 8192 samples. */
static float *
stretch (const float *w, guint w_length, double alpha, guint * n_out)
{
  const guint size = 8192;
  double *x = fftw_alloc_real (size);
  fftw_complex *X = fftw_alloc_complex (size / 2 + 1);
  fftw_plan plan = fftw_plan_dft_r2c_1d (size, x, X, FFTW_ESTIMATE);
  float *out;

  g_assert_cmpuint (w_length + 1024, <=, size);
  memset (x, 0, sizeof (double) * size);
  for (guint i = 0; i < w_length; i++)
    x[i] = w[i];
  fftw_execute (plan);
  *n_out = (guint) floor ((w_length - 1) / alpha) + 1;
  out = g_new (float, *n_out);
  for (guint i = 0; i < *n_out; i++) {
    const double t = alpha * i;
    const double step_re = cos (2.0 * M_PI * t / size);
    const double step_im = sin (2.0 * M_PI * t / size);
    double re = 1.0, im = 0.0, sum = X[0][0];
    for (guint k = 1; k < size / 2; k++) {
      const double r = re * step_re - im * step_im;
      im = re * step_im + im * step_re;
      re = r;
      sum += 2.0 * (X[k][0] * re - X[k][1] * im);
    }
    out[i] = (float) (sum / size);
  }
  fftw_destroy_plan (plan);
  fftw_free (x);
  fftw_free (X);
  return out;
}

/* @w at times alpha * i by cubic Lagrange interpolation: rough (about
 * -40 dB), enough to locate the correlation peak of a whole echo. */
static float *
stretch_rough (const float *w, guint w_length, double alpha, guint * n_out)
{
  float *out;

  *n_out = (guint) floor ((w_length - 3) / alpha);
  out = g_new (float, *n_out);
  for (guint i = 0; i < *n_out; i++) {
    const double x = alpha * i;
    const guint k = MAX ((guint) x, 1);
    const double f = x - k;
    out[i] = (float) ((-w[k - 1] * f * (f - 1) * (f - 2)
            + w[k + 2] * (f + 1) * f * (f - 1)) / 6.0
        + (w[k] * (f + 1) * (f - 1) * (f - 2)
            - w[k + 1] * (f + 1) * f * (f - 2)) / 2.0);
  }
  return out;
}

/* Doppler time-scale alpha of the single echo in @channel (the echo is
 * w (alpha (t - t0))). First the whole waveform, stretched on a grid of
 * alpha, is correlated with the echo: the best gives alpha to 1e-3 and t0.
 * Then the reception positions of Hann-windowed segments of a template
 * stretched by the estimate are measured (searched near where the estimate
 * puts them) and a line fitted through them against their emission
 * positions: its slope is 1 / alpha. */
static double
measure_time_scale (const float *channel, guint length, const float *w)
{
  enum { SEGMENTS = 9, SEGMENT = 512 };
  guint first = 0, last = length - 1, n_x;
  double alpha = 1.0, t0 = 0.0, best = -INFINITY;

  while (first < length && channel[first] == 0.0f)
    first++;
  while (last > first && channel[last] == 0.0f)
    last--;
  g_assert_cmpuint (last, >, first + L / 2);
  n_x = last + 1 - first;

  for (double a = 0.93; a < 1.07; a += 0.001) {
    guint n_t;
    float *t = stretch_rough (w, L, a, &n_t);
    double *r = sonar_test_xcorr (channel + first, n_x, t, n_t);
    gsize peak;
    const double value = sonar_test_max_abs (r, n_x + n_t - 1, &peak);

    if (value > best) {
      best = value;
      alpha = a;
      t0 = (double) peak - (n_t - 1);
    }
    g_free (r);
    g_free (t);
  }

  for (int round = 0; round < 3; round++) {
    const double alpha_t = alpha;
    guint n_t;
    float *t = stretch (w, L, alpha_t, &n_t);
    float segment[SEGMENT];
    double sx = 0, sy = 0, sxx = 0, sxy = 0, slope;

    for (int s = 0; s < SEGMENTS; s++) {
      const guint start = 200 + s * (n_t - 400 - SEGMENT) / (SEGMENTS - 1);
      /* Emission time (waveform samples) of the segment's centre. */
      const double x = alpha_t * (start + 0.5 * (SEGMENT - 1));
      const double guess = t0 + x / alpha - 0.5 * (SEGMENT - 1);
      double y;

      for (guint i = 0; i < SEGMENT; i++)
        segment[i] = t[start + i] * (float) (0.5 - 0.5 * cos (2.0 * M_PI
                * (i + 0.5) / SEGMENT));
      y = sonar_test_delay (channel + first, n_x, segment, SEGMENT,
          guess - 16.0, guess + 16.0, NULL) + 0.5 * (SEGMENT - 1);
      sx += x;
      sy += y;
      sxx += x * x;
      sxy += x * y;
    }
    slope = (SEGMENTS * sxy - sx * sy) / (SEGMENTS * sxx - sx * sx);
    alpha = 1.0 / slope;
    t0 = (sy - slope * sx) / SEGMENTS;
    g_free (t);
  }
  return alpha;
}

/* A reflector on boresight moving radially: the echo's time-scale equals
 * (c - v) / (c + v) to 1e-5, and the exact bistatic value of the pair. */
static void
test_doppler_scale (void)
{
  static const double speeds[] = { -7.0, -0.02, 0.02, 7.0 };
  const double range = 3.0;
  const guint ping_length = 14000;
  SonarGeometry geometry;
  guint best_n = 0, best_j = 0;
  double best = INFINITY;

  /* The pair nearest the array centre: the most monostatic one. */
  sonar_geometry_init_default (&geometry);
  for (guint n = 0; n < geometry.n_emitters; n++) {
    for (guint j = 0; j < geometry.n_microphones; j++) {
      const double d = sonar_vec3_dot (geometry.emitters[n],
          geometry.emitters[n]) + sonar_vec3_dot (geometry.microphones[j],
          geometry.microphones[j]);
      if (d < best) {
        best = d;
        best_n = n;
        best_j = j;
      }
    }
  }

  for (guint s = 0; s < G_N_ELEMENTS (speeds); s++) {
    const double v = speeds[s];
    SonarSetup *setup = pair_setup (geometry.emitters[best_n],
        geometry.microphones[best_j], default_waveforms () + best_n * L,
        ping_length);
    SonarSimulatorParams params = quiet_params ();
    SonarScene scene;
    SonarTruth truth;
    float *out;
    double measured, mono, exact;

    scene_init (&scene, 1);
    scene.reflectors[0].position = sonar_vec3 (0.0, 0.0, range);
    scene.reflectors[0].velocity = sonar_vec3 (0.0, 0.0, v);
    out = render (setup, &scene, &params, 0, 0.0, &truth);
    measured = measure_time_scale (out, ping_length,
        default_waveforms () + best_n * L);

    /* Exact: d tau_e / dt = (c - u_e . V) / (c + u_m . V), u_e and u_m the
     * unit vectors from emitter and from microphone to the reflector, at
     * the reflection of the echo's centre. */
    {
      const SonarVec3 p = sonar_vec3 (0.0, 0.0, range + v * (truth.echo_delay
              / 2.0 + 0.5 * L / FS));
      const SonarVec3 ue = sonar_vec3_sub (p, geometry.emitters[best_n]);
      const SonarVec3 um = sonar_vec3_sub (p, geometry.microphones[best_j]);
      exact = (C - v * ue.z / sonar_vec3_norm (ue))
          / (C + v * um.z / sonar_vec3_norm (um));
    }
    mono = (C - v) / (C + v);
    g_test_message ("v = %+.2f m/s: time scale measured %.8f, (c-v)/(c+v) "
        "%.8f (error %.1e), exact bistatic %.8f (error %.1e)", v, measured,
        mono, measured - mono, exact, measured - exact);
    g_assert_cmpfloat (fabs (measured - mono), <, 1e-5);
    g_assert_cmpfloat (fabs (measured - exact), <, 1e-5);

    g_free (out);
    g_free (scene.reflectors);
    sonar_setup_unref (setup);
  }
  sonar_geometry_clear (&geometry);
}

/* A Gaussian-windowed sum of in-band sines: band-limited to far below
 * float precision, so its value at any fractional time is known exactly. */
static const double sine_freqs[] = { 21.3e3, 37.9e3, 52.1e3, 66.7e3, 79.2e3 };
static const double sine_phases[] = { 0.3, 2.1, 4.0, 1.2, 5.5 };

static double
analytic_raw (double x)
{
  const double sigma = L / 10.0, u = (x - 0.5 * (L - 1)) / sigma;
  double sum = 0.0;

  for (guint k = 0; k < G_N_ELEMENTS (sine_freqs); k++)
    sum += sin (2.0 * M_PI * sine_freqs[k] * x / FS + sine_phases[k]);
  return exp (-0.5 * u * u) * sum;
}

/* Solves |a - b(tau)| = c (t - tau) for tau by fixed-point iteration (a
 * contraction for |v| < c): independent of the simulator's closed form. */
static double
solve_back (SonarVec3 a, SonarVec3 b0, SonarVec3 vb, double t, double tau)
{
  for (int i = 0; i < 100; i++) {
    const SonarVec3 b = sonar_vec3_add (b0, sonar_vec3_scale (vb, tau));
    tau = t - sonar_vec3_norm (sonar_vec3_sub (a, b)) / C;
  }
  return tau;
}

typedef struct
{
  const char *name;
  double ping_time;
  SonarVec3 position;           /* relative to the sensor at the ping */
  SonarVec3 velocity;
  SonarVec3 sensor_position;    /* at t = 0 */
  SonarVec3 sensor_velocity;
} AccuracyCase;

/* Sample by sample against the analytic waveform and the iterative
 * geometry: still, moving with a moving sensor at a late ping, and close
 * and fast (where the echo's time-warp bends most within a ping). */
static void
test_interpolation_accuracy (void)
{
  static const AccuracyCase cases[] = {
    {"still at 1.5 m", 0.0, {0.3, 0.2, 1.5}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}},
    {"7 m/s at 1.5 m, sensor 0.36 m/s", 0.37, {0.3, 0.2, 1.5},
        {1.0, -0.5, 7.0}, {0.1, -0.05, -0.5}, {0.2, 0.0, 0.3}},
    {"10 m/s across at 0.15 m", 0.02, {-0.04, 0.01, 0.15},
        {10.0, 0.0, -3.0}, {0, 0, 0}, {0.0, 0.0, 0.3}},
  };
  const guint ping_length = 12000;
  const SonarVec3 e = sonar_vec3 (0.031, 0.012, 0.0);
  const SonarVec3 m = sonar_vec3 (-0.018, 0.006, 0.0);
  const double strength = 3.0;
  float *w = g_new (float, L);
  double norm = 0.0;
  SonarSetup *setup;

  for (guint i = 0; i < L; i++)
    norm = MAX (norm, fabs (analytic_raw (i)));
  for (guint i = 0; i < L; i++)
    w[i] = (float) (analytic_raw (i) / norm);
  setup = pair_setup (e, m, w, ping_length);

  for (guint c = 0; c < G_N_ELEMENTS (cases); c++) {
    const AccuracyCase *x = &cases[c];
    const SonarVec3 s_ping = sonar_vec3_add (x->sensor_position,
        sonar_vec3_scale (x->sensor_velocity, x->ping_time));
    SonarSimulatorParams params = quiet_params ();
    SonarScene scene;
    SonarVec3 p0;
    float *out;
    double worst = 0.0, peak = 0.0;

    scene_init (&scene, 1);
    scene.sensor_position = x->sensor_position;
    scene.sensor_velocity = x->sensor_velocity;
    p0 = sonar_vec3_sub (sonar_vec3_add (x->position, s_ping),
        sonar_vec3_scale (x->velocity, x->ping_time));
    scene.reflectors[0].position = p0;
    scene.reflectors[0].velocity = x->velocity;
    scene.reflectors[0].strength = strength;
    out = render (setup, &scene, &params, 0, x->ping_time, NULL);

    for (guint i = 0; i < ping_length; i++) {
      const double t = x->ping_time + i / FS;
      const SonarVec3 mt = sonar_vec3_add (sonar_vec3_add (x->sensor_position,
              m), sonar_vec3_scale (x->sensor_velocity, t));
      const double tau_r = solve_back (mt, p0, x->velocity, t, t);
      const SonarVec3 pr = sonar_vec3_add (p0, sonar_vec3_scale (x->velocity,
              tau_r));
      const double tau_e = solve_back (pr, sonar_vec3_add (x->sensor_position,
              e), x->sensor_velocity, tau_r, tau_r);
      const double path = C * (t - tau_e);
      const double ref = strength / (path * path)
          * analytic_raw ((tau_e - x->ping_time) * FS) / norm;
      worst = MAX (worst, fabs (out[i] - ref));
      peak = MAX (peak, fabs (ref));
    }
    g_test_message ("%s: worst error %.1f dB relative to the echo peak",
        x->name, 20.0 * log10 (worst / peak));
    g_assert_cmpfloat (peak, >, 0.0);
    g_assert_cmpfloat (worst / peak, <, 1e-4);
    g_free (out);
    g_free (scene.reflectors);
  }
  sonar_setup_unref (setup);
  g_free (w);
}

static void
test_noise (void)
{
  const guint ping_length = 20000;
  SonarSetup *setup = default_setup (-1, ping_length);
  const gsize total = (gsize) setup->geometry.n_microphones * ping_length;
  SonarSimulatorParams params = quiet_params ();
  SonarScene empty, scene;
  float *a, *b, *c, *quiet;
  double rms;

  scene_init (&empty, 0);
  scene_init (&scene, 1);
  scene.reflectors[0].position = sonar_vec3 (0.2, 0.1, 1.0);
  scene.reflectors[0].velocity = sonar_vec3 (0.0, 0.0, -1.0);

  quiet = render (setup, &empty, &params, 3, 0.3, NULL);
  g_assert_cmpfloat (energy (quiet, total), ==, 0.0);

  params.noise_amplitude = 0.05;
  params.seed = 42;
  a = render (setup, &empty, &params, 3, 0.3, NULL);
  b = render (setup, &empty, &params, 3, 0.3, NULL);
  c = render (setup, &empty, &params, 4, 0.3, NULL);
  g_assert_cmpmem (a, total * sizeof (float), b, total * sizeof (float));
  g_assert_true (memcmp (a, c, total * sizeof (float)) != 0);
  rms = sqrt (energy (a, total) / total);
  g_test_message ("noise rms %.5f for %.5f", rms, params.noise_amplitude);
  g_assert_cmpfloat (fabs (rms / params.noise_amplitude - 1.0), <, 0.02);
  g_free (a);
  g_free (b);
  g_free (c);

  /* With an echo too, and whatever was rendered before. */
  a = render (setup, &scene, &params, 9, 1.5, NULL);
  {
    SonarSimulator *sim = sonar_simulator_new (setup, &params, NULL);
    b = g_new (float, total);
    sonar_simulator_render (sim, &empty, 2, 0.0, b, NULL);
    sonar_simulator_render (sim, &scene, 9, 1.5, b, NULL);
    sonar_simulator_free (sim);
  }
  g_assert_cmpmem (a, total * sizeof (float), b, total * sizeof (float));
  g_free (a);
  g_free (b);

  g_free (quiet);
  g_free (empty.reflectors);
  g_free (scene.reflectors);
  sonar_setup_unref (setup);
}

/* Echoes add: two reflectors render as the sum of each alone. */
static void
test_superposition (void)
{
  const guint ping_length = 9000;
  SonarSetup *setup = default_setup (-1, ping_length);
  const gsize total = (gsize) setup->geometry.n_microphones * ping_length;
  SonarSimulatorParams params = quiet_params ();
  SonarScene both, one, other;
  float *ab, *a, *b;
  double worst = 0.0, peak = 0.0;

  scene_init (&both, 2);
  both.reflectors[0].position = direction_point (1.0, -10.0, 5.0);
  both.reflectors[1].position = direction_point (1.003, 12.0, -5.0);
  both.reflectors[1].velocity = sonar_vec3 (0.5, 0.0, -3.0);
  scene_init (&one, 1);
  one.reflectors[0] = both.reflectors[0];
  scene_init (&other, 1);
  other.reflectors[0] = both.reflectors[1];
  ab = render (setup, &both, &params, 0, 0.0, NULL);
  a = render (setup, &one, &params, 0, 0.0, NULL);
  b = render (setup, &other, &params, 0, 0.0, NULL);
  for (gsize i = 0; i < total; i++) {
    worst = MAX (worst, fabs (ab[i] - a[i] - b[i]));
    peak = MAX (peak, fabs (ab[i]));
  }
  g_assert_cmpfloat (worst, <=, 1e-6 * peak);
  g_free (ab);
  g_free (a);
  g_free (b);
  g_free (both.reflectors);
  g_free (one.reflectors);
  g_free (other.reflectors);
  sonar_setup_unref (setup);
}

/* An echo wholly outside the window leaves the recording exactly zero. */
static void
test_outside_window (void)
{
  const guint ping_length = 8000;
  SonarSetup *setup = default_setup (-1, ping_length);
  const gsize total = (gsize) setup->geometry.n_microphones * ping_length;
  SonarSimulatorParams params = quiet_params ();
  SonarSimulator *sim = sonar_simulator_new (setup, &params, NULL);
  SonarScene scene;
  float *out = g_new (float, total);
  gint64 start;

  scene_init (&scene, 64);
  for (guint k = 0; k < scene.n_reflectors; k++) {
    scene.reflectors[k].position = direction_point (20.0 + 0.1 * k,
        -60.0 + 2.0 * k, 0.0);
    scene.reflectors[k].velocity = sonar_vec3 (0.0, 0.0, -5.0);
  }
  start = g_get_monotonic_time ();
  sonar_simulator_render (sim, &scene, 0, 0.0, out, NULL);
  g_test_message ("64 reflectors beyond the window: %.2f ms",
      (g_get_monotonic_time () - start) / 1000.0);
  g_assert_cmpfloat (energy (out, total), ==, 0.0);

  /* Cut by the end of the window: present, not beyond. */
  scene.n_reflectors = 1;
  scene.reflectors[0].position = sonar_vec3 (0.0, 0.0,
      (ping_length - L / 2) / FS * C / 2.0);
  scene.reflectors[0].velocity = sonar_vec3 (0.0, 0.0, 0.0);
  sonar_simulator_render (sim, &scene, 0, 0.0, out, NULL);
  g_assert_cmpfloat (energy (out, total), >, 0.0);
  g_assert_true (all_finite (out, total));

  sonar_simulator_free (sim);
  g_free (out);
  g_free (scene.reflectors);
  sonar_setup_unref (setup);
}

typedef struct
{
  const char *name;
  SonarReflectorKind kind;
  SonarVec3 position;
  SonarVec3 velocity;
  double radius;
  SonarVec3 sensor_velocity;
} Extreme;

static void
test_extremes (void)
{
  const Extreme cases[] = {
    {"0.1 m", 0, {0, 0, 0.1}, {0, 0, 0}, 0, {0, 0, 0}},
    {"0.01 m", 0, {0, 0, 0.01}, {0, 0, 0}, 0, {0, 0, 0}},
    {"on a microphone", 0, {-0.0384, 0.0151, 0.0}, {0, 0, 0}, 0, {0, 0, 0}},
    {"20 m", 0, {0, 0, 20.0}, {0, 0, 0}, 0, {0, 0, 0}},
    {"azimuth +90", 0, {1.0, 0, 0}, {0, 0, 0}, 0, {0, 0, 0}},
    {"azimuth -90", 0, {-1.0, 0, 0}, {0, 0, 0}, 0, {0, 0, 0}},
    {"elevation +90", 0, {0, 1.0, 0}, {0, 0, 0}, 0, {0, 0, 0}},
    {"elevation -90", 0, {0, -1.0, 0}, {0, 0, 0}, 0, {0, 0, 0}},
    {"behind", 0, {0.2, 0, -1.0}, {0, 0, 0}, 0, {0, 0, 0}},
    {"+10 m/s", 0, {0, 0, 1.0}, {0, 0, 10.0}, 0, {0, 0, 0}},
    {"-10 m/s", 0, {0, 0, 1.0}, {0, 0, -10.0}, 0, {0, 0, 0}},
    {"sideways 10 m/s", 0, {0.3, 0, 1.0}, {10.0, 0, 0}, 0, {0, 0, 0}},
    {"sensor 0.3 m/s", 0, {0.3, 0, 1.5}, {0, 0, 0}, 0, {0, 0, 0.3}},
    {"cylinder", 1, {-0.3, 0.1, 1.2}, {0, 0, -1.0}, 0.1, {0.3, 0, 0}},
    {"cylinder 1 cm away", 1, {0, 0, 0.11}, {0, 0, 0}, 0.1, {0, 0, 0}},
    {"cylinder around the sensor", 1, {0, 0, 0}, {0, 0, 0}, 0.5, {0, 0, 0}},
    {"supersonic", 0, {0, 0, 1.0}, {0, 0, -400.0}, 0, {0, 0, 0}},
    {"sonic", 0, {0, 0, 1.0}, {0, 0, C}, 0, {0, 0, 0}},
  };
  const guint ping_length = 20000;
  SonarSetup *setup = default_setup (-1, ping_length);
  const gsize total = (gsize) setup->geometry.n_microphones * ping_length;
  SonarSimulatorParams params = quiet_params ();
  SonarSimulator *sim = sonar_simulator_new (setup, &params, NULL);
  float *out = g_new (float, total);
  SonarScene scene;
  SonarTruth truth;

  scene_init (&scene, 1);
  for (guint c = 0; c < G_N_ELEMENTS (cases); c++) {
    const Extreme *x = &cases[c];
    const gboolean audible = sonar_vec3_norm (x->velocity) < C;
    double e, outside = 0.0, first, last;

    scene.sensor_velocity = x->sensor_velocity;
    scene.reflectors[0].kind = x->kind;
    scene.reflectors[0].position = x->position;
    scene.reflectors[0].velocity = x->velocity;
    scene.reflectors[0].radius = x->radius;
    sonar_simulator_render (sim, &scene, 0, 0.0, out, &truth);
    g_assert_true (all_finite (out, total));
    e = energy (out, total);
    /* Where the echo must lie: around the centre path's delay, stretched
     * by at most 7 % at 10 m/s, spread by the array's size. */
    first = truth.echo_delay * FS - 300.0;
    last = truth.echo_delay * FS + 1.07 * L + 300.0;
    for (guint j = 0; j < setup->geometry.n_microphones; j++) {
      for (guint i = 0; i < ping_length; i++) {
        if (i < first || i > last)
          outside += (double) out[(gsize) j * ping_length + i] *
              out[(gsize) j * ping_length + i];
      }
    }
    g_test_message ("%s: echo delay %.1f samples, energy %.3g", x->name,
        truth.echo_delay * FS, e);
    if (!audible) {
      g_assert_cmpfloat (e, ==, 0.0);
      g_assert_true (isinf (truth.echo_delay));
    } else if (truth.echo_delay * FS < ping_length) {
      g_assert_cmpfloat (e, >, 0.0);
      g_assert_cmpfloat (outside, <=, 1e-12 * e);
    } else {
      g_assert_cmpfloat (e, ==, 0.0);
    }
  }
  g_free (scene.reflectors);

  /* No reflector at all. */
  scene_init (&scene, 0);
  sonar_simulator_render (sim, &scene, 0, 0.0, out, NULL);
  g_assert_cmpfloat (energy (out, total), ==, 0.0);
  g_free (scene.reflectors);

  /* Overlapping echoes, a few millimetres apart. */
  scene_init (&scene, 4);
  for (guint k = 0; k < 4; k++) {
    scene.reflectors[k].position = direction_point (1.0 + 0.002 * k,
        5.0 * k, 0.0);
    scene.reflectors[k].velocity = sonar_vec3 (0.0, 0.0, k - 1.5);
  }
  sonar_simulator_render (sim, &scene, 0, 0.0, out, NULL);
  g_assert_true (all_finite (out, total));
  g_assert_cmpfloat (energy (out, total), >, 0.0);
  g_free (scene.reflectors);

  sonar_simulator_free (sim);
  g_free (out);
  sonar_setup_unref (setup);
}

static void
test_clip (void)
{
  const guint ping_length = 6000;
  SonarSetup *setup = default_setup (-1, ping_length);
  const gsize total = (gsize) setup->geometry.n_microphones * ping_length;
  SonarSimulatorParams params = quiet_params ();
  SonarScene scene;
  float *raw, *clipped;
  double max_raw = 0.0, max_clipped = 0.0;

  scene_init (&scene, 1);
  scene.reflectors[0].position = sonar_vec3 (0.0, 0.0, 0.1);
  raw = render (setup, &scene, &params, 0, 0.0, NULL);
  params.clip = TRUE;
  params.noise_amplitude = 0.1;
  clipped = render (setup, &scene, &params, 0, 0.0, NULL);
  for (gsize i = 0; i < total; i++) {
    max_raw = MAX (max_raw, fabs (raw[i]));
    max_clipped = MAX (max_clipped, fabs (clipped[i]));
  }
  g_test_message ("0.1 m: peak %.1f unclipped, %.3f clipped", max_raw,
      max_clipped);
  g_assert_cmpfloat (max_raw, >, 10.0);
  g_assert_cmpfloat (max_clipped, <=, 1.0);
  g_assert_cmpfloat (max_clipped, ==, 1.0);
  g_free (raw);
  g_free (clipped);
  g_free (scene.reflectors);
  sonar_setup_unref (setup);
}

/* Iterative solution of the centre path: leaves the array centre at T,
 * reflects at *tau_r, back at the centre at the returned time. */
static double
centre_path (SonarVec3 p0, SonarVec3 v, SonarVec3 s0, SonarVec3 u,
    double ping_time, double h, double *tau_r)
{
  const SonarVec3 s_t = sonar_vec3_add (s0, sonar_vec3_scale (u, ping_time));
  double tr = ping_time, t = ping_time;

  for (int i = 0; i < 100; i++) {
    const SonarVec3 p = sonar_vec3_add (p0, sonar_vec3_scale (v, tr));
    tr = ping_time + (sonar_vec3_norm (sonar_vec3_sub (p, s_t)) - h) / C;
  }
  for (int i = 0; i < 100; i++) {
    const SonarVec3 p = sonar_vec3_add (p0, sonar_vec3_scale (v, tr));
    const SonarVec3 s = sonar_vec3_add (s0, sonar_vec3_scale (u, t));
    t = tr + (sonar_vec3_norm (sonar_vec3_sub (s, p)) - h) / C;
  }
  *tau_r = tr;
  return t;
}

static double
range_at (SonarVec3 p0, SonarVec3 v, SonarVec3 s0, SonarVec3 u, double rho,
    double t)
{
  SonarVec3 d = sonar_vec3_sub (sonar_vec3_add (p0, sonar_vec3_scale (v, t)),
      sonar_vec3_add (s0, sonar_vec3_scale (u, t)));
  const double horizontal = hypot (d.x, d.z);

  d.x -= rho * d.x / horizontal;
  d.z -= rho * d.z / horizontal;
  return sonar_vec3_norm (d);
}

static void
test_truth (void)
{
  const guint ping_length = 12000;
  SonarSetup *setup = default_setup (-1, ping_length);
  SonarSimulatorParams params = quiet_params ();
  const double ping_time = 2.25;
  SonarScene scene;
  SonarTruth truth[3], again[3];
  float *out;

  scene_init (&scene, 3);
  scene.sensor_position = sonar_vec3 (1.0, 0.0, -2.0);
  scene.sensor_velocity = sonar_vec3 (0.3, 0.0, 0.2);
  /* Receding, approaching, and a cylinder passing by. */
  scene.reflectors[0].position = sonar_vec3 (1.5, 0.3, 0.5);
  scene.reflectors[0].velocity = sonar_vec3 (0.5, 0.1, 1.5);
  scene.reflectors[0].strength = 0.7;
  scene.reflectors[1].position = sonar_vec3 (0.0, -0.2, 4.0);
  scene.reflectors[1].velocity = sonar_vec3 (-0.2, 0.0, -1.0);
  scene.reflectors[2].kind = SONAR_REFLECTOR_CYLINDER;
  scene.reflectors[2].position = sonar_vec3 (3.0, 0.0, 1.0);
  scene.reflectors[2].velocity = sonar_vec3 (-0.8, 0.0, 0.1);
  scene.reflectors[2].radius = 0.12;
  out = render (setup, &scene, &params, 5, ping_time, truth);
  sonar_simulator_truth (setup, &scene, ping_time, again);
  g_assert_cmpmem (truth, sizeof (truth), again, sizeof (again));

  for (guint k = 0; k < 3; k++) {
    const SonarReflector *r = &scene.reflectors[k];
    const double rho = r->kind == SONAR_REFLECTOR_CYLINDER ? r->radius : 0;
    const SonarVec3 u = scene.sensor_velocity, s0 = scene.sensor_position;
    double tau_r, back, rate;
    SonarVec3 p;

    back = centre_path (r->position, r->velocity, s0, u, ping_time, rho,
        &tau_r);
    p = sonar_vec3_sub (sonar_vec3_add (r->position,
            sonar_vec3_scale (r->velocity, tau_r)), sonar_vec3_add (s0,
            sonar_vec3_scale (u, tau_r)));
    if (rho > 0.0) {
      const double horizontal = hypot (p.x, p.z);
      p.x -= rho * p.x / horizontal;
      p.z -= rho * p.z / horizontal;
    }
    /* d(range)/dt by a central difference. */
    rate = (range_at (r->position, r->velocity, s0, u, rho, tau_r + 1e-4)
        - range_at (r->position, r->velocity, s0, u, rho, tau_r - 1e-4))
        / 2e-4;
    g_test_message ("reflector %u: range %.6f m, radial velocity %+.6f m/s "
        "(d(range)/dt %+.6f), delay %.9f s", k, truth[k].range,
        truth[k].radial_velocity, rate, truth[k].echo_delay);

    g_assert_cmpuint (truth[k].reflector, ==, k);
    g_assert_cmpint (truth[k].kind, ==, r->kind);
    g_assert_cmpfloat (truth[k].strength, ==, r->strength);
    g_assert_cmpfloat (sonar_vec3_norm (sonar_vec3_sub (truth[k].position,
                p)), <, 1e-9);
    g_assert_cmpfloat (sonar_vec3_norm (sonar_vec3_sub (truth[k].velocity,
                sonar_vec3_sub (r->velocity, u))), <, 1e-12);
    g_assert_cmpfloat (fabs (truth[k].range - sonar_vec3_norm (p)), <, 1e-9);
    g_assert_cmpfloat (fabs (truth[k].radial_velocity - rate), <, 1e-6);
    g_assert_cmpfloat (fabs (truth[k].echo_delay - (back - ping_time)), <,
        1e-12);
    {
      double az, el;
      sonar_vec3_to_direction (p, &az, &el);
      g_assert_cmpfloat (fabs (truth[k].azimuth - az), <, 1e-6);
      g_assert_cmpfloat (fabs (truth[k].elevation - el), <, 1e-6);
    }
  }
  /* Receding is positive. */
  g_assert_cmpfloat (truth[0].radial_velocity, >, 0.5);
  g_assert_cmpfloat (truth[1].radial_velocity, <, -0.5);

  g_free (out);
  g_free (scene.reflectors);
  sonar_setup_unref (setup);
}

/* ISO 9613-1 absorption in dB/m, written independently of the simulator. */
static double
iso_absorption (double f, double celsius, double humidity)
{
  const double t = celsius + 273.15, t_rel = t / 293.15;
  const double p_sat = pow (10.0, 4.6151 - 6.8346 * pow (273.16 / t, 1.261));
  const double h = humidity * p_sat;
  const double f_o = 24.0 + 4.04e4 * h * (0.02 + h) / (0.391 + h);
  const double f_n = (9.0 + 280.0 * h * exp (-4.170 * (cbrt (1.0 / t_rel)
              - 1.0))) / sqrt (t_rel);
  const double oxygen = 0.01275 * exp (-2239.1 / t) / (f_o + f * f / f_o);
  const double nitrogen = 0.1068 * exp (-3352.0 / t) / (f_n + f * f / f_n);

  return 8.686 * f * f * (1.84e-11 * sqrt (t_rel)
      + (oxygen + nitrogen) / pow (t_rel, 2.5));
}

/* Power spectrum (FFT size @size) of @x. */
static double *
power_spectrum (const float *x, guint n, guint size)
{
  double *in = fftw_alloc_real (size);
  fftw_complex *spectrum = fftw_alloc_complex (size / 2 + 1);
  fftw_plan plan = fftw_plan_dft_r2c_1d (size, in, spectrum, FFTW_ESTIMATE);
  double *power = g_new (double, size / 2 + 1);

  memset (in, 0, sizeof (double) * size);
  for (guint i = 0; i < n; i++)
    in[i] = x[i];
  fftw_execute (plan);
  for (guint k = 0; k <= size / 2; k++)
    power[k] = spectrum[k][0] * spectrum[k][0] + spectrum[k][1] *
        spectrum[k][1];
  fftw_destroy_plan (plan);
  fftw_free (in);
  fftw_free (spectrum);
  return power;
}

static void
test_air_absorption (void)
{
  /* ISO 9613-2 Table 2, 20 C, 70 % RH: 1, 2, 4, 8 kHz in dB/km. */
  static const double table_f[] = { 1000, 2000, 4000, 8000 };
  static const double table_db_km[] = { 5.0, 9.0, 22.9, 76.6 };
  static const double bands[2][2] = { {20e3, 30e3}, {70e3, 80e3} };
  const guint ping_length = 32768;
  const double range = 10.0;
  SonarSetup *setup = pair_setup (sonar_vec3 (0.01, 0, 0),
      sonar_vec3 (-0.01, 0, 0), default_waveforms (), ping_length);
  SonarSimulatorParams params = quiet_params ();
  SonarScene scene;
  SonarTruth truth;
  float *dry, *wet;
  double *p_dry, *p_wet, measured[2], expected[2];

  for (guint i = 0; i < G_N_ELEMENTS (table_f); i++)
    g_assert_cmpfloat (fabs (iso_absorption (table_f[i], 20.0, 70.0) * 1e3
            / table_db_km[i] - 1.0), <, 0.03);

  scene_init (&scene, 1);
  scene.reflectors[0].position = sonar_vec3 (0.0, 0.0, range);
  dry = render (setup, &scene, &params, 0, 0.0, &truth);
  params.air_absorption = TRUE;
  wet = render (setup, &scene, &params, 0, 0.0, NULL);
  g_assert_cmpfloat (truth.echo_delay * FS + L, <, ping_length);
  p_dry = power_spectrum (dry, ping_length, ping_length);
  p_wet = power_spectrum (wet, ping_length, ping_length);

  for (guint b = 0; b < 2; b++) {
    const double path = 2.0 * range;
    double e_dry = 0.0, e_wet = 0.0, e_expected = 0.0;
    for (guint k = 0; k <= ping_length / 2; k++) {
      const double f = k * FS / ping_length;
      if (f < bands[b][0] || f > bands[b][1])
        continue;
      e_dry += p_dry[k];
      e_wet += p_wet[k];
      e_expected += p_dry[k] * pow (10.0, -iso_absorption (f, 20.0,
              50.0) * path / 10.0);
    }
    measured[b] = 10.0 * log10 (e_wet / e_dry);
    expected[b] = 10.0 * log10 (e_expected / e_dry);
    g_test_message ("%.0f-%.0f kHz over %.0f m: attenuation %.2f dB, ISO "
        "%.2f dB (%.3f dB/m at the band centre)", bands[b][0] / 1e3,
        bands[b][1] / 1e3, path, -measured[b], -expected[b],
        iso_absorption (0.5 * (bands[b][0] + bands[b][1]), 20.0, 50.0));
  }
  g_assert_cmpfloat (measured[1], <, measured[0] - 10.0);
  g_assert_cmpfloat (fabs ((measured[1] - measured[0])
          - (expected[1] - expected[0])), <, 1.0);
  g_assert_cmpfloat (fabs (measured[0] - expected[0]), <, 1.0);
  g_assert_cmpfloat (fabs (measured[1] - expected[1]), <, 1.0);

  g_free (p_dry);
  g_free (p_wet);
  g_free (dry);
  g_free (wet);
  g_free (scene.reflectors);
  sonar_setup_unref (setup);
}

/* The default array with six reflectors (one cylinder, three moving):
 * reports the render time. */
static void
test_performance (void)
{
  const guint ping_length = 17000, pings = 10;
  SonarSetup *setup = default_setup (-1, ping_length);
  const gsize total = (gsize) setup->geometry.n_microphones * ping_length;
  float *out = g_new (float, total);
  SonarScene scene;
  SonarTruth truth[6];

  scene_init (&scene, 6);
  scene.reflectors[0].position = direction_point (0.8, -30.0, 0.0);
  scene.reflectors[1].position = direction_point (1.2, -10.0, 5.0);
  scene.reflectors[1].velocity = sonar_vec3 (0.0, 0.0, 0.3);
  scene.reflectors[2].position = direction_point (1.6, 0.0, 0.0);
  scene.reflectors[2].velocity = sonar_vec3 (0.0, 0.0, -2.0);
  scene.reflectors[3].position = direction_point (2.0, 15.0, -5.0);
  scene.reflectors[4].position = direction_point (2.4, 30.0, 10.0);
  scene.reflectors[4].velocity = sonar_vec3 (1.0, 0.0, 0.0);
  scene.reflectors[5].kind = SONAR_REFLECTOR_CYLINDER;
  scene.reflectors[5].position = direction_point (1.0, 45.0, 0.0);
  scene.reflectors[5].radius = 0.1;

  for (int variant = 0; variant < 3; variant++) {
    SonarSimulatorParams params = quiet_params ();
    SonarSimulator *sim;
    double sum = 0.0, best = INFINITY;

    params.noise_amplitude = variant >= 1 ? 0.01 : 0.0;
    params.air_absorption = variant == 2;
    sim = sonar_simulator_new (setup, &params, NULL);
    sonar_simulator_render (sim, &scene, 0, 0.0, out, truth);
    for (guint p = 1; p <= pings; p++) {
      const gint64 start = g_get_monotonic_time ();
      double ms;

      sonar_simulator_render (sim, &scene, p, p / 12.0, out, truth);
      ms = (g_get_monotonic_time () - start) / 1000.0;
      sum += ms;
      best = MIN (best, ms);
    }
    g_test_message ("render, 8 x 32, 6 reflectors, %u samples%s: %.1f ms "
        "(mean), %.1f ms (best)", ping_length, variant == 0 ? "" :
        variant == 1 ? ", noise" : ", noise, air absorption", sum / pings,
        best);
    g_assert_true (all_finite (out, total));
    sonar_simulator_free (sim);
  }
  g_free (out);
  g_free (scene.reflectors);
  sonar_setup_unref (setup);
}

/* direct_path: every emission heard straight by every microphone of the
 * default sensor, at its distance's delay and direct_path / d^2: within
 * -90 dB of the same built by the tests' own windowed-sinc delay (-107.6
 * measured); none
 * with 0; a negative coupling refused with a message. */
static void
test_direct_path (void)
{
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarSetup) setup = sonar_setup_new_default (5.0, &error);
  SonarSimulatorParams params = quiet_params ();
  const SonarGeometry *g;
  SonarScene scene;
  g_autofree float *out = NULL, *want = NULL, *none = NULL;
  gsize total;
  double err = 0.0;

  g_assert_no_error (error);
  g = &setup->geometry;
  total = (gsize) g->n_microphones * setup->ping_length;
  scene_init (&scene, 0);
  none = render (setup, &scene, &params, 0, 0.0, NULL);
  g_assert_cmpfloat (energy (none, total), ==, 0.0);
  params.direct_path = 0.1;
  out = render (setup, &scene, &params, 0, 0.0, NULL);
  want = g_new0 (float, total);
  for (guint j = 0; j < g->n_microphones; j++)
    for (guint n = 0; n < g->n_emitters; n++) {
      const double d = sonar_vec3_norm (sonar_vec3_sub (g->microphones[j],
              g->emitters[n]));
      sonar_test_add_delayed (want + (gsize) j * setup->ping_length,
          setup->ping_length, sonar_setup_waveform (setup, n),
          setup->waveform_length, d / setup->speed_of_sound *
          setup->sample_rate, 0.1 / (d * d));
    }
  for (gsize i = 0; i < total; i++)
    err += ((double) out[i] - want[i]) * ((double) out[i] - want[i]);
  g_test_message ("direct path against the windowed sinc: %.1f dB",
      10.0 * log10 (err / energy (want, total)));
  g_assert_cmpfloat (err, <, 1e-9 * energy (want, total));

  params.direct_path = -1.0;
  g_assert_null (sonar_simulator_new (setup, &params, &error));
  g_assert_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS);
  g_assert_cmpstr (error->message, ==, "simulator: direct-path coupling -1 "
      "must be between 0 and 1e6");
  g_free (scene.reflectors);
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/simulator/static-delays", test_static_delays);
  g_test_add_func ("/simulator/doppler-scale", test_doppler_scale);
  g_test_add_func ("/simulator/interpolation-accuracy",
      test_interpolation_accuracy);
  g_test_add_func ("/simulator/noise", test_noise);
  g_test_add_func ("/simulator/superposition", test_superposition);
  g_test_add_func ("/simulator/outside-window", test_outside_window);
  g_test_add_func ("/simulator/extremes", test_extremes);
  g_test_add_func ("/simulator/clip", test_clip);
  g_test_add_func ("/simulator/truth", test_truth);
  g_test_add_func ("/simulator/air-absorption", test_air_absorption);
  g_test_add_func ("/simulator/direct-path", test_direct_path);
  g_test_add_func ("/simulator/performance", test_performance);
  return g_test_run ();
}
