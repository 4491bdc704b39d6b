/* fuzz-waveforms.c: libFuzzer harness for emission waveforms files
 * (sonar_waveforms_load_file). */
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
  guint n_emitters, length;
  double sample_rate, band_low, band_high;
  GError *error = NULL;
  float *waveforms = sonar_waveforms_load_file (fuzz_input_file (data, size),
      &n_emitters, &length, &sample_rate, &band_low, &band_high, &error);

  if (waveforms)
    g_free (waveforms);
  else
    g_error_free (error);
  return 0;
}
