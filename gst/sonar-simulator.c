/* sonar-simulator.c: see sonar-simulator.h.
 *
 * Times are handled in double precision relative to the ping time T (local
 * time 0 = sample 0 of the window), so a large T costs no precision.
 *
 * Geometry of one echo (emitter E, reflector P, microphone M, all moving in
 * straight lines, air at rest). For the sample recorded at local time t:
 *   reflection:  |M(t) - P(tau_r)| = c (t - tau_r) + h
 *   emission:    |P(tau_r) - E(tau_e)| = c (tau_r - tau_e) + h
 * Each is |d + v s| = c s + h in the unknown leg duration s >= 0, with d
 * the separation at a known instant and v the velocity of the element at
 * the unknown end: the quadratic (c^2 - |v|^2) s^2 - 2 (d.v - c h) s
 * - (|d|^2 - h^2) = 0, solved exactly (leg_time()). The same function
 * solves the legs forwards, from an emission instant, to bound the echo.
 *
 * The closed form is evaluated every NODE_SPACING samples of each echo
 * (both legs, in double precision); the emission instant and the amplitude
 * in between are the cubics through the four nearest of these nodes,
 * stepped by forward differences. The error is below 0.024 H^4 times the
 * largest 4th derivative, H the node spacing, which grows as v^4 / r^3 for
 * a relative speed v at distance r from the nearest element: at 10 m/s it
 * measures 5e-6 samples at 5 cm, 1e-6 at 10 cm and 1e-9 at 1 m (see
 * sonar-simulator.h); the tests compare every sample with an independent
 * iterative solution.
 *
 * Cylinder model: a vertical cylinder of radius rho reflects specularly
 * from the surface point on the bisector of the directions (seen from the
 * axis, in the horizontal plane) to the emitter and to the microphone; for
 * elements far compared with rho each leg is then shorter than the distance
 * to the axis by h = rho cos (theta / 2), theta the angle between those
 * directions. So the axis point is tracked like a point reflector and both
 * legs are shortened by h. theta is taken once per emitter-microphone pair
 * and ping, from the geometry at the echo's centre: it changes negligibly
 * during one ping. The reflection happens at the axis point's height. A
 * point is a cylinder with h = 0.
 *
 * Amplitude: strength / (r_e + r_m)^2 (paper eq. 6) with r_e + r_m =
 * c (t - tau_e) the acoustic path of each sample, so the spreading loss of
 * a fast mover changes along its echo as it does physically. The path is
 * clamped at MIN_PATH so that a reflector on an element stays finite.
 *
 * Interpolation: each waveform is read through its SonarInterp
 * (sonar-interp.h), stepping table coordinates directly in the inner loop.
 *
 * Air absorption: ISO 9613-1 at 20 C, 50 % RH, applied as a zero-phase
 * gain on each waveform's spectrum for the reflector's centre path length
 * (c times its echo delay): sonar_interp_filter() rebuilds the tables per
 * reflector and ping with the plans and buffers made in _new().
 */
#include "sonar-simulator.h"
#include "sonar-error.h"
#include "sonar-memory.h"
#include "sonar-interp.h"
#include "sonar-rng.h"

#include <gio/gio.h>
#include <math.h>
#include <string.h>

#define NODE_SPACING 64         /* samples between exact solutions */
#define MIN_PATH 0.01           /* m */

/* Conditions of the air absorption model. */
#define AIR_KELVIN 293.15
#define AIR_HUMIDITY 50.0       /* % */

struct _SonarSimulator
{
  SonarSetup *setup;
  SonarSimulatorParams params;

  SonarInterp **waveforms;      /* [n_emitters] */

  /* Only with air absorption. */
  guint n_bins;
  double *absorption;           /* nepers per metre, per bin */
  float *gains;                 /* per bin, for the current reflector */

  /* Per-ping scratch, sized in _new(). */
  guint *spans;                 /* [2 * (j * n_emitters + n)] sample range */
  double *heights;              /* [j * n_emitters + n] leg shortening h */
  double *node_pos;             /* table positions at the nodes of one echo */
  double *node_amp;             /* amplitudes at the nodes of one echo */
};

