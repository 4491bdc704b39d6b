/* sonar-setup.h: the one description of the sensor that every stage shares.
 *
 * A SonarSetup is immutable once made and reference counted: the source
 * makes it (or dopplerbank, from a sensor description file), it travels
 * downstream in the sticky "sonar-setup" event (see docs/CONTRACTS.md and
 * sonar-contracts.h) and every element keeps a reference. It holds the
 * sample rate, the speed of sound, the microphone and emitter positions
 * (sensor frame, metres), the N emission waveforms, the band they occupy,
 * the ping framing of the recording (where each ping starts, how long its
 * window is, how far apart pings are in time) and the field of view the
 * array resolves.
 */
#ifndef SONAR_SETUP_H
#define SONAR_SETUP_H

#include <glib.h>
#include "sonar-vec3.h"

G_BEGIN_DECLS

#define SONAR_DEFAULT_SAMPLE_RATE     450000.0
#define SONAR_DEFAULT_SPEED_OF_SOUND  343.0
#define SONAR_DEFAULT_BAND_LOW        20000.0
#define SONAR_DEFAULT_BAND_HIGH       80000.0
#define SONAR_DEFAULT_WAVEFORM_LENGTH 4000
#define SONAR_DEFAULT_N_EMITTERS      8

/* Limits every loader and property checks against. */
#define SONAR_MAX_MICROPHONES 256
#define SONAR_MAX_EMITTERS    64
#define SONAR_MAX_WAVEFORM_LENGTH (1u << 20)
#define SONAR_MAX_PING_LENGTH (1u << 24)
#define SONAR_MAX_PING_PERIOD 3600.0    /* s */
#define SONAR_MAX_WAVEFORM_SAMPLE 1e6   /* |sample| in a waveforms file */
#define SONAR_FRAME_ID_MAX 64   /* bytes of a frame id, its NUL included */

typedef struct
{
  guint n_microphones;
  SonarVec3 *microphones;       /* sensor frame, m */
  guint n_emitters;
  SonarVec3 *emitters;          /* sensor frame, m */
} SonarGeometry;

/* The directions an array resolves: a line of microphones only the
 * horizontal fan (elevation 0), a planar array the frontal hemisphere. */
typedef enum
{
  SONAR_FIELD_OF_VIEW_FAN,
  SONAR_FIELD_OF_VIEW_HEMISPHERE,
} SonarFieldOfView;

/* Everything a set-up is made of (sonar_setup_new copies it). */
typedef struct
{
  double sample_rate;           /* Hz */
  double speed_of_sound;        /* m/s */
  double band_low, band_high;   /* Hz: the band the waveforms occupy */
  const SonarGeometry *geometry;
  guint waveform_length;        /* samples */
  /* n_emitters rows of waveform_length: what each emitter sends, sample 0
   * at the ping's trigger instant (an emitter that starts late has leading
   * zeros: sonar_waveforms_delay ()). */
  const float *waveforms;
  /* Ping framing of a recording: ping k's trigger instant is sample
   * trigger_offset + round (k * ping_stride) of the stream; the ping is
   * the ping_length samples from there; it happened ping_period seconds
   * after ping k - 1. ping_stride 0: ping_period * sample_rate (a
   * continuous recording), or ping_length without a period (windows
   * stored back to back); ping_period 0: ping_length / sample_rate. */
  guint ping_length;
  double ping_period;           /* s */
  double ping_stride;           /* samples */
  guint64 trigger_offset;       /* samples */
  SonarFieldOfView field_of_view;
  /* Name of the sensor's frame that its results are in (as ROS's
   * header.frame_id), carried to every detection; NULL or "" for none;
   * at most SONAR_FRAME_ID_MAX - 1 bytes of printable ASCII. */
  const char *frame_id;
} SonarSetupParams;

