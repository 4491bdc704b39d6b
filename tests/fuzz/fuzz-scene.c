/* fuzz-scene.c: libFuzzer harness for scene files (sonar_scene_load_file). */
#include "fuzz-input.h"
#include "sonar-scene.h"

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
  SonarScene scene = { 0 };
  GError *error = NULL;

  if (sonar_scene_load_file (&scene, fuzz_input_file (data, size), &error))
    sonar_scene_clear (&scene);
  else
    g_error_free (error);
  return 0;
}