void
sonar_simulator_params_init_default (SonarSimulatorParams * params)
{
  params->noise_amplitude = 0.01;
  params->seed = 0;
  params->clip = FALSE;
  params->air_absorption = FALSE;
  params->direct_path = 0.0;
}

/* ISO 9613-1:1993 pure-tone absorption of air (eq. 3 to 5, B.1 to B.3) in
 * dB/m, at standard pressure. The standard states it up to 10 kHz; at the
 * sonar's frequencies it is the accepted classical-plus-relaxation model. */
static double
air_absorption_db_per_m (double frequency, double kelvin, double humidity)
{
  const double t0 = 293.15, t01 = 273.16;
  const double tr = kelvin / t0;
  const double csat = -6.8346 * pow (t01 / kelvin, 1.261) + 4.6151;
  const double h = humidity * pow (10.0, csat);
  const double fr_o = 24.0 + 4.04e4 * h * (0.02 + h) / (0.391 + h);
  const double fr_n = pow (tr, -0.5) * (9.0 + 280.0 * h *
      exp (-4.170 * (pow (tr, -1.0 / 3.0) - 1.0)));
  const double f2 = frequency * frequency;

  return 8.686 * f2 * (1.84e-11 * sqrt (tr) + pow (tr, -2.5) *
      (0.01275 * exp (-2239.1 / kelvin) / (fr_o + f2 / fr_o)
          + 0.1068 * exp (-3352.0 / kelvin) / (fr_n + f2 / fr_n)));
}

SonarSimulator *
sonar_simulator_new (SonarSetup * setup, const SonarSimulatorParams * params,
    GError ** error)
{
  SonarSimulator *sim;
  const guint n_emitters = setup->geometry.n_emitters;
  const guint length = setup->waveform_length;

  g_return_val_if_fail (setup != NULL && params != NULL, NULL);

  if (!(params->noise_amplitude >= 0.0 && params->noise_amplitude <= 1e6)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "simulator: noise amplitude %g must be between 0 and 1e6",
        params->noise_amplitude);
    return NULL;
  }
  if (!(params->direct_path >= 0.0 && params->direct_path <= 1e6)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "simulator: direct-path coupling %g must be between 0 and 1e6",
        params->direct_path);
    return NULL;
  }

  sim = g_new0 (SonarSimulator, 1);
  sim->setup = sonar_setup_ref (setup);
  sim->params = *params;

  sim->waveforms = g_new (SonarInterp *, n_emitters);
  for (guint e = 0; e < n_emitters; e++) {
    const float *w = sonar_setup_waveform (setup, e);
    /* Rendering is sequential: one set of rebuild buffers serves all. */
    sim->waveforms[e] = params->air_absorption ?
        sonar_interp_new_filterable (w, length, e ? sim->waveforms[0] : NULL)
        : sonar_interp_new (w, length);
  }

  if (params->air_absorption) {
    sim->n_bins = sonar_interp_n_bins (sim->waveforms[0]);
    sim->absorption = g_new (double, sim->n_bins);
    sim->gains = g_new (float, sim->n_bins);
    for (guint k = 0; k < sim->n_bins; k++)
      sim->absorption[k] = air_absorption_db_per_m (sonar_interp_bin_frequency
          (sim->waveforms[0], k) * setup->sample_rate, AIR_KELVIN,
          AIR_HUMIDITY) * (G_LN10 / 20.0);
  }

  sim->node_pos = g_new (double, setup->ping_length / NODE_SPACING + 4);
  sim->node_amp = g_new (double, setup->ping_length / NODE_SPACING + 4);
  sim->spans = g_new (guint, 2 * (gsize) n_emitters *
      setup->geometry.n_microphones);
  sim->heights = g_new (double, (gsize) n_emitters *
      setup->geometry.n_microphones);
  return sim;
}

guint64
sonar_simulator_memory (const SonarSetup * setup, guint n_windows)
{
  const guint64 window = sonar_memory_array ((guint64)
      setup->geometry.n_microphones * setup->ping_length, sizeof (float));

  return sonar_memory_add (sonar_memory_array (setup->geometry.n_emitters,
          sonar_interp_memory (setup->waveform_length)),
      sonar_memory_add (sonar_memory_array (n_windows, window),
          /* node_pos and node_amp */
          2 * sizeof (double) * (setup->ping_length / NODE_SPACING + 4)));
}