typedef struct
{
  /*< public, read-only >*/
  double sample_rate;           /* Hz */
  double speed_of_sound;        /* m/s */
  double band_low, band_high;   /* Hz: the band the waveforms occupy */
  SonarGeometry geometry;
  guint waveform_length;        /* samples */
  const float *waveforms;       /* n_emitters rows of waveform_length */
  guint ping_length;            /* samples recorded per ping and channel */
  double ping_period;           /* s between pings */
  double ping_stride;           /* samples between ping starts in a stream */
  guint64 trigger_offset;       /* samples before ping 0 in a stream */
  SonarFieldOfView field_of_view;
  char frame_id[SONAR_FRAME_ID_MAX];    /* "" for none */
  /*< private >*/
  gint ref_count;
} SonarSetup;

/* Geometry ---------------------------------------------------------------*/

/* The 32-microphone eRTIS layout and the project's 8 default emitters. */
void sonar_geometry_init_default (SonarGeometry * geometry);
void sonar_geometry_clear (SonarGeometry * geometry);
void sonar_geometry_copy (SonarGeometry * dest, const SonarGeometry * src);

/* Loads a geometry file (format: docs/FORMATS.md). On error returns FALSE
 * and sets @error with the file name and the problem. */
gboolean sonar_geometry_load_file (SonarGeometry * geometry,
    const char *path, GError ** error);

/* Checks counts, finiteness and coincident elements. */
gboolean sonar_geometry_validate (const SonarGeometry * geometry,
    GError ** error);

/* What the array resolves: the hemisphere when its elements span the x-y
 * plane, the fan when they lie on a line. */
SonarFieldOfView sonar_geometry_field_of_view (const SonarGeometry *
    geometry);

/* TRUE when every element lies in the x-y plane (within 1 um): such an
 * array cannot tell a direction in front from its mirror image behind
 * (sonar-egomotion.h, sonar-track.h). */
gboolean sonar_geometry_is_planar (const SonarGeometry * geometry);

const char *sonar_field_of_view_to_string (SonarFieldOfView view);
/* FALSE for a name that is not "fan" or "hemisphere". */
gboolean sonar_field_of_view_from_string (const char *name,
    SonarFieldOfView * view);

/* Waveforms file (format: docs/FORMATS.md). Returns a newly allocated
 * n_emitters * length array. *band_low / *band_high receive the file's
 * "band", or else the band holding all but 1e-4 of the waveforms' energy
 * at each end. */
float *sonar_waveforms_load_file (const char *path, guint * n_emitters,
    guint * length, double *sample_rate, double *band_low,
    double *band_high, GError ** error);

/* Rows of @length samples delayed by @delays[n] samples each (>= 0,
 * fractional delays read through the band-limited interpolator): what the
 * emitters send, counted from the trigger instant. Returns a new
 * n_rows * *delayed_length array. */
float *sonar_waveforms_delay (const float *waveforms, guint n_rows,
    guint length, const double *delays, guint * delayed_length);

/* The band holding all but @fraction of the waveforms' energy at each end
 * (Hz). */
void sonar_waveforms_estimate_band (const float *waveforms, guint n_rows,
    guint length, double sample_rate, double fraction, double *low,
    double *high);

/* Setup ------------------------------------------------------------------*/

/* Zero framing (pings back to back from sample 0), the fan; everything
 * else must be filled in. */
void sonar_setup_params_init (SonarSetupParams * params);

/* Copies everything it is given; validates it. */
SonarSetup *sonar_setup_new (const SonarSetupParams * params,
    GError ** error);

/* The stream sample where ping @index starts (its trigger instant). */
guint64 sonar_setup_ping_start (const SonarSetup * setup, guint64 index);

/* The farthest range whose whole echo lies inside one ping's window, seen
 * from the array's farthest element, rounded down to the millimetre; and
 * the farthest range any part of an echo reaches (the lag at the window's
 * end). */
double sonar_setup_recorded_range (const SonarSetup * setup);
double sonar_setup_window_range (const SonarSetup * setup);

/* Samples per ping that hold the whole echo of an object at @max_range m,
 * seen from the array's farthest element (sonarsrc's recording window). */
