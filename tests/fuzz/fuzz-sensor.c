/* fuzz-sensor.c: libFuzzer harness for sensor description files
 * (sonar_sensor_file_load). */
#include "fuzz-input.h"
#include "sonar-sensor-file.h"

int LLVMFuzzerInitialize (int *argc, char ***argv);
int LLVMFuzzerTestOneInput (const uint8_t * data, size_t size);

int
LLVMFuzzerInitialize (int *argc, char ***argv)
{
  fuzz_input_init ();
  return 0;
}

int
LLVMFuzzerTestOneInput (const uint8_t * data, size_t size)
{
  GError *error = NULL;
  SonarSetup *setup = sonar_sensor_file_load (fuzz_input_file (data, size),
      &error);

  if (setup)
    sonar_setup_unref (setup);
  else
    g_error_free (error);
  return 0;
}