void
sonar_simulator_free (SonarSimulator * sim)
{
  if (!sim)
    return;
  for (guint e = 0; e < sim->setup->geometry.n_emitters; e++)
    sonar_interp_free (sim->waveforms[e]);
  g_free (sim->waveforms);
  g_free (sim->absorption);
  g_free (sim->gains);
  g_free (sim->node_pos);
  g_free (sim->node_amp);
  g_free (sim->spans);
  g_free (sim->heights);
  sonar_setup_unref (sim->setup);
  g_free (sim);
}

/* Duration s >= 0 of a leg |d + v s| = c s + h, given a = c^2 - |v|^2 > 0,
 * ch = c h and hh = h^2. The positive root (b + sqrt D) / a is taken as
 * q / (sqrt D - b) when b < 0, so that it never cancels. |d| < h (inside
 * a cylinder) is clamped to a zero-length leg. */
static double
leg_time (SonarVec3 d, SonarVec3 v, double a, double ch, double hh)
{
  const double b = sonar_vec3_dot (d, v) - ch;
  const double q = MAX (sonar_vec3_dot (d, d) - hh, 0.0);
  const double w = fabs (b) + sqrt (b * b + a * q);

  return b >= 0.0 ? w / a : q / w;
}

/* Motion of one reflector relative to the sensor, in local time. */
typedef struct
{
  double c;
  SonarVec3 rel;                /* P - S at local time 0 */
  SonarVec3 w;                  /* V - U */
  SonarVec3 v;                  /* reflector velocity */
  SonarVec3 u;                  /* sensor velocity */
  double a_v, a_u;              /* c^2 - |V|^2, c^2 - |U|^2 */
} Motion;

/* FALSE when no echo can be computed: the reflector or the sensor moves at
 * (or within 0.05 % of) the speed of sound or faster, or the state is not
 * finite. Such a reflector is simply not rendered (the scene validator
 * rejects speeds of c / 2 and more anyway). */
static gboolean
motion_init (Motion * m, const SonarSetup * setup, const SonarScene * scene,
    const SonarReflector * r, double ping_time)
{
  const SonarVec3 p = sonar_vec3_add (r->position,
      sonar_vec3_scale (r->velocity, ping_time));
  const SonarVec3 s = sonar_vec3_add (scene->sensor_position,
      sonar_vec3_scale (scene->sensor_velocity, ping_time));

  m->c = setup->speed_of_sound;
  m->rel = sonar_vec3_sub (p, s);
  m->v = r->velocity;
  m->u = scene->sensor_velocity;
  m->w = sonar_vec3_sub (m->v, m->u);
  m->a_v = m->c * m->c - sonar_vec3_dot (m->v, m->v);
  m->a_u = m->c * m->c - sonar_vec3_dot (m->u, m->u);
  return m->a_v > 1e-3 * m->c * m->c && m->a_u > 1e-3 * m->c * m->c
      && isfinite (m->a_v) && isfinite (m->a_u) && isfinite (m->rel.x)
      && isfinite (m->rel.y) && isfinite (m->rel.z) && isfinite (r->radius)
      && r->radius >= 0.0;
}

/* Reflector minus emitter at local time tau, emitter at offset e. */
static inline SonarVec3
emitter_side (const Motion * m, SonarVec3 e, double tau)
{
  return sonar_vec3_add (sonar_vec3_sub (m->rel, e), sonar_vec3_scale (m->w,
          tau));
}

/* Microphone minus reflector at local time tau, microphone at offset mic. */
static inline SonarVec3
microphone_side (const Motion * m, SonarVec3 mic, double tau)
{
  return sonar_vec3_sub (sonar_vec3_sub (mic, m->rel), sonar_vec3_scale (m->w,
          tau));
}

/* Forward in time: the local instant at which the wave that emitter offset
 * e sends at local time tau_e reaches microphone offset mic via the
 * reflector; *tau_r receives the reflection instant. */