guint sonar_ping_length_for_range (const SonarGeometry * geometry,
    double speed_of_sound, double sample_rate, guint waveform_length,
    double max_range);

/* sonarsrc's default sensor, without geometry or waveforms files: the
 * built-in array, the default waveforms, c = 343 m/s, a window holding
 * the whole echo of an object at @max_range m (the benchmark's and the
 * FFTW wisdom's set-up). */
SonarSetup *sonar_setup_new_default (double max_range, GError ** error);

/* The set-up of a recording made elsewhere: the geometry file (NULL: the
 * built-in array), the waveforms file, the speed of sound and the samples
 * per ping; pings back to back from sample 0, the fan (the properties
 * dopplerbank had before sensor description files: sonar-sensor-file.h).
 * Every error names the file and the problem. */
SonarSetup *sonar_setup_new_from_files (const char *geometry_file,
    const char *waveforms_file, double speed_of_sound, guint ping_length,
    GError ** error);

SonarSetup *sonar_setup_ref (SonarSetup * setup);
void sonar_setup_unref (SonarSetup * setup);

/* Limits of sonar_setup_check (). */
#define SONAR_MIN_BAND_ENERGY 0.5       /* share of the emissions' energy */
#define SONAR_MAX_CROSS_CORRELATION_DB -6.0
/* What the set-up cannot do, in words for a user (NULL when nothing): a
 * virtual array (every emitter + microphone position) with no aperture
 * across the directions it images cannot resolve direction; an emission
 * with less than SONAR_MIN_BAND_ENERGY of its energy in the band, or none,
 * is mostly filtered away; two emissions whose normalised cross-correlation
 * peaks above SONAR_MAX_CROSS_CORRELATION_DB cannot be told apart, so the
 * MIMO image and the per-emitter Doppler curves mix them. g_free it. */
char *sonar_setup_check (const SonarSetup * setup);

/* Seconds after the trigger at which the emissions' energy is centred
 * (all emitters together): 4.44 ms for 4000 samples of noise at 450 kHz.
 * A radial velocity measured over the echo holds there. */
double sonar_setup_emission_centre (const SonarSetup * setup);

/* The widest spacing of Doppler hypotheses (m/s) for the sensor's
 * emissions, at most SONAR_HYPOTHESIS_SPACING_MAX: an echo between two of
 * them must keep, at the nearer,
 * - most of each emitter's power: the spacing is at most
 *   SONAR_HYPOTHESIS_SPACING_LOBES of the Doppler main lobe c / (2 f0 T)
 *   of the longest emission (T its energy's duration, sqrt(12) times its
 *   RMS spread in time: 8.9 ms for 4000 samples of noise at 450 kHz, a
 *   lobe of 0.39 m/s);
 * - its emitters' phases together: a velocity error dv moves an echo by 2
 *   dv t / c at time t, so emitters whose energy is centred D apart
 *   (staggered or time-division emitters) turn 2 pi f0 2 dv D / c apart;
 *   at half a spacing that is at most 60 degrees: c / (6 f0 D).
 * f0 is the band's centre. The default sensor's emitters are
 * simultaneous: 0.3, as before; one emitter 14 ms late: 0.08, where 0.3
 * lost every moving object to velocityest's coherence test; waveforms of
 * 89 ms: 0.033 (tests/test-setup.c). */
#define SONAR_HYPOTHESIS_SPACING_MAX 0.3
#define SONAR_HYPOTHESIS_SPACING_LOBES 0.85
double sonar_setup_hypothesis_spacing (const SonarSetup * setup);

/* TRUE when both describe the same sensor (every number equal). */
gboolean sonar_setup_equal (const SonarSetup * a, const SonarSetup * b);

static inline const float *
sonar_setup_waveform (const SonarSetup * setup, guint emitter)
{
  return setup->waveforms + (gsize) emitter * setup->waveform_length;
}

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarSetup, sonar_setup_unref)

G_END_DECLS

#endif /* SONAR_SETUP_H */
