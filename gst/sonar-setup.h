/* sonar-setup.h: the one description of the sensor that every stage shares.
 *
 * A SonarSetup is immutable once made and reference counted: the source
 * makes it, it travels downstream in the sticky "sonar-setup" event
 * (see docs/CONTRACTS.md and sonar-contracts.h) and every element keeps a
 * reference. It holds the sample rate, the speed of sound, the microphone
 * and emitter positions (sensor frame, metres), the N emission waveforms,
 * the band they occupy, and the length of one ping's recording window.
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

typedef struct
{
  guint n_microphones;
  SonarVec3 *microphones;       /* sensor frame, m */
  guint n_emitters;
  SonarVec3 *emitters;          /* sensor frame, m */
} SonarGeometry;

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

/* Waveforms file (format: docs/FORMATS.md). Returns a newly allocated
 * n_emitters * length array. *band_low / *band_high receive the file's
 * "band", or else the band holding all but 1e-4 of the waveforms' energy
 * at each end. */
float *sonar_waveforms_load_file (const char *path, guint * n_emitters,
    guint * length, double *sample_rate, double *band_low,
    double *band_high, GError ** error);

/* Setup ------------------------------------------------------------------*/

/* Copies everything it is given; validates it. */
SonarSetup *sonar_setup_new (double sample_rate, double speed_of_sound,
    double band_low, double band_high, const SonarGeometry * geometry,
    guint waveform_length, const float *waveforms, guint ping_length,
    GError ** error);

/* Samples per ping that hold the whole echo of an object at @max_range m,
 * seen from the array's farthest element (sonarsrc's recording window). */
guint sonar_ping_length_for_range (const SonarGeometry * geometry,
    double speed_of_sound, double sample_rate, guint waveform_length,
    double max_range);

/* The set-up of a recording made elsewhere: the geometry file (NULL: the
 * built-in array), the waveforms file, the speed of sound and the samples
 * per ping. Every error names the file and the problem. */
SonarSetup *sonar_setup_new_from_files (const char *geometry_file,
    const char *waveforms_file, double speed_of_sound, guint ping_length,
    GError ** error);

SonarSetup *sonar_setup_ref (SonarSetup * setup);
void sonar_setup_unref (SonarSetup * setup);

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