static double
echo_arrival (const Motion * m, SonarVec3 e, SonarVec3 mic, double h,
    double tau_e, double *tau_r)
{
  const double tr = tau_e + leg_time (emitter_side (m, e, tau_e), m->v,
      m->a_v, m->c * h, h * h);

  if (tau_r)
    *tau_r = tr;
  return tr + leg_time (microphone_side (m, mic, tr), m->u, m->a_u,
      m->c * h, h * h);
}

static double
reflector_radius (const SonarReflector * r)
{
  return r->kind == SONAR_REFLECTOR_CYLINDER ? r->radius : 0.0;
}

/* Truth of reflector @k (see SonarTruth); *tau_r receives the local
 * reflection instant of the centre path. FALSE when it cannot echo. */
static gboolean
centre_truth (const SonarSetup * setup, const SonarScene * scene, guint k,
    double ping_time, Motion * m, SonarTruth * truth, double *tau_r)
{
  const SonarReflector *r = &scene->reflectors[k];
  const SonarVec3 origin = { 0.0, 0.0, 0.0 };
  const gboolean ok = motion_init (m, setup, scene, r, ping_time);
  double tr = 0.0, delay = INFINITY;
  SonarVec3 p;

  /* The centre sees a cylinder head-on: theta = 0, h = rho. */
  if (ok)
    delay = echo_arrival (m, origin, origin, reflector_radius (r), 0.0, &tr);
  p = sonar_vec3_add (m->rel, sonar_vec3_scale (m->w, tr));
  if (r->kind == SONAR_REFLECTOR_CYLINDER) {
    const double horizontal = hypot (p.x, p.z);
    if (horizontal > 0.0) {
      p.x -= r->radius * p.x / horizontal;
      p.z -= r->radius * p.z / horizontal;
    }
  }

  truth->reflector = k;
  truth->kind = r->kind;
  truth->position = p;
  truth->velocity = m->w;
  truth->range = sonar_vec3_norm (p);
  sonar_vec3_to_direction (p, &truth->azimuth, &truth->elevation);
  /* For the nearest point of a cylinder too, d|p|/dt = p.w / |p|: that
   * point slides tangentially, perpendicular to p. */
  truth->radial_velocity = truth->range > 0.0 ?
      sonar_vec3_dot (p, m->w) / truth->range : 0.0;
  truth->echo_delay = delay;
  truth->strength = r->strength;
  *tau_r = tr;
  return ok;
}

void
sonar_simulator_truth (const SonarSetup * setup, const SonarScene * scene,
    double ping_time, SonarTruth * truth)
{
  for (guint k = 0; k < scene->n_reflectors; k++) {
    Motion m;
    double tau_r;
    centre_truth (setup, scene, k, ping_time, &m, &truth[k], &tau_r);
  }
}

/* Leg shortening h = rho cos (theta / 2) of a cylinder for one pair, theta
 * taken at local time @tau in the horizontal plane. */
static double
cylinder_height (const Motion * m, double rho, SonarVec3 e, SonarVec3 mic,
    double tau)
{
  const SonarVec3 to_e = emitter_side (m, e, tau);      /* axis - emitter */
  const SonarVec3 to_m = microphone_side (m, mic, tau); /* mic - axis */
  const double norms = hypot (to_e.x, to_e.z) * hypot (to_m.x, to_m.z);
  const double cos_theta = norms > 0.0 ?
      -(to_e.x * to_m.x + to_e.z * to_m.z) / norms : 1.0;

  return rho * sqrt (MAX (0.5 * (1.0 + cos_theta), 0.0));
}

static inline guint
clamp_sample (double x, guint length)
{
  return x <= 0.0 ? 0 : x >= length ? length : (guint) x;
}

/* Exact table coordinates and amplitudes of one echo at the samples
 * i0 + NODE_SPACING * (k - 1), k < n_nodes: backwards from each
 * reception instant t to the reflection, then to the emission. */
