/* sonar-simulator.h: physical simulation of one ping of the MIMO sonar.
 *
 * Every emitter sends its waveform at the ping instant; every reflector
 * sends back what reaches it; every microphone records the sum plus noise.
 * The echo of a moving reflector is computed from the exact time-varying
 * geometry: the reflection and emission instants are solved in closed form
 * (straight-line motion, air at rest) every 64 recorded samples and
 * interpolated in between by cubics through the nearest four solutions.
 * Measured at 10 m/s in random directions, the emission instant of every
 * sample is within 5e-6 samples of the exact one while the reflector stays
 * 5 cm or more from every element, 1e-6 beyond 10 cm, 3e-8 beyond 30 cm
 * and 1e-9 beyond 1 m, far below what the float recording resolves; the
 * error grows as 1 / distance^3 closer in (0.05 samples within 2 cm).
 * The waveform is read between its samples with the band-limited
 * interpolator of sonar-interp.h. Amplitude follows the paper's eq. 6:
 * strength / (r_emitter + r_microphone)^2.
 *
 * Cost grows with reflectors x emitters x microphones x echo length, never
 * with the recording window: samples outside every echo are never visited.
 */
#ifndef SONAR_SIMULATOR_H
#define SONAR_SIMULATOR_H

#include <glib.h>
#include "sonar-setup.h"
#include "sonar-scene.h"

G_BEGIN_DECLS

/* Ground truth of one reflector for one ping, in the sensor frame, taken at
 * the instant the ping (leaving the array centre at the ping time) reaches
 * the reflector: that is the state of the object the echo describes. */
typedef struct
{
  guint reflector;              /* index in the scene */
  SonarReflectorKind kind;
  SonarVec3 position;           /* m, sensor frame (cylinder: nearest surface point) */
  SonarVec3 velocity;           /* m/s, relative to the sensor */
  double range;                 /* m, |position| */
  double azimuth;               /* degrees */
  double elevation;             /* degrees */
  double radial_velocity;       /* m/s, d(range)/dt, positive = moving away */
  double echo_delay;            /* s, two-way travel time array centre -> object -> array centre */
  double strength;
} SonarTruth;

typedef struct
{
  double noise_amplitude;       /* rms of white Gaussian noise added per sample */
  guint64 seed;                 /* noise seed; ping p uses a stream derived from (seed, p) */
  gboolean clip;                /* saturate the recording at +-1 like an ADC */
  gboolean air_absorption;      /* frequency-dependent absorption of air (20 C, 50 % RH) */
  /* >= 0: the microphones also hear the emitters straight, as a real
   * sensor's do: emitter n's waveform |m_j - e_n| / c after it starts,
   * times direct_path / |m_j - e_n|^2 (eq. 6 with one leg; 0.1: 33-71 dB
   * over a unit reflector's echo at 1 m on the default set-up); 0: none. */
  double direct_path;
} SonarSimulatorParams;

typedef struct _SonarSimulator SonarSimulator;

void sonar_simulator_params_init_default (SonarSimulatorParams * params);

/* Set-up work (interpolation tables of the waveforms) happens here, once. */
SonarSimulator *sonar_simulator_new (SonarSetup * setup,
    const SonarSimulatorParams * params, GError ** error);
void sonar_simulator_free (SonarSimulator * sim);
/* Bytes a simulator of @setup allocates, plus @n_windows recording windows
 * (microphones x ping length float32) that its user renders pings into:
 * checked before sonar_simulator_new with sonar_memory_check. */
guint64 sonar_simulator_memory (const SonarSetup * setup, guint n_windows);

/* Renders ping number @ping_index, emitted at world time @ping_time (s),
 * into @out: n_microphones planar channels of setup->ping_length samples
 * (out[j * ping_length + i]). @truth, if not NULL, receives one entry per
 * reflector of @scene. Never fails: echoes partly or wholly outside the
 * window are cut, reflectors closer than a wavelength are still finite. */
void sonar_simulator_render (SonarSimulator * sim, const SonarScene * scene,
    guint64 ping_index, double ping_time, float *out, SonarTruth * truth);

/* Ground truth only (no rendering). */
void sonar_simulator_truth (const SonarSetup * setup,
    const SonarScene * scene, double ping_time, SonarTruth * truth);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarSimulator, sonar_simulator_free)

G_END_DECLS

#endif /* SONAR_SIMULATOR_H */
