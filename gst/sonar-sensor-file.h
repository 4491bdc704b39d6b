/* sonar-sensor-file.h: the sensor description file, everything a recording
 * made anywhere needs to be processed: the array, the emissions and the
 * timing of the pings in the recording (docs/FORMATS.md).
 *
 * A user writes it once per sensor; sonarsrc writes it for what it emits
 * (its write-sensor-file property), so that a recording of sonarsrc's pings
 * replays exactly as the live pings.
 */
#ifndef SONAR_SENSOR_FILE_H
#define SONAR_SENSOR_FILE_H

#include "sonar-setup.h"

G_BEGIN_DECLS

/* Largest emitter delay and trigger offset a file may give, in seconds. */
#define SONAR_MAX_EMITTER_DELAY 1.0
#define SONAR_MAX_TRIGGER_OFFSET 3600.0

/* Loads @path. File names inside it (the emissions WAV) are relative to
 * its folder. Per-emitter delays and the fraction of a sample in the
 * trigger offset are folded into the set-up's waveforms (what each emitter
 * sends, counted from the ping's trigger sample). Every error names the
 * file and the member. */
SonarSetup *sonar_sensor_file_load (const char *path, GError ** error);

/* Writes @setup as a sensor description, the waveforms inline, so that
 * sonar_sensor_file_load () gives back an equal set-up. */
gboolean sonar_sensor_file_save (const SonarSetup * setup, const char *path,
    GError ** error);

G_END_DECLS

#endif /* SONAR_SENSOR_FILE_H */
