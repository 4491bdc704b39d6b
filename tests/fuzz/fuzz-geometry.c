/* fuzz-geometry.c: libFuzzer harness for array geometry files
 * (sonar_geometry_load_file). */
#include "fuzz-input.h"
#include "sonar-setup.h"

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
  SonarGeometry geometry = { 0 };
  GError *error = NULL;

  if (sonar_geometry_load_file (&geometry, fuzz_input_file (data, size),
          &error))
    sonar_geometry_clear (&geometry);
  else
    g_error_free (error);
  return 0;
}