static void
solve_nodes (SonarSimulator * sim, const Motion * m, SonarVec3 e,
    SonarVec3 mic, double h, double strength, guint i0, guint n_nodes)
{
  const double fs = sim->setup->sample_rate, dt = 1.0 / fs;
  const double ch = m->c * h, hh = h * h;

  for (guint k = 0; k < n_nodes; k++) {
    const double t = (i0 + NODE_SPACING * ((double) k - 1.0)) * dt;
    const double tr = t - leg_time (microphone_side (m, mic, t), m->v,
        m->a_v, ch, hh);
    const double te = tr - leg_time (emitter_side (m, e, tr), m->u, m->a_u,
        ch, hh);
    const double path = MAX (m->c * (t - te), MIN_PATH);

    sim->node_pos[k] = sonar_interp_table_position (te * fs);
    sim->node_amp[k] = strength / (path * path);
  }
}

/* Forward differences, at sample steps, of the cubic through y[0..3] at
 * nodes -1, 0, 1, 2 (NODE_SPACING samples apart), from node 0. */
static inline void
cubic_differences (const double y[4], double d[4])
{
  const double n = NODE_SPACING;
  const double c1 = (y[2] - y[0] / 3.0 - y[1] / 2.0 - y[3] / 6.0) / n;
  const double c2 = ((y[0] + y[2]) / 2.0 - y[1]) / (n * n);
  const double c3 = ((y[3] - y[0]) / 6.0 + (y[1] - y[2]) / 2.0) / (n * n * n);

  d[0] = y[1];
  d[1] = c1 + c2 + c3;
  d[2] = 2.0 * c2 + 6.0 * c3;
  d[3] = 6.0 * c3;
}

/* Adds the echo whose nodes were solved over samples [i0, i1). */
static void
add_echo (const SonarSimulator * sim, const SonarInterp * waveform, guint i0,
    guint i1, float *restrict channel)
{
  const double last = sonar_interp_table_end (waveform);
  guint i = i0;

  for (guint k = 0; i < i1; k++) {
    /* Nodes k .. k + 3 surround samples [i, i + NODE_SPACING). */
    const guint end = MIN (i1, i + NODE_SPACING);
    double p[4], amp[4];
    float a[4];

    cubic_differences (sim->node_pos + k, p);
    cubic_differences (sim->node_amp + k, amp);
    /* Single precision is plenty for the amplitude, and faster. */
    for (guint q = 0; q < 4; q++)
      a[q] = (float) amp[q];
    for (; i < end; i++) {
      channel[i] += a[0] * sonar_interp_at_table (waveform,
          CLAMP (p[0], 0.0, last));
      p[0] += p[1];
      p[1] += p[2];
      p[2] += p[3];
      a[0] += a[1];
      a[1] += a[2];
      a[2] += a[3];
    }
  }
}

static void
render_reflector (SonarSimulator * sim, const SonarReflector * r,
    const Motion * m, double tau_centre, double echo_delay, float *out)
{
  const SonarSetup *setup = sim->setup;
  const SonarGeometry *g = &setup->geometry;
  const guint n_e = g->n_emitters, n_m = g->n_microphones;
  const guint length = setup->ping_length;
  const double fs = setup->sample_rate, dt = 1.0 / fs;
  const double rho = reflector_radius (r);
  const double tau_mid = tau_centre + 0.5 * (setup->waveform_length - 1) * dt;
  /* Emission instants of the ends of the interpolated waveform. */
  const double first = -SONAR_INTERP_PAD * dt;
  const double last = (setup->waveform_length - 1 + SONAR_INTERP_PAD) * dt;
  gboolean any = FALSE;

  for (guint j = 0; j < n_m; j++) {
    for (guint n = 0; n < n_e; n++) {
      const gsize pair = (gsize) j * n_e + n;
      const double h = cylinder_height (m, rho, g->emitters[n],
          g->microphones[j], tau_mid);
      const double t0 = echo_arrival (m, g->emitters[n], g->microphones[j],
          h, first, NULL);
      const double t1 = echo_arrival (m, g->emitters[n], g->microphones[j],
          h, last, NULL);
      const guint i0 = clamp_sample (ceil (t0 * fs), length);
      const guint i1 = clamp_sample (floor (t1 * fs) + 1.0, length);

      sim->heights[pair] = h;
      sim->spans[2 * pair] = i0;
      sim->spans[2 * pair + 1] = MAX (i0, i1);
      any |= i1 > i0;
    }
  }
  if (!any)
    return;

  if (sim->absorption) {
    const double path = m->c * echo_delay;
    for (guint k = 0; k < sim->n_bins; k++)
      sim->gains[k] = (float) exp (-sim->absorption[k] * path);
    for (guint n = 0; n < n_e; n++)
      sonar_interp_filter (sim->waveforms[n], sim->gains);
  }

  /* Emitter by emitter, so that its table stays in the cache. */
  for (guint n = 0; n < n_e; n++) {
    for (guint j = 0; j < n_m; j++) {
      const gsize pair = (gsize) j * n_e + n;
      const guint i0 = sim->spans[2 * pair], i1 = sim->spans[2 * pair + 1];

      if (i1 == i0)
        continue;
      solve_nodes (sim, m, g->emitters[n], g->microphones[j],
          sim->heights[pair], r->strength, i0,
          (i1 - i0 + NODE_SPACING - 1) / NODE_SPACING + 3);
      add_echo (sim, sim->waveforms[n], i0, i1, out + (gsize) j * length);
    }
  }
}

/* Every emission heard straight by every microphone (the sensor is still
 * in its own frame): emitter n's waveform, which starts at the ping
 * instant (its delay in its leading zeros), |m_j - e_n| / c later. */
static void
render_direct_path (SonarSimulator * sim, float *out)
{
  const SonarSetup *setup = sim->setup;
  const SonarGeometry *g = &setup->geometry;
  const guint length = setup->ping_length;
  const double fs = setup->sample_rate;

  for (guint n = 0; n < g->n_emitters; n++) {
    /* Air absorption over centimetres is nothing: the waveform itself. */
    if (sim->absorption)
      sonar_interp_filter (sim->waveforms[n], NULL);
    for (guint j = 0; j < g->n_microphones; j++) {
      const double d = sonar_vec3_norm (sonar_vec3_sub (g->microphones[j],
              g->emitters[n]));
      const double gain = sim->params.direct_path / MAX (d * d, 1e-6);
      const double delay = d / setup->speed_of_sound * fs;
      const guint i0 = clamp_sample (ceil (delay - SONAR_INTERP_PAD),
          length);
      const guint i1 = clamp_sample (floor (delay + setup->waveform_length +
              SONAR_INTERP_PAD) + 1.0, length);
      float *mic = out + (gsize) j * length;

      for (guint i = i0; i < i1; i++)
        mic[i] += (float) (gain * sonar_interp_at (sim->waveforms[n],
                i - delay));
    }
  }
}

void
sonar_simulator_render (SonarSimulator * sim, const SonarScene * scene,
    guint64 ping_index, double ping_time, float *out, SonarTruth * truth)
{
  const SonarSetup *setup = sim->setup;
  const gsize total = (gsize) setup->geometry.n_microphones *
      setup->ping_length;

  memset (out, 0, sizeof (float) * total);
  for (guint k = 0; k < scene->n_reflectors; k++) {
    const SonarReflector *r = &scene->reflectors[k];
    SonarTruth t;
    Motion m;
    double tau_r;
    const gboolean ok = centre_truth (setup, scene, k, ping_time, &m, &t,
        &tau_r);

    if (truth)
      truth[k] = t;
    /* An absurd strength would overflow the float recording. */
    if (ok && r->strength > 0.0 && r->strength < 1e12)
      render_reflector (sim, r, &m, tau_r, t.echo_delay, out);
  }

  if (sim->params.direct_path > 0.0)
    render_direct_path (sim, out);

  if (sim->params.noise_amplitude > 0.0) {
    const double sigma = sim->params.noise_amplitude;
    SonarRng rng;

    /* One stream per ping: any ping can be reproduced on its own. */
    sonar_rng_init (&rng, sim->params.seed, ping_index);
    for (gsize i = 0; i < total; i++)
      out[i] += (float) (sigma * sonar_rng_gaussian (&rng));
  }
  if (sim->params.clip) {
    for (gsize i = 0; i < total; i++)
      out[i] = CLAMP (out[i], -1.0f, 1.0f);
  }
}
